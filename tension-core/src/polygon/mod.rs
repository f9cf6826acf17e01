//! The feasible tension polygon of a robot with two degrees of redundancy,
//! in the null-space coordinates `lambda` (Lamaury & Gouttefarde 2013,
//! Sect. 2.1): `t = t_p + N lambda` is feasible when
//! `t_min - t_p <= N lambda <= t_max - t_p` (their Eq. 5), `2 M` half-planes.
//!
//! Half-plane `h = 2 k + side` belongs to cable `k`; `side` 0 is the lower
//! limit, 1 the upper. Each is written `a_h . lambda <= c_h` with the outward
//! normal `a_h` (`-n_k` for the lower limit, `n_k` for the upper) and the
//! slack `c_h - a_h . lambda >= 0` inside.
//!
//! Two ways to the vertices, tested against each other:
//! * [`FeasiblePolygon::walk`]: a first vertex (warm or by the cold search over
//!   line pairs, Eq. 8), then from vertex to vertex along the edges
//!   (Eqs. 9-21), counter-clockwise, with the rule for three or more
//!   concurrent lines (Sect. 2.3);
//! * [`FeasiblePolygon::brute_force`]: every pairwise intersection that
//!   satisfies all half-planes (Mikelsons et al. 2008), sorted by angle.
//!
//! The centroid is the shoelace formula (Eqs. 22-23) on the ordered vertices.

mod brute_force;
mod centroid;
mod first_vertex;
mod walk;

use nalgebra::Vector2;

pub use centroid::centroid;
use centroid::Shoelace;

use crate::{
    scalar::{all_finite, finite, max, min},
    tolerance, Error, Real,
};

/// Which limit of a cable a polygon edge lies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Bound {
    /// `t_i = t_min_i`.
    Min,
    /// `t_i = t_max_i`.
    Max,
}

/// Two cables at a limit each: a vertex of the feasible polygon. It does not
/// depend on the null-space basis, so it carries over from one control cycle
/// to the next as the warm start of [`FeasiblePolygon::walk`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ActivePair {
    /// First cable (0-based) and the limit it is at.
    pub first: (u8, Bound),
    /// Second cable (0-based) and the limit it is at.
    pub second: (u8, Bound),
}

/// A vertex and the two half-planes whose lines cross there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vertex<T: Real> {
    /// Position in null-space coordinates.
    pub point: Vector2<T>,
    /// The two half-plane indices (`2 * cable + side`).
    pub lines: (u8, u8),
    /// Bound on the position's error from rounding: the slack tolerance
    /// amplified by the conditioning of the two lines (large when they are
    /// nearly parallel).
    pub error: T,
}

/// Up to `4 M` vertices without allocation (a convex polygon cut from `2 M`
/// half-planes has at most `2 M`; the brute force may see a few more
/// near-duplicates before merging them), and the last walk's [`WalkHints`]
/// (the next cycle's, [`FeasiblePolygon::walk_into`]).
#[derive(Debug, Clone)]
pub struct VertexList<T: Real, const M: usize> {
    slots: [[Vertex<T>; M]; 4],
    len: usize,
    /// Kept by [`Self::clear`]: the walk reads a line's entry before it
    /// writes it.
    hints: WalkHints<M>,
    /// Whether the brute force filled the list (see [`Self::by_brute_force`]).
    brute_force: bool,
    /// The line the walk was about to take a second time when it stopped
    /// ([`NO_LINE`]: it did not stop so), read after the walk by
    /// `close_after_revisit`.
    revisit: u8,
}

/// The line a walk took after each line along the polygon's boundary
/// (`[cable][side]`; none for a line that was no edge): a walk of the next
/// cycle's polygon tries each first ([`FeasiblePolygon::walk_into`]). Any
/// content gives the same answer, bit for bit, as none; the last cycle's
/// saves most of the walk's tests. Sixteen bytes for eight cables: what a
/// solver that makes its polygon anew each call carries from one call to
/// the next ([`crate::TensionSolver::solve`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WalkHints<const M: usize> {
    successor: [[u8; 2]; M],
}

/// No successor known (a hint of none).
const NO_LINE: u8 = u8::MAX;

impl<const M: usize> WalkHints<M> {
    /// No line's successor known: every step a full one.
    pub const NONE: Self = Self { successor: [[NO_LINE; 2]; M] };

