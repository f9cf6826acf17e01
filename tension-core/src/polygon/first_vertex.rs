//! The cold search for a first vertex of the feasible polygon (Lamaury &
//! Gouttefarde 2013, Eq. 8).
use nalgebra::Vector2;

use super::*;

impl<T: Real, const M: usize> FeasiblePolygon<T, M> {
    /// Cold search for a first vertex (their Eq. 8: a pair of lines whose
    /// crossing satisfies every half-plane), `O(M^2)` when the answer is
    /// clear.
    ///
    /// Each cable's two parallel lines are clipped against the other cables'
    /// limits (`lower_j <= n_j . (p_0 + s d) <= upper_j`, an interval of `s`
    /// per cable, `O(M)` per line). A line whose interval is non-empty
    /// offers the pair at its lower end, then at its upper end, as
    /// candidates, checked like any pair (`vertex_of`). A line whose
    /// interval is empty by more than four times the largest acceptance
    /// tolerance of any of its pairs (the slack tolerance widened by the
    /// crossing's error bound; crossings with lines too close to parallel
    /// for `intersect` are no vertex and do not count) holds no
    /// vertex at all and is left out, and so is a line that a (nearly)
    /// parallel cable's half-plane excludes by as much wherever a vertex of
    /// it could lie (the line of a twin cable outside its twin's, at a
    /// symmetric pose). Candidates are checked first against the cable
    /// that ends the interval at the other end. Only
    /// when no candidate held do the remaining lines' pairs go through the
    /// exhaustive search, in a fixed order (at most `4 C(M, 2)` pairs of
    /// `O(M)` checks), so the search finds a vertex exactly when the
    /// exhaustive one would.
    pub fn first_vertex(&self) -> Option<Vertex<T>> {
        self.first_vertex_from(0)
    }

    /// [`Self::first_vertex`] with cable `first`'s lines clipped first, then
    /// the others in turn (`first + 1` on, wrapping): a vertex exactly when
    /// there is one, found sooner when `first`'s lines are edges. The walk
    /// passes the cable that cut its lost warm start off
    /// ([`Self::walk_into`]): where a vertex went from one cycle to the
    /// next, the line that took its place is usually that cable's (at a
    /// symmetric pose, the twin of one of its lines). Not inlined: the
    /// walk's code stays as it was.
    #[inline(never)]
    pub fn first_vertex_from(&self, first: usize) -> Option<Vertex<T>> {
        self.clip::<true>(first).0
    }

    /// The lines [`Self::first_vertex`]'s clipping does not prove empty
    /// (a bit per line `2 k + side`), all of them clipped, none searched:
    /// every vertex the pair check accepts lies on two of them.
    pub fn lines_not_proven_empty(&self) -> u64 {
        self.clip::<false>(0).1
    }

