//! The polygon's centroid (Lamaury & Gouttefarde 2013, Eqs. 22-23) and its
//! most robust vertex, the warm start of the next cycle.

use nalgebra::Vector2;

use super::*;

impl<T: Real, const M: usize> FeasiblePolygon<T, M> {
    /// Centroid of ordered vertices and the most robust vertex (computed
    /// here unless the walk already found it).
    pub(super) fn finish(
        &self,
        vertices: &VertexList<T, M>,
        robust_pair: Option<ActivePair>,
        held: bool,
        hinted_steps: usize,
    ) -> Result<PolygonSummary<T>, Error> {
        let (centroid, area) = centroid(vertices, self.tol, self.inv_scale);
        let robust_pair = robust_pair.unwrap_or_else(|| {
            let mut best = vertices.get(0);
            let mut best_margin = -T::max_value().unwrap_or_else(T::one);
            for v in vertices.iter() {
                let margin = (0..2 * M)
                    .filter(|&g| self.is_used(g) && g != v.lines.0 as usize && g != v.lines.1 as usize)
                    .map(|g| self.slack(g, &v.point) / self.norms[g / 2])
                    .fold(T::max_value().unwrap_or_else(T::one), min);
                if margin > best_margin {
                    best_margin = margin;
                    best = v;
                }
            }
            pair_of(best.lines)
        });
        if !all_finite([centroid.x, centroid.y, area]) {
            return Err(Error::NonFinite);
        }
        Ok(PolygonSummary {
            centroid,
            vertices: vertices.len(),
            area,
            robust_pair,
            warm_start_held: held,
            hinted_steps,
        })
    }
}

/// Centroid and area of a polygon given by its ordered vertices: the
/// shoelace formulas (Lamaury & Gouttefarde 2013, Eqs. 22-23), taken about
/// the first vertex for accuracy, in coordinates multiplied by `inv_scale`
/// (the inverse of the polygon's size: the centroid's sums are cubes of the
/// coordinates, which overflow `f32` for polygons beyond 7e12 N). A polygon of (numerically) zero area, a
/// point or a segment, has as centroid the midpoint of its two farthest
/// vertices.
pub fn centroid<T: Real, const M: usize>(
    vertices: &VertexList<T, M>,
    tol: T,
    inv_scale: T,
) -> (Vector2<T>, T) {
    let q = vertices.len();
    if q == 0 {
        return (Vector2::zeros(), T::zero());
    }
    let origin = vertices.get(0).point;
    let inv = inv_scale;
    let extent = T::one() / inv_scale;
    let mut twice_area = T::zero();
    let mut cx = T::zero();
    let mut cy = T::zero();
    let (mut lo, mut hi) = (Vector2::zeros(), Vector2::zeros());
    let mut p = Vector2::zeros();
    for i in 0..q {
        let n = (vertices.get((i + 1) % q).point - origin) * inv;
        let cross = p.x * n.y - n.x * p.y;
        twice_area += cross;
        cx += (p.x + n.x) * cross;
        cy += (p.y + n.y) * cross;
        lo = Vector2::new(min(lo.x, p.x), min(lo.y, p.y));
        hi = Vector2::new(max(hi.x, p.x), max(hi.y, p.y));
        p = n;
    }
    // In the scaled coordinates: area * inv^2, tolerance * inv.
    let area = twice_area * T::lit(0.5);
    if area > tol * inv * (hi - lo).norm_squared().sqrt_native() {
        let c = Vector2::new(cx, cy) / (T::lit(6.0) * area);
        return (c * extent + origin, area * extent * extent);
    }
    // Zero area: the midpoint of the two farthest vertices.
    let mut diameter = T::zero();
    let mut far = (origin, origin);
    for i in 0..q {
        for j in (i + 1)..q {
            let dist = (vertices.get(j).point - vertices.get(i).point).norm_squared().sqrt_native();
            if dist > diameter {
                diameter = dist;
                far = (vertices.get(i).point, vertices.get(j).point);
            }
        }
    }
    ((far.0 + far.1) * T::lit(0.5), T::zero())
}
