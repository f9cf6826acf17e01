//! One entry point for every method, with the warm-start state a control
//! loop carries from one cycle to the next ([`PreviousCycle`]).

use nalgebra::{SMatrix, SVector};

use crate::{
    linalg::WrenchFactorization,
    methods::{self, Method, PolygonWork, PreviousCycle, Workspace},
    polygon::WalkHints,
    Error, Real, Solution, TensionLimits,
};

/// A method plus the previous cycle's result it warm-starts from
/// (the barycenter's active pair, the analytic centre's tensions) and, for
/// [`Self::solve`], the last polygon's [`WalkHints`].
#[derive(Debug, Clone, Copy)]
pub struct TensionSolver<T: Real, const M: usize> {
    method: Method,
    previous: PreviousCycle<T, M>,
    /// The last walk's successors, for [`Self::solve`], whose polygon is
    /// made anew each call ([`Self::solve_with`]'s scratch keeps its own).
    hints: WalkHints<M>,
}

impl<T: Real, const M: usize> TensionSolver<T, M> {
    /// A solver with no history.
    pub fn new(method: Method) -> Self {
        Self { method, previous: PreviousCycle::NONE, hints: WalkHints::NONE }
    }

    /// The method.
    pub fn method(&self) -> Method {
        self.method
    }

    /// What the next call warm-starts from.
    pub fn previous(&self) -> &PreviousCycle<T, M> {
        &self.previous
    }

    /// Forgets the previous cycle (after a jump in the trajectory).
    pub fn reset(&mut self) {
        self.previous = PreviousCycle::NONE;
        self.hints = WalkHints::NONE;
    }

    /// Solves `W t = f` within the limits, warm-started from the previous
    /// successful call. A failed call leaves the warm-start state as it was.
    ///
    /// The barycenter's walk also tries the last call's polygon's edges
    /// first (the solver's [`WalkHints`]: the same answer, bit for bit, with
    /// fewer tests), as a control loop's kept [`Workspace`] does for
    /// [`Self::solve_with`].
    pub fn solve<const N: usize>(
        &mut self,
        w: &SMatrix<T, N, M>,
        f: &SVector<T, N>,
        limits: &TensionLimits<T, M>,
    ) -> Result<Solution<T, M>, Error> {
        // The polygon's room is made only if the method has a polygon.
        let mut scratch = Workspace::lazy(self.hints);
        // The result is built once and returned as is (no unwrapping and
        // re-wrapping of the solution through `?`).
        let result = methods::solve_with(self.method, &mut scratch, w, f, limits, &self.previous);
        if let Ok(solution) = &result {
            self.previous.remember(solution);
            if let Some(hints) = scratch.polygon.hints() {
                self.hints = hints;
            }
        }
        result
    }

    /// [`Self::solve`] with the factorisation and the polygon written to
    /// the caller's `scratch` ([`methods::solve_with`]): the same result,
    /// without clearing them anew every call.
    pub fn solve_with<const N: usize>(
        &mut self,
        scratch: &mut Workspace<T, N, M>,
        w: &SMatrix<T, N, M>,
        f: &SVector<T, N>,
        limits: &TensionLimits<T, M>,
    ) -> Result<Solution<T, M>, Error> {
        let result = methods::solve_with(self.method, scratch, w, f, limits, &self.previous);
        if let Ok(solution) = &result {
            self.previous.remember(solution);
        }
        result
    }

