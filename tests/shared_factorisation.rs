//! One factorisation of `W` a cycle, shared by the estimator and the
//! tension solver: [`WrenchFactorization::solve_gram`] (the normal
//! equations `W W^T x = g` through `R`) against an independent solve of
//! the formed Gram matrix, and [`methods::solve_factored`] /
//! [`TensionSolver::solve_factored`] against [`methods::solve_with`], which
//! factors `W` itself.

use cdpr_integration_tests::{frame_poses, persisted_config, shipped_robot};
use nalgebra::{DMatrix, DVector, SMatrix, SVector};
use proptest::prelude::*;
use tension_core::linalg::WrenchFactorization;
use tension_core::methods::{self, PolygonWork, Workspace};
use tension_core::{Error, Method, PreviousCycle, Robot, TensionSolver};

/// `W W^T x = g` by an LU of the formed Gram matrix in `f64` (nalgebra's,
/// not tension-core's arithmetic), and the Gram matrix's condition number
/// (from its singular values).
fn gram_reference(w: &SMatrix<f64, 6, 8>, g: &SVector<f64, 6>) -> (DVector<f64>, f64) {
    let a = DMatrix::from_fn(6, 6, |i, j| w.row(i).dot(&w.row(j)));
    let sv = a.clone().svd(false, false).singular_values;
    let cond = sv.max() / sv.min();
    let x = a.lu().solve(&DVector::from_column_slice(g.as_slice())).expect("regular Gram matrix");
    (x, cond)
}

proptest! {
    #![proptest_config(persisted_config(256, file!()))]

    /// Through `R` the normal equations give the Gram matrix's solution to
    /// rounding amplified by its condition number.
    #[test]
    fn solve_gram_is_the_gram_matrix_solve(
        entries in prop::collection::vec(-1.0f64..1.0, 48),
        rhs in prop::collection::vec(-10.0f64..10.0, 6),
    ) {
        let w = SMatrix::<f64, 6, 8>::from_column_slice(&entries);
        let g = SVector::<f64, 6>::from_column_slice(&rhs);
        let (reference, cond) = gram_reference(&w, &g);
        prop_assume!(cond < 1e8);
        let fact = WrenchFactorization::new(&w).unwrap();
        let x = fact.solve_gram(&g, 0.0, 0.0).expect("no pivot test asked for");
        let scale = reference.amax().max(1e-300);
        for i in 0..6 {
            prop_assert!(
                (x[i] - reference[i]).abs() <= 1e-13 * cond * scale,
                "x[{i}] {} vs {} (condition {cond:.3e})", x[i], reference[i]
            );
        }
    }
}

/// The pivot test is the one a factorisation of `W W^T` makes: a row of
/// `W` within `1e-5` of another's direction gives a relative pivot of
/// about `1e-10`, refused at `1e-6` and accepted without the test; a
/// regular `W` passes it.
#[test]
fn solve_gram_refuses_a_nearly_dependent_row() {
    let regular = SMatrix::<f64, 6, 8>::from_fn(|i, j| (((i * 8 + j) * (i * 8 + j) + 1) as f64).sin());
    let g = SVector::<f64, 6>::new(1.0, -2.0, 0.5, 0.25, 3.0, -1.0);
    let fact = WrenchFactorization::new(&regular).unwrap();
    assert!(fact.solve_gram(&g, 1e-12, 1e-6).is_some());
    let mut nearly = regular;
    let row4 = regular.row(4).into_owned();
    nearly.set_row(5, &(row4 * 2.0 + regular.row(5) * 1e-5));
    let fact = WrenchFactorization::new(&nearly).unwrap();
    assert_eq!(fact.solve_gram(&g, 1e-12, 1e-6), None);
    let x = fact.solve_gram(&g, 0.0, 0.0).expect("no pivot test");
    let (reference, _) = gram_reference(&nearly, &g);
    assert!((DVector::from_column_slice(x.as_slice()) - &reference).amax() <= 1e-3 * reference.amax());
    // An absolute floor above every pivot refuses even the regular `W`.
    let fact = WrenchFactorization::new(&regular).unwrap();
    assert_eq!(fact.solve_gram(&g, 1e6, 0.0), None);
}

