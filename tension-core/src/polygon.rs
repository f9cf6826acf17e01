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

use nalgebra::Vector2;

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
/// near-duplicates before merging them).
#[derive(Debug, Clone)]
pub struct VertexList<T: Real, const M: usize> {
    slots: [[Vertex<T>; M]; 4],
    len: usize,
}

impl<T: Real, const M: usize> VertexList<T, M> {
    /// An empty list.
    pub fn new() -> Self {
        let empty = Vertex { point: Vector2::zeros(), lines: (0, 0), error: T::zero() };
        Self { slots: [[empty; M]; 4], len: 0 }
    }

    /// Removes every vertex.
    pub fn clear(&mut self) {
        self.len = 0;
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
}

impl<T: Real, const M: usize> PolygonCentroid<T, M> {
    fn from_summary(s: PolygonSummary<T>, vertices: VertexList<T, M>) -> Self {
        Self {
            centroid: s.centroid,
            vertices,
            area: s.area,
            robust_pair: s.robust_pair,
            warm_start_held: s.warm_start_held,
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
    parallel: T,
    /// `parallel * norms[k]`: below this, `|n_k . d|` for a unit `d` counts
    /// as parallel.
    ptol: [T; M],
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
            parallel: T::zero(),
            ptol: z,
        }
    }

    /// Checks `rows`, `lower` and `upper` and derives the rest ([`Self::new`]).
    pub(crate) fn prepare(&mut self) -> Result<(), Error> {
        if M > 32 {
            return Err(Error::UnsupportedShape);
        }
        let rows_finite = all_finite(self.rows.iter().flat_map(|r| [r.x, r.y]));
        if !(rows_finite && finite(&self.lower) && finite(&self.upper)) {
            return Err(Error::NonFinite);
        }
        let mut scale = T::one();
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
        for k in 0..M {
            if self.lower[k] > self.upper[k] {
                return Err(Error::InvalidLimits);
            }
            self.used[k] = true;
            if self.norms[k] <= row_floor {
                if self.lower[k] > tol || self.upper[k] < -tol {
                    return Err(Error::Infeasible);
                }
                self.used[k] = false;
            }
            self.ptol[k] = parallel * self.norms[k];
        }
        self.tol = tol;
        self.parallel = parallel;
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
    /// `None` when (nearly) parallel.
    #[inline]
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
        if h1 / 2 == h2 / 2 || !self.is_used(h1) || !self.is_used(h2) {
            return None;
        }
        let (p, error) = self.intersect(h1, h2)?;
        let t = self.tol;
        for k in 0..M {
            if !self.used[k] {
                continue;
            }
            // Both half-planes of cable k: n_k . p - lower >= -w, upper - n_k . p >= -w.
            let w = t + self.norms[k] * error;
            let np = self.rows[k].dot(&p);
            if !(np - self.lower[k] >= -w && self.upper[k] - np >= -w) {
                return None;
            }
        }
        Some(Vertex { point: p, lines: (h1 as u8, h2 as u8), error })
    }