    /// The line the last walk took after line `h` (`2 M` or more: none).
    fn successor(&self, h: usize) -> usize {
        self.successor.as_flattened().get(h).map_or(usize::MAX, |&g| g as usize)
    }

    /// Records that the walk took line `g` after line `h`.
    fn set_successor(&mut self, h: usize, g: usize) {
        if let Some(s) = self.successor.as_flattened_mut().get_mut(h) {
            *s = g as u8;
        }
    }
}

impl<const M: usize> Default for WalkHints<M> {
    fn default() -> Self {
        Self::NONE
    }
}

impl<T: Real, const M: usize> VertexList<T, M> {
    /// An empty list with no successor known.
    pub fn new() -> Self {
        Self::with_hints(WalkHints::NONE)
    }

    /// An empty list whose next walk tries `hints` (a last walk's, kept by
    /// its caller: [`Self::hints`]).
    pub fn with_hints(hints: WalkHints<M>) -> Self {
        let empty = Vertex { point: Vector2::zeros(), lines: (0, 0), error: T::zero() };
        Self { slots: [[empty; M]; 4], len: 0, hints, brute_force: false, revisit: NO_LINE }
    }

    /// The last walk's successors (what the next walk of this list tries).
    pub fn hints(&self) -> WalkHints<M> {
        self.hints
    }

    /// Removes every vertex (the successors stay: see [`VertexList`]).
    pub fn clear(&mut self) {
        self.len = 0;
        self.brute_force = false;
        self.revisit = NO_LINE;
    }

    /// Whether the vertices are the brute force's: asked for
    /// ([`FeasiblePolygon::brute_force_into`]), or the walk's fallback after
    /// a numerical anomaly (an edge met twice where the walk has not come
    /// back round), `O(M^3)` ([`FeasiblePolygon::walk_into`]).
    pub fn by_brute_force(&self) -> bool {
        self.brute_force
    }

    /// The line the last walk took after line `h` (`2 M` or more: none).
    fn successor(&self, h: usize) -> usize {
        self.hints.successor(h)
    }

    /// Records that the walk took line `g` after line `h`.
    fn set_successor(&mut self, h: usize, g: usize) {
        self.hints.set_successor(h, g);
    }

    /// Capacity, `4 M`.
    pub const CAPACITY: usize = 4 * M;

    fn push(&mut self, v: Vertex<T>) -> Result<(), Error> {
        if self.len >= Self::CAPACITY {
            return Err(Error::NoConvergence);
        }
        self.slots[self.len / M][self.len % M] = v;
        self.len += 1;
        Ok(())
    }

    /// Number of vertices.
    pub fn len(&self) -> usize {
        self.len
    }

    /// `true` when there is no vertex.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Vertex `i`, `i < len()`.
    pub fn get(&self, i: usize) -> Vertex<T> {
        self.slots[i / M][i % M]
    }

    fn set(&mut self, i: usize, v: Vertex<T>) {
        self.slots[i / M][i % M] = v;
    }

    /// The vertices in order.
    pub fn iter(&self) -> impl Iterator<Item = Vertex<T>> + '_ {
        (0..self.len).map(move |i| self.get(i))
    }
}

impl<T: Real, const M: usize> Default for VertexList<T, M> {
    fn default() -> Self {
        Self::new()
    }
}

/// The result of a vertex enumeration.
#[derive(Debug, Clone)]
pub struct PolygonCentroid<T: Real, const M: usize> {
    /// Centroid (by area) in null-space coordinates.
    pub centroid: Vector2<T>,
    /// Vertices, counter-clockwise.
    pub vertices: VertexList<T, M>,
    /// Area (zero for a degenerate polygon: a point or a segment).
    pub area: T,
    /// The vertex farthest from being cut off by a third line, to warm-start
    /// the next call from.
    pub robust_pair: ActivePair,
    /// `true` when the walk started from the given warm start.
    pub warm_start_held: bool,
    /// How many of the walk's steps took the line the previous polygon
    /// gave (see [`FeasiblePolygon::walk_into`]); the rest were full steps.
    pub hinted_steps: usize,
}

