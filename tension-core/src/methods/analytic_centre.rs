//! The analytic centre of the feasible tensions (Di Paola, Goldsztejn, Zoppi
//! & Caro 2024), any degree of redundancy `r = M - N >= 0`.
//!
//! It minimises the weighted logarithmic barrier (their Eq. 13)
//!
//! `phi(t) = -sum_i (c_lo_i log(t_i - t_min_i) + c_hi_i log(t_max_i - t_i)) - sum_j c_j log(-g_j(t))`
//!
//! subject to `W t = f`, by Newton's method (their Algorithm 1, after Boyd &
//! Vandenberghe Sect. 10.2-10.3) in null-space coordinates: with `Z` the
//! orthonormal null-space basis, the step is `dt = W^+ (f - W t) + Z dl`,
//! `(Z^T H Z) dl = -Z^T (grad + H W^+ (f - W t))`. The stopping rule is the
//! norm of the optimality conditions (their Eq. 15): with the multipliers
//! eliminated, `|Z^T grad phi|` (made dimensionless by the half-range of the
//! limits, and never below the rounding floor `64 eps |grad phi| + eps |H t|`,
//! the larger one close to a limit: the gradient's own rounding and that of
//! the iterate, one ulp of each tension, through the box Hessian `H`) and
//! `W t = f`. Each line search halves the
//! step at most 24 times.
//!
//! **Start.** Newton needs a point strictly inside the domain (the box and
//! `g_j < 0`), not necessarily on `W t = f` (their footnote 8). Tried in
//! order: the warm start projected onto `W t = f`, the warm start itself, the
//! closed-form solution (`t_m` projected, Pott 2009), the box centre `t_m`,
//! then `t_min + theta (t_max - t_min)` for `theta = 1/4, 1/10, 1/30, 1/100`
//! (extra constraints such as friction usually bound tensions from above).
//! While `W t != f`, steps are cut to 99 % of the way to the box boundary;
//! the first full step lands on `W t = f` and from then on a backtracking
//! (Armijo) line search on `phi` keeps every iterate in the domain.
//!
//! **Infeasible poses.** If the iterates cannot reach `W t = f` (the box
//! cuts four infeasible-start steps in a row below `1e-3` of the Newton
//! step, or the iterations run out), the exact minimum-norm search of
//! [`super::min_2_norm`] (the feasible polygon for `r = 2`, a dual active set
//! with a Farkas certificate otherwise; bounded) decides: no tensions
//! ([`Error::Infeasible`]) or tensions Newton could not centre
//! ([`Error::NoConvergence`]). Should it fail itself, a bounded
//! projected-gradient search for `min |W t - f|` over the box looks for a
//! Farkas certificate `y`: `sum_i max(y.w_i t_min_i, y.w_i t_max_i) < y.f`
//! proves that no tension in the box balances the wrench.

use nalgebra::{SMatrix, SVector};

use super::{PolygonWork, PreviousCycle, Problem};
use crate::{
    tolerance,
    linalg::{cholesky_solve_leading, WrenchFactorization},
    scalar::{finite, greater},
    solution::{robustness, Diagnostics, Solution, WarmStart},
    Error, Real, TensionLimits,
};

/// A smooth convex constraint `g(t) < 0` on the tensions (Di Paola et al.
/// 2024, Sect. 4.1, set `C`), e.g. friction of a mobile base (their Eq. 19).
/// Implementations must return finite values for finite `t`.
pub trait ConvexConstraint<T: Real, const M: usize> {
    /// `g(t)`; the constraint holds where it is negative.
    fn value(&self, t: &SVector<T, M>) -> T;
    /// `grad g(t)`.
    fn gradient(&self, t: &SVector<T, M>) -> SVector<T, M>;
    /// `hess g(t)` (positive semi-definite for a convex `g`).
    fn hessian(&self, t: &SVector<T, M>) -> SMatrix<T, M, M>;
    /// Barrier weight `c_j > 0` (their Eq. 13); 1 by default.
    fn weight(&self) -> T {
        T::one()
    }
}

/// Barrier weights per bound (`c_lo_i`, `c_hi_i` of Di Paola et al. 2024,
/// Eq. 13): raising one pushes the centre away from that bound.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BarrierWeights<T: Real, const M: usize> {
    lower: SVector<T, M>,
    upper: SVector<T, M>,
}

impl<T: Real, const M: usize> BarrierWeights<T, M> {
    /// Every weight 1: the plain analytic centre (their Eq. 12).
    pub fn uniform() -> Self {
        Self { lower: SVector::repeat(T::one()), upper: SVector::repeat(T::one()) }
    }

