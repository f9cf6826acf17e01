//! `optimally-safe` (`docs/conventions.md`): the feasible tensions farthest from every limit,
//! `argmax_t min_i min(t_i - t_min_i, t_max_i - t_i)` subject to `W t = f`
//! (Borgstrom et al. 2009; Di Paola et al. 2024, Eqs. 9-10: the robustness
//! index of [`crate::robustness`]). With equal limits for every cable this is
//! the tension vector of smallest infinity-norm distance to the box centre
//! (Di Paola et al. 2024, Remark 3.3, Eq. 11); with per-cable limits it is
//! the distance to the nearest limit, in newtons, as the robustness index.
//!
//! In null-space coordinates (`t = t_p + Z lambda`, see
//! [`crate::active_set`]) it is the linear programme in `(lambda, s)`:
//! maximise `s` subject to `slack_h(lambda) >= s` for the `2 M` limits. The
//! optimum `s*` is unique; the maximiser `lambda` need not be: when the
//! null-space rows of the critical cables are parallel, a whole segment is
//! optimal (Di Paola et al. 2024, Remark 3.2 and after Eq. 10). Our choice for
//! that tie: the point of smallest 2-norm among the maximisers (projection of
//! the origin onto `{slack_h >= max(s* - 16 tol, min(s*, 0))}`: never beyond
//! the limits, so that where `s*` is below the tie's width, at the
//! workspace border or with `f32`'s wider tolerance, every feasible point
//! is a tie), the same rule as `min-1-norm`.
//!
//! * `r = 2`, exact in a fixed number of operations: the optimum of the LP
//!   is a vertex of the 3-D polyhedron `{(lambda, s): slack_h >= s}`, i.e.
//!   three limit lines offset inwards by the same `s` meet there. Every
//!   triple of the `2 M` lines (the same cable's two limits included: a
//!   cable with a narrow range sits at its middle) is solved (a 2x2 system),
//!   and `s*` is the largest smallest slack `min_h slack_h` over these points
//!   (evaluated at each point, so that rounding of an ill-conditioned triple
//!   can only make its point look worse, never better): `C(2M, 3)` triples,
//!   the `O(M)` evaluation only for a triple whose common slack beats the best
//!   so far, `O(M^4)` in the worst case (560 triples for `M = 8`).
//! * other `r`: the primal active-set method of [`crate::active_set`] in
//!   `r + 1` unknowns from the `min-2-norm` point (whose smallest slack gives
//!   the start `s`), at most [`crate::active_set::step_cap`] `= 8 M + 8`
//!   steps ([`Error::NoConvergence`] beyond).
//!
//! Errors: [`Error::Infeasible`] when `s* < 0` beyond rounding (no tension
//! vector is within the limits: the largest smallest-slack is negative) or
//! a Farkas certificate; [`Error::NonFinite`], [`Error::Singular`],
//! [`Error::NoConvergence`].
//!
//! Continuity: **not continuous** in general (an LP); the answer jumps from
//! one end of the optimal segment to the other where the rows of the two
//! critical cables pass through parallel (see `tests/more_methods.rs`).

use nalgebra::{SVector, Vector2};

use super::{PolygonWork, PreviousCycle, Problem};
use crate::{
    active_set::{minimise_linear, project, small, Constraints, NullSpaceProblem},
    scalar::{greater, max, min},
    solution::{checked_solution, Solution, WarmStart},
    Error, Real,
};

/// Reads the null-space basis.
pub const NULL_SPACE: bool = true;

/// Starts cold every call.
pub const WARM_START: bool = false;

/// Any redundancy.
pub const fn supports(n: usize, m: usize) -> bool {
    super::any_redundancy(n, m)
}

/// The safest tensions (see the module header); no warm start.
pub fn solve<T: Real, const N: usize, const M: usize>(
    problem: &Problem<'_, T, N, M>,
    _previous: &PreviousCycle<T, M>,
    _work: &mut PolygonWork<T, N, M>,
) -> Result<Solution<T, M>, Error> {
    let Problem { f, limits, factorization: fact, .. } = *problem;
    let prob = NullSpaceProblem::new(fact, f, limits)?;
    let tol = prob.tolerance();
    let r = prob.redundancy();
    let (s_best, lambda_best, mut steps) = match if r == 2 { triples(&prob) } else { None } {
        Some((s, lambda)) => (s, lambda, 0),
        None => linear_programme(&prob)?,
    };
    if !s_best.is_finite() || s_best < -T::lit(4.0) * tol {
        return Err(Error::Infeasible);
    }
    // Tie-break: the smallest 2-norm among the (nearly) safest points,
    // never beyond the limits: where the safest point is closer to a limit
    // than the tie's width (the workspace border, or `f32`'s wider
    // tolerance), every feasible point is a tie and the set is the
    // feasible polygon itself (`s* < 0`, within rounding: the safest).
    let margin = max(s_best - T::lit(16.0) * tol, min(s_best, T::zero()));

    let lambda = match project(&Constraints::limits(&prob).with_margin(margin), &SVector::zeros(), tol) {
        Ok(p) => {
            steps += p.steps;
            p.x
        }
        // Rounding made the safest set look empty: keep the optimum found.
        Err(Error::Infeasible) => lambda_best,
        Err(e) => return Err(e),
    };
    checked_solution(&prob.tensions(&lambda), limits, tol, steps, 0, None, WarmStart::NotGiven)
}