/// [`PolygonCentroid`] without the vertices, which stay in the caller's
/// [`VertexList`] ([`FeasiblePolygon::walk_into`]): a few words to return.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolygonSummary<T: Real> {
    /// Centroid (by area) in null-space coordinates.
    pub centroid: Vector2<T>,
    /// Number of vertices.
    pub vertices: usize,
    /// Area (zero for a degenerate polygon: a point or a segment).
    pub area: T,
    /// The vertex farthest from being cut off by a third line.
    pub robust_pair: ActivePair,
    /// `true` when the walk started from the given warm start.
    pub warm_start_held: bool,
    /// How many of the walk's steps took the line the previous polygon
    /// gave; the rest were full steps.
    pub hinted_steps: usize,
}

impl<T: Real, const M: usize> PolygonCentroid<T, M> {
    fn from_summary(s: PolygonSummary<T>, vertices: VertexList<T, M>) -> Self {
        Self {
            centroid: s.centroid,
            vertices,
            area: s.area,
            robust_pair: s.robust_pair,
            warm_start_held: s.warm_start_held,
            hinted_steps: s.hinted_steps,
        }
    }
}

/// The `2 M` half-planes in null-space coordinates.
#[derive(Debug, Clone)]
pub struct FeasiblePolygon<T: Real, const M: usize> {
    pub(crate) rows: [Vector2<T>; M],
    norms: [T; M],
    pub(crate) lower: [T; M],
    pub(crate) upper: [T; M],
    used: [bool; M],
    tol: T,
    /// `1 / scale`, the offsets' size: the centroid's sums are taken in
    /// coordinates of about unit size.
    inv_scale: T,
    parallel: T,
    /// `parallel * norms[k]`: below this, `|n_k . d|` for a unit `d` counts
    /// as parallel.
    ptol: [T; M],
    /// The half-planes scaled to unit normals, for the walk's inner loops
    /// ([`UnitLines`]).
    unit: UnitLines<T, M>,
    /// Twice the largest `tol_k / parallel` over the cables: along a unit
    /// direction a line approached at a rate above `parallel` whose step
    /// exceeds the smallest one by more than this is not reached within its
    /// tolerance there (the walk's test for concurrent lines can skip it).
    tie_gap: T,
    /// Four times the largest `tol_k`: a line farther than this from a
    /// step's point is not reached there within its tolerance, with room
    /// for the rounding of the walk's steps (its hinted steps' test).
    clear_gap: T,
}

/// Cable `k`'s two half-planes divided by `|n_k|`: `lo_k <= u_k . lambda
/// <= hi_k` with the unit normal `u_k = n_k / |n_k|` and the slack
/// tolerance `tol_k = tol / |n_k|` in the same (length) units. Slacks and
/// rates along a unit direction are then the tension-unit ones divided by
/// `|n_k|`, so every test of the walk reads as before without a division
/// per cable. A cable left out (a negligible row) has `u_k = 0` and limits
/// at plus and minus the largest finite value: never reached, never the
/// smallest margin, so the walk needs no test for it.
#[derive(Debug, Clone)]
pub(crate) struct UnitLines<T: Real, const M: usize> {
    pub(crate) ux: [T; M],
    pub(crate) uy: [T; M],
    pub(crate) lo: [T; M],
    pub(crate) hi: [T; M],
    pub(crate) tol: [T; M],
}

impl<T: Real, const M: usize> FeasiblePolygon<T, M> {
    /// Half-planes `lower_k <= n_k . lambda <= upper_k` for each cable `k`
    /// (`lower = t_min - t_p`, `upper = t_max - t_p`). A cable whose row `n_k`
    /// is (numerically) zero has a tension fixed by equilibrium: it is checked
    /// against its limits and left out ([`Error::Infeasible`] if outside).
    pub fn new(rows: [Vector2<T>; M], lower: [T; M], upper: [T; M]) -> Result<Self, Error> {
        let mut poly = Self::zeroed();
        poly.rows = rows;
        poly.lower = lower;
        poly.upper = upper;
        poly.prepare()?;
        Ok(poly)
    }

    /// No half-plane set yet: fill `rows`, `lower`, `upper`, then [`Self::prepare`].
    pub(crate) fn zeroed() -> Self {
        let z = [T::zero(); M];
        Self {
            rows: [Vector2::zeros(); M],
            norms: z,
            lower: z,
            upper: z,
            used: [false; M],
            tol: T::zero(),
            inv_scale: T::one(),
            parallel: T::zero(),
            ptol: z,
            unit: UnitLines { ux: z, uy: z, lo: z, hi: z, tol: z },
            tie_gap: T::zero(),
            clear_gap: T::zero(),
        }
    }

