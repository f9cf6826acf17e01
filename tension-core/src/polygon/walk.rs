//! The walk from vertex to vertex along the polygon's edges, counter-clockwise
//! (Lamaury & Gouttefarde 2013, Eqs. 9-21, concurrent lines: Sect. 2.3).
use nalgebra::Vector2;

use super::*;

impl<T: Real, const M: usize> FeasiblePolygon<T, M> {
    /// All vertices by walking the boundary counter-clockwise from a first
    /// vertex (warm start if it still gives a vertex, else the cold search),
    /// and their centroid.
    ///
    /// Worst case: the cold search (`O(M^2)` clipping, and `4 C(M,2)` solves,
    /// `O(M^3)`, only for lines it cannot rule out), then at most
    /// `2 M` walk steps of `O(M)` each, then the `O(M^2)` choice of the
    /// warm-start vertex. Should rounding make the walk revisit an edge
    /// other than by coming back round along the line of its first vertices
    /// (`close_after_revisit`), it falls back to [`Self::brute_force`]
    /// (`O(M^3)` too).
    pub fn walk(&self, warm: Option<ActivePair>) -> Result<PolygonCentroid<T, M>, Error> {
        let mut vertices = VertexList::new();
        let summary = self.walk_into(warm, &mut vertices)?;
        Ok(PolygonCentroid::from_summary(summary, vertices))
    }

    /// [`Self::walk`] with the vertices written to the caller's list (which
    /// is cleared first): nothing large is returned. The walk records in
    /// the list each line's successor along the boundary; when the warm
    /// start holds, the successors the list kept from its last walk (a
    /// control loop's: the last cycle's polygon) are read first, as each
    /// line's likely successor; a step takes one only when it is provably
    /// the full step's choice (`hinted_step`), so any content gives the same
    /// answer, bit for bit, as an empty list, and the summary counts the
    /// steps that did (`hinted_steps`).
    pub fn walk_into(
        &self,
        warm: Option<ActivePair>,
        vertices: &mut VertexList<T, M>,
    ) -> Result<PolygonSummary<T>, Error> {
        let mut held = false;
        let mut start = None;
        // The cable whose lines the cold search clips first: the one that
        // cut a lost warm start off (its lines are the likeliest edges near
        // where the last vertex was), else the first.
        let mut first_cable = 0;
        if let Some(pair) = warm {
            let h1 = line_index(pair.first);
            let h2 = line_index(pair.second);
            if h1 < 2 * M && h2 < 2 * M {
                start = self.warm_vertex(h1, h2, &mut first_cable);
                held = start.is_some();
            }
        }
        let (start, known) = match start {
            Some(Start { vertex, active, margin }) => (vertex, Some((active, margin))),
            None => (self.first_vertex_from(first_cable).ok_or(Error::Infeasible)?, None),
        };
        // The caller's list still holds its last walk's successors (a control
        // loop's: the previous cycle's): each line's is tried first, when
        // the warm start from it held (after a lost one the polygon has
        // changed too much for its lines to be worth a try).
        match self.walk_from(start, known, vertices, held) {
            Some((robust_pair, hinted, sums)) => {
                self.finish(vertices, Some(sums), Some(robust_pair), held, hinted)
            }
            None => self.after_anomaly(vertices, held),
        }
    }

