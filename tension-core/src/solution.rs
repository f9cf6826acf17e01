//! What every method returns: the tensions and diagnostics.

use nalgebra::SVector;

use crate::{polygon::ActivePair, scalar::finite, Error, Real, TensionLimits};

/// Whether a warm start was offered and whether it held.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WarmStart {
    /// No warm start was given (or the method has none).
    NotGiven,
    /// The previous cycle's data gave the starting point.
    Held,
    /// The previous cycle's data no longer applied; the cold start ran.
    Lost,
}

/// Per-call diagnostics. Fields that do not apply to a method are zero.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Diagnostics {
    /// Vertices of the feasible polygon (barycenter methods).
    pub vertices: u8,
    /// Newton iterations (analytic centre) or closed-form evaluations
    /// (closed form: 1, improved closed form: 1 + cables fixed).
    pub iterations: u8,
    /// Cables fixed at a limit (improved closed form).
    pub fixed_cables: u8,
    /// Whether the warm start held.
    pub warm_start: WarmStart,
    /// The active pair to warm-start the next barycenter call from.
    pub active_pair: Option<ActivePair>,
}

impl Diagnostics {
    pub(crate) const fn empty() -> Self {
        Self {
            vertices: 0,
            iterations: 0,
            fixed_cables: 0,
            warm_start: WarmStart::NotGiven,
            active_pair: None,
        }
    }
}

/// A tension vector with `W t = f` and `t_min <= t <= t_max`, and how it was found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solution<T: Real, const M: usize> {
    /// Cable tensions, newtons.
    pub tensions: SVector<T, M>,
    /// Smallest distance to a limit, `min_i min(t_i - t_min_i, t_max_i - t_i)`
    /// (the robustness index of Di Paola et al. 2024, Eq. 10).
    pub robustness: T,
    /// Method-specific diagnostics.
    pub diagnostics: Diagnostics,
}

/// Smallest distance of `t` to a limit (Di Paola et al. 2024, Eq. 10);
/// negative when a limit is violated.
pub fn robustness<T: Real, const M: usize>(t: &SVector<T, M>, limits: &TensionLimits<T, M>) -> T {
    let mut d = T::max_value().unwrap_or_else(T::one);
    for i in 0..M {
        // Plain comparisons: `f32::min` is a libm call on the Cortex-M4F.
        let (lo, hi) = (t[i] - limits.min()[i], limits.max()[i] - t[i]);
        if lo < d {
            d = lo;
        }
        if hi < d {
            d = hi;
        }
    }
    d
}

/// Checks and packs a result: finite, within the limits up to `tol`
/// (else [`Error::NoConvergence`]: a numerical failure, not a proof).
pub(crate) fn checked_solution<T: Real, const M: usize>(
    t: &SVector<T, M>,
    limits: &TensionLimits<T, M>,
    tol: T,
    steps: usize,
    vertices: u8,
    active_pair: Option<ActivePair>,
    warm_start: WarmStart,
) -> Result<Solution<T, M>, Error> {
    if !finite(t.as_slice()) {
        return Err(Error::NonFinite);
    }
    let robustness = robustness(t, limits);
    if !robustness.is_finite() || robustness < -T::lit(4.0) * tol {
        return Err(Error::NoConvergence);
    }
    Ok(Solution {
        tensions: *t,
        robustness,
        diagnostics: Diagnostics {
            vertices,
            iterations: steps.min(u8::MAX as usize) as u8,
            warm_start,
            active_pair,
            ..Diagnostics::empty()
        },
    })
}
