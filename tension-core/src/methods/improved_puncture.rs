//! `improved-puncture` (`docs/conventions.md`): the puncture method of
//! [`super::puncture`] towards Pott's improved closed form
//! ([`super::improved_closed_form`]), for the poses where the plain closed
//! form leaves the limits. Any degree of redundancy.

use super::{PolygonWork, PreviousCycle, Problem};
use crate::{Error, Real, Solution};

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
    work: &mut PolygonWork<T, N, M>,
) -> Result<Solution<T, M>, Error> {
    super::puncture::towards(problem, || super::improved_closed_form::solve(problem, previous, work))
}
