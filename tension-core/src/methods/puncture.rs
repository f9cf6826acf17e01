//! `puncture` (`docs/conventions.md`): the puncture method, and the steps it
//! shares with [`super::improved_puncture`]. Both are from (Müller, Reichert &
//! Bruckmann 2014, "Analysis of a real-time capable cable force computation
//! method", CableCon 2014, in Cable-Driven Parallel Robots, Springer 2015,
//! pp. 227-238), any degree of redundancy.
//!
//! The paper is not in the project's library; this is the method as we
//! implement it, in words:
//!
//! 1. `t_0 = W^+ f`, the minimum-norm solution of `W t = f` (the smallest
//!    tensions in the 2-norm without limits). If `t_min <= t_0 <= t_max` it
//!    is the answer.
//! 2. Otherwise a feasible end point `t_e` with `W t_e = f`:
//!    * `puncture`: Pott's closed form, `t_e = t_m + W^+ (f - W t_m)` with
//!      `t_m = (t_min + t_max) / 2` ([`super::closed_form`]);
//!    * `improved-puncture`: Pott's improved closed form (Pott 2013,
//!      Sect. 2, [`super::improved_closed_form`]), which fixes violating
//!      cables at their limits and so succeeds on more poses: the
//!      improvement for the poses where the plain method's end point leaves
//!      the limits.
//!
//!    If the end point cannot be found the method fails with that method's
//!    error ([`Error::Infeasible`] when the closed form proves the pose
//!    infeasible, Pott 2013 Eq. 3; [`Error::MethodFailed`] otherwise).
//! 3. Both points solve `W t = f`, so the whole line `t(s) = t_0 + s (t_e - t_0)`
//!    does. The answer is where that line, from the outside point `t_0`,
//!    punctures the box of limits: the smallest `s` in `[0, 1]` with
//!    `t_min <= t(s) <= t_max`, `s* = max_i s_i` where `s_i` is where cable `i`
//!    enters its range (`(t_min,i - t_0,i) / (t_e,i - t_0,i)` for a cable below
//!    its range, `(t_0,i - t_max,i) / (t_0,i - t_e,i)` above it, 0 inside).
//!    The cable that defines `s*` ends exactly at its limit: the answer is
//!    on the boundary of the feasible set, the feasible point of that line
//!    nearest to the minimum-norm solution.
//!
//! Cost: one Householder factorisation and one closed form (`puncture`), or
//! the improved closed form's at most `M - N + 1` factorisations, plus `O(M)`.
//!
//! Choices where our reading of the literature leaves room: the base point
//! of both methods is the unconstrained minimum-norm solution `W^+ f` (some
//! implementations re-base the improved method on the minimum-norm solution
//! of the reduced problem); a cable above its upper limit at `t_0` is handled
//! like one below its lower limit (the entry parameter above).
//!
//! Continuity: `puncture` is continuous where it succeeds (`t_0`, `t_e` and
//! the entry parameters are continuous while `t_e` is strictly inside), but,
//! like the closed form, it fails ([`Error::MethodFailed`]) well inside the
//! workspace. `improved-puncture` inherits the improved closed form's jumps
//! when the set of fixed cables changes; see `tests/more_methods.rs`.

use nalgebra::SVector;

use super::{PolygonWork, PreviousCycle, Problem};
use crate::{
    linalg::WrenchFactorization,
    scalar::finite,
    solution::{robustness, Diagnostics, Solution},
    Error, Real, TensionLimits,
};

/// Reads only the particular solution.
pub const NULL_SPACE: bool = false;

/// Starts cold every call.
pub const WARM_START: bool = false;

/// Any redundancy.
pub const fn supports(n: usize, m: usize) -> bool {
    super::any_redundancy(n, m)
}

/// `W^+ f` if within the limits, else where the line from it to the closed
/// form enters the limits (see the module header); no warm start.
pub fn solve<T: Real, const N: usize, const M: usize>(
    problem: &Problem<'_, T, N, M>,
    previous: &PreviousCycle<T, M>,
    work: &mut PolygonWork<T, N, M>,
) -> Result<Solution<T, M>, Error> {
    towards(problem, || super::closed_form::solve(problem, previous, work))
}

/// Steps 1 and 3 of the module header with the end point `end` computes
/// (step 2: the closed form here, the improved one for
/// [`super::improved_puncture`]); the iterations count the end point's
/// evaluations plus one, and its fixed cables carry over.
pub(crate) fn towards<T: Real, const N: usize, const M: usize>(
    problem: &Problem<'_, T, N, M>,
    end: impl FnOnce() -> Result<Solution<T, M>, Error>,
) -> Result<Solution<T, M>, Error> {
    let t0 = base_point(problem.factorization, problem.f)?;
    if inside(&t0, problem.limits) {
        return Ok(pack(t0, problem.limits, Diagnostics { iterations: 1, ..Diagnostics::empty() }));
    }
    let end = end()?;
    let t = along_line(&t0, &end.tensions, problem.limits)?;
    let diagnostics = Diagnostics {
        iterations: end.diagnostics.iterations.saturating_add(1),
        fixed_cables: end.diagnostics.fixed_cables,
        ..Diagnostics::empty()
    };
    Ok(pack(t, problem.limits, diagnostics))
}

fn base_point<T: Real, const N: usize, const M: usize>(
    fact: &WrenchFactorization<T, N, M>,
    f: &SVector<T, N>,
) -> Result<SVector<T, M>, Error> {
    if !finite(f.as_slice()) {
        return Err(Error::NonFinite);
    }
    let t0 = fact.min_norm_solution(f);
    if finite(t0.as_slice()) {
        Ok(t0)
    } else {
        Err(Error::NonFinite)
    }
}

fn inside<T: Real, const M: usize>(t: &SVector<T, M>, limits: &TensionLimits<T, M>) -> bool {
    (0..M).all(|i| t[i] >= limits.min()[i] && t[i] <= limits.max()[i])
}

/// The puncture point `t_0 + s* (t_e - t_0)` (step 3 of the module header);
/// `t_e` must be within the limits.
fn along_line<T: Real, const M: usize>(
    t0: &SVector<T, M>,
    te: &SVector<T, M>,
    limits: &TensionLimits<T, M>,
) -> Result<SVector<T, M>, Error> {
    let d = te - t0;
    let mut s = T::zero();
    for i in 0..M {
        let (lo, hi) = (limits.min()[i], limits.max()[i]);
        // t_e,i is within [lo, hi], so d_i has the sign that enters the range.
        let entry = if t0[i] < lo {
            (lo - t0[i]) / d[i]
        } else if t0[i] > hi {
            (t0[i] - hi) / -d[i]
        } else {
            continue;
        };
        s = s.max(entry.min(T::one()));
    }
    let t = t0 + d * s;
    if finite(t.as_slice()) {
        Ok(t)
    } else {
        Err(Error::NonFinite)
    }
}

fn pack<T: Real, const M: usize>(
    t: SVector<T, M>,
    limits: &TensionLimits<T, M>,
    diagnostics: Diagnostics,
) -> Solution<T, M> {
    Solution { tensions: t, robustness: robustness(&t, limits), diagnostics }
}