    /// Cold search for a first vertex (their Eq. 8: a pair of lines whose
    /// crossing satisfies every half-plane), `O(M^2)` when the answer is
    /// clear.
    ///
    /// Each cable's two parallel lines are clipped against the other cables'
    /// limits (`lower_j <= n_j . (p_0 + s d) <= upper_j`, an interval of `s`
    /// per cable, `O(M)` per line). A line whose interval is non-empty
    /// offers the pair at its lower end, then at its upper end, as
    /// candidates, checked like any pair ([`Self::vertex_of`]). A line whose
    /// interval is empty by more than four times the largest acceptance
    /// tolerance of any of its pairs (the slack tolerance widened by the
    /// crossing's error bound) holds no vertex at all and is left out. Only
    /// when no candidate held do the remaining lines' pairs go through the
    /// exhaustive search, in a fixed order (at most `4 C(M, 2)` pairs of
    /// `O(M)` checks), so the search finds a vertex exactly when the
    /// exhaustive one would.
    pub fn first_vertex(&self) -> Option<Vertex<T>> {
        let none = 2 * M;
        // Lines not proven empty (M <= 32, so 2 M bits fit).
        let mut open: u64 = 0;
        for k1 in 0..M {
            if !self.used[k1] {
                continue;
            }
            let n1 = self.norms[k1];
            let u = self.rows[k1] / n1;
            let d = Vector2::new(-u.y, u.x);
            // Foot points of the two lines on u: p = u b / |n_k1|, b = lower or upper.
            let (b_lo, b_hi) = (self.lower[k1] / n1, self.upper[k1] / n1);
            // Per line (side 0: lower, 1: upper): interval [lo, hi] of s,
            // the lines attaining its ends and their rates |n_j . d|.
            let big = T::max_value()?;
            let mut lo = [-big; 2];
            let mut hi = [big; 2];
            let mut g_lo = [none; 2];
            let mut g_hi = [none; 2];
            let mut r_lo = [T::zero(); 2];
            let mut r_hi = [T::zero(); 2];
            // Largest error bound of a crossing on these lines (same for both).
            let mut err = T::zero();
            for j in 0..M {
                if !self.used[j] || j == k1 {
                    continue;
                }
                let nd = self.rows[j].dot(&d);
                let nu = self.rows[j].dot(&u);
                let and = nd.abs();
                // The crossing's error bound tol (|n_1| + |n_j|) / |det|, with
                // |det| = |n_1| |n_j . d|, not below where `intersect` stops.
                let den = max(and, T::lit(0.5) * self.ptol[j]);
                let e = self.tol * (n1 + self.norms[j]) / (n1 * den);
                err = max(err, e);
                if and <= self.ptol[j] {
                    continue; // (nearly) parallel: left out, which only widens the interval
                }
                for side in 0..2 {
                    let np = nu * if side == 0 { b_lo } else { b_hi };
                    let sa = (self.lower[j] - np) / nd;
                    let sb = (self.upper[j] - np) / nd;
                    let (s_min, h_min, s_max, h_max) =
                        if nd > T::zero() { (sa, 2 * j, sb, 2 * j + 1) } else { (sb, 2 * j + 1, sa, 2 * j) };
                    if s_min > lo[side] {
                        lo[side] = s_min;
                        g_lo[side] = h_min;
                        r_lo[side] = and;
                    }
                    if s_max < hi[side] {
                        hi[side] = s_max;
                        g_hi[side] = h_max;
                        r_hi[side] = and;
                    }
                }
            }
            let accept = T::lit(4.0) * (self.tol + self.row_max() * err);
            for side in 0..2 {
                let h1 = 2 * k1 + side;
                let gap = lo[side] - hi[side];
                if g_lo[side] != none && g_hi[side] != none && gap > T::zero() {
                    // Every point of the line violates one of the two ends'
                    // half-planes by at least this much.
                    let (ra, rb) = (r_lo[side], r_hi[side]);
                    let violation = gap * ra * rb / (ra + rb);
                    if violation > accept {
                        continue;
                    }
                }
                open |= 1 << h1;
                for g in [g_lo[side], g_hi[side]] {
                    if g != none {
                        if let Some(v) = self.vertex_of(h1.min(g), h1.max(g)) {
                            return Some(v);
                        }
                    }
                }
            }
        }
        // No candidate held: every pair of the lines left.
        for h1 in 0..2 * M {
            if open & (1 << h1) == 0 {
                continue;
            }
            for h2 in (h1 + 1)..2 * M {
                if open & (1 << h2) != 0 {
                    if let Some(v) = self.vertex_of(h1, h2) {
                        return Some(v);
                    }
                }
            }
        }
        None
    }

    /// Largest row norm.
    fn row_max(&self) -> T {
        self.norms.iter().fold(T::zero(), |a, &b| max(a, b))
    }

    /// All vertices by walking the boundary counter-clockwise from a first
    /// vertex (warm start if it still gives a vertex, else the cold search),
    /// and their centroid.
    ///
    /// Worst case: the cold search (`O(M^2)` clipping, and `4 C(M,2)` solves,
    /// `O(M^3)`, only for lines it cannot rule out), then at most
    /// `2 M` walk steps of `O(M)` each, then the `O(M^2)` choice of the
    /// warm-start vertex. Should rounding make the walk revisit an edge, it
    /// falls back to [`Self::brute_force`] (`O(M^3)` too).
    pub fn walk(&self, warm: Option<ActivePair>) -> Result<PolygonCentroid<T, M>, Error> {
        let mut vertices = VertexList::new();
        let summary = self.walk_into(warm, &mut vertices)?;
        Ok(PolygonCentroid::from_summary(summary, vertices))
    }

    /// [`Self::walk`] with the vertices written to the caller's list (which
    /// is cleared first): nothing large is returned.
    pub fn walk_into(
        &self,
        warm: Option<ActivePair>,
        vertices: &mut VertexList<T, M>,
    ) -> Result<PolygonSummary<T>, Error> {
        let mut held = false;
        let mut start = None;
        if let Some(pair) = warm {
            let h1 = line_index(pair.first);
            let h2 = line_index(pair.second);
            if h1 < 2 * M && h2 < 2 * M {
                start = self.vertex_of(h1, h2);
                held = start.is_some();
            }
        }
        let start = match start {
            Some(v) => v,
            None => self.first_vertex().ok_or(Error::Infeasible)?,
        };
        match self.walk_from(start, vertices) {
            Some(robust_pair) => self.finish(vertices, Some(robust_pair), held),
            None => self.brute_force_into(vertices),
        }
    }