    /// Weights for the lower and upper bounds; each must be finite and `> 0`.
    pub fn new(lower: SVector<T, M>, upper: SVector<T, M>) -> Result<Self, Error> {
        if !(finite(lower.as_slice()) && finite(upper.as_slice())) {
            return Err(Error::NonFinite);
        }
        if lower.iter().chain(upper.iter()).any(|&c| c <= T::zero()) {
            return Err(Error::InvalidLimits);
        }
        Ok(Self { lower, upper })
    }
}

impl<T: Real, const M: usize> Default for BarrierWeights<T, M> {
    fn default() -> Self {
        Self::uniform()
    }
}

/// Stopping rule and iteration cap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AnalyticCentreSettings<T: Real> {
    /// Stop when `|Z^T grad phi| * min_i (t_max_i - t_min_i) / 2` is below
    /// this (dimensionless). Default: `max(1e-10, 1000 eps)`, i.e. `1e-10`
    /// in `f64` (the paper's Table 1) and `1.2e-4` in `f32`.
    pub tolerance: T,
    /// Newton iterations at most. Default 50 (the paper reports at most 7).
    pub max_iterations: u8,
}

impl<T: Real> Default for AnalyticCentreSettings<T> {
    fn default() -> Self {
        Self { tolerance: tolerance::analytic_centre_default(), max_iterations: 50 }
    }
}

/// The analytic-centre problem: weights, extra constraints and settings.
#[derive(Clone, Copy)]
pub struct AnalyticCentre<'a, T: Real, const M: usize> {
    /// Barrier weights per bound.
    pub weights: BarrierWeights<T, M>,
    /// Extra constraints `g_j(t) < 0`.
    pub constraints: &'a [&'a dyn ConvexConstraint<T, M>],
    /// Stopping rule and cap.
    pub settings: AnalyticCentreSettings<T>,
}

impl<T: Real, const M: usize> Default for AnalyticCentre<'_, T, M> {
    fn default() -> Self {
        Self {
            weights: BarrierWeights::uniform(),
            constraints: &[],
            settings: AnalyticCentreSettings::default(),
        }
    }
}

/// Reads the null-space basis.
pub const NULL_SPACE: bool = true;

/// Uses the previous cycle's solution (`PreviousCycle`).
pub const WARM_START: bool = true;

/// Any redundancy.
pub const fn supports(n: usize, m: usize) -> bool {
    super::any_redundancy(n, m)
}

/// `analytic-centre` with unit weights, no extra constraint and the default
/// settings, warm-started from `previous.tensions`.
pub fn solve<T: Real, const N: usize, const M: usize>(
    problem: &Problem<'_, T, N, M>,
    previous: &PreviousCycle<T, M>,
    _work: &mut PolygonWork<T, N, M>,
) -> Result<Solution<T, M>, Error> {
    AnalyticCentre::default().solve(problem, previous.tensions.as_ref())
}

/// Infeasible-start steps shorter than this, [`STUCK_LIMIT`] times in a row,
/// mean the box stops the iterates short of `W t = f` (their residual
/// shrinks by `1 - s` per step): the infeasibility decision takes over.
const STUCK_STEP: f64 = 1.0e-3;
/// See [`STUCK_STEP`].
const STUCK_LIMIT: u32 = 4;
/// Halvings of one line search at most.
const LINE_SEARCH_HALVINGS: usize = 24;

/// The terms of one Newton iteration at `t`.
struct NewtonTerms<T: Real, const M: usize> {
    /// `grad phi(t)`.
    grad: SVector<T, M>,
    /// The diagonal box Hessian.
    box_hessian: SVector<T, M>,
    /// `H step_p`, `step_p = W^+ (f - W t)`.
    h_step_p: SVector<T, M>,
    /// `|Z^T grad phi|`.
    reduced_grad_norm: T,
}

