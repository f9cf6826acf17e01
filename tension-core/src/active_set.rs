//! Small dense active-set solvers on the null-space coordinates of the
//! tension problem, for any degree of redundancy `r = M - N`: the engine of
//! `min-2-norm`, `min-1-norm` and `optimally-safe` when `r != 2` (and of the
//! tie-breaks of the latter two for every `r`).
//!
//! With the minimum-norm particular solution `t_p = W^+ f` and an orthonormal
//! null-space basis `Z` (`M x r`, [`WrenchFactorization`]), every solution of
//! `W t = f` is `t = t_p + Z lambda` and the limits are the `2 M` half-spaces
//! (Lamaury & Gouttefarde 2013, Eq. 5, for any `r`)
//!
//! * lower limit of cable `k` (index `2 k`): `-z_k . lambda <= t_p,k - t_min,k`,
//! * upper limit of cable `k` (index `2 k + 1`): `z_k . lambda <= t_max,k - t_p,k`,
//!
//! with `z_k` row `k` of `Z`. Because `t_p` is orthogonal to the null space,
//! `|t|^2 = |t_p|^2 + |lambda|^2`.
//!
//! Two solvers, both allocation-free and with an iteration cap:
//! * [`project`]: the point of a polyhedron closest to a target, by the dual
//!   active-set method of Goldfarb & Idnani (1983) with the identity as
//!   Hessian. It starts from the unconstrained minimiser and adds one violated
//!   constraint at a time, dropping an active one whenever its multiplier
//!   would turn negative; the dual objective grows strictly, so no active set
//!   repeats. A violated constraint that is a non-positive combination of the
//!   active ones is a Farkas certificate: [`Error::Infeasible`].
//! * [`minimise_linear`]: a linear objective from a feasible start, by the
//!   primal active-set (simplex-like) method: move along the negative
//!   gradient projected on the active constraints until a constraint blocks
//!   (add it), or, where the projection vanishes, drop the active constraint
//!   with a negative multiplier. Ties are broken by the lowest constraint index
//!   (Bland's rule), which excludes cycling on degenerate vertices.
//!
//! Each step rebuilds the orthonormal basis of the active normals (classical
//! Gram-Schmidt applied twice), `O(d^2 M)` with `d <= M` the dimension, and
//! tests the `2 M + 1` constraints, `O(d M)`. Both solvers stop with
//! [`Error::NoConvergence`] after [`step_cap`] steps.

use nalgebra::{SMatrix, SVector};

use crate::{
    linalg::WrenchFactorization,
    scalar::{finite, greater},
    tolerance, Error, Real, TensionLimits,
};

/// Step cap of [`project`] and [`minimise_linear`]: `8 M + 8` steps (additions
/// plus drops). Each added constraint is followed by at most `d <= M` drops
/// and a vertex has at most `d` active constraints. On the property tests
/// (`M` up to 8, `r` from 0 to 4) no method call needed more than `4.4 M`
/// steps in total over its (up to three) runs.
pub const fn step_cap(m: usize) -> usize {
    8 * m + 8
}

/// The tension problem in null-space coordinates, `t = t_p + Z lambda`.
#[derive(Debug, Clone)]
pub struct NullSpaceProblem<T: Real, const M: usize> {
    particular: SVector<T, M>,
    /// Null-space basis in columns `0..r`, zero elsewhere.
    z: SMatrix<T, M, M>,
    lower: SVector<T, M>,
    upper: SVector<T, M>,
    r: usize,
    tol: T,
}

