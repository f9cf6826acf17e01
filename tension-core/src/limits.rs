//! Tension limits per cable.

use nalgebra::SVector;

use crate::{scalar::finite, Error, Real};

/// Lower and upper tension limit of every cable, `0 <= t_min < t_max`
/// (conventions, "Robot description files": the same for every cable unless a cable
/// overrides).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TensionLimits<T: Real, const M: usize> {
    min: SVector<T, M>,
    max: SVector<T, M>,
}

impl<T: Real, const M: usize> TensionLimits<T, M> {
    /// Per-cable limits; [`Error::NonFinite`] or [`Error::InvalidLimits`]
    /// unless every pair is finite with `0 <= t_min < t_max`, and small
    /// enough that the methods' sums of squares of tensions stay finite
    /// (`M t_max^2` below the largest float: `t_max` up to about 6.5e18 N in
    /// `f32` and 4.7e153 N in `f64` for 8 cables); larger limits would make
    /// every pose `nonfinite` instead of being refused once.
    pub fn new(min: SVector<T, M>, max: SVector<T, M>) -> Result<Self, Error> {
        if !(finite(min.as_slice()) && finite(max.as_slice())) {
            return Err(Error::NonFinite);
        }
        let squares_limit = T::max_value().unwrap_or_else(T::one) / T::lit(M.max(1) as f64);
        for i in 0..M {
            if min[i] < T::zero() || min[i] >= max[i] || max[i] * max[i] >= squares_limit {
                return Err(Error::InvalidLimits);
            }
        }
        Ok(Self { min, max })
    }

    /// The same limits for every cable.
    pub fn uniform(min: T, max: T) -> Result<Self, Error> {
        Self::new(SVector::repeat(min), SVector::repeat(max))
    }

    /// Lower limits `t_min`.
    pub fn min(&self) -> &SVector<T, M> {
        &self.min
    }

    /// Upper limits `t_max`.
    pub fn max(&self) -> &SVector<T, M> {
        &self.max
    }

    /// Middle of the box, `t_m = (t_min + t_max) / 2` (Pott et al. 2009).
    pub fn middle(&self) -> SVector<T, M> {
        (self.min + self.max) * T::lit(0.5)
    }

    /// Largest absolute limit, the tension scale tolerances are relative to.
    pub fn scale(&self) -> T {
        self.max.iter().fold(T::zero(), |a, &b| a.max(b.abs()))
    }
}