    /// The polygon after the walk met an anomaly (an edge met twice): closed
    /// where the walk has come back round ([`Self::close_after_revisit`]),
    /// or else every vertex by the pairs of the lines the clipping does not
    /// prove empty (the others hold none). Out of the walk's code.
    #[inline(never)]
    fn after_anomaly(&self, vertices: &mut VertexList<T, M>, held: bool) -> Result<PolygonSummary<T>, Error> {
        if self.close_after_revisit(vertices) {
            // The next cycle's warm start as the walk picks it: the vertex
            // farthest from the lines of the cables that do not define it,
            // among those whose lines' crossing can be computed (the next
            // cycle's check computes it).
            let big = T::max_value().ok_or(Error::NonFinite)?;
            let (mut best, mut best_margin) = (vertices.get(0).lines, -big);
            for v in vertices.iter() {
                let (a, b) = (v.lines.0 as usize, v.lines.1 as usize);
                let margin = self.margin_at(&v.point, a / 2, b / 2, big);
                if margin > best_margin && self.intersect(a, b).is_some() {
                    (best, best_margin) = (v.lines, margin);
                }
            }
            self.finish(vertices, None, Some(pair_of(best)), held, 0)
        } else {
            self.brute_force_among(self.lines_not_proven_empty(), vertices)
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
    ///
    /// With `hints`, a step first tries the line the list's successors give
    /// for the edge (its successor in the last walk's polygon, read before
    /// this walk records its own): it is taken when
    /// [`Self::hinted_step`] proves that the full step would take it, by one
    /// dot product per cable at the new vertex instead of two, a division
    /// and the search for the smallest step; the vertices are the same, bit
    /// for bit.
    fn walk_from(
        &self,
        start: Vertex<T>,
        known: Option<(u64, T)>,
        vertices: &mut VertexList<T, M>,
        hints: bool,
    ) -> Option<(ActivePair, usize, Shoelace<T>)> {
        // The first vertex's active lines and margin ([`Start`]), unless the
        // warm start's check computed them.
        let (active, mut best_margin) = match known {
            Some(known) => known,
            None => {
                let s = self.start_at(start)?;
                (s.active, s.margin)
            }
        };
        vertices.clear();
        vertices.push(start).ok()?;
        // The centroid's sums, each vertex added as it is found.
        let mut sums = Shoelace::new(start.point, self.inv_scale);
        // Every test below is on the unit-normal lines (`UnitLines`): slacks
        // and rates in length units, no division by a row norm per cable,
        // no test for a cable left out.
        let u = &self.unit;
        // Outgoing edge at the first vertex: an active line along which no
        // other active half-plane is violated (Sect. 2.2.2, Eqs. 10-11).
        let mut edge = None;
        let mut candidates = active;
        for _ in 0..2 * M {
            if candidates == 0 {
                break;
            }
            let h = candidates.trailing_zeros() as usize;
            candidates &= candidates - 1;
            let o = self.unit_normal(h);
            let d = Vector2::new(-o.y, o.x);
            let mut others = active & !(1 << h);
            let mut blocked = false;
            for _ in 0..2 * M {
                if others == 0 {
                    break;
                }
                let g = others.trailing_zeros() as usize;
                others &= others - 1;
                if self.unit_normal(g).dot(&d) > self.parallel {
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
            return Some((pair_of(best_lines), 0, sums)); // a single point
        };
        let mut visited: u64 = 1 << first_edge;
        let mut h = first_edge;
        let mut v = start.point;
        // The edge that led to `v` (none yet at the first vertex, whose
        // margin is known).
        let mut prev = None;
        let big = T::max_value()?;
        let par = self.parallel;
        // Whether `v` was taken from the step rather than computed as the
        // crossing of its two lines.
        let mut guessed = false;
        // Per cable, the slack to the limit the edge approaches (`big`:
        // never reached) and the signed rate u_k . d at which it is
        // approached (zero: never reached).
        let mut slacks = [big; M];
        let mut rates = [T::zero(); M];
        // `u_k . d` of the cables within the parallel threshold of the edge.
        let mut shallow_rates = [T::zero(); M];
        // Whether `v`'s margin is still to be compared (it was reached by a
        // full step, whose pass at `v` compares it; a hinted step skips that
        // pass). The first vertex's is known.
        let mut margin_pending = false;
        let mut hinted_steps = 0;
        let mut hints_trusted = true;
        for _ in 0..=2 * M {
            let hc = h / 2;
            let o = self.unit_normal(h);
            let d = Vector2::new(-o.y, o.x);
            let hinted = vertices.successor(h);
            let tried = if hints && hints_trusted && hinted < 2 * M {
                let step = self.hinted_step(h, hinted, &v, &d, big);
                // One wrong hint and the rest of the walk takes full steps:
                // a polygon whose lines changed costs at most one test more.
                hints_trusted = step.is_some();
                step
            } else {
                None
            };
            if let Some((w, error, w_margin)) = tried {
                // What the full step below would do, in the same order.
                if margin_pending && !guessed {
                    let margin = self.margin_at(&v, hc, prev.map_or(hc, |p| p / 2), big);
                    if margin > best_margin {
                        best_margin = margin;
                        best_lines = (pc_line(prev), h as u8);
                    }
                }
                hinted_steps += 1;
                vertices.set_successor(h, hinted);
                if hinted == first_edge {
                    return Some((pair_of(best_lines), hinted_steps, sums));
                }
                if visited & (1 << hinted) != 0 {
                    vertices.revisit = hinted as u8;
                    return None;
                }
                visited |= 1 << hinted;
                vertices.push(Vertex { point: w, lines: (h as u8, hinted as u8), error }).ok()?;
                sums.add(w);
                if w_margin > best_margin {
                    best_margin = w_margin;
                    best_lines = (h as u8, hinted as u8);
                }
                margin_pending = false;
                guessed = false;
                prev = Some(h);
                h = hinted;
                v = w;
                continue;
            }
            // The cables whose lines define `v` (the edge's and the previous
            // edge's), left out of its margin; none at the first vertex,
            // whose margin is known.
            let skip_margin = prev.is_none();
            let pc = prev.map_or(hc, |p| p / 2);
            // Smallest step to another line along the edge (Eqs. 16-19): per
            // cable only the limit the direction approaches can be reached,
            // and never on the edge's own cable (its lines are parallel to
            // the edge). The same pass gives the margin of `v` (its smallest
            // slack to the lines of the cables that do not define it).
            let mut alpha_min = big;
            // The second smallest step and the cable of the smallest.
            let mut alpha_second = big;
            let mut nearest = M;
            let mut margin = big;
            // The cables whose lines are within the parallel threshold of
            // the edge (a bit per cable).
            let mut shallow: u32 = 0;
            for k in 0..M {
                let nv = u.ux[k] * v.x + u.uy[k] * v.y;
                let nd = u.ux[k] * d.x + u.uy[k] * d.y;
                let (s_lo, s_hi) = (nv - u.lo[k], u.hi[k] - nv);
                let own = k == hc;
                if !(own || k == pc) {
                    margin = min(margin, min(s_lo, s_hi));
                }
                // The signed rate: positive towards the upper limit.
                let (slack, rate) = if own {
                    (big, T::zero())
                } else if nd > par {
                    (s_hi, nd)
                } else if nd < -par {
                    (s_lo, nd)
                } else {
                    // Within the parallel threshold: looked at below.
                    shallow |= 1 << k;
                    shallow_rates[k] = nd;
                    (big, T::zero())
                };
                slacks[k] = slack;
                rates[k] = rate;
                if rate != T::zero() {
                    let step = slack / rate.abs();
                    if step < alpha_min {
                        alpha_second = alpha_min;
                        alpha_min = step;
                        nearest = k;
                    } else if step < alpha_second {
                        alpha_second = step;
                    }
                }
            }
            // A vertex whose lines cross too shallowly to be computed (taken
            // from the step along the edge) is no warm start: the next
            // cycle could not find it again.
            if !skip_margin && !guessed && margin > best_margin {
                best_margin = margin;
                best_lines = (pc_line(prev), h as u8);
            }
            // A line within the parallel threshold of the edge that the edge
            // runs along (within `apart` of it here: a twin cable's, or the
            // one just left) is never reached; one well apart that the edge
            // approaches is, far along it (a sliver: at 4.5e-3 rad a
            // 0.76-long edge drifted 1.7e-3 past such a line). Rare, and
            // out of the loop above, whose registers it would cost.
            let mut reached_shallow = 0;
            if shallow != 0 {
                reached_shallow = self.reach_shallow(
                    shallow,
                    &v,
                    &shallow_rates,
                    (&mut slacks, &mut rates),
                    (&mut alpha_min, &mut alpha_second, &mut nearest),
                );
            }
            if nearest == M {
                return None;
            }
            let alpha = max(alpha_min, T::zero());
            // Among lines reached there (ties: concurrent lines, Sect. 2.3),
            // the edge-supporting one bounds the normal cone: the largest
            // counter-clockwise angle from the current normal. A line's slack
            // at the step is `slack_k - alpha |u_k . d|` (`big` for a line
            // never reached). When every other step exceeds the smallest by
            // more than `tie_gap` no other line is reached within its
            // tolerance (`|u_k . d| > parallel`), and the nearest cable's
            // line is the one: the search below would find it alone.
            let mut next = None;
            let mut best_cos = big;
            let mut first_edge_cos = None;
            // (`tie_gap` proves nothing for a line within the parallel
            // threshold: those reached are tested one by one.)
            if alpha_second - alpha > self.tie_gap
                && self.none_ties(reached_shallow, nearest, alpha, &slacks, &rates)
            {
                next = Some(if rates[nearest] > T::zero() { 2 * nearest + 1 } else { 2 * nearest });
            } else {
                for k in 0..M {
                    let rate = rates[k];
                    if slacks[k] - alpha * rate.abs() <= u.tol[k] {
                        let (g, cos) = if rate > T::zero() {
                            (2 * k + 1, u.ux[k] * o.x + u.uy[k] * o.y)
                        } else {
                            (2 * k, -(u.ux[k] * o.x + u.uy[k] * o.y))
                        };
                        if cos < best_cos {
                            best_cos = cos;
                            next = Some(g);
                        }
                        if g == first_edge {
                            first_edge_cos = Some(cos);
                        }
                    }
                }
            }
            // Back at the first vertex, a line that coincides with the first
            // edge's (two cables whose limits meet the null space alike, as
            // at a symmetric pose) ties with it: the walk is closed, not on a
            // new edge that it would then meet twice.
            if first_edge_cos.is_some_and(|c| c <= best_cos + self.parallel) {
                next = Some(first_edge);
            }
            let g = next?;
            vertices.set_successor(h, g);
            if g == first_edge {
                return Some((pair_of(best_lines), hinted_steps, sums));
            }
            if visited & (1 << g) != 0 {
                vertices.revisit = g as u8;
                return None;
            }
            visited |= 1 << g;
            let (w, error) = match self.intersect(h, g) {
                Some(crossing) => {
                    guessed = false;
                    crossing
                }
                None => {
                    guessed = true;
                    (v + d * alpha, self.tol)
                }
            };
            vertices.push(Vertex { point: w, lines: (h as u8, g as u8), error }).ok()?;
            sums.add(w);
            margin_pending = true;
            prev = Some(h);
            h = g;
            v = w;
        }
        None
    }

    /// After the walk met an edge twice: whether it has in fact come back
    /// round, and if so the polygon closed in the list. The walk is on the
    /// list's last edge `h` and was about to take line `g` a second time
    /// (the list's record of it: only the walk's revisit writes it, so the
    /// answer never depends on the successors kept from an earlier walk).
    /// It has come back round when either
    /// * the first vertex lies on `h`'s line within the slack tolerance
    ///   widened by its error bound: the edge along `h` closes the list as
    ///   it is; or
    /// * the crossing `w` of `h` and `g` is a vertex ([`Self::vertex_of`]'s
    ///   check), every vertex before the one at which the walk left `g`
    ///   lies on `g`'s line within that acceptance (dropping them drops a
    ///   sliver along `g`), and `w` comes before that vertex along `g` in
    ///   the walk's direction: the list becomes the vertices from that one
    ///   to the last, then `w`.
    ///
    /// Both happen when the first vertex is the crossing of two nearly
    /// parallel lines (a pair of twin cables', whose crossing has a large
    /// error bound; or three lines nearly concurrent there) and the walk
    /// comes back round along one of them instead of its first edge.
    /// Otherwise `false` (the list unchanged): the brute force decides.
    /// Only after an anomaly, out of the walk, which it costs nothing.
    /// (Along random streams of `f32` setpoints 2 mm and 4 mrad apart, 93
    /// cycles of suspended-8 and 190 of IPAnema 1 in 4 000 000 met an edge
    /// twice, and cost the board's solver 18 461-21 018 instructions by the
    /// brute force: `tests/barycenter.rs`.)
    fn close_after_revisit(&self, vertices: &mut VertexList<T, M>) -> bool {
        // The line the walk was about to take again (none: it stopped
        // otherwise, and nothing is closed).
        let g = vertices.revisit as usize;
        let n = vertices.len();
        if n < 2 || g >= 2 * M {
            return false;
        }
        let h = vertices.get(n - 1).lines.1 as usize;
        let u = &self.unit;
        // Whether vertex `v` lies on line `line` within the slack tolerance
        // widened by its error bound.
        let on_line = |line: usize, v: &Vertex<T>| {
            let k = line / 2;
            let nv = u.ux[k] * v.point.x + u.uy[k] * v.point.y;
            let slack = if line % 2 == 1 { u.hi[k] - nv } else { nv - u.lo[k] };
            slack.abs() <= u.tol[k] + v.error
        };
        // Back round along `h` itself: the first vertex on `h`'s line, and
        // the edge along `h` closes the polygon as it is.
        if on_line(h, &vertices.get(0)) {
            return true;
        }
        // The vertex at which the walk left `g` (arrived along it).
        let Some(left) = (1..n).find(|&i| vertices.get(i).lines.0 as usize == g) else {
            return false;
        };
        let Some(w) = self.vertex_of(h.min(g), h.max(g)) else {
            return false;
        };
        if !(0..left).all(|i| on_line(g, &vertices.get(i))) {
            return false;
        }
        let k = g / 2;
        let o = self.unit_normal(g);
        let d = Vector2::new(-o.y, o.x);
        let next = vertices.get(left);
        if (next.point - w.point).dot(&d) < -(u.tol[k] + next.error + w.error) {
            return false;
        }
        for i in left..n {
            vertices.set(i - left, vertices.get(i));
        }
        vertices.len = n - left;
        // In the walk's order: `w` is entered along `h` and left along `g`.
        vertices.push(Vertex { point: w.point, lines: (h as u8, g as u8), error: w.error }).is_ok()
    }

    /// The crossing of lines `h1` and `h2` as the first vertex when it
    /// satisfies every half-plane within the slack tolerance widened by its
    /// error bound (as [`Self::vertex_of`] checks it, on the unit lines:
    /// `u_k . p - lo_k >= -(tol_k + error)`), with its active lines and
    /// margin ([`Start`]). The check stops at the first cable that rejects
    /// the crossing (a lost warm start then costs the cold search no more
    /// than it must), and names it in `cut`: the cold search clips its lines
    /// first ([`Self::first_vertex_from`]); a held one's slacks are taken
    /// again for the rest.
    fn warm_vertex(&self, h1: usize, h2: usize, cut: &mut usize) -> Option<Start<T>> {
        if h1 / 2 == h2 / 2 || !self.is_used(h1) || !self.is_used(h2) {
            return None;
        }
        let (p, error) = self.intersect(h1, h2)?;
        let u = &self.unit;
        for k in 0..M {
            let nv = u.ux[k] * p.x + u.uy[k] * p.y;
            // The slack to the nearer limit (the limits are finite, so the
            // two slacks are NaN together or not at all; false for a NaN).
            let holds = min(nv - u.lo[k], u.hi[k] - nv) >= -(u.tol[k] + error);
            if !holds {
                *cut = k;
                return None;
            }
        }
        self.start_at(Vertex { point: p, lines: (h1 as u8, h2 as u8), error })
    }

    /// The first vertex's active lines and margin ([`Start`]).
    #[inline(always)]
    fn start_at(&self, vertex: Vertex<T>) -> Option<Start<T>> {
        let u = &self.unit;
        let (l0, l1) = (vertex.lines.0 as usize, vertex.lines.1 as usize);
        // The two lines that define the vertex are active by construction
        // (their computed slack can exceed the tolerance when they are
        // nearly parallel).
        let mut active: u64 = (1 << l0) | (1 << l1);
        // Its smallest slack to another cable's lines.
        let mut margin = T::max_value()?;
        let p = vertex.point;
        for k in 0..M {
            let nv = u.ux[k] * p.x + u.uy[k] * p.y;
            let (s_lo, s_hi) = (nv - u.lo[k], u.hi[k] - nv);
            // The slack to the nearer limit: one comparison for the margin,
            // and the two lines tested for activity only when it is within
            // the tolerance (neither is otherwise).
            let near = min(s_lo, s_hi);
            if near <= u.tol[k] {
                if s_lo.abs() <= u.tol[k] {
                    active |= 1 << (2 * k);
                }
                if s_hi.abs() <= u.tol[k] {
                    active |= 1 << (2 * k + 1);
                }
            }
            if k != l0 / 2 && k != l1 / 2 {
                margin = min(margin, near);
            }
        }
        Some(Start { vertex, active, margin })
    }

    /// The step along edge `h` from `v` (direction `d`) to line `g`, when
    /// the full step of [`Self::walk_from`] would take it: `g`'s cable is
    /// approached on `g`'s side beyond the parallel threshold, the two lines'
    /// crossing is computable, and at the crossing the line each other
    /// cable's rate approaches is more than `clear_gap` away (widened by the
    /// distance between the crossing and the point the step along `d`
    /// reaches). Then no other line is reached before `g`'s or within its
    /// tolerance at the step's point, approached beyond the parallel
    /// threshold or within it (the full step's test for such a line: its
    /// slack at `v` above `alpha |u_k . d| + tol_k`), whichever of its two
    /// rules (the smallest step alone, or the search among the lines
    /// reached) the full step applies: its next line is `g` and its vertex
    /// this crossing. Returns the crossing, its error bound and its margin
    /// (the full step's margin of it, bit for bit); `None` when any of that
    /// fails (or `g` is no line: no hint).
    #[inline]
    fn hinted_step(
        &self,
        h: usize,
        g: usize,
        v: &Vector2<T>,
        d: &Vector2<T>,
        big: T,
    ) -> Option<(Vector2<T>, T, T)> {
        let u = &self.unit;
        let (hc, gc) = (h / 2, g / 2);
        if g >= 2 * M || gc == hc {
            return None;
        }
        let nd = u.ux[gc] * d.x + u.uy[gc] * d.y;
        let nv = u.ux[gc] * v.x + u.uy[gc] * v.y;
        // Approached on `g`'s side beyond the parallel threshold (false for
        // a NaN), or the full step would not take `g`.
        let upper = g % 2 == 1;
        let toward = if upper { nd > self.parallel } else { nd < -self.parallel };
        if !toward {
            return None;
        }
        let slack = if upper { u.hi[gc] - nv } else { nv - u.lo[gc] };
        let alpha = max(slack / nd.abs(), T::zero());
        let (w, error) = self.intersect(h, g)?;
        let reached = v + d * alpha;
        let need = self.clear_gap + (w.x - reached.x).abs() + (w.y - reached.y).abs();
        let margin = self.margin_at(&w, hc, gc, big);
        // Both lines of every other cable far (the usual case), or failing
        // that (a twin of the edge's cable, whose lines run beside the
        // edge), the approached one of each. A line more than `clear_gap`
        // beyond `w` is a line the hint missed (a line the edge leaves lies
        // beyond `w` by no more than it lay beyond `v`, within tolerance):
        // no second pass for it.
        let clear =
            margin > need || (margin > -self.clear_gap && self.approached_clear(&w, d, (hc, gc), need));
        clear.then_some((w, error, margin))
    }

    /// Whether at `w` every cable but `skip`'s has the line that direction
    /// `d` approaches more than `need` away.
    fn approached_clear(&self, w: &Vector2<T>, d: &Vector2<T>, skip: (usize, usize), need: T) -> bool {
        let u = &self.unit;
        for k in 0..M {
            if k == skip.0 || k == skip.1 {
                continue;
            }
            let nv = u.ux[k] * w.x + u.uy[k] * w.y;
            let nd = u.ux[k] * d.x + u.uy[k] * d.y;
            let slack = if nd > T::zero() { u.hi[k] - nv } else { nv - u.lo[k] };
            let far = slack > need;
            if !far {
                return false;
            }
        }
        true
    }

    /// The smallest slack at `p` to the lines of the cables other than `a`
    /// and `b` (`big` when there is none), computed as the full step of
    /// [`Self::walk_from`] computes its margin.
    #[inline]
    fn margin_at(&self, p: &Vector2<T>, a: usize, b: usize, big: T) -> T {
        let u = &self.unit;
        let mut margin = big;
        for k in 0..M {
            let nv = u.ux[k] * p.x + u.uy[k] * p.y;
            let (s_lo, s_hi) = (nv - u.lo[k], u.hi[k] - nv);
            if !(k == a || k == b) {
                margin = min(margin, min(s_lo, s_hi));
            }
        }
        margin
    }

    /// The cables in `shallow` (a bit per cable: lines within the parallel
    /// threshold of the edge from `v`, their `u_k . d` in `shallow_rates`)
    /// whose line the edge
    /// approaches from more than four slack tolerances away: their slack
    /// and rate written, and the smallest, second smallest and nearest
    /// steps updated. Returns those cables (a bit per cable).
    #[inline]
    fn reach_shallow(
        &self,
        shallow: u32,
        v: &Vector2<T>,
        shallow_rates: &[T; M],
        (slacks, rates): (&mut [T; M], &mut [T; M]),
        (alpha_min, alpha_second, nearest): (&mut T, &mut T, &mut usize),
    ) -> u32 {
        let u = &self.unit;
        let mut rest = shallow;
        let mut reached = 0;
        for _ in 0..M {
            if rest == 0 {
                break;
            }
            let k = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let nd = shallow_rates[k];
            // Relevant (below) needs `4 tol_k < slack <= alpha |nd| + tol_k`:
            // never for a line as parallel as a twin cable's.
            let alpha = max(*alpha_min, T::zero());
            if alpha * nd.abs() <= T::lit(3.0) * u.tol[k] {
                continue;
            }
            let nv = u.ux[k] * v.x + u.uy[k] * v.y;
            let apart = T::lit(4.0) * u.tol[k];
            let slack = if nd > T::zero() {
                u.hi[k] - nv
            } else if nd < T::zero() {
                nv - u.lo[k]
            } else {
                continue;
            };
            // Neither reached before the nearest line nor within its
            // tolerance there: nothing to change.
            let reach = alpha * nd.abs() + u.tol[k];
            let relevant = slack > apart && slack <= reach;
            if !relevant {
                continue;
            }
            slacks[k] = slack;
            rates[k] = nd;
            reached |= 1 << k;
            let step = slack / nd.abs();
            if step < *alpha_min {
                *alpha_second = *alpha_min;
                *alpha_min = step;
                *nearest = k;
            } else if step < *alpha_second {
                *alpha_second = step;
            }
        }
        reached
    }

    /// Whether no cable in `cables` (a bit per cable) but `nearest` is
    /// reached within its tolerance at step `alpha` (slack at the step
    /// `slack_k - alpha |rate_k|` above `tol_k`).
    #[inline]
    fn none_ties(&self, cables: u32, nearest: usize, alpha: T, slacks: &[T; M], rates: &[T; M]) -> bool {
        let mut rest = cables & !(1 << nearest);
        for _ in 0..M {
            if rest == 0 {
                return true;
            }
            let k = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let clear = slacks[k] - alpha * rates[k].abs() > self.unit.tol[k];
            if !clear {
                return false;
            }
        }
        rest == 0
    }
}

/// The previous edge's line as stored in a vertex (`0` when none: only
/// read once there is one).
#[inline]
fn pc_line(prev: Option<usize>) -> u8 {
    prev.map_or(0, |p| p as u8)
}

/// The walk's first vertex, the lines active there (a bit per line `2 k +
/// side`: its two and any other within the slack tolerance) and its margin
/// (its smallest slack to the lines of the cables that do not define it).
struct Start<T: Real> {
    vertex: Vertex<T>,
    active: u64,
    margin: T,
}