impl<T: Real, const M: usize> NullSpaceProblem<T, M> {
    /// `t_p = W^+ f`, the basis, and the offsets `t_min - t_p`, `t_max - t_p`.
    /// Errors: [`Error::NonFinite`] for a non-finite `f` or an overflow.
    pub fn new<const N: usize>(
        fact: &WrenchFactorization<T, N, M>,
        f: &SVector<T, N>,
        limits: &TensionLimits<T, M>,
    ) -> Result<Self, Error> {
        if !finite(f.as_slice()) {
            return Err(Error::NonFinite);
        }
        let particular = fact.min_norm_solution(f);
        let r = fact.redundancy();
        let z = SMatrix::<T, M, M>::from_fn(|i, k| if k < r { fact.null(i, k) } else { T::zero() });
        let lower = limits.min() - particular;
        let upper = limits.max() - particular;
        if !(finite(particular.as_slice()) && finite(lower.as_slice()) && finite(upper.as_slice())) {
            return Err(Error::NonFinite);
        }
        // Relative to the offsets only, as the polygon's (no floor of 1 N).
        let mut scale = T::zero();
        for k in 0..M {
            scale = scale.max(lower[k].abs()).max(upper[k].abs());
        }
        let tol = tolerance::slack(scale);
        Ok(Self { particular, z, lower, upper, r, tol })
    }

    /// The degree of redundancy `r`.
    pub fn redundancy(&self) -> usize {
        self.r
    }

    /// Slack tolerance, tension units.
    pub fn tolerance(&self) -> T {
        self.tol
    }

    /// `t_p`.
    pub fn particular(&self) -> &SVector<T, M> {
        &self.particular
    }

    /// Row `k` of `Z` as a vector of `M` entries (zero beyond `r`).
    pub fn row(&self, k: usize) -> SVector<T, M> {
        self.z.row(k).transpose()
    }

    /// `t_min_k - t_p,k` and `t_max_k - t_p,k`.
    pub fn offsets(&self, k: usize) -> (T, T) {
        (self.lower[k], self.upper[k])
    }

    /// Tensions `t_p + Z lambda` (the first `r` entries of `lambda`).
    pub fn tensions(&self, lambda: &SVector<T, M>) -> SVector<T, M> {
        let mut t = self.particular;
        for k in 0..self.r {
            t += self.z.column(k) * lambda[k];
        }
        t
    }

    /// `sum_k z_k`, the gradient of `sum_i t_i` in `lambda`.
    pub fn sum_gradient(&self) -> SVector<T, M> {
        let mut g = SVector::<T, M>::zeros();
        for k in 0..M {
            g += self.row(k);
        }
        g
    }
}

/// The half-spaces of a [`NullSpaceProblem`], optionally
/// * with one more coordinate `s` (index `r`) that every slack must exceed,
///   `slack_h(lambda) >= s` (optimally safe, Borgstrom et al. 2009);
/// * with every slack at least `margin` (tension units);
/// * with one extra half-space `a . x <= b` (index `2 M`), `|a| = 1`.
#[derive(Debug, Clone, Copy)]
pub struct Constraints<'a, T: Real, const M: usize> {
    problem: &'a NullSpaceProblem<T, M>,
    with_s: bool,
    margin: T,
    extra: Option<(SVector<T, M>, T)>,
}

impl<'a, T: Real, const M: usize> Constraints<'a, T, M> {
    /// The limits alone, in `lambda` (dimension `r`).
    pub fn limits(problem: &'a NullSpaceProblem<T, M>) -> Self {
        Self { problem, with_s: false, margin: T::zero(), extra: None }
    }

    /// The limits with the robustness variable `s` (dimension `r + 1`).
    pub fn with_robustness(problem: &'a NullSpaceProblem<T, M>) -> Self {
        Self { with_s: true, ..Self::limits(problem) }
    }

    /// Every slack at least `margin`.
    pub fn with_margin(self, margin: T) -> Self {
        Self { margin, ..self }
    }

    /// One more half-space `a . x <= b`; `a` is normalised here. A zero `a`
    /// adds nothing.
    pub fn with_extra(self, a: &SVector<T, M>, b: T) -> Self {
        let n = length(a);
        if !greater_than_zero(n) {
            return self;
        }
        Self { extra: Some((a / n, b / n)), ..self }
    }