impl<T: Real, const M: usize> AnalyticCentre<'_, T, M> {
    /// Solves for the analytic centre of `W t = f` within the limits and the
    /// extra constraints, from `start` (the previous cycle's tensions) when
    /// it can (see the module header).
    pub fn solve<const N: usize>(
        &self,
        problem: &Problem<'_, T, N, M>,
        start: Option<&SVector<T, M>>,
    ) -> Result<Solution<T, M>, Error> {
        let Problem { w, f, limits, factorization: fact } = *problem;
        if !finite(f.as_slice()) {
            return Err(Error::NonFinite);
        }
        if let Some(s) = start {
            if !finite(s.as_slice()) {
                return Err(Error::NonFinite);
            }
        }
        if !greater(self.settings.tolerance, T::zero()) {
            return Err(Error::InvalidLimits);
        }
        let half_range = (0..M)
            .map(|i| (limits.max()[i] - limits.min()[i]) * T::lit(0.5))
            .fold(T::max_value().unwrap_or_else(T::one), |a, b| a.min(b));
        let (mut t, warm_start) = self.start_point(problem, start)?;

        let f_scale = f.amax() + w.amax() * limits.scale();
        let eq_tol = tolerance::equality(f_scale);
        let mut on_sigma = (f - w * t).amax() <= eq_tol;
        let mut hr: SMatrix<T, M, M> = SMatrix::zeros();
        let mut stuck = 0;
        for iteration in 0..=self.settings.max_iterations {
            let step_p = fact.min_norm_solution(&(f - w * t));
            let terms = self.newton_terms(fact, &t, &step_p, limits, &mut hr);
            // Never below the rounding floor of the gradient: close to a limit
            // its terms are large, and so is their rounding (64 eps |grad|),
            // and the iterate itself is known to one ulp of each tension,
            // which moves the gradient by the Hessian times that (eps |H t|).
            let hessian_iterate = terms.box_hessian.component_mul(&t).norm_squared().sqrt_native();
            let rounding =
                tolerance::gradient_rounding(terms.grad.norm_squared().sqrt_native(), hessian_iterate) * half_range;
            if on_sigma && terms.reduced_grad_norm * half_range <= self.settings.tolerance.max(rounding) {
                // Limits near the largest float can put W t beyond it: such
                // a result cannot be checked, so it is not returned.
                let residual = f - w * t;
                if !finite(t.as_slice()) || !finite(residual.as_slice()) {
                    return Err(Error::NonFinite);
                }
                // `on_sigma` allows the rounding of the terms of `W t`; the
                // answer meets `W t = f` to the rounding of the solve. Should
                // that leave the limits (a start that was only near the
                // solutions, e.g. the unique one of `m = n` out of the box),
                // the infeasibility decision settles it.
                t += fact.min_norm_solution(&residual);
                if !self.in_domain(&t, limits) {
                    on_sigma = false;
                    break;
                }
                return Ok(Solution {
                    tensions: t,
                    robustness: robustness(&t, limits),
                    diagnostics: Diagnostics { iterations: iteration, warm_start, ..Diagnostics::empty() },
                });
            }
            if iteration == self.settings.max_iterations {
                break;
            }
            // A reduced Hessian that rounding made indefinite (huge barrier
            // terms near a limit, in f32) says nothing about `W`: the
            // iteration stops and the infeasibility decision settles it.
            let Ok(step) = newton_step(fact, &terms, step_p, &mut hr) else { break };
            let Some(s) = self.line_search(&mut t, &step, &terms.grad, limits, on_sigma) else { break };
            if !on_sigma {
                stuck = if s < T::lit(STUCK_STEP) { stuck + 1 } else { 0 };
                if stuck >= STUCK_LIMIT {
                    break;
                }
            }
            if !on_sigma && s == T::one() {
                on_sigma = true;
                t = t + fact.min_norm_solution(&(f - w * t));
                if !self.in_domain(&t, limits) {
                    break;
                }
            }
        }
        if on_sigma {
            Err(Error::NoConvergence)
        } else {
            Err(decide_infeasible(problem, &t))
        }
    }

    /// A point strictly inside the domain, on `W t = f` if possible (the
    /// order of the module header), and whether the warm start gave it.
    fn start_point<const N: usize>(
        &self,
        problem: &Problem<'_, T, N, M>,
        start: Option<&SVector<T, M>>,
    ) -> Result<(SVector<T, M>, WarmStart), Error> {
        let Problem { w, f, limits, factorization: fact } = *problem;
        let project = |t: &SVector<T, M>| t + fact.min_norm_solution(&(f - w * t));
        let middle = limits.middle();
        let mut candidates: [Option<SVector<T, M>>; 8] = [None; 8];
        if let Some(s) = start {
            candidates[0] = Some(project(s));
            candidates[1] = Some(*s);
        }
        candidates[2] = Some(project(&middle));
        candidates[3] = Some(middle);
        for (slot, theta) in candidates[4..].iter_mut().zip([0.25, 0.1, 1.0 / 30.0, 0.01]) {
            *slot = Some(limits.min() + (limits.max() - limits.min()) * T::lit(theta));
        }
        let (chosen, t) = candidates
            .iter()
            .enumerate()
            .find_map(|(k, c)| c.filter(|c| self.in_domain(c, limits)).map(|c| (k, c)))
            .ok_or(Error::NoConvergence)?;
        let warm_start = match start {
            None => WarmStart::NotGiven,
            Some(_) if chosen <= 1 => WarmStart::Held,
            Some(_) => WarmStart::Lost,
        };
        Ok((t, warm_start))
    }

    /// Gradient, `H step_p` and the constraints' part of the reduced Hessian
    /// `Z^T H Z` (into `hr`, cleared first), each user callback evaluated
    /// once.
    #[inline(never)]
    fn newton_terms<const N: usize>(
        &self,
        fact: &WrenchFactorization<T, N, M>,
        t: &SVector<T, M>,
        step_p: &SVector<T, M>,
        limits: &TensionLimits<T, M>,
        hr: &mut SMatrix<T, M, M>,
    ) -> NewtonTerms<T, M> {
        let r = M - N;
        let box_hessian = self.box_hessian(t, limits);
        let mut grad = self.box_gradient(t, limits);
        let mut h_step_p = box_hessian.component_mul(step_p);
        hr.fill(T::zero());
        for c in self.constraints {
            let g = c.value(t);
            let dg = c.gradient(t);
            let d2g = c.hessian(t);
            let weight = c.weight();
            grad += dg * (weight / -g);
            h_step_p += dg * (weight * dg.dot(step_p) / (g * g)) - d2g * step_p * (weight / g);
            let mut zdg: SVector<T, M> = SVector::zeros();
            for a in 0..r {
                for i in 0..M {
                    zdg[a] += fact.null(i, a) * dg[i];
                }
            }
            for a in 0..r {
                for b in 0..=a {
                    let mut zhz = T::zero();
                    for i in 0..M {
                        for j in 0..M {
                            zhz += fact.null(i, a) * d2g[(i, j)] * fact.null(j, b);
                        }
                    }
                    hr[(a, b)] += weight * (zdg[a] * zdg[b] / (g * g) - zhz / g);
                }
            }
        }
        let mut s = T::zero();
        for a in 0..r {
            let mut za = T::zero();
            for i in 0..M {
                za += fact.null(i, a) * grad[i];
            }
            s += za * za;
        }
        NewtonTerms { grad, box_hessian, h_step_p, reduced_grad_norm: s.sqrt_native() }
    }

    /// Backtracking along `step` from `t`: the step is first cut to 99 % of
    /// the way to the box boundary, then halved (at most
    /// [`LINE_SEARCH_HALVINGS`] times) until the trial is in the domain and,
    /// on `W t = f`, decreases the barrier enough (Armijo). Moves `t` and
    /// returns the step length, or `None` when no trial was accepted.
    fn line_search(
        &self,
        t: &mut SVector<T, M>,
        step: &SVector<T, M>,
        grad: &SVector<T, M>,
        limits: &TensionLimits<T, M>,
        on_sigma: bool,
    ) -> Option<T> {
        let mut s_max = T::max_value().unwrap_or_else(T::one);
        for i in 0..M {
            if step[i] > T::zero() {
                s_max = s_max.min((limits.max()[i] - t[i]) / step[i]);
            } else if step[i] < T::zero() {
                s_max = s_max.min((limits.min()[i] - t[i]) / step[i]);
            }
        }
        let mut s = if s_max > T::one() { T::one() } else { T::lit(0.99) * s_max };
        let slope = grad.dot(step);
        let phi0 = self.barrier(t, limits);
        let small_decrement = -slope < T::lit(1.0e-3);
        for _ in 0..LINE_SEARCH_HALVINGS {
            let trial = *t + step * s;
            if self.in_domain(&trial, limits)
                && (!on_sigma || small_decrement || self.barrier(&trial, limits) <= phi0 + T::lit(0.25) * s * slope)
            {
                *t = trial;
                return Some(s);
            }
            s *= T::lit(0.5);
        }
        None
    }

    fn in_domain(&self, t: &SVector<T, M>, limits: &TensionLimits<T, M>) -> bool {
        finite(t.as_slice())
            && (0..M).all(|i| t[i] > limits.min()[i] && t[i] < limits.max()[i])
            && self.constraints.iter().all(|c| c.value(t) < T::zero())
    }

    fn barrier(&self, t: &SVector<T, M>, limits: &TensionLimits<T, M>) -> T {
        let mut phi = T::zero();
        for i in 0..M {
            phi -= self.weights.lower[i] * (t[i] - limits.min()[i]).ln()
                + self.weights.upper[i] * (limits.max()[i] - t[i]).ln();
        }
        for c in self.constraints {
            phi -= c.weight() * (-c.value(t)).ln();
        }
        phi
    }

    /// Gradient of the limits' barrier terms.
    fn box_gradient(&self, t: &SVector<T, M>, limits: &TensionLimits<T, M>) -> SVector<T, M> {
        SVector::from_fn(|i, _| {
            -self.weights.lower[i] / (t[i] - limits.min()[i])
                + self.weights.upper[i] / (limits.max()[i] - t[i])
        })
    }

    fn box_hessian(&self, t: &SVector<T, M>, limits: &TensionLimits<T, M>) -> SVector<T, M> {
        SVector::from_fn(|i, _| {
            let lo = t[i] - limits.min()[i];
            let hi = limits.max()[i] - t[i];
            self.weights.lower[i] / (lo * lo) + self.weights.upper[i] / (hi * hi)
        })
    }
}

