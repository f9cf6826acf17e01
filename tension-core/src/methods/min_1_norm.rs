//! `min-1-norm` (`docs/conventions.md`): the feasible tensions of smallest
//! sum (tensions are non-negative, so the 1-norm), ties broken by the
//! smallest 2-norm; any degree of redundancy. How, and the cost: see
//! [`super::min_2_norm`], which it shares the polygon and the active sets
//! with.

use nalgebra::SVector;

use super::{PolygonWork, PreviousCycle, Problem};
use crate::{
    active_set::{minimise_linear, project, Constraints, NullSpaceProblem},
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

/// The smallest `sum t_i`, then the smallest `|t|_2` among the minimisers;
/// `previous.active_pair` warm-starts the walk for `r = 2`.
pub fn solve<T: Real, const N: usize, const M: usize>(
    problem: &Problem<'_, T, N, M>,
    previous: &PreviousCycle<T, M>,
    _work: &mut PolygonWork<T, N, M>,
) -> Result<Solution<T, M>, Error> {
    if let Some(decided) = decided_on_polygon(problem, previous, Norm::One) {
        return decided;
    }
    let Problem { f, limits, factorization, .. } = *problem;
    let prob = NullSpaceProblem::new(factorization, f, limits)?;
    let tol = prob.tolerance();
    let base = Constraints::limits(&prob);
    let start = project(&base, &SVector::zeros(), tol)?;
    let g = prob.sum_gradient();
    let (x, lp_steps) = minimise_linear(&base, &g, &start.x, &start.active[..start.active_len])?;
    // Among the minimisers (within the rounding of the sum), the smallest 2-norm.
    let best = g.dot(&x) + T::lit(M as f64) * tol;
    let cut = base.with_extra(&g, best);
    let (lambda, tie_steps) = match project(&cut, &SVector::zeros(), tol) {
        Ok(tie) => (tie.x, tie.steps),
        // The cut holds `x`, a feasible minimiser: an "infeasible" from the
        // tie-break is rounding of the cut's normal against the active limits
        // it is a combination of (at the optimum `g` lies in their cone), never
        // a proof about the tensions. Keep the minimiser found.
        Err(Error::Infeasible) => (x, 0),
        Err(e) => return Err(e),
    };
    let steps = start.steps + lp_steps + tie_steps;
    checked_solution(&prob.tensions(&lambda), limits, tol, steps, 0, None, WarmStart::NotGiven)
}
