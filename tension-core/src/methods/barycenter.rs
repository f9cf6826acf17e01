//! `barycenter` (`docs/conventions.md`): the centroid of the feasible polygon
//! found by walking its edges (Lamaury & Gouttefarde 2013, Sect. 2.2-2.3),
//! warm-started from the previous cycle's active pair when it is given and
//! still a vertex; `M = N + 2`.
//!
//! Cost: one Householder factorisation (`O(N^2 M)`), then the walk: with a
//! held warm start `O(M^2)`; cold, `O(M^2)` to clip every line against the
//! other cables, and the exhaustive `4 C(M,2)` line pairs (`O(M^3)`) only for
//! lines the clipping cannot rule out.

use super::{PolygonRoom, PolygonWork, Problem, PreviousCycle};
use crate::{Error, Real, Solution};

/// Reads the null-space basis.
pub const NULL_SPACE: bool = true;

/// Uses the previous cycle's solution (`PreviousCycle`).
pub const WARM_START: bool = true;

/// Two degrees of redundancy.
pub const fn supports(n: usize, m: usize) -> bool {
    super::redundancy_two(n, m)
}

/// The walk's centroid, warm-started from `previous.active_pair`.
pub fn solve<T: Real, const N: usize, const M: usize>(
    problem: &Problem<'_, T, N, M>,
    previous: &PreviousCycle<T, M>,
    work: &mut PolygonWork<T, N, M>,
) -> Result<Solution<T, M>, Error> {
    let PolygonRoom { polygon: poly, vertices } = work.room();
    poly.set(problem.factorization, problem.f, problem.limits)?;
    let found = poly.polygon.walk_into(previous.active_pair, vertices)?;
    poly.centroid_solution(&found, problem.limits, previous.active_pair)
}
