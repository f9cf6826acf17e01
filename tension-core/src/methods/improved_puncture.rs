//! `improved-puncture` (`docs/conventions.md`): the puncture method of
//! [`super::puncture`] towards Pott's improved closed form
//! ([`super::improved_closed_form`]), for the poses where the plain closed
//! form leaves the limits. Any degree of redundancy.

use super::{
    puncture::{along_line, base_point, inside, pack},
    PreviousCycle, Problem,
};
use crate::{solution::Diagnostics, Error, Real, Solution};

/// Reads only the particular solution.
pub const NULL_SPACE: bool = false;

/// Starts cold every call.
pub const WARM_START: bool = false;

/// Any redundancy.
pub const fn supports(n: usize, m: usize) -> bool {
    super::any_redundancy(n, m)
}

/// `W^+ f` if within the limits, else where the line from it to the
/// improved closed form enters the limits; no warm start.
pub fn solve<T: Real, const N: usize, const M: usize>(
    problem: &Problem<'_, T, N, M>,
    previous: &PreviousCycle<T, M>,
) -> Result<Solution<T, M>, Error> {
    let t0 = base_point(problem.factorization, problem.f)?;
    if inside(&t0, problem.limits) {
        return Ok(pack(t0, problem.limits, Diagnostics { iterations: 1, ..Diagnostics::empty() }));
    }
    let end = super::improved_closed_form::solve(problem, previous)?;
    let t = along_line(&t0, &end.tensions, problem.limits)?;
    let diagnostics = Diagnostics {
        iterations: end.diagnostics.iterations.saturating_add(1),
        fixed_cables: end.diagnostics.fixed_cables,
        ..Diagnostics::empty()
    };
    Ok(pack(t, problem.limits, diagnostics))
}
