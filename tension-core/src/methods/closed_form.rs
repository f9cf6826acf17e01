//! `closed-form` (`docs/conventions.md`): Pott's closed-form tension
//! distribution (Pott, Bruckmann & Mikelsons 2009; Pott 2013, Eq. 2), any
//! degree of redundancy, and the reduced closed form its improved variant
//! ([`super::improved_closed_form`]) and the puncture methods build on.

use nalgebra::{SMatrix, SVector};

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

/// `t = t_m + W^+ (f - W t_m)` with `t_m = (t_min + t_max) / 2` (Pott 2013,
/// Eq. 2); no warm start.
///
/// Errors where `t` leaves the limits: [`Error::Infeasible`] when
/// `|t - t_m|_2` exceeds the half-diagonal of the tension box, so that the
/// affine set of solutions misses the box (the upper bound of Pott 2013,
/// Eq. 3, with per-cable limits); [`Error::MethodFailed`] otherwise.
pub fn solve<T: Real, const N: usize, const M: usize>(
    problem: &Problem<'_, T, N, M>,
    _previous: &PreviousCycle<T, M>,
    _work: &mut PolygonWork<T, N, M>,
) -> Result<Solution<T, M>, Error> {
    let Problem { w, f, limits, factorization } = *problem;
    if !finite(f.as_slice()) {
        return Err(Error::NonFinite);
    }
    let all = [true; M];
    let t = reduced_closed_form(factorization, w, f, limits, &all)?;
    match first_violation(&t, limits, &all) {
        None => Ok(Solution {
            tensions: t,
            robustness: robustness(&t, limits),
            diagnostics: Diagnostics { iterations: 1, ..Diagnostics::empty() },
        }),
        Some(_) if misses_box(&t, limits, &all) => Err(Error::Infeasible),
        Some(_) => Err(Error::MethodFailed),
    }
}

/// Closed form on the cables marked free: `t = t_m + W'^+ (f - W' t_m)`,
/// zero on the others (`fact` must be factored with the same columns).
pub(crate) fn reduced_closed_form<T: Real, const N: usize, const M: usize>(
    fact: &WrenchFactorization<T, N, M>,
    w: &SMatrix<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
    free: &[bool; M],
) -> Result<SVector<T, M>, Error> {
    let mut middle = limits.middle();
    for i in 0..M {
        if !free[i] {
            middle[i] = T::zero();
        }
    }
    let residual = f - w * middle;
    let t = middle + fact.min_norm_solution(&residual);
    if finite(t.as_slice()) {
        Ok(t)
    } else {
        Err(Error::NonFinite)
    }
}

/// The free cable with the largest violation and the bound it violates.
pub(crate) fn first_violation<T: Real, const M: usize>(
    t: &SVector<T, M>,
    limits: &TensionLimits<T, M>,
    free: &[bool; M],
) -> Option<(usize, T)> {
    let mut worst: Option<(usize, T, T)> = None;
    for i in 0..M {
        if !free[i] {
            continue;
        }
        let (excess, bound) = if t[i] > limits.max()[i] {
            (t[i] - limits.max()[i], limits.max()[i])
        } else if t[i] < limits.min()[i] {
            (limits.min()[i] - t[i], limits.min()[i])
        } else {
            continue;
        };
        if worst.is_none_or(|(_, e, _)| excess > e) {
            worst = Some((i, excess, bound));
        }
    }
    worst.map(|(i, _, b)| (i, b))
}

/// Pott 2013, Eq. 3 (upper bound): the closest point of the solution set to
/// the box centre is farther than the box's circumscribed sphere, so the
/// solution set misses the box.
pub(crate) fn misses_box<T: Real, const M: usize>(
    t: &SVector<T, M>,
    limits: &TensionLimits<T, M>,
    free: &[bool; M],
) -> bool {
    let middle = limits.middle();
    let mut dist2 = T::zero();
    let mut radius2 = T::zero();
    for i in 0..M {
        if free[i] {
            let half = (limits.max()[i] - limits.min()[i]) * T::lit(0.5);
            dist2 += (t[i] - middle[i]) * (t[i] - middle[i]);
            radius2 += half * half;
        }
    }
    dist2 > radius2
}
