//! The feasible tensions of smallest 2-norm and of smallest 1-norm
//! (`min-2-norm`, `min-1-norm`), any degree of redundancy `r = M - N`.
//!
//! * `min-2-norm`: `argmin |t|_2` subject to `W t = f`,
//!   `t_min <= t <= t_max` (Di Paola et al. 2024, Eq. 8, left; the energy
//!   optimal distribution). With `t = t_p + Z lambda` and `t_p = W^+ f`
//!   orthogonal to the null space, `|t|^2 = |t_p|^2 + |lambda|^2`: the answer
//!   is the point of the feasible set closest to `lambda = 0`, unique.
//! * `min-1-norm`: `argmin sum_i t_i` over the same set (tensions are
//!   non-negative, so this is the 1-norm): a linear programme. Its minimiser
//!   need not be unique (when `sum_k z_k` is orthogonal to an edge); the tie
//!   is broken by the smallest 2-norm among the minimisers, so the answer is
//!   unique and the same for every `r` (our choice: the literature's LP
//!   solvers return whichever vertex they meet first).
//!
//! For `r = 2` both are exact and bounded from the feasible polygon's
//! vertices, as the barycenter walk computes them
//! ([`crate::polygon::FeasiblePolygon::walk`], warm-started like the
//! barycenter): the 2-norm optimum is the origin if it is inside, else the
//! closest point of the closest edge; the 1-norm optimum is the set of
//! vertices of smallest `sum t` (one vertex, or the two ends of an edge),
//! of which the closest point to the origin is taken. Cost: the walk plus
//! `O(M)` per vertex.
//!
//! For other `r` the active-set solvers of [`crate::active_set`]: the
//! Goldfarb-Idnani projection for the 2-norm; for the 1-norm the primal
//! active-set method from the 2-norm optimum, then the projection of the
//! origin onto the feasible set cut by `sum t <= optimum + tol`. Each stops
//! after [`crate::active_set::step_cap`] `= 8 M + 8` steps
//! ([`Error::NoConvergence`]).
//!
//! Errors: [`Error::Infeasible`] (the walk finds no vertex, or a Farkas
//! certificate), [`Error::NonFinite`], [`Error::Singular`],
//! [`Error::NoConvergence`].

use nalgebra::{SMatrix, SVector, Vector2};

use crate::{
    active_set::{minimise_linear, project, Constraints, NullSpaceProblem},
    barycenter::{ActivePair, TensionPolygon},
    linalg::WrenchFactorization,
    polygon::VertexList,
    scalar::{finite, greater},
    solution::{robustness, Diagnostics, Solution, WarmStart},
    Error, Real, TensionLimits,
};

/// `min-2-norm` (see the module header); `warm` is the previous cycle's
/// active pair (used for `r = 2`).
pub fn min_2_norm<T: Real, const N: usize, const M: usize>(
    w: &SMatrix<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
    warm: Option<ActivePair>,
) -> Result<Solution<T, M>, Error> {
    min_2_norm_factored(&WrenchFactorization::new(w)?, f, limits, warm)
}

/// [`min_2_norm`] on an already factored wrench matrix.
pub fn min_2_norm_factored<T: Real, const N: usize, const M: usize>(
    fact: &WrenchFactorization<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
    warm: Option<ActivePair>,
) -> Result<Solution<T, M>, Error> {
    if M == N + 2 {
        let on_the_polygon = on_polygon(fact, f, limits, warm, Norm::Two);
        // Near a nearly degenerate vertex (three limit lines almost
        // concurrent) rounding can put the polygon's optimum beyond a third
        // limit by more than the tolerance (seen in `f32` on IPAnema 1);
        // the active-set method below then decides.
        if !matches!(on_the_polygon, Err(Error::NoConvergence)) {
            return on_the_polygon;
        }
    }
    let prob = NullSpaceProblem::new(fact, f, limits)?;
    let p = project(&Constraints::limits(&prob), &SVector::zeros(), prob.tolerance())?;
    finish(&prob.tensions(&p.x), limits, prob.tolerance(), p.steps, 0, None, WarmStart::NotGiven)
}

/// `min-1-norm` (see the module header); `warm` is the previous cycle's
/// active pair (used for `r = 2`).
pub fn min_1_norm<T: Real, const N: usize, const M: usize>(
    w: &SMatrix<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
    warm: Option<ActivePair>,
) -> Result<Solution<T, M>, Error> {
    min_1_norm_factored(&WrenchFactorization::new(w)?, f, limits, warm)
}

/// [`min_1_norm`] on an already factored wrench matrix.
pub fn min_1_norm_factored<T: Real, const N: usize, const M: usize>(
    fact: &WrenchFactorization<T, N, M>,
    f: &SVector<T, N>,
    limits: &TensionLimits<T, M>,
    warm: Option<ActivePair>,
) -> Result<Solution<T, M>, Error> {
    if M == N + 2 {
        let on_the_polygon = on_polygon(fact, f, limits, warm, Norm::One);
        // As for min-2-norm: the active sets decide when rounding put the
        // polygon's optimum beyond a limit.
        if !matches!(on_the_polygon, Err(Error::NoConvergence)) {
            return on_the_polygon;
        }
    }
    let prob = NullSpaceProblem::new(fact, f, limits)?;
    let tol = prob.tolerance();
    let base = Constraints::limits(&prob);
    let start = project(&base, &SVector::zeros(), tol)?;
    let g = prob.sum_gradient();
    let (x, lp_steps) = minimise_linear(&base, &g, &start.x, &start.active[..start.active_len])?;
    // Among the minimisers (within the rounding of the sum), the smallest 2-norm.
    let best = g.dot(&x) + T::lit(M as f64) * tol;
    let cut = base.with_extra(&g, best);
    let tie = project(&cut, &SVector::zeros(), tol)?;
    let steps = start.steps + lp_steps + tie.steps;
    finish(&prob.tensions(&tie.x), limits, tol, steps, 0, None, WarmStart::NotGiven)
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Norm {
    One,
    Two,
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
    finish(
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

/// Checks and packs a result: finite, within the limits up to `tol`
/// (else [`Error::NoConvergence`]: a numerical failure, not a proof).
pub(crate) fn finish<T: Real, const M: usize>(
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
