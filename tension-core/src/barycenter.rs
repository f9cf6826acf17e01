//! The barycenter of the feasible tension polygon (`M = N + 2` cables):
//! Lamaury & Gouttefarde 2013 (walk along the edges) and, as the reference it
//! is tested against, Mikelsons et al. 2008 (every pairwise intersection).
//!
//! Both map the polygon's centroid `lambda_c` back to tensions,
//! `t_c = t_p + N lambda_c` (Lamaury & Gouttefarde 2013, after Eq. 23). The
//! centroid is affine-equivariant, so `t_c` does not depend on the null-space
//! basis or on the particular solution chosen.

use nalgebra::{SMatrix, SVector, Vector2};

pub use crate::polygon::{ActivePair, Bound};
use crate::{
    linalg::WrenchFactorization,
    polygon::{FeasiblePolygon, PolygonSummary, VertexList},
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
        for k in 0..M {
            let row = Vector2::new(fact.null(k, 0), fact.null(k, 1));
            self.rows[k] = row;
            poly.rows[k] = row;
            poly.lower[k] = limits.min()[k] - self.particular[k];
            poly.upper[k] = limits.max()[k] - self.particular[k];
        }
        poly.prepare()
    }

    /// Tensions at null-space coordinates `lambda`.
    pub fn tensions(&self, lambda: &Vector2<T>) -> SVector<T, M> {
        SVector::from_fn(|k, _| self.particular[k] + self.rows[k].dot(lambda))
    }

    fn solution(
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

/// `barycenter` (conventions): the centroid of the feasible polygon by walking its
/// edges (Lamaury & Gouttefarde 2013, Sect. 2.2-2.3), warm-started from the
/// previous cycle's active pair when it is given and still a vertex.
///
/// Cost: one Householder factorisation (`O(N^2 M)`), then the walk: with a
/// held warm start `O(M^2)`; cold, `O(M^2)` to clip every line against the
/// other cables, and the exhaustive `4 C(M,2)` line pairs (`O(M^3)`) only for
/// lines the clipping cannot rule out.
pub fn barycenter<T: Real, const N: usize, const M: usize>(
    w: &SMatrix<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
    warm: Option<ActivePair>,
) -> Result<Solution<T, M>, Error> {
    if M != N + 2 {
        return Err(Error::UnsupportedShape);
    }
    barycenter_factored(&WrenchFactorization::new(w)?, f, limits, warm)
}

/// [`barycenter`] on an already factored wrench matrix.
pub fn barycenter_factored<T: Real, const N: usize, const M: usize>(
    fact: &WrenchFactorization<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
    warm: Option<ActivePair>,
) -> Result<Solution<T, M>, Error> {
    let mut poly = TensionPolygon::zeroed();
    poly.set(fact, f, limits)?;
    let mut vertices = VertexList::new();
    let found = poly.polygon.walk_into(warm, &mut vertices)?;
    poly.solution(&found, limits, warm)
}

/// `barycenter-brute` (conventions): the same centroid from every pairwise line
/// intersection (Mikelsons et al. 2008), `O(M^3)`.
pub fn barycenter_brute<T: Real, const N: usize, const M: usize>(
    w: &SMatrix<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
) -> Result<Solution<T, M>, Error> {
    if M != N + 2 {
        return Err(Error::UnsupportedShape);
    }
    barycenter_brute_factored(&WrenchFactorization::new(w)?, f, limits)
}

/// [`barycenter_brute`] on an already factored wrench matrix.
pub fn barycenter_brute_factored<T: Real, const N: usize, const M: usize>(
    fact: &WrenchFactorization<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
) -> Result<Solution<T, M>, Error> {
    let mut poly = TensionPolygon::zeroed();
    poly.set(fact, f, limits)?;
    let mut vertices = VertexList::new();
    let found = poly.polygon.brute_force_into(&mut vertices)?;
    poly.solution(&found, limits, None)
}
