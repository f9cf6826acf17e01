//! The optima of the 2-norm and of the sum of the tensions over the feasible
//! polygon (`r = 2`), exactly and in bounded time from the vertices the
//! barycenter walk computes ([`crate::polygon::FeasiblePolygon::walk`],
//! warm-started like the barycenter): the 2-norm optimum is the origin if it
//! is inside (`t_p = W^+ f` is orthogonal to the null space, so
//! `|t|^2 = |t_p|^2 + |lambda|^2`), else the closest point of the closest
//! edge; the 1-norm optimum is the set of vertices of smallest `sum t` (one
//! vertex, or the two ends of an edge), of which the point closest to the
//! origin is taken. Cost: the walk plus `O(M)` per vertex. Used by
//! [`crate::methods::min_2_norm`] and [`crate::methods::min_1_norm`].

use nalgebra::{SVector, Vector2};

use crate::{
    linalg::WrenchFactorization,
    methods::{PreviousCycle, Problem},
    polygon::{ActivePair, VertexList},
    scalar::greater,
    solution::{checked_solution, Solution, WarmStart},
    tension_polygon::TensionPolygon,
    Error, Real, TensionLimits,
};

#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Norm {
    /// `sum t_i`.
    One,
    /// `|t|_2`.
    Two,
}

/// The norm's optimum from the polygon when `r = 2` and the polygon
/// decides; `None` for the active sets to decide: any other redundancy, or
/// a polygon optimum that rounding put beyond a third limit by more than the
/// tolerance (near a nearly degenerate vertex, three limit lines almost
/// concurrent; seen in `f32` on IPAnema 1), reported as `NoConvergence`.
pub(crate) fn decided_on_polygon<T: Real, const N: usize, const M: usize>(
    problem: &Problem<'_, T, N, M>,
    previous: &PreviousCycle<T, M>,
    norm: Norm,
) -> Option<Result<Solution<T, M>, Error>> {
    if M != N + 2 {
        return None;
    }
    let found = on_polygon(problem.factorization, problem.f, problem.limits, previous.active_pair, norm);
    (!matches!(found, Err(Error::NoConvergence))).then_some(found)
}

/// `r = 2`: the optimum from the walk's vertices.
fn on_polygon<T: Real, const N: usize, const M: usize>(
    fact: &WrenchFactorization<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
    warm: Option<ActivePair>,
    norm: Norm,
) -> Result<Solution<T, M>, Error> {
    let poly = TensionPolygon::new(fact, f, limits)?;
    let found = poly.polygon.walk(warm)?;
    let vertices = &found.vertices;
    let lambda = match norm {
        Norm::Two => {
            let (p, edge) = closest_to_origin(vertices.len(), |i| vertices.get(i).point);
            on_edge_line(&poly.polygon, p, edge.map(|(a, b)| (vertices.get(a), vertices.get(b))))
        }
        Norm::One => {
            // g . lambda = sum t - sum t_p.
            let g = poly.rows.iter().fold(Vector2::zeros(), |a, r| a + r);
            let mut best = T::max_value().unwrap_or_else(T::one);
            for v in vertices.iter() {
                best = best.min(g.dot(&v.point));
            }
            let cut = best + T::lit(M as f64) * poly.polygon.tolerance();
            // The minimising vertices, in order: one vertex or an edge's two ends.
            let chosen = |v: &crate::polygon::Vertex<T>| g.dot(&v.point) <= cut;
            let count = vertices.iter().filter(chosen).count();
            let nth = |i: usize| vertices.iter().filter(chosen).nth(i);
            let (p, edge) = closest_to_origin(count, |i| nth(i).map_or(Vector2::zeros(), |v| v.point));
            on_edge_line(&poly.polygon, p, edge.and_then(|(a, b)| Some((nth(a)?, nth(b)?))))
        }
    };
    let tensions = poly.tensions(&lambda);
    let warm_start = match (warm, found.warm_start_held) {
        (None, _) => WarmStart::NotGiven,
        (Some(_), true) => WarmStart::Held,
        (Some(_), false) => WarmStart::Lost,
    };
    checked_solution(
        &tensions,
        limits,
        poly.polygon.tolerance(),
        0,
        vertex_count(vertices),
        Some(found.robust_pair),
        warm_start,
    )
}

fn vertex_count<T: Real, const M: usize>(v: &VertexList<T, M>) -> u8 {
    v.len().min(u8::MAX as usize) as u8
}

/// A point found inside an edge, recomputed as the origin's projection on
/// the edge's own line (the line both end vertices lie on). Interpolating
/// between the vertices carries their rounding error, which in `f32` and
/// between nearly parallel neighbours can put the point beyond that very
/// limit by many times the polygon's tolerance; the line's own data do not.
/// Kept as it is when the vertices share no line or the line is degenerate.
fn on_edge_line<T: Real, const M: usize>(
    polygon: &crate::polygon::FeasiblePolygon<T, M>,
    p: Vector2<T>,
    edge: Option<(crate::polygon::Vertex<T>, crate::polygon::Vertex<T>)>,
) -> Vector2<T> {
    let Some((a, b)) = edge else { return p };
    let shared = [a.lines.0, a.lines.1].into_iter().find(|&h| h == b.lines.0 || h == b.lines.1);
    let Some(h) = shared else { return p };
    let (n, c) = polygon.line(usize::from(h));
    let n2 = n.norm_squared();
    if greater(n2, T::zero()) {
        n * (c / n2)
    } else {
        p
    }
}

/// The point closest to the origin of the convex polygon with the given
/// vertices in counter-clockwise order (`count >= 1`; a point or a segment
/// when `count <= 2`): the origin if it is strictly inside, else the closest
/// point over the edges (each: the projection clamped to the segment), with
/// the indices of the edge's two vertices when it lies strictly inside one.
pub(crate) fn closest_to_origin<T: Real>(
    count: usize,
    vertex: impl Fn(usize) -> Vector2<T>,
) -> (Vector2<T>, Option<(usize, usize)>) {
    if count == 0 {
        return (Vector2::zeros(), None);
    }
    let mut inside = count >= 3;
    let mut best = vertex(0);
    let mut best_d = best.norm_squared();
    let mut best_edge = None;
    for i in 0..count {
        let j = (i + 1) % count;
        let a = vertex(i);
        let b = vertex(j);
        let d = b - a;
        // Cross product of the edge with the vector to the origin.
        if !greater(d.x * (-a.y) - d.y * (-a.x), T::zero()) {
            inside = false;
        }
        let len2 = d.norm_squared();
        let tau = if len2 > T::zero() { (-a.dot(&d) / len2).max(T::zero()).min(T::one()) } else { T::zero() };
        let p = a + d * tau;
        let pd = p.norm_squared();
        if pd < best_d {
            best_d = pd;
            best = p;
            best_edge = (tau > T::zero() && tau < T::one() && i != j).then_some((i, j));
        }
    }
    if inside {
        (Vector2::zeros(), None)
    } else {
        (best, best_edge)
    }
}
