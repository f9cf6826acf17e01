//! The numerical tolerances every method shares, in one place, each with the
//! reason for its size. `eps` is the scalar's machine epsilon (`f32`:
//! 1.2e-7, `f64`: 2.2e-16); every tolerance that compares quantities with a
//! unit is scaled by the size of those quantities, so the same problem in
//! other units gets the same answers.

use crate::Real;

/// Slack tolerance of a limit line, in tension units: `64 eps scale`, with
/// `scale` the largest offset `|t_min - t_p|`, `|t_max - t_p|`. The offsets
/// carry the rounding of `t_p = W^+ f` (a Householder solve, a few `eps`
/// per cable) and of `N lambda` (two products); 64 leaves a factor of about
/// ten over the rounding measured on the shipped robots, so a vertex on a
/// line is never taken as outside it.
#[inline]
pub fn slack<T: Real>(scale: T) -> T {
    T::lit(64.0) * T::eps() * scale
}

/// A null-space row shorter than `1e3 eps` of the longest is zero: that
/// cable's tension is fixed by `W t = f` (its row is pure rounding of the
/// orthogonal factor, which is accurate to a few hundred `eps`).
#[inline]
pub fn negligible_row<T: Real>(row_max: T) -> T {
    T::lit(1.0e3) * T::eps() * row_max
}

/// `16 sqrt(eps)`: the sine of the angle below which two limit lines are
/// parallel, and the relative size below which a step or pivot is zero. Two
/// lines at angle `a` cross at a point whose rounding error grows like
/// `eps / a`; at `a = 16 sqrt(eps)` that is `sqrt(eps) / 16` of the polygon
/// (1.7e-4 in `f32`), beyond which the crossing is noise, and the sliver
/// between two such lines is too thin to move a centroid.
#[inline]
pub fn parallel<T: Real>() -> T {
    T::lit(16.0) * T::eps().sqrt_native()
}

/// `256 eps`: a relative change of a linear objective below which an
/// active-set step is stationary. Decided at rounding level (not at
/// [`parallel`], 5e-3 in `f32`, which would stop on a slowly improving edge).
#[inline]
pub fn stationary<T: Real>() -> T {
    T::lit(256.0) * T::eps()
}

/// The rank test of the Householder factorisation: a diagonal entry of `R`
/// at or below `16 M eps max|R_kk|` is zero (the backward error of `M`
/// reflections is a small multiple of `M eps |W|`).
#[inline]
pub fn rank<T: Real>(m: usize, r_max: T) -> T {
    T::lit(16.0) * T::lit(m as f64) * T::eps() * r_max
}

/// A cable shorter than `1e3 eps` of the robot's size has no direction
/// (its unit vector would be rounding divided by rounding).
#[inline]
pub fn degenerate_length<T: Real>(size: T) -> T {
    T::lit(1.0e3) * T::eps() * size.max(T::eps())
}

/// `W t = f` holds when the residual is within `1e3 eps scale`, with `scale`
/// `|f| + |W| |limits|` (the size of the terms being summed, `M` of them
/// per row, each rounded); also the margin a Farkas certificate must clear.
#[inline]
pub fn equality<T: Real>(scale: T) -> T {
    T::lit(1.0e3) * T::eps() * scale
}

/// The rounding floor of a barrier's gradient `g` at an iterate `t` with
/// the (diagonal) Hessian `H`: `64 eps |g| + eps |H t|`. Close to a limit the
/// barrier's terms are large and so is their rounding (the first term); and
/// `t` itself is only known to one ulp of each tension, `eps |t_i|`, which
/// moves the gradient by `h_ii eps |t_i|` (the second: near a limit `h_ii`
/// is the inverse squared slack, and this term dominates). A stopping rule
/// below this floor could never be met.
#[inline]
pub fn gradient_rounding<T: Real>(gradient_norm: T, hessian_times_iterate_norm: T) -> T {
    T::lit(64.0) * T::eps() * gradient_norm + T::eps() * hessian_times_iterate_norm
}

/// The analytic centre's default stopping tolerance (dimensionless):
/// `max(1e-10, 1000 eps)`, the paper's `1e-10` in `f64` (Di Paola et al.
/// 2024, Table 1) and `1.2e-4` in `f32`, where `1e-10` is below rounding.
#[inline]
pub fn analytic_centre_default<T: Real>() -> T {
    T::lit(1.0e-10).max(T::lit(1000.0) * T::eps())
}
