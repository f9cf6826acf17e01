//! `improved-closed-form` (`docs/conventions.md`): Pott 2013, Sect. 2, any
//! degree of redundancy.

use nalgebra::SVector;

use super::{
    closed_form::{first_violation, misses_box, reduced_closed_form},
    PolygonWork, PreviousCycle, Problem,
};
use crate::{
    linalg::WrenchFactorization,
    scalar::finite,
    solution::{robustness, Diagnostics, Solution},
    Error, Real,
};

/// Reads only the particular solution.
pub const NULL_SPACE: bool = false;

/// Starts cold every call.
pub const WARM_START: bool = false;

/// Any redundancy.
pub const fn supports(n: usize, m: usize) -> bool {
    super::any_redundancy(n, m)
}

/// While some tension is out of bounds, fix the cable with the largest
/// violation at the bound it violates and solve the reduced closed form
/// (Pott 2013, Eq. 4). At most `M - N + 1` closed-form evaluations; the first
/// uses `problem`'s factorisation, each later one factors the reduced `W`.
///
/// Errors: [`Error::Infeasible`] when the first evaluation already proves the
/// pose infeasible (Eq. 3); [`Error::MethodFailed`] when fewer than `N` free
/// cables would remain, or the reduced wrench matrix loses rank: the method
/// has no proof of completeness (Pott 2013, footnote 3), so this does not
/// certify infeasibility.
pub fn solve<T: Real, const N: usize, const M: usize>(
    problem: &Problem<'_, T, N, M>,
    _previous: &PreviousCycle<T, M>,
    _work: &mut PolygonWork<T, N, M>,
) -> Result<Solution<T, M>, Error> {
    let Problem { w, f, limits, factorization } = *problem;
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
        let reduced = if evaluation == 0 {
            reduced_closed_form(factorization, w, &reduced_f, limits, &free)?
        } else {
            // A reduced matrix that loses rank is no proof of infeasibility.
            let fact = match WrenchFactorization::with_columns(w, &free) {
                Ok(fact) => fact,
                Err(Error::Singular) => return Err(Error::MethodFailed),
                Err(e) => return Err(e),
            };
            reduced_closed_form(&fact, w, &reduced_f, limits, &free)?
        };
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
