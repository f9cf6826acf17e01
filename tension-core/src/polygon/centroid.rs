//! The polygon's centroid (Lamaury & Gouttefarde 2013, Eqs. 22-23) and its
//! most robust vertex, the warm start of the next cycle.

use nalgebra::Vector2;

use super::*;

impl<T: Real, const M: usize> FeasiblePolygon<T, M> {
    /// The centroid and area of `vertices` (ordered, as the walk leaves
    /// them) by [`centroid`] with this polygon's tolerance and scale: what
    /// the walk's running sums give for the list it fills.
    pub fn centroid_of(&self, vertices: &VertexList<T, M>) -> (Vector2<T>, T) {
        centroid(vertices, self.tol, self.inv_scale)
    }

    /// Centroid of ordered vertices and the most robust vertex (computed
    /// here unless the walk already found it); `sums`, the shoelace sums of
    /// `vertices` taken as they were found (the walk's), or `None` to take
    /// them here.
    pub(super) fn finish(
        &self,
        vertices: &VertexList<T, M>,
        sums: Option<Shoelace<T>>,
        robust_pair: Option<ActivePair>,
        held: bool,
        hinted_steps: usize,
    ) -> Result<PolygonSummary<T>, Error> {
        let (centroid, area) = match sums {
            Some(sums) => sums.close(vertices, self.tol),
            None => centroid(vertices, self.tol, self.inv_scale),
        };
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
    if vertices.is_empty() {
        return (Vector2::zeros(), T::zero());
    }
    let mut sums = Shoelace::new(vertices.get(0).point, inv_scale);
    for v in vertices.iter().skip(1) {
        sums.add(v.point);
    }
    sums.close(vertices, tol)
}

/// The shoelace sums of [`centroid`] over vertices given one at a time, in
/// order, from the first (the origin): the walk adds each vertex as it
/// finds it, so the centroid needs no second pass over the list.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Shoelace<T: Real> {
    origin: Vector2<T>,
    inv: T,
    /// The last vertex added, about the origin and scaled.
    p: Vector2<T>,
    twice_area: T,
    cx: T,
    cy: T,
    lo: Vector2<T>,
    hi: Vector2<T>,
}

impl<T: Real> Shoelace<T> {
    /// The sums of the first vertex alone (`inv_scale` as in [`centroid`]).
    pub(crate) fn new(origin: Vector2<T>, inv_scale: T) -> Self {
        let z = Vector2::zeros();
        Self {
            origin,
            inv: inv_scale,
            p: z,
            twice_area: T::zero(),
            cx: T::zero(),
            cy: T::zero(),
            lo: z,
            hi: z,
        }
    }

    /// The next vertex.
    pub(crate) fn add(&mut self, v: Vector2<T>) {
        let (p, n) = (self.p, (v - self.origin) * self.inv);
        let cross = p.x * n.y - n.x * p.y;
        self.twice_area += cross;
        self.cx += (p.x + n.x) * cross;
        self.cy += (p.y + n.y) * cross;
        self.lo = Vector2::new(min(self.lo.x, p.x), min(self.lo.y, p.y));
        self.hi = Vector2::new(max(self.hi.x, p.x), max(self.hi.y, p.y));
        self.p = n;
    }

    /// The centroid and area once every vertex is added: the closing edge
    /// back to the first, then Eqs. 22-23, or for a polygon of
    /// (numerically) zero area the midpoint of its two farthest vertices
    /// (read from `vertices`, the ones added).
    pub(crate) fn close<const M: usize>(mut self, vertices: &VertexList<T, M>, tol: T) -> (Vector2<T>, T) {
        self.add(self.origin);
        let (origin, inv) = (self.origin, self.inv);
        let extent = T::one() / inv;
        // In the scaled coordinates: area * inv^2, tolerance * inv.
        let area = self.twice_area * T::lit(0.5);
        if area > tol * inv * (self.hi - self.lo).norm_squared().sqrt_native() {
            let c = Vector2::new(self.cx, self.cy) / (T::lit(6.0) * area);
            return (c * extent + origin, area * extent * extent);
        }
        let q = vertices.len();
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
}
