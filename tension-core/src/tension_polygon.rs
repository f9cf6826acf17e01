//! The feasible tension polygon of a problem with two degrees of redundancy
//! (`M = N + 2`) in null-space coordinates, `t = t_p + N lambda` (Lamaury &
//! Gouttefarde 2013, Eqs. 2-6), and the way back from a point of it to
//! tensions. The barycenter methods, the norms and the firmware's profiling
//! build it; [`crate::polygon`] walks it.
//!
//! The barycenter maps the polygon's centroid `lambda_c` back to tensions,
//! `t_c = t_p + N lambda_c` (after Eq. 23). The centroid is
//! affine-equivariant, so `t_c` does not depend on the null-space basis or on
//! the particular solution chosen.

use nalgebra::{SVector, Vector2};

use crate::{
    linalg::WrenchFactorization,
    polygon::{ActivePair, FeasiblePolygon, PolygonSummary},
    scalar::finite,
    solution::{robustness, Diagnostics, Solution, WarmStart},
    Error, Real, TensionLimits,
};

/// The feasible polygon of `W t = f`, `t_min <= t <= t_max` in null-space
/// coordinates, with the particular solution and basis that map it back.
pub struct TensionPolygon<T: Real, const N: usize, const M: usize> {
    /// Minimum-norm particular solution `t_p = W^+ f` (Eq. 2).
    pub particular: SVector<T, M>,
    /// Rows `n_k` of the orthonormal null-space basis (Eq. 6).
    pub rows: [Vector2<T>; M],
    /// The half-planes of Eq. 5.
    pub polygon: FeasiblePolygon<T, M>,
}

impl<T: Real, const N: usize, const M: usize> TensionPolygon<T, N, M> {
    /// Builds the polygon from a factored wrench matrix.
    pub fn new(
        fact: &WrenchFactorization<T, N, M>,
        f: &SVector<T, N>,
        limits: &TensionLimits<T, M>,
    ) -> Result<Self, Error> {
        let mut poly = Self::zeroed();
        poly.set(fact, f, limits)?;
        Ok(poly)
    }

    /// An empty polygon to be filled by [`Self::set`].
    pub fn zeroed() -> Self {
        Self { particular: SVector::zeros(), rows: [Vector2::zeros(); M], polygon: FeasiblePolygon::zeroed() }
    }

    /// [`Self::new`] in place (nothing large moves through a `Result`).
    pub fn set(
        &mut self,
        fact: &WrenchFactorization<T, N, M>,
        f: &SVector<T, N>,
        limits: &TensionLimits<T, M>,
    ) -> Result<(), Error> {
        if M != N + 2 {
            return Err(Error::UnsupportedShape);
        }
        if !finite(f.as_slice()) {
            return Err(Error::NonFinite);
        }
        self.particular = fact.min_norm_solution(f);
        if !finite(self.particular.as_slice()) {
            return Err(Error::NonFinite);
        }
        let poly = &mut self.polygon;
        // Built as whole arrays and stored at once: `prepare_finite` reads
        // them right away, and with wide vectors (`-C target-cpu=native` on
        // an AVX-512 host) a load of several entries just stored one by one
        // waits for those stores (this call 103 -> 137 ns there; now 97,
        // and 94 in the default build; the same arithmetic).
        let rows: [Vector2<T>; M] = core::array::from_fn(|k| Vector2::new(fact.null(k, 0), fact.null(k, 1)));
        let lower: [T; M] = core::array::from_fn(|k| limits.min()[k] - self.particular[k]);
        let upper: [T; M] = core::array::from_fn(|k| limits.max()[k] - self.particular[k]);
        self.rows = rows;
        poly.rows = rows;
        poly.lower = lower;
        poly.upper = upper;
        // The rows are the factorisation's null space (checked finite
        // there), the bounds finite limits minus the finite particular
        // solution (the limits are far below the largest float).
        poly.prepare_finite()
    }

    /// Tensions at null-space coordinates `lambda`.
    pub fn tensions(&self, lambda: &Vector2<T>) -> SVector<T, M> {
        SVector::from_fn(|k, _| self.particular[k] + self.rows[k].dot(lambda))
    }

    /// The solution at the centroid of `found` (the barycenter methods).
    pub(crate) fn centroid_solution(
        &self,
        found: &PolygonSummary<T>,
        limits: &TensionLimits<T, M>,
        warm: Option<ActivePair>,
    ) -> Result<Solution<T, M>, Error> {
        let tensions = self.tensions(&found.centroid);
        let robustness = robustness(&tensions, limits);
        // The centroid lies in the polygon; rounding may put a degenerate
        // (zero-area) one a few ulps outside, never more than the tolerance.
        if robustness < -self.polygon.tolerance() || !finite(tensions.as_slice()) {
            return Err(Error::Infeasible);
        }
        Ok(Solution {
            tensions,
            robustness,
            diagnostics: Diagnostics {
                vertices: found.vertices as u8,
                warm_start: match (warm, found.warm_start_held) {
                    (None, _) => WarmStart::NotGiven,
                    (Some(_), true) => WarmStart::Held,
                    (Some(_), false) => WarmStart::Lost,
                },
                active_pair: Some(found.robust_pair),
                ..Diagnostics::empty()
            },
        })
    }
}
