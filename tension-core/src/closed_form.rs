//! Pott's closed-form tension distribution (Pott, Bruckmann & Mikelsons 2009)
//! and its improved variant (Pott 2013), for any degree of redundancy.

use nalgebra::{SMatrix, SVector};

use crate::{
    linalg::WrenchFactorization,
    scalar::finite,
    solution::{robustness, Diagnostics, Solution},
    Error, Real, TensionLimits,
};

/// `closed-form` (conventions): `t = t_m + W^+ (f - W t_m)` with
/// `t_m = (t_min + t_max) / 2` (Pott 2013, Eq. 2).
///
/// Errors where `t` leaves the limits: [`Error::Infeasible`] when
/// `|t - t_m|_2` exceeds the half-diagonal of the tension box, so that the
/// affine set of solutions misses the box (the upper bound of Pott 2013,
/// Eq. 3, with per-cable limits); [`Error::MethodFailed`] otherwise.
pub fn closed_form<T: Real, const N: usize, const M: usize>(
    w: &SMatrix<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
) -> Result<Solution<T, M>, Error> {
    let fact = WrenchFactorization::new(w)?;
    closed_form_factored(&fact, w, f, limits)
}

/// [`closed_form`] on an already factored wrench matrix.
pub fn closed_form_factored<T: Real, const N: usize, const M: usize>(
    fact: &WrenchFactorization<T, N, M>,
    w: &SMatrix<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
) -> Result<Solution<T, M>, Error> {
    if !finite(f.as_slice()) {
        return Err(Error::NonFinite);
    }
    let all = [true; M];
    let t = reduced_closed_form(fact, w, f, limits, &all)?;
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

/// `improved-closed-form` (conventions, Pott 2013, Sect. 2): while some tension is
/// out of bounds, fix the cable with the largest violation at the bound it
/// violates and solve the reduced closed form (Eq. 4). At most `M - N + 1`
/// closed-form evaluations.
///
/// Errors: [`Error::Infeasible`] when the first evaluation already proves the
/// pose infeasible (Eq. 3); [`Error::MethodFailed`] when fewer than `N` free
/// cables would remain, or the reduced wrench matrix loses rank: the method
/// has no proof of completeness (Pott 2013, footnote 3), so this does not
/// certify infeasibility.
pub fn improved_closed_form<T: Real, const N: usize, const M: usize>(
    w: &SMatrix<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
) -> Result<Solution<T, M>, Error> {
    if N == 0 || N > M {
        return Err(Error::UnsupportedShape);
    }
    if !finite(f.as_slice()) {
        return Err(Error::NonFinite);
    }
    let mut free = [true; M];
    let mut fixed: SVector<T, M> = SVector::zeros();
    let mut free_count = M;
    for evaluation in 0..=(M - N) {
        // Reduced right-hand side: f' = f - sum over fixed cables of w_i t_i.
        let mut reduced_f = *f;
        for i in 0..M {
            if !free[i] {
                reduced_f -= w.column(i) * fixed[i];
            }
        }
        let fact = match WrenchFactorization::with_columns(w, &free) {
            Ok(fact) => fact,
            Err(Error::Singular) if evaluation > 0 => return Err(Error::MethodFailed),
            Err(e) => return Err(e),
        };
        let reduced = reduced_closed_form(&fact, w, &reduced_f, limits, &free)?;
        let mut t = reduced;
        for i in 0..M {
            if !free[i] {
                t[i] = fixed[i];
            }
        }
        let Some((worst, bound)) = first_violation(&t, limits, &free) else {
            return Ok(Solution {
                tensions: t,
                robustness: robustness(&t, limits),
                diagnostics: Diagnostics {
                    iterations: (evaluation + 1) as u8,
                    fixed_cables: evaluation as u8,
                    ..Diagnostics::empty()
                },
            });
        };
        if evaluation == 0 && misses_box(&t, limits, &free) {
            return Err(Error::Infeasible);
        }
        if free_count == N {
            return Err(Error::MethodFailed);
        }
        free[worst] = false;
        fixed[worst] = bound;
        free_count -= 1;
    }
    Err(Error::MethodFailed)
}

/// Closed form on the cables marked free: `t = t_m + W'^+ (f - W' t_m)`,
/// zero on the others (`fact` must be factored with the same columns).
fn reduced_closed_form<T: Real, const N: usize, const M: usize>(
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
fn first_violation<T: Real, const M: usize>(
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
fn misses_box<T: Real, const M: usize>(
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
