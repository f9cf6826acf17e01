//! `min-2-norm` and, in [`super::min_1_norm`], `min-1-norm`
//! (`docs/conventions.md`): the feasible tensions of smallest 2-norm and of
//! smallest sum, any degree of redundancy `r = M - N`.
//!
//! * `min-2-norm`: `argmin |t|_2` subject to `W t = f`,
//!   `t_min <= t <= t_max` (Di Paola et al. 2024, Eq. 8, left; the energy
//!   optimal distribution). With `t = t_p + Z lambda` and `t_p = W^+ f`
//!   orthogonal to the null space, `|t|^2 = |t_p|^2 + |lambda|^2`: the answer
//!   is the point of the feasible set closest to `lambda = 0`, unique.
//! * `min-1-norm`: `argmin sum_i t_i` over the same set (tensions are
//!   non-negative, so this is the 1-norm): a linear programme. Its minimiser
//!   need not be unique (when `sum_k z_k` is orthogonal to an edge); the tie
//!   is broken by the smallest 2-norm among the minimisers, so the answer is
//!   unique and the same for every `r` (our choice: the literature's LP
//!   solvers return whichever vertex they meet first).
//!
//! For `r = 2` both are exact and bounded from the feasible polygon's
//! vertices, as the barycenter walk computes them
//! (`polygon_optimum`, [`crate::polygon::FeasiblePolygon::walk`], warm-started like the
//! barycenter): the 2-norm optimum is the origin if it is inside, else the
//! closest point of the closest edge; the 1-norm optimum is the set of
//! vertices of smallest `sum t` (one vertex, or the two ends of an edge),
//! of which the closest point to the origin is taken. Cost: the walk plus
//! `O(M)` per vertex.
//!
//! For other `r` the active-set solvers of [`crate::active_set`]: the
//! Goldfarb-Idnani projection for the 2-norm; for the 1-norm the primal
//! active-set method from the 2-norm optimum, then the projection of the
//! origin onto the feasible set cut by `sum t <= optimum + tol`. Each stops
//! after [`crate::active_set::step_cap`] `= 8 M + 8` steps
//! ([`Error::NoConvergence`]).
//!
//! Errors: [`Error::Infeasible`] (the walk finds no vertex, or a Farkas
//! certificate), [`Error::NonFinite`], [`Error::Singular`],
//! [`Error::NoConvergence`].

use nalgebra::SVector;

use super::{PolygonWork, PreviousCycle, Problem};
use crate::{
    active_set::{project, Constraints, NullSpaceProblem},
    polygon_optimum::{decided_on_polygon, Norm},
    solution::{checked_solution, Solution, WarmStart},
    Error, Real,
};

/// Reads the null-space basis.
pub const NULL_SPACE: bool = true;

/// Uses the previous cycle's solution (`PreviousCycle`).
pub const WARM_START: bool = true;

/// Any redundancy.
pub const fn supports(n: usize, m: usize) -> bool {
    super::any_redundancy(n, m)
}

/// The smallest `|t|_2` (see the module header); `previous.active_pair`
/// warm-starts the walk for `r = 2`.
pub fn solve<T: Real, const N: usize, const M: usize>(
    problem: &Problem<'_, T, N, M>,
    previous: &PreviousCycle<T, M>,
    _work: &mut PolygonWork<T, N, M>,
) -> Result<Solution<T, M>, Error> {
    smallest(problem, previous)
}

/// [`solve`] without the room it does not use (the analytic centre's
/// verdict calls it).
pub(crate) fn smallest<T: Real, const N: usize, const M: usize>(
    problem: &Problem<'_, T, N, M>,
    previous: &PreviousCycle<T, M>,
) -> Result<Solution<T, M>, Error> {
    if let Some(decided) = decided_on_polygon(problem, previous, Norm::Two) {
        return decided;
    }
    let Problem { f, limits, factorization, .. } = *problem;
    let prob = NullSpaceProblem::new(factorization, f, limits)?;
    let p = project(&Constraints::limits(&prob), &SVector::zeros(), prob.tolerance())?;
    checked_solution(&prob.tensions(&p.x), limits, prob.tolerance(), p.steps, 0, None, WarmStart::NotGiven)
}