/// The Newton step `step_p + Z dl` with `(Z^T H Z) dl = -Z^T (grad + H step_p)`
/// (`hr` holds the constraints' part of `Z^T H Z` on entry).
#[inline(never)]
fn newton_step<T: Real, const N: usize, const M: usize>(
    fact: &WrenchFactorization<T, N, M>,
    terms: &NewtonTerms<T, M>,
    step_p: SVector<T, M>,
    hr: &mut SMatrix<T, M, M>,
) -> Result<SVector<T, M>, Error> {
    let r = M - N;
    let mut rhs: SVector<T, M> = SVector::zeros();
    for a in 0..r {
        let mut s = T::zero();
        for i in 0..M {
            s += fact.null(i, a) * (terms.grad[i] + terms.h_step_p[i]);
        }
        rhs[a] = -s;
        for b in 0..=a {
            let mut s = T::zero();
            for i in 0..M {
                s += fact.null(i, a) * terms.box_hessian[i] * fact.null(i, b);
            }
            hr[(a, b)] += s;
        }
    }
    for a in 0..r {
        for b in 0..a {
            hr[(b, a)] = hr[(a, b)];
        }
    }
    cholesky_solve_leading(hr, &mut rhs, r)?;
    let mut step = step_p;
    for i in 0..M {
        for a in 0..r {
            step[i] += fact.null(i, a) * rhs[a];
        }
    }
    if finite(step.as_slice()) {
        Ok(step)
    } else {
        Err(Error::NonFinite)
    }
}

