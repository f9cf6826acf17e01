//! The scalar type: `f32` on the board, `f64` on the host.

use nalgebra::RealField;

/// A real scalar the whole crate is generic over (implemented for `f32` and
/// `f64`). Tolerances are derived from its machine epsilon so that the same
/// code is correct in both precisions.
pub trait Real: RealField + Copy {
    /// Converts an `f64` literal (exact for the small constants used here).
    fn lit(x: f64) -> Self;
    /// Machine epsilon of the type.
    fn eps() -> Self;
}

impl Real for f64 {
    #[inline]
    fn lit(x: f64) -> Self {
        x
    }
    #[inline]
    fn eps() -> Self {
        f64::EPSILON
    }
}

impl Real for f32 {
    #[inline]
    fn lit(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn eps() -> Self {
        f32::EPSILON
    }
}

/// `true` when every entry of the slice is finite.
pub(crate) fn all_finite<T: Real>(values: impl IntoIterator<Item = T>) -> bool {
    values.into_iter().all(|v| v.is_finite())
}

/// `a > b`, false when either is NaN (written as a call so that the NaN case
/// reads as intended where it is negated).
#[inline]
pub(crate) fn greater<T: Real>(a: T, b: T) -> bool {
    a > b
}