    /// Dimension of `x`: `r`, or `r + 1` with `s`.
    pub fn dim(&self) -> usize {
        self.problem.r + usize::from(self.with_s)
    }

    fn count(&self) -> usize {
        2 * M + usize::from(self.extra.is_some())
    }

    fn normal(&self, h: usize) -> SVector<T, M> {
        if h >= 2 * M {
            return self.extra.map(|(a, _)| a).unwrap_or_else(SVector::zeros);
        }
        let mut a = self.problem.row(h / 2);
        if h.is_multiple_of(2) {
            a = -a;
        }
        if self.with_s {
            a[self.problem.r] = T::one();
        }
        a
    }

    fn offset(&self, h: usize) -> T {
        if h >= 2 * M {
            return self.extra.map(|(_, b)| b).unwrap_or_else(T::zero);
        }
        let k = h / 2;
        let b = if h.is_multiple_of(2) { -self.problem.lower[k] } else { self.problem.upper[k] };
        b - self.margin
    }

    /// `a_h . x - b_h` (positive: violated).
    fn violation(&self, h: usize, x: &SVector<T, M>) -> T {
        self.normal(h).dot(x) - self.offset(h)
    }
}

/// The result of [`project`]: the point, its active constraints, the steps.
#[derive(Debug, Clone, Copy)]
pub struct Projected<T: Real, const M: usize> {
    /// The closest point (first `dim` entries).
    pub x: SVector<T, M>,
    /// Active constraint indices, `active[..active_len]`.
    pub active: [usize; M],
    /// Number of active constraints.
    pub active_len: usize,
    /// Additions plus drops.
    pub steps: usize,
}

/// Orthonormal basis `q_1..q_len` of the active normals, `N = Q R`.
struct Basis<T: Real, const M: usize> {
    q: [SVector<T, M>; M],
    r: SMatrix<T, M, M>,
    len: usize,
}

impl<T: Real, const M: usize> Basis<T, M> {
    fn new(c: &Constraints<'_, T, M>, active: &[usize]) -> Result<Self, Error> {
        let mut basis = Self { q: [SVector::zeros(); M], r: SMatrix::zeros(), len: 0 };
        for (i, &h) in active.iter().enumerate().take(M) {
            let a = c.normal(h);
            let (z, coef) = basis.split(&a);
            let nz = length(&z);
            if !greater(nz, small::<T>() * length(&a)) {
                return Err(Error::NoConvergence);
            }
            for j in 0..i {
                basis.r[(j, i)] = coef[j];
            }
            basis.r[(i, i)] = nz;
            basis.q[i] = z / nz;
            basis.len = i + 1;
        }
        Ok(basis)
    }

    /// `v = Q c + z` with `z` orthogonal to the basis (Gram-Schmidt twice).
    fn split(&self, v: &SVector<T, M>) -> (SVector<T, M>, SVector<T, M>) {
        let mut z = *v;
        let mut c = SVector::<T, M>::zeros();
        for _ in 0..2 {
            for j in 0..self.len {
                let cj = self.q[j].dot(&z);
                c[j] += cj;
                z -= self.q[j] * cj;
            }
        }
        (z, c)
    }

    /// `y` with `R y = c` (back substitution): `v = N y + z`.
    fn coefficients(&self, c: &SVector<T, M>) -> SVector<T, M> {
        let mut y = SVector::<T, M>::zeros();
        for i in (0..self.len).rev() {
            let mut s = c[i];
            for j in (i + 1)..self.len {
                s -= self.r[(i, j)] * y[j];
            }
            y[i] = s / self.r[(i, i)];
        }
        y
    }
}