    /// Checks `rows`, `lower` and `upper` and derives the rest ([`Self::new`]).
    pub(crate) fn prepare(&mut self) -> Result<(), Error> {
        let rows_finite = all_finite(self.rows.iter().flat_map(|r| [r.x, r.y]));
        if !(rows_finite && finite(&self.lower) && finite(&self.upper)) {
            return Err(Error::NonFinite);
        }
        self.prepare_finite()
    }

    /// [`Self::prepare`] for `rows`, `lower` and `upper` known to be finite
    /// (the tension polygon's: null-space rows the factorisation checked,
    /// limits [`crate::TensionLimits`] keeps finite minus a particular
    /// solution checked finite).
    pub(crate) fn prepare_finite(&mut self) -> Result<(), Error> {
        if M > 32 {
            return Err(Error::UnsupportedShape);
        }
        // The tolerances scale with the limits' offsets alone (no floor of
        // 1 N): the same problem in other units gets the same answer.
        let mut scale = T::zero();
        let mut row_max = T::zero();
        for k in 0..M {
            let n = self.rows[k].norm_squared().sqrt_native();
            self.norms[k] = n;
            scale = max(scale, max(self.lower[k].abs(), self.upper[k].abs()));
            row_max = max(row_max, n);
        }
        if row_max == T::zero() {
            return Err(Error::Singular);
        }
        // Slack tolerance in tension units: rounding of t_p and of N lambda.
        let tol = tolerance::slack(scale);
        let row_floor = tolerance::negligible_row(row_max);
        // Lines closer than this to parallel (sine of their angle) are taken
        // as parallel: their crossing is lost in rounding, and the sliver
        // between them is too thin to move the centroid.
        let parallel = tolerance::parallel::<T>();
        // Per cable, in one pass: the limits' order, whether its row counts
        // (a negligible one's tension is fixed by equilibrium: checked
        // against its limits and left out), and its unit line.
        let big = T::max_value().unwrap_or_else(T::one);
        let mut tol_max = T::zero();
        for k in 0..M {
            if self.lower[k] > self.upper[k] {
                return Err(Error::InvalidLimits);
            }
            let n = self.norms[k];
            let negligible = n <= row_floor;
            if negligible && (self.lower[k] > tol || self.upper[k] < -tol) {
                return Err(Error::Infeasible);
            }
            self.used[k] = !negligible;
            self.ptol[k] = parallel * n;
            let u = &mut self.unit;
            if !negligible {
                let inv = T::one() / n;
                u.ux[k] = self.rows[k].x * inv;
                u.uy[k] = self.rows[k].y * inv;
                u.lo[k] = self.lower[k] * inv;
                u.hi[k] = self.upper[k] * inv;
                u.tol[k] = tol * inv;
                tol_max = max(tol_max, u.tol[k]);
            } else {
                (u.ux[k], u.uy[k], u.lo[k], u.hi[k], u.tol[k]) = (T::zero(), T::zero(), -big, big, T::zero());
            }
        }
        self.tol = tol;
        self.inv_scale = if scale > T::zero() { T::one() / scale } else { T::one() };
        self.parallel = parallel;
        self.tie_gap = T::lit(2.0) * tol_max / parallel;
        self.clear_gap = T::lit(4.0) * tol_max;
        Ok(())
    }

    /// The slack tolerance used for "on a line" and "feasible", tension units.
    pub fn tolerance(&self) -> T {
        self.tol
    }

    #[inline]
    fn normal(&self, h: usize) -> Vector2<T> {
        let n = self.rows[h / 2];
        if h.is_multiple_of(2) {
            -n
        } else {
            n
        }
    }

    /// Half-plane `h`'s outward unit normal (zero for a cable left out).
    #[inline]
    fn unit_normal(&self, h: usize) -> Vector2<T> {
        let k = h / 2;
        let n = Vector2::new(self.unit.ux[k], self.unit.uy[k]);
        if h.is_multiple_of(2) {
            -n
        } else {
            n
        }
    }

    #[inline]
    fn offset(&self, h: usize) -> T {
        if h.is_multiple_of(2) {
            -self.lower[h / 2]
        } else {
            self.upper[h / 2]
        }
    }

