//! Every pairwise intersection of the limit lines (Mikelsons et al. 2008):
//! the reference the walk is tested against.
use nalgebra::Vector2;

use super::*;

impl<T: Real, const M: usize> FeasiblePolygon<T, M> {
    /// Every pairwise intersection that is feasible, merged with any other
    /// within their error bounds and sorted by angle about their mean (Mikelsons et al.
    /// 2008): `C(2M, 2)` solves of `O(M)` checks, `O(M^3)`.
    pub fn brute_force(&self) -> Result<PolygonCentroid<T, M>, Error> {
        let mut vertices = VertexList::new();
        let summary = self.brute_force_into(&mut vertices)?;
        Ok(PolygonCentroid::from_summary(summary, vertices))
    }

    /// [`Self::brute_force`] with the vertices written to the caller's list
    /// (which is cleared first).
    pub fn brute_force_into(&self, vertices: &mut VertexList<T, M>) -> Result<PolygonSummary<T>, Error> {
        self.brute_force_among(u64::MAX, vertices)
    }

    /// [`Self::brute_force_into`] over the pairs of the lines marked in
    /// `lines` (a bit per line `2 k + side`; lines from 64 on are always
    /// taken): the same vertices, in the same
    /// order, when every line left out holds no vertex (the lines
    /// [`Self::lines_not_proven_empty`] leaves out).
    // Inlined: the reference's call (all lines) folds the line tests away.
    #[inline(always)]
    pub fn brute_force_among(
        &self,
        lines: u64,
        vertices: &mut VertexList<T, M>,
    ) -> Result<PolygonSummary<T>, Error> {
        vertices.clear();
        vertices.brute_force = true;
        // Lines beyond the mask's 64 bits are all taken.
        let marked = |h: usize| h >= 64 || (lines >> h) & 1 != 0;
        for h1 in 0..2 * M {
            if !marked(h1) {
                continue;
            }
            for h2 in (h1 + 1)..2 * M {
                if !marked(h2) {
                    continue;
                }
                if let Some(v) = self.vertex_of(h1, h2) {
                    let merge = |u: &Vertex<T>| T::lit(4.0) * self.tol + u.error + v.error;
                    if !vertices.iter().any(|u| (u.point - v.point).norm_squared().sqrt_native() <= merge(&u))
                    {
                        vertices.push(v)?;
                    }
                }
            }
        }
        if vertices.is_empty() {
            return Err(Error::Infeasible);
        }
        // Sort counter-clockwise about the mean (insertion sort, <= 4M
        // items), each vertex's angle computed once (an `atan2` is a few
        // hundred instructions on the board: not one per comparison).
        let mut mean = Vector2::zeros();
        for v in vertices.iter() {
            mean += v.point;
        }
        mean /= T::lit(vertices.len() as f64);
        let mut slots = [[T::zero(); M]; 4];
        let angles = slots.as_flattened_mut();
        for (a, v) in angles.iter_mut().zip(vertices.iter()) {
            let p = v.point - mean;
            *a = p.y.atan2(p.x);
        }
        for i in 1..vertices.len() {
            let mut j = i;
            while j > 0 && angles[j - 1] > angles[j] {
                let a = vertices.get(j - 1);
                vertices.set(j - 1, vertices.get(j));
                vertices.set(j, a);
                angles.swap(j - 1, j);
                j -= 1;
            }
        }
        self.finish(vertices, None, None, false, 0)
    }
}