/// The point of `{x : a_h . x <= b_h}` closest to `target` (Euclidean, in the
/// first `dim` coordinates), by the dual active-set method of Goldfarb &
/// Idnani (1983) with identity Hessian. Constraints violated by no more
/// than `tol` count as satisfied.
///
/// Errors: [`Error::Infeasible`] with a Farkas certificate (a violated
/// constraint whose normal is a non-positive combination of active normals);
/// [`Error::NoConvergence`] after [`step_cap`] steps or on a numerical
/// anomaly (a non-finite step).
pub fn project<T: Real, const M: usize>(
    c: &Constraints<'_, T, M>,
    target: &SVector<T, M>,
    tol: T,
) -> Result<Projected<T, M>, Error> {
    let dim = c.dim();
    let mut x = SVector::<T, M>::from_fn(|i, _| if i < dim { target[i] } else { T::zero() });
    let mut active = [0usize; M];
    let mut u = [T::zero(); M];
    let mut len = 0usize;
    let mut steps = 0usize;
    let cap = step_cap(M);
    let small = small::<T>();
    loop {
        // The most violated constraint (NaN never compares greater).
        let mut p = None;
        let mut worst = tol;
        for h in 0..c.count() {
            if active[..len].contains(&h) {
                continue;
            }
            let v = c.violation(h, &x);
            if v > worst {
                worst = v;
                p = Some(h);
            }
        }
        let Some(p) = p else {
            if !finite(x.as_slice()) {
                return Err(Error::NoConvergence);
            }
            return Ok(Projected { x, active, active_len: len, steps });
        };
        let a = c.normal(p);
        let a_len = length(&a);
        let mut u_p = T::zero();
        loop {
            steps += 1;
            if steps > cap {
                return Err(Error::NoConvergence);
            }
            let basis = Basis::new(c, &active[..len])?;
            let (z, coef) = basis.split(&a);
            let r = basis.coefficients(&coef);
            // Largest dual step before an active multiplier reaches zero.
            let mut t_dual = None;
            let mut drop = 0;
            for i in 0..len {
                if r[i] > small * a_len {
                    let ratio = u[i] / r[i];
                    if t_dual.is_none_or(|t| ratio < t) {
                        t_dual = Some(ratio);
                        drop = i;
                    }
                }
            }
            let zz = z.norm_squared();
            let dependent = !greater(zz.sqrt_native(), small * a_len);
            let t_full = if dependent { None } else { Some(c.violation(p, &x) / zz) };
            let (t, full) = match (t_full, t_dual) {
                (None, None) => return Err(Error::Infeasible),
                (Some(tf), Some(td)) if td < tf => (td, false),
                (Some(tf), _) => (tf, true),
                (None, Some(td)) => (td, false),
            };
            if !t.is_finite() {
                return Err(Error::NoConvergence);
            }
            let t = t.max(T::zero());
            if !dependent {
                x -= z * t;
            }
            for i in 0..len {
                u[i] -= r[i] * t;
            }
            u_p += t;
            if full {
                active[len] = p;
                u[len] = u_p;
                len += 1;
                break;
            }
            // Drop the blocking constraint (its multiplier is now zero).
            for i in drop..len - 1 {
                active[i] = active[i + 1];
                u[i] = u[i + 1];
            }
            len -= 1;
        }
    }
}

