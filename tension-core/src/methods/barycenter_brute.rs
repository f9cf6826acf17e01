//! `barycenter-brute` (`docs/conventions.md`): the same centroid as
//! [`super::barycenter`] from every pairwise intersection of the limit lines
//! (Mikelsons et al. 2008), `O(M^3)`; the reference the walk is tested
//! against. `M = N + 2`, no warm start.

use super::{PolygonRoom, PolygonWork, Problem, PreviousCycle};
use crate::{Error, Real, Solution};

/// Reads the null-space basis.
pub const NULL_SPACE: bool = true;

/// Starts cold every call.
pub const WARM_START: bool = false;

/// Two degrees of redundancy.
pub const fn supports(n: usize, m: usize) -> bool {
    super::redundancy_two(n, m)
}

/// The centroid of every feasible pairwise intersection.
pub fn solve<T: Real, const N: usize, const M: usize>(
    problem: &Problem<'_, T, N, M>,
    _previous: &PreviousCycle<T, M>,
    work: &mut PolygonWork<T, N, M>,
) -> Result<Solution<T, M>, Error> {
    let PolygonRoom { polygon: poly, vertices } = work.room();
    poly.set(problem.factorization, problem.f, problem.limits)?;
    let found = poly.polygon.brute_force_into(vertices)?;
    poly.centroid_solution(&found, problem.limits, None)
}