    #[inline]
    fn slack(&self, h: usize, p: &Vector2<T>) -> T {
        self.offset(h) - self.normal(h).dot(p)
    }

    #[inline]
    fn is_used(&self, h: usize) -> bool {
        self.used[h / 2]
    }

    /// Half-plane `h`'s line `n . lambda = c` as `(n, c)` (`h = 2 k` is
    /// cable `k`'s lower limit, `2 k + 1` its upper one).
    pub(crate) fn line(&self, h: usize) -> (Vector2<T>, T) {
        (self.normal(h), self.offset(h))
    }

    /// `true` when `p` satisfies every half-plane within the tolerance.
    pub fn contains(&self, p: &Vector2<T>) -> bool {
        (0..2 * M).all(|h| !self.is_used(h) || self.slack(h, p) >= -self.tol)
    }

    /// Intersection of the lines of half-planes `h1` and `h2` (Cramer's rule
    /// on their Eq. 6) and a bound on its error, `tol (|a_1| + |a_2|) / |det|`;
    /// `None` when (nearly) parallel. (Always inlined: out of line, as the
    /// walk's hinted and full steps both call it, it cost the board's step
    /// about 300 instructions.)
    #[inline(always)]
    fn intersect(&self, h1: usize, h2: usize) -> Option<(Vector2<T>, T)> {
        let a1 = self.normal(h1);
        let a2 = self.normal(h2);
        let (n1, n2) = (self.norms[h1 / 2], self.norms[h2 / 2]);
        let det = a1.x * a2.y - a1.y * a2.x;
        let abs_det = det.abs();
        if abs_det <= self.parallel * n1 * n2 {
            return None;
        }
        let c1 = self.offset(h1);
        let c2 = self.offset(h2);
        let p = Vector2::new((c1 * a2.y - c2 * a1.y) / det, (a1.x * c2 - a2.x * c1) / det);
        let error = self.tol * (n1 + n2) / abs_det;
        (p.x.is_finite() & p.y.is_finite() & error.is_finite()).then_some((p, error))
    }

    /// The vertex of two lines if it satisfies every half-plane within the
    /// tolerance widened by its own error bound.
    fn vertex_of(&self, h1: usize, h2: usize) -> Option<Vertex<T>> {
        self.vertex_of_checking(h1, h2, M)
    }

    /// [`Self::vertex_of`] checking cable `first` before the others (the one
    /// the caller expects to reject the crossing, if any: the rest are
    /// then not read; `M` or more: none first). The same answer. Never
    /// inlined: the cold search's loops keep their registers (inlined, as
    /// the board's raised inlining threshold did, the stress set's
    /// barycenter worst rose 11 055 -> 11 619).
    #[inline(never)]
    fn vertex_of_checking(&self, h1: usize, h2: usize, first: usize) -> Option<Vertex<T>> {
        if h1 / 2 == h2 / 2 || !self.is_used(h1) || !self.is_used(h2) {
            return None;
        }
        let (p, error) = self.intersect(h1, h2)?;
        let t = self.tol;
        // Both half-planes of cable k: n_k . p - lower >= -w, upper - n_k . p >= -w.
        let holds = |k: usize| {
            let w = t + self.norms[k] * error;
            let np = self.rows[k].dot(&p);
            !self.used[k] || (np - self.lower[k] >= -w && self.upper[k] - np >= -w)
        };
        if first < M && !holds(first) {
            return None;
        }
        for k in 0..M {
            if !holds(k) {
                return None;
            }
        }
        Some(Vertex { point: p, lines: (h1 as u8, h2 as u8), error })
    }

    /// Largest row norm.
    fn row_max(&self) -> T {
        self.norms.iter().fold(T::zero(), |a, &b| max(a, b))
    }
}

fn pair_of(lines: (u8, u8)) -> ActivePair {
    ActivePair { first: line_of(lines.0 as usize), second: line_of(lines.1 as usize) }
}

fn line_index((cable, bound): (u8, Bound)) -> usize {
    2 * cable as usize + if bound == Bound::Max { 1 } else { 0 }
}

fn line_of(h: usize) -> (u8, Bound) {
    ((h / 2) as u8, if h % 2 == 1 { Bound::Max } else { Bound::Min })
}
