//! One entry point for every method, with the warm-start state a control
//! loop carries from one cycle to the next.

use nalgebra::{SMatrix, SVector};

use crate::{
    analytic_centre::AnalyticCentre,
    barycenter::{barycenter_brute_factored, barycenter_factored, ActivePair},
    closed_form::{closed_form_factored, improved_closed_form},
    linalg::WrenchFactorization,
    norms::{min_1_norm_factored, min_2_norm_factored},
    optimally_safe::optimally_safe_factored,
    puncture::{improved_puncture, puncture_factored},
    Error, Real, Solution, TensionLimits,
};

/// The tension distribution methods, named as in the conventions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// `barycenter`: Lamaury & Gouttefarde 2013 (`M = N + 2`).
    Barycenter,
    /// `barycenter-brute`: Mikelsons et al. 2008 (`M = N + 2`).
    BarycenterBrute,
    /// `analytic-centre`: Di Paola et al. 2024 (any `M >= N`).
    AnalyticCentre,
    /// `closed-form`: Pott et al. 2009 (any `M >= N`).
    ClosedForm,
    /// `improved-closed-form`: Pott 2013 (any `M >= N`).
    ImprovedClosedForm,
    /// `puncture`: Müller, Reichert & Bruckmann 2014 (any `M >= N`).
    Puncture,
    /// `improved-puncture`: Müller, Reichert & Bruckmann 2014 (any `M >= N`).
    ImprovedPuncture,
    /// `min-2-norm`: smallest 2-norm (any `M >= N`).
    Min2Norm,
    /// `min-1-norm`: smallest 1-norm (any `M >= N`).
    Min1Norm,
    /// `optimally-safe`: Borgstrom et al. 2009 (any `M >= N`).
    OptimallySafe,
}

impl Method {
    /// Every method, in the conventions' order.
    pub const ALL: [Method; 10] = [
        Method::Barycenter,
        Method::BarycenterBrute,
        Method::AnalyticCentre,
        Method::ClosedForm,
        Method::ImprovedClosedForm,
        Method::Puncture,
        Method::ImprovedPuncture,
        Method::Min2Norm,
        Method::Min1Norm,
        Method::OptimallySafe,
    ];

    /// The conventions' name.
    pub const fn name(self) -> &'static str {
        match self {
            Method::Barycenter => "barycenter",
            Method::BarycenterBrute => "barycenter-brute",
            Method::AnalyticCentre => "analytic-centre",
            Method::ClosedForm => "closed-form",
            Method::ImprovedClosedForm => "improved-closed-form",
            Method::Puncture => "puncture",
            Method::ImprovedPuncture => "improved-puncture",
            Method::Min2Norm => "min-2-norm",
            Method::Min1Norm => "min-1-norm",
            Method::OptimallySafe => "optimally-safe",
        }
    }

    /// Parses the conventions' name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Whether the method applies to `M` cables and `N` degrees of freedom.
    pub const fn supports(self, n: usize, m: usize) -> bool {
        match self {
            Method::Barycenter | Method::BarycenterBrute => m == n + 2,
            _ => m >= n && n > 0,
        }
    }
}

/// A method plus the previous cycle's result it warm-starts from
/// (the barycenter's active pair, the analytic centre's tensions).
#[derive(Debug, Clone, Copy)]
pub struct TensionSolver<T: Real, const M: usize> {
    method: Method,
    previous_pair: Option<ActivePair>,
    previous_tensions: Option<SVector<T, M>>,
}

impl<T: Real, const M: usize> TensionSolver<T, M> {
    /// A solver with no history.
    pub fn new(method: Method) -> Self {
        Self { method, previous_pair: None, previous_tensions: None }
    }

    /// The method.
    pub fn method(&self) -> Method {
        self.method
    }

    /// Forgets the previous cycle (after a jump in the trajectory).
    pub fn reset(&mut self) {
        self.previous_pair = None;
        self.previous_tensions = None;
    }