    /// [`Self::solve_with`] for a `W` the caller has factored already
    /// ([`methods::solve_factored`]: `factorization` must be `w`'s, with
    /// [`Method::null_columns`] null-space columns for this solver's
    /// method), the polygon written to `work`.
    pub fn solve_factored<const N: usize>(
        &mut self,
        factorization: &WrenchFactorization<T, N, M>,
        work: &mut PolygonWork<T, N, M>,
        w: &SMatrix<T, N, M>,
        f: &SVector<T, N>,
        limits: &TensionLimits<T, M>,
    ) -> Result<Solution<T, M>, Error> {
        let result = methods::solve_factored(self.method, factorization, work, w, f, limits, &self.previous);
        if let Ok(solution) = &result {
            self.previous.remember(solution);
        }
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_call_keeps_the_warm_start_and_reset_forgets_it() {
        let w = SMatrix::<f64, 1, 3>::new(1.0, 1.0, 1.0);
        let limits = TensionLimits::uniform(1.0, 10.0).unwrap();
        let mut solver = TensionSolver::<f64, 3>::new(Method::Barycenter);
        solver.solve(&w, &SVector::<f64, 1>::new(12.0), &limits).unwrap();
        let pair = solver.previous.active_pair;
        assert!(pair.is_some());
        assert_eq!(solver.solve(&w, &SVector::<f64, 1>::new(100.0), &limits).unwrap_err(), Error::Infeasible);
        assert_eq!(solver.previous.active_pair, pair);
        let again = solver.solve(&w, &SVector::<f64, 1>::new(12.0), &limits).unwrap();
        assert_eq!(again.diagnostics.warm_start, crate::WarmStart::Held);
        solver.reset();
        let cold = solver.solve(&w, &SVector::<f64, 1>::new(12.0), &limits).unwrap();
        assert_eq!(cold.diagnostics.warm_start, crate::WarmStart::NotGiven);
        // Sum 12 in [1, 10]^3: the triangle's centroid is 4 each.
        assert!((cold.tensions - SVector::<f64, 3>::repeat(4.0)).amax() < 1e-12);
    }

    /// `solve` carries the last walk's hints from call to call: along a
    /// sequence of nearby polygons (and across an infeasible call, which
    /// keeps them) they are the ones a walk of the next polygon takes
    /// hinted steps from, the answers are those of the same solver without
    /// them, bit for bit, and `reset` forgets them.
    #[test]
    fn solve_carries_the_last_walks_hints() {
        use crate::{linalg::WrenchFactorization, polygon::VertexList, tension_polygon::TensionPolygon};
        let limits =
            TensionLimits::new(SVector::from([1.0, 0.5, 2.0]), SVector::from([10.0, 9.0, 12.0])).unwrap();
        let w = SMatrix::<f64, 1, 3>::new(1.0, 0.8, 1.3);
        let mut fact = WrenchFactorization::<f64, 1, 3>::zeroed();
        fact.factor(&w, &[true; 3], 2).unwrap();
        let mut carried = TensionSolver::<f64, 3>::new(Method::Barycenter);
        let (mut compared, mut hinted) = (0, 0);
        for f in [12.0, 12.4, 12.8, 100.0, 13.2, 13.6, 14.0] {
            let f = SVector::<f64, 1>::new(f);
            let hints = carried.hints;
            let bare = TensionSolver { hints: WalkHints::NONE, ..carried };
            let feasible = f[0] < 50.0;
            if feasible {
                // What the carried hints do for this polygon's walk.
                let poly = TensionPolygon::new(&fact, &f, &limits).unwrap();
                let mut list = VertexList::with_hints(hints);
                hinted +=
                    poly.polygon.walk_into(carried.previous.active_pair, &mut list).unwrap().hinted_steps;
                let mut bare = bare;
                assert_eq!(carried.solve(&w, &f, &limits), bare.solve(&w, &f, &limits), "f = {f}");
                assert_eq!(carried.previous, bare.previous);
                assert_eq!(carried.hints, list.hints(), "f = {f}");
                compared += 1;
            } else {
                assert_eq!(carried.solve(&w, &f, &limits).unwrap_err(), Error::Infeasible);
                assert_eq!(carried.hints, hints, "an infeasible call keeps them");
            }
            assert_ne!(carried.hints, WalkHints::NONE);
        }
        assert_eq!(compared, 6);
        // Every walk after the first took hinted steps.
        assert!(hinted >= 5, "{hinted} hinted steps");
        carried.reset();
        assert_eq!(carried.hints, WalkHints::NONE);
    }

    /// `solve_with` is `solve` whatever the scratch held before: the same
    /// answers and warm starts along a sequence of problems (feasible,
    /// infeasible, another method's factorisation and polygon left in the
    /// workspace), for both polygon methods.
    #[test]
    fn solve_with_a_kept_workspace_is_solve() {
        let limits = TensionLimits::uniform(1.0, 10.0).unwrap();
        let w = SMatrix::<f64, 1, 3>::new(1.0, 1.0, 1.0);
        let mut scratch = Workspace::<f64, 1, 3>::new();
        let mut compared = 0;
        for method in [Method::Barycenter, Method::BarycenterBrute] {
            let mut other = TensionSolver::<f64, 3>::new(Method::ClosedForm);
            let _ = other.solve_with(&mut scratch, &w, &SVector::<f64, 1>::new(5.0), &limits);
            let mut plain = TensionSolver::<f64, 3>::new(method);
            let mut kept = TensionSolver::<f64, 3>::new(method);
            for f in [12.0, 13.0, 100.0, 3.5, 29.0, 30.0, 31.0, 12.0] {
                let f = SVector::<f64, 1>::new(f);
                let a = plain.solve(&w, &f, &limits);
                let b = kept.solve_with(&mut scratch, &w, &f, &limits);
                assert_eq!(a, b, "{method:?}, f = {f}");
                assert_eq!(plain.previous, kept.previous);
                compared += 1;
            }
        }
        assert_eq!(compared, 16);
    }
}