/// Slack of limit `h` as `c - a . lambda` (`r = 2`).
fn line<T: Real, const M: usize>(prob: &NullSpaceProblem<T, M>, h: usize) -> (Vector2<T>, T) {
    let z = prob.row(h / 2);
    let n = Vector2::new(z[0], z[1]);
    let (lower, upper) = prob.offsets(h / 2);
    if h.is_multiple_of(2) {
        (-n, -lower)
    } else {
        (n, upper)
    }
}

/// `r = 2`: the best feasible vertex over every triple of limit lines;
/// `None` if no triple is well-conditioned (then the LP runs).
fn triples<T: Real, const M: usize>(prob: &NullSpaceProblem<T, M>) -> Option<(T, SVector<T, M>)> {
    let small = small::<T>();
    let mut best: Option<(T, Vector2<T>)> = None;
    for h1 in 0..2 * M {
        let (a1, c1) = line(prob, h1);
        for h2 in (h1 + 1)..2 * M {
            let (a2, c2) = line(prob, h2);
            let d2 = a2 - a1;
            let e2 = c2 - c1;
            let n2 = d2.norm_squared().sqrt_native();
            for h3 in (h2 + 1)..2 * M {
                let (a3, c3) = line(prob, h3);
                let d3 = a3 - a1;
                let e3 = c3 - c1;
                let n3 = d3.norm_squared().sqrt_native();
                // a_i . lambda + s = c_i for the three: subtract the first.
                let det = d2.x * d3.y - d2.y * d3.x;
                if !greater(det.abs(), small * n2 * n3) {
                    continue;
                }
                let lambda = Vector2::new((e2 * d3.y - e3 * d2.y) / det, (d2.x * e3 - d3.x * e2) / det);
                let s = c1 - a1.dot(&lambda);
                // The three slacks equal s, so the smallest slack is at most s.
                if best.is_some_and(|(b, _)| !greater(s, b)) || !s.is_finite() {
                    continue;
                }
                // The value of the point is its actual smallest slack (not
                // the s of the 2x2 solve): a lower bound on s* that the point
                // attains, whatever the rounding of an ill-conditioned triple.
                let mut value = s;
                for g in 0..2 * M {
                    let (a, c) = line(prob, g);
                    value = value.min(c - a.dot(&lambda));
                    if best.is_some_and(|(b, _)| !greater(value, b)) {
                        break;
                    }
                }
                if value.is_finite() && best.is_none_or(|(b, _)| value > b) {
                    best = Some((value, lambda));
                }
            }
        }
    }
    best.map(|(s, l)| (s, SVector::from_fn(|i, _| if i < 2 { l[i] } else { T::zero() })))
}

/// Any `r`: the LP in `(lambda, s)` from the `min-2-norm` point.
fn linear_programme<T: Real, const M: usize>(
    prob: &NullSpaceProblem<T, M>,
) -> Result<(T, SVector<T, M>, usize), Error> {
    let tol = prob.tolerance();
    let r = prob.redundancy();
    let start = project(&Constraints::limits(prob), &SVector::zeros(), tol)?;
    let c = Constraints::with_robustness(prob);
    // s0 = the smallest slack at the start; its limit is the active one.
    let t = prob.tensions(&start.x);
    let mut s0 = T::max_value().unwrap_or_else(T::one);
    let mut h0 = 0;
    for k in 0..M {
        let (lower, upper) = prob.offsets(k);
        let dt = t[k] - prob.particular()[k];
        for (h, slack) in [(2 * k, dt - lower), (2 * k + 1, upper - dt)] {
            if slack < s0 {
                s0 = slack;
                h0 = h;
            }
        }
    }
    let mut x0 = start.x;
    x0[r] = s0;
    let g = SVector::<T, M>::from_fn(|i, _| if i == r { -T::one() } else { T::zero() });
    let (x, steps) = minimise_linear(&c, &g, &x0, &[h0])?;
    let lambda = SVector::from_fn(|i, _| if i < r { x[i] } else { T::zero() });
    Ok((x[r], lambda, start.steps + steps))
}