/// Minimises `g . x` over `{x : a_h . x <= b_h}` from a feasible `x0` whose
/// constraints `start` are active with linearly independent normals, by the
/// primal active-set method with Bland's rule (see the module header).
/// Returns the optimal point and the steps taken.
///
/// Errors: [`Error::NoConvergence`] after [`step_cap`] steps, if the
/// objective is unbounded (impossible for the bounded tension problems), or
/// on a non-finite step.
pub fn minimise_linear<T: Real, const M: usize>(
    c: &Constraints<'_, T, M>,
    g: &SVector<T, M>,
    x0: &SVector<T, M>,
    start: &[usize],
) -> Result<(SVector<T, M>, usize), Error> {
    let small = small::<T>();
    // Stationarity is decided at rounding level (not at `small`, 5e-3 in
    // f32, which would stop on a slowly improving edge).
    let flat = tolerance::stationary::<T>();
    let mut x = *x0;
    let mut active = [0usize; M];
    let mut len = start.len().min(M).min(c.dim());
    active[..len].copy_from_slice(&start[..len]);
    let g_len = length(g);
    for steps in 1..=step_cap(M) {
        let basis = Basis::new(c, &active[..len])?;
        let (pz, coef) = basis.split(g);
        let pz_len = length(&pz);
        if pz_len > flat * g_len {
            // Move along -pz until the first constraint blocks.
            let dir = -pz;
            let mut best: Option<(T, usize)> = None;
            for h in 0..c.count() {
                if active[..len].contains(&h) {
                    continue;
                }
                let a = c.normal(h);
                let ad = a.dot(&dir);
                if ad > small * length(&a) * pz_len {
                    let slack = (c.offset(h) - a.dot(&x)).max(T::zero());
                    let alpha = slack / ad;
                    if best.is_none_or(|(b, _)| alpha < b) {
                        best = Some((alpha, h));
                    }
                }
            }
            let Some((alpha, h)) = best else {
                return Err(Error::NoConvergence);
            };
            x += dir * alpha;
            if !finite(x.as_slice()) {
                return Err(Error::NoConvergence);
            }
            active[len] = h;
            len += 1;
        } else {
            // g = N y: multipliers u = -y must be non-negative.
            let y = basis.coefficients(&coef);
            let mut drop: Option<usize> = None;
            for i in 0..len {
                if -y[i] < -flat * g_len && drop.is_none_or(|d| active[i] < active[d]) {
                    drop = Some(i);
                }
            }
            let Some(d) = drop else {
                return Ok((x, steps));
            };
            for i in d..len - 1 {
                active[i] = active[i + 1];
            }
            len -= 1;
        }
    }
    Err(Error::NoConvergence)
}

/// [`tolerance::parallel`]: the relative threshold for "parallel" and "zero".
#[inline]
pub(crate) fn small<T: Real>() -> T {
    tolerance::parallel()
}

#[inline]
pub(crate) fn length<T: Real, const M: usize>(v: &SVector<T, M>) -> T {
    v.norm_squared().sqrt_native()
}

#[inline]
fn greater_than_zero<T: Real>(x: T) -> bool {
    x > T::zero()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::SMatrix;

    #[test]
    fn projection_and_lp_on_a_small_problem() {
        // One DOF, three cables: t1 + t2 + t3 = 12 in [1, 10]^3 (r = 2).
        let w = SMatrix::<f64, 1, 3>::new(1.0, 1.0, 1.0);
        let fact = WrenchFactorization::new(&w).unwrap();
        let limits = TensionLimits::uniform(1.0, 10.0).unwrap();
        let f = SVector::<f64, 1>::new(12.0);
        let prob = NullSpaceProblem::new(&fact, &f, &limits).unwrap();
        let c = Constraints::limits(&prob);
        // t_p = (4, 4, 4) is feasible: the projection of 0 is 0.
        let p = project(&c, &SVector::zeros(), prob.tolerance()).unwrap();
        assert!(prob.tensions(&p.x).iter().all(|t| (t - 4.0).abs() < 1e-12));
        // Minimise t1: t1 = 1, the rest shared equally by the min-norm tie-break is not
        // part of the LP; any point with t1 = 1 is optimal.
        let g = SVector::<f64, 3>::from_fn(|i, _| if i < 2 { prob.row(0)[i] } else { 0.0 });
        let (x, _) = minimise_linear(&c, &g, &p.x, &p.active[..p.active_len]).unwrap();
        assert!((prob.tensions(&x)[0] - 1.0).abs() < 1e-12);
        // Sum 40 > 30: infeasible, with a certificate.
        let prob = NullSpaceProblem::new(&fact, &SVector::<f64, 1>::new(40.0), &limits).unwrap();
        let c = Constraints::limits(&prob);
        assert_eq!(project(&c, &SVector::zeros(), prob.tolerance()).unwrap_err(), Error::Infeasible);
    }
}