/// Every method, warm-started along a table of frame poses (feasible,
/// infeasible, outside the workspace): factoring first and solving with
/// the factorisation gives the very result of `solve_with`, bit for bit,
/// and the same warm-start state.
fn factored_is_solve_with(robot: &Robot<f64, 6, 8>, centre: [f64; 3], half_size: [f64; 4]) -> usize {
    let poses = frame_poses(centre, half_size, 400, 11);
    let mut compared = 0;
    for method in Method::ALL.into_iter().filter(|m| m.supports(6, 8)) {
        let mut plain = TensionSolver::<f64, 8>::new(method);
        let mut shared = TensionSolver::<f64, 8>::new(method);
        let mut scratch = Workspace::<f64, 6, 8>::new();
        let mut fact = WrenchFactorization::<f64, 6, 8>::zeroed();
        let mut work = PolygonWork::<f64, 6, 8>::new();
        for pose in &poses {
            let (Ok(w), Ok(f)) =
                (robot.wrench_matrix(pose), robot.required_wrench(pose, &SVector::zeros(), None))
            else {
                continue;
            };
            let a = plain.solve_with(&mut scratch, &w, &f, robot.limits());
            let b = match fact.factor(&w, &[true; 8], method.null_columns(6, 8)) {
                Ok(()) => shared.solve_factored(&fact, &mut work, &w, &f, robot.limits()),
                Err(e) => Err(e),
            };
            assert_eq!(a, b, "{method:?} at {pose:?}");
            assert_eq!(plain.previous(), shared.previous(), "{method:?} at {pose:?}");
            compared += 1;
        }
    }
    compared
}

#[test]
fn solve_factored_is_solve_with_for_every_method() {
    let suspended: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let ipanema: Robot<f64, 6, 8> = shipped_robot("ipanema1");
    let compared = factored_is_solve_with(&suspended, [0.0, 0.0, 1.6], [1.5, 1.2, 1.0, 0.3])
        + factored_is_solve_with(&ipanema, [0.0, 0.0, 1.0], [1.8, 1.4, 0.9, 0.4]);
    // 400 poses a robot, ten methods: every one compared.
    assert!(compared >= 2 * 400 * 9, "only {compared} comparisons");
}

/// A factorisation that holds nothing (never made, or failed) or lacks the
/// null space a method reads is refused, never solved with.
#[test]
fn solve_factored_refuses_a_factorisation_it_cannot_use() {
    let robot: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let pose = SVector::<f64, 6>::new(0.0, 0.0, 1.6, 0.0, 0.0, 0.0);
    let w = robot.wrench_matrix(&pose).unwrap();
    let f = robot.required_wrench(&pose, &SVector::zeros(), None).unwrap();
    let limits = robot.limits();
    let none = PreviousCycle::NONE;
    let mut work = PolygonWork::<f64, 6, 8>::new();
    let mut fact = WrenchFactorization::<f64, 6, 8>::zeroed();
    let mut refused = 0;
    for method in [Method::Barycenter, Method::ClosedForm, Method::AnalyticCentre] {
        let never = methods::solve_factored(method, &fact, &mut work, &w, &f, limits, &none);
        assert_eq!(never.unwrap_err(), Error::UnsupportedShape, "{method:?}");
        refused += 1;
    }
    // Without the null space: the closed form solves, the polygon methods refuse.
    fact.factor(&w, &[true; 8], 0).unwrap();
    assert!(methods::solve_factored(Method::ClosedForm, &fact, &mut work, &w, &f, limits, &none).is_ok());
    let polygon = methods::solve_factored(Method::Barycenter, &fact, &mut work, &w, &f, limits, &none);
    assert_eq!(polygon.unwrap_err(), Error::UnsupportedShape);
    refused += 1;
    // A failed factorisation (a rank-deficient `W`) holds nothing.
    let mut singular = w;
    let row = w.row(0).into_owned();
    singular.set_row(1, &(row * 3.0));
    assert_eq!(fact.factor(&singular, &[true; 8], 2), Err(Error::Singular));
    assert_eq!(fact.null_columns(), None);
    let failed = methods::solve_factored(Method::ClosedForm, &fact, &mut work, &singular, &f, limits, &none);
    assert_eq!(failed.unwrap_err(), Error::UnsupportedShape);
    refused += 1;
    assert_eq!(refused, 5);
}