/// Newton could not reach `W t = f` (last iterate `t`): the minimum-norm
/// tensions within the limits, found exactly in a bounded number of steps
/// (the polygon for `r = 2`, a dual active set otherwise), settle whether any
/// exist; should that search fail, a Farkas certificate from `t` or the box
/// centre. [`Error::Infeasible`] only with a proof.
fn decide_infeasible<T: Real, const N: usize, const M: usize>(problem: &Problem<'_, T, N, M>, t: &SVector<T, M>) -> Error {
    let Problem { w, f, limits, .. } = *problem;
    match super::min_2_norm::smallest(problem, &PreviousCycle::NONE) {
        Err(Error::Infeasible) => return Error::Infeasible,
        // Feasible tensions exist; Newton could not centre them.
        Ok(_) => return Error::NoConvergence,
        Err(_) => {}
    }
    if certify_infeasible(w, f, limits, t) || certify_infeasible(w, f, limits, &limits.middle()) {
        Error::Infeasible
    } else {
        Error::NoConvergence
    }
}

/// A Farkas certificate that `W t = f` has no solution in the box, searched
/// by at most 64 projected-gradient steps on `|W t - f|^2` from `t0`.
fn certify_infeasible<T: Real, const N: usize, const M: usize>(
    w: &SMatrix<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
    t0: &SVector<T, M>,
) -> bool {
    let clamp =
        |t: SVector<T, M>| SVector::<T, M>::from_fn(|i, _| t[i].max(limits.min()[i]).min(limits.max()[i]));
    let lipschitz = w.norm_squared();
    if !greater(lipschitz, T::zero()) {
        return false;
    }
    let mut t = clamp(*t0);
    for _ in 0..64 {
        let y = f - w * t;
        if !finite(y.as_slice()) {
            return false;
        }
        let mut support = T::zero();
        let mut magnitude = y.dot(f).abs();
        for i in 0..M {
            let p = y.dot(&w.column(i));
            support += if p > T::zero() { p * limits.max()[i] } else { p * limits.min()[i] };
            magnitude += p.abs() * limits.max()[i];
        }
        if support < y.dot(f) - tolerance::equality(magnitude) {
            return true;
        }
        t = clamp(t + w.transpose() * y / lipschitz);
    }
    false
}