    /// The walk itself; `None` on a numerical anomaly (an edge met twice).
    /// Also returns the vertex farthest from the lines that do not define
    /// it (the robust warm start for the next cycle), from slacks the walk
    /// computes anyway.
    ///
    /// Per step and per cable: `n_k . v` and `n_k . d` (two dot products), at
    /// most one division for the limit the edge approaches (Eqs. 16-18), then
    /// the smallest step (Eq. 19) and, among lines reached at the same point,
    /// the edge-supporting one (Sect. 2.3).
    fn walk_from(&self, start: Vertex<T>, vertices: &mut VertexList<T, M>) -> Option<ActivePair> {
        vertices.clear();
        vertices.push(start).ok()?;
        // Outgoing edge at the first vertex: an active line along which no
        // other active half-plane is violated (Sect. 2.2.2, Eqs. 10-11). The
        // two lines that define the vertex are active by construction (their
        // computed slack can exceed the tolerance when they are nearly parallel).
        let (l0, l1) = (start.lines.0 as usize, start.lines.1 as usize);
        let mut active: u64 = (1 << l0) | (1 << l1);
        // Margin of the first vertex: its smallest slack to another cable's lines.
        let mut best_margin = T::max_value()?;
        for k in 0..M {
            if !self.used[k] {
                continue;
            }
            let nv = self.rows[k].dot(&start.point);
            let (s_lo, s_hi) = (nv - self.lower[k], self.upper[k] - nv);
            if s_lo.abs() <= self.tol {
                active |= 1 << (2 * k);
            }
            if s_hi.abs() <= self.tol {
                active |= 1 << (2 * k + 1);
            }
            if k != l0 / 2 && k != l1 / 2 {
                best_margin = min(best_margin, min(s_lo, s_hi) / self.norms[k]);
            }
        }
        let mut edge = None;
        let mut candidates = active;
        for _ in 0..2 * M {
            if candidates == 0 {
                break;
            }
            let h = candidates.trailing_zeros() as usize;
            candidates &= candidates - 1;
            let d = direction(&self.normal(h), self.norms[h / 2]);
            let mut others = active & !(1 << h);
            let mut blocked = false;
            for _ in 0..2 * M {
                if others == 0 {
                    break;
                }
                let g = others.trailing_zeros() as usize;
                others &= others - 1;
                if self.normal(g).dot(&d) > self.ptol[g / 2] {
                    blocked = true;
                    break;
                }
            }
            if !blocked {
                edge = Some(h);
                break;
            }
        }
        let mut best_lines = start.lines;
        let Some(first_edge) = edge else {
            return Some(pair_of(best_lines)); // a single point
        };
        let mut visited: u64 = 1 << first_edge;
        let mut h = first_edge;
        let mut v = start.point;
        // The edge that led to `v` (none yet at the first vertex, whose
        // margin is known).
        let mut prev = None;
        let big = T::max_value()?;
        // Per cable, the step to the limit the edge approaches and the rate
        // n_k . d at which it is approached (zero: never reached).
        let mut steps = [big; M];
        let mut rates = [T::zero(); M];
        for _ in 0..=2 * M {
            let a_h = self.normal(h);
            let o = a_h / self.norms[h / 2];
            let d = Vector2::new(-o.y, o.x);
            // Smallest step to another line along the edge (Eqs. 16-19): per
            // cable only the limit the direction approaches can be reached.
            // The same pass gives the margin of `v` (its smallest slack to
            // the lines of the cables that do not define it).
            let mut alpha_min = big;
            let mut any = false;
            let mut margin = big;
            for k in 0..M {
                if !self.used[k] {
                    continue;
                }
                let nv = self.rows[k].dot(&v);
                let nd = self.rows[k].dot(&d);
                let (s_lo, s_hi) = (nv - self.lower[k], self.upper[k] - nv);
                if let Some(p) = prev {
                    if k != h / 2 && k != p / 2 {
                        margin = min(margin, min(s_lo, s_hi) / self.norms[k]);
                    }
                }
                let dtol = self.ptol[k];
                // The signed rate: positive towards the upper limit.
                let (alpha, rate) = if nd > dtol && 2 * k + 1 != h {
                    (s_hi / nd, nd)
                } else if -nd > dtol && 2 * k != h {
                    (s_lo / -nd, nd)
                } else {
                    rates[k] = T::zero();
                    continue;
                };
                any = true;
                steps[k] = alpha;
                rates[k] = rate;
                alpha_min = min(alpha_min, alpha);
            }
            if let Some(p) = prev {
                if margin > best_margin {
                    best_margin = margin;
                    best_lines = (p as u8, h as u8);
                }
            }
            if !any {
                return None;
            }
            let alpha = max(alpha_min, T::zero());
            // Among lines reached there (ties: concurrent lines, Sect. 2.3),
            // the edge-supporting one bounds the normal cone: the largest
            // counter-clockwise angle from the current normal. A line's slack
            // at the step is `(step_k - alpha) |n_k . d|`.
            let mut next = None;
            let mut best_cos = big;
            for k in 0..M {
                let rate = rates[k];
                if rate == T::zero() {
                    continue;
                }
                let (g, sign, speed) =
                    if rate > T::zero() { (2 * k + 1, T::one(), rate) } else { (2 * k, -T::one(), -rate) };
                if (steps[k] - alpha) * speed <= self.tol {
                    let cos = sign * self.rows[k].dot(&o) / self.norms[k];
                    if cos < best_cos {
                        best_cos = cos;
                        next = Some(g);
                    }
                }
            }
            let g = next?;
            if g == first_edge {
                return Some(pair_of(best_lines));
            }
            if visited & (1 << g) != 0 {
                return None;
            }
            visited |= 1 << g;
            let w_guess = v + d * alpha;
            let (w, error) = self.intersect(h, g).unwrap_or((w_guess, self.tol));
            vertices.push(Vertex { point: w, lines: (h as u8, g as u8), error }).ok()?;
            prev = Some(h);
            h = g;
            v = w;
        }
        None
    }

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
        vertices.clear();
        for h1 in 0..2 * M {
            for h2 in (h1 + 1)..2 * M {
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
        // Sort counter-clockwise about the mean (insertion sort, <= 4M items).
        let mut mean = Vector2::zeros();
        for v in vertices.iter() {
            mean += v.point;
        }
        mean /= T::lit(vertices.len() as f64);
        let angle = |v: &Vertex<T>| {
            let p = v.point - mean;
            p.y.atan2(p.x)
        };
        for i in 1..vertices.len() {
            let mut j = i;
            while j > 0 && angle(&vertices.get(j - 1)) > angle(&vertices.get(j)) {
                let a = vertices.get(j - 1);
                vertices.set(j - 1, vertices.get(j));
                vertices.set(j, a);
                j -= 1;
            }
        }
        self.finish(vertices, None, false)
    }

    /// Centroid of ordered vertices and the most robust vertex (computed
    /// here unless the walk already found it).
    fn finish(
        &self,
        vertices: &VertexList<T, M>,
        robust_pair: Option<ActivePair>,
        held: bool,
    ) -> Result<PolygonSummary<T>, Error> {
        let (centroid, area) = centroid(vertices, self.tol);
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
        Ok(PolygonSummary { centroid, vertices: vertices.len(), area, robust_pair, warm_start_held: held })
    }
}

fn pair_of(lines: (u8, u8)) -> ActivePair {
    ActivePair { first: line_of(lines.0 as usize), second: line_of(lines.1 as usize) }
}

/// Counter-clockwise direction along a line with outward normal `a`.
#[inline]
fn direction<T: Real>(a: &Vector2<T>, norm: T) -> Vector2<T> {
    let o = a / norm;
    Vector2::new(-o.y, o.x)
}

fn line_index((cable, bound): (u8, Bound)) -> usize {
    2 * cable as usize + if bound == Bound::Max { 1 } else { 0 }
}

fn line_of(h: usize) -> (u8, Bound) {
    ((h / 2) as u8, if h % 2 == 1 { Bound::Max } else { Bound::Min })
}

/// Centroid and area of a polygon given by its ordered vertices: the
/// shoelace formulas (Lamaury & Gouttefarde 2013, Eqs. 22-23), taken about
/// the first vertex for accuracy. A polygon of (numerically) zero area, a
/// point or a segment, has as centroid the midpoint of its two farthest
/// vertices.
pub fn centroid<T: Real, const M: usize>(vertices: &VertexList<T, M>, tol: T) -> (Vector2<T>, T) {
    let q = vertices.len();
    if q == 0 {
        return (Vector2::zeros(), T::zero());
    }
    let origin = vertices.get(0).point;
    let mut twice_area = T::zero();
    let mut cx = T::zero();
    let mut cy = T::zero();
    let (mut lo, mut hi) = (Vector2::zeros(), Vector2::zeros());
    for i in 0..q {
        let p = vertices.get(i).point - origin;
        let n = vertices.get((i + 1) % q).point - origin;
        let cross = p.x * n.y - n.x * p.y;
        twice_area += cross;
        cx += (p.x + n.x) * cross;
        cy += (p.y + n.y) * cross;
        lo = Vector2::new(min(lo.x, p.x), min(lo.y, p.y));
        hi = Vector2::new(max(hi.x, p.x), max(hi.y, p.y));
    }
    let area = twice_area * T::lit(0.5);
    if area > tol * (hi - lo).norm_squared().sqrt_native() {
        let c = Vector2::new(cx, cy) / (T::lit(6.0) * area);
        return (c + origin, area);
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