    /// The clipping of every line against the other cables, with the first
    /// vertex searched as it goes (`FIND`: [`Self::first_vertex`], which
    /// returns at the first) or not (the lines it leaves open).
    #[inline(always)]
    fn clip<const FIND: bool>(&self, first: usize) -> (Option<Vertex<T>>, u64) {
        let none = 2 * M;
        let first = if first < M { first } else { 0 };
        // Lines not proven empty (M <= 32, so 2 M bits fit).
        let mut open: u64 = 0;
        // `first`, then the others in turn (`first + 1`, ..., wrapping).
        let mut next = first;
        for _ in 0..M {
            let k1 = next;
            next = if next + 1 == M { 0 } else { next + 1 };
            if !self.used[k1] {
                continue;
            }
            let n1 = self.norms[k1];
            let u = self.rows[k1] / n1;
            let d = Vector2::new(-u.y, u.x);
            // Foot points of the two lines on u: p = u b / |n_k1|, b = lower or upper.
            let b = [self.lower[k1] / n1, self.upper[k1] / n1];
            // Per line (side 0: lower, 1: upper): interval [lo, hi] of s,
            // the lines attaining its ends and their rates |n_j . d|.
            // (No largest value: nothing is proven, every line stays open.)
            let Some(big) = T::max_value() else { return (None, u64::MAX) };
            let mut lo = [-big; 2];
            let mut hi = [big; 2];
            let mut g_lo = [none; 2];
            let mut g_hi = [none; 2];
            let mut r_lo = [T::zero(); 2];
            let mut r_hi = [T::zero(); 2];
            // Largest error bound of a crossing on these lines that can be a
            // vertex (same for both).
            let mut err = T::zero();
            // The cables (nearly) parallel to these lines, left out of the
            // intervals (a bit per cable).
            let mut parallel: u32 = 0;
            for j in 0..M {
                if !self.used[j] || j == k1 {
                    continue;
                }
                let nd = self.rows[j].dot(&d);
                let nu = self.rows[j].dot(&u);
                let and = nd.abs();
                // The crossing's error bound tol (|n_1| + |n_j|) / |det|, with
                // |det| = |n_1| |n_j . d|, for the cables whose crossing
                // `intersect` may give: a line at half its parallel
                // threshold never crosses (by a factor 2 over rounding), so
                // its (huge) bound is no tolerance of any vertex.
                if and > T::lit(0.5) * self.ptol[j] {
                    err = max(err, self.tol * (n1 + self.norms[j]) / (n1 * and));
                }
                if and <= self.ptol[j] {
                    // (Nearly) parallel: left out of the interval, which only
                    // widens it; kept for the check below.
                    parallel |= 1 << j;
                    continue;
                }
                for side in 0..2 {
                    let np = nu * b[side];
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
                if parallel != 0 && g_lo[side] != none && g_hi[side] != none {
                    // A vertex the pair check accepts lies on the line within
                    // `accept / rate` of the interval (beyond an end, the
                    // half-plane that ends it is violated at that rate): a
                    // (nearly) parallel cable's half-plane violated by more
                    // than `accept` at both of those points is violated all
                    // along them (linear in s), and the line holds no vertex
                    // (a twin cable's line beside it, at a symmetric pose).
                    let ends = [(lo[side], r_lo[side]), (hi[side], r_hi[side])];
                    if self.outside_a_parallel_cable(parallel, k1, side, ends, accept) {
                        continue;
                    }
                }
                open |= 1 << h1;
                if !FIND {
                    continue;
                }
                // Each candidate checked first against the cable ending the
                // interval at the other end (which rejects it when the
                // interval is empty).
                for (g, other) in [(g_lo[side], g_hi[side]), (g_hi[side], g_lo[side])] {
                    if g != none {
                        if let Some(v) = self.vertex_of_checking(h1.min(g), h1.max(g), other / 2) {
                            return (Some(v), open);
                        }
                    }
                }
            }
        }
        if !FIND {
            return (None, open);
        }
        // No candidate held: every pair of the lines left.
        for h1 in 0..2 * M {
            if open & (1 << h1) == 0 {
                continue;
            }
            for h2 in (h1 + 1)..2 * M {
                if open & (1 << h2) != 0 {
                    if let Some(v) = self.vertex_of(h1, h2) {
                        return (Some(v), open);
                    }
                }
            }
        }
        (None, open)
    }

    /// Whether one of the cables in `parallel` (a bit per cable) has a
    /// half-plane violated by more than `accept` all along line `2 k1 +
    /// side` from `accept / rate` before its interval's lower end to as far
    /// beyond its upper end (`ends`: each end's `s` and rate): linear in `s`,
    /// so checked at those two points. Not inlined: the clipping's loop
    /// keeps its registers.
    #[inline(never)]
    fn outside_a_parallel_cable(
        &self,
        parallel: u32,
        k1: usize,
        side: usize,
        ends: [(T, T); 2],
        accept: T,
    ) -> bool {
        let n1 = self.norms[k1];
        let u = self.rows[k1] / n1;
        let d = Vector2::new(-u.y, u.x);
        let b = if side == 0 { self.lower[k1] } else { self.upper[k1] } / n1;
        let [(lo, r_lo), (hi, r_hi)] = ends;
        let (pa, pb) = (u * b + d * (lo - accept / r_lo), u * b + d * (hi + accept / r_hi));
        let mut rest = parallel;
        for _ in 0..M {
            if rest == 0 {
                break;
            }
            let j = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let (na, nb) = (self.rows[j].dot(&pa), self.rows[j].dot(&pb));
            let below = min(self.lower[j] - na, self.lower[j] - nb);
            let above = min(na - self.upper[j], nb - self.upper[j]);
            if below > accept || above > accept {
                return true;
            }
        }
        false
    }
}