    /// Solves `W t = f` within the limits, warm-started from the previous
    /// successful call. A failed call leaves the warm-start state as it was.
    pub fn solve<const N: usize>(
        &mut self,
        w: &SMatrix<T, N, M>,
        f: &SVector<T, N>,
        limits: &TensionLimits<T, M>,
    ) -> Result<Solution<T, M>, Error> {
        if !self.method.supports(N, M) {
            return Err(Error::UnsupportedShape);
        }
        // The result is built once and returned as is (no unwrapping and
        // re-wrapping of the solution through `?`).
        let result = match self.method {
            Method::ImprovedClosedForm => improved_closed_form(w, f, limits),
            Method::ImprovedPuncture => improved_puncture(w, f, limits),
            method => {
                // Filled in place: no factorisation moved through a `Result`.
                let mut fact = WrenchFactorization::zeroed();
                let null_columns = if method == Method::ClosedForm { 0 } else { M - N };
                fact.factor(w, &[true; M], null_columns)?;
                match method {
                    Method::Barycenter => barycenter_factored(&fact, f, limits, self.previous_pair),
                    Method::BarycenterBrute => barycenter_brute_factored(&fact, f, limits),
                    Method::AnalyticCentre => AnalyticCentre::default().solve_factored(
                        &fact,
                        w,
                        f,
                        limits,
                        self.previous_tensions.as_ref(),
                    ),
                    Method::Puncture => puncture_factored(&fact, w, f, limits),
                    Method::Min2Norm => min_2_norm_factored(&fact, f, limits, self.previous_pair),
                    Method::Min1Norm => min_1_norm_factored(&fact, f, limits, self.previous_pair),
                    Method::OptimallySafe => optimally_safe_factored(&fact, f, limits),
                    _ => closed_form_factored(&fact, w, f, limits),
                }
            }
        };
        if let Ok(solution) = &result {
            if let Some(pair) = solution.diagnostics.active_pair {
                self.previous_pair = Some(pair);
            }
            self.previous_tensions = Some(solution.tensions);
        }
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_shapes() {
        for m in Method::ALL {
            assert_eq!(Method::from_name(m.name()), Some(m));
        }
        assert_eq!(Method::from_name("barycentre"), None);
        assert!(Method::Barycenter.supports(6, 8) && !Method::Barycenter.supports(6, 7));
        assert!(Method::ImprovedClosedForm.supports(6, 12) && !Method::ClosedForm.supports(6, 5));
    }

    #[test]
    fn failed_call_keeps_the_warm_start_and_reset_forgets_it() {
        let w = SMatrix::<f64, 1, 3>::new(1.0, 1.0, 1.0);
        let limits = TensionLimits::uniform(1.0, 10.0).unwrap();
        let mut solver = TensionSolver::<f64, 3>::new(Method::Barycenter);
        solver.solve(&w, &SVector::<f64, 1>::new(12.0), &limits).unwrap();
        let pair = solver.previous_pair;
        assert!(pair.is_some());
        assert_eq!(solver.solve(&w, &SVector::<f64, 1>::new(100.0), &limits).unwrap_err(), Error::Infeasible);
        assert_eq!(solver.previous_pair, pair);
        let again = solver.solve(&w, &SVector::<f64, 1>::new(12.0), &limits).unwrap();
        assert_eq!(again.diagnostics.warm_start, crate::WarmStart::Held);
        solver.reset();
        let cold = solver.solve(&w, &SVector::<f64, 1>::new(12.0), &limits).unwrap();
        assert_eq!(cold.diagnostics.warm_start, crate::WarmStart::NotGiven);
        // Sum 12 in [1, 10]^3: the triangle's centroid is 4 each.
        assert!((cold.tensions - SVector::<f64, 3>::repeat(4.0)).amax() < 1e-12);
    }
}
