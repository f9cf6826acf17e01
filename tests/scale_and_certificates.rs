//! What an independent hostile campaign found wrong outside the 6 x 8 happy
//! path, each as a test that fails without its fix:
//! * an `infeasible` must be a certificate: random shapes with redundancy
//!   0 to 6, feasible by construction, never get it; where a method says it on
//!   a random wrench, an independent LP (clarabel) agrees;
//! * the same problem scaled by `s` (limits and wrench, 1e-30 to 1e30 in
//!   `f64`) has the same status and tensions scaled by `s`;
//! * a warm start may make a method faster, never make it fail: random (not
//!   smooth) pose tables through `TensionSolver` for every method that warm
//!   starts give the cold start's status;
//! * the analytic centre at `m = n` meets `W t = f` to rounding, warm or cold.

use cdpr_integration_tests::shipped_robot;
use clarabel::{algebra::CscMatrix, solver::*};
use nalgebra::{SMatrix, SVector};
use proptest::prelude::*;
use tension_core::linalg::WrenchFactorization;
use tension_core::{solve, Error, Method, PreviousCycle, Real, Robot, TensionLimits, TensionSolver};

/// Whether some `t` with `W t = f` lies within the limits, by clarabel (an
/// interior-point LP with infeasibility certificates of its own).
fn lp_feasible<const N: usize, const M: usize>(
    w: &SMatrix<f64, N, M>,
    f: &SVector<f64, N>,
    limits: &TensionLimits<f64, M>,
) -> Option<bool> {
    let p = CscMatrix::zeros((M, M));
    let q = vec![0.0; M];
    let rows = N + 2 * M;
    let mut dense = vec![vec![0.0; M]; rows];
    let mut b = vec![0.0; rows];
    for r in 0..N {
        for c in 0..M {
            dense[r][c] = w[(r, c)];
        }
        b[r] = f[r];
    }
    for i in 0..M {
        dense[N + i][i] = 1.0;
        b[N + i] = limits.max()[i];
        dense[N + M + i][i] = -1.0;
        b[N + M + i] = -limits.min()[i];
    }
    let a = CscMatrix::from(&dense);
    let cones = [ZeroConeT(N), NonnegativeConeT(2 * M)];
    let settings = DefaultSettingsBuilder::default().verbose(false).build().ok()?;
    let mut solver = DefaultSolver::new(&p, &q, &a, &b, &cones, settings).ok()?;
    solver.solve();
    match solver.solution.status {
        SolverStatus::Solved => Some(true),
        SolverStatus::PrimalInfeasible => Some(false),
        _ => None,
    }
}

/// A well-conditioned `W` (entries in [-1, 1] plus a dominant block), a `t0`
/// at least 10 % of the range inside every limit, and `f = W t0`.
fn feasible_problem<const N: usize, const M: usize>(
) -> impl Strategy<Value = (SMatrix<f64, N, M>, SVector<f64, N>, TensionLimits<f64, M>)> {
    (
        prop::collection::vec(-1.0f64..1.0, N * M),
        prop::collection::vec(0.1f64..0.9, M),
        0.0f64..20.0,
        1.0f64..500.0,
    )
        .prop_map(|(entries, inside, t_min, width)| {
            let w = SMatrix::from_fn(|i, j| entries[i * M + j] + if i == j % N { 2.0 } else { 0.0 });
            let limits = TensionLimits::uniform(t_min, t_min + width).unwrap();
            let t0 = SVector::<f64, M>::from_fn(|i, _| t_min + width * inside[i]);
            (w, w * t0, limits)
        })
}

/// Every method on a problem that has tensions strictly inside the limits:
/// none may say `infeasible`. Returns the number of methods that answered.
fn never_falsely_infeasible<T: Real + std::fmt::Debug, const N: usize, const M: usize>(
    w: &SMatrix<f64, N, M>,
    f: &SVector<f64, N>,
    limits: &TensionLimits<f64, M>,
) -> usize {
    let w = w.map(T::lit);
    let f = f.map(T::lit);
    let limits = TensionLimits::new(limits.min().map(T::lit), limits.max().map(T::lit)).unwrap();
    let mut answered = 0;
    for method in Method::ALL.into_iter().filter(|m| m.supports(N, M)) {
        match solve(method, &w, &f, &limits, &PreviousCycle::NONE) {
            Err(Error::Infeasible) => panic!("{method:?} {N}x{M}: infeasible on a feasible problem"),
            Ok(_) => answered += 1,
            Err(_) => {}
        }
    }
    answered
}

macro_rules! shapes {
    ($($name:ident: $n:literal x $m:literal,)*) => {
        proptest! {
            #![proptest_config(cdpr_integration_tests::persisted_config(cdpr_integration_tests::campaign_cases(64), file!()))]
            $(
                #[test]
                fn $name((w, f, limits) in feasible_problem::<$n, $m>()) {
                    let a = never_falsely_infeasible::<f64, $n, $m>(&w, &f, &limits);
                    let b = never_falsely_infeasible::<f32, $n, $m>(&w, &f, &limits);
                    // The methods for any redundancy answer a problem this far
                    // inside, unless `W` is singular to the precision (f32 at
                    // a condition number of 1e5 and more).
                    let singular_f32 = WrenchFactorization::new(&w.map(|x| x as f32)).is_err();
                    prop_assert!(a >= 4 && (b >= 4 || singular_f32), "{a} / {b} methods answered");
                }
            )*
        }
    };
}

shapes! {
    feasible_2x2: 2 x 2,
    feasible_2x4: 2 x 4,
    feasible_2x6: 2 x 6,
    feasible_2x8: 2 x 8,
    feasible_3x4: 3 x 4,
    feasible_3x5: 3 x 5,
    feasible_3x8: 3 x 8,
    feasible_6x6: 6 x 6,
    feasible_6x7: 6 x 7,
    feasible_6x8: 6 x 8,
    feasible_6x9: 6 x 9,
    feasible_6x10: 6 x 10,
    feasible_6x12: 6 x 12,
}

/// Random wrenches (feasible or not): where `min-1-norm`, `min-2-norm` or
/// `optimally-safe` says `infeasible`, clarabel must find no tensions either.
fn infeasible_agrees_with_the_lp<const N: usize, const M: usize>(cases: u32) {
    let mut runner = proptest::test_runner::TestRunner::new(cdpr_integration_tests::persisted_config(
        cdpr_integration_tests::campaign_cases(cases),
        file!(),
    ));
    let infeasible = std::cell::Cell::new(0usize);
    runner
        .run(&cdpr_integration_tests::random_problem::<N, M>(3.0), |(w, f, limits)| {
            for method in [Method::Min1Norm, Method::Min2Norm, Method::OptimallySafe, Method::AnalyticCentre]
            {
                if solve(method, &w, &f, &limits, &PreviousCycle::NONE) == Err(Error::Infeasible) {
                    infeasible.set(infeasible.get() + 1);
                    prop_assert_ne!(lp_feasible(&w, &f, &limits), Some(true), "{:?} {}x{}", method, N, M);
                }
            }
            Ok(())
        })
        .unwrap();
    // The strategy pushes half the wrenches out: some certificates were checked.
    assert!(infeasible.get() > 0, "{N}x{M}: no infeasible case reached the LP");
}

#[test]
fn infeasible_agrees_with_the_lp_on_every_redundancy() {
    infeasible_agrees_with_the_lp::<3, 3>(128);
    infeasible_agrees_with_the_lp::<3, 5>(128);
    infeasible_agrees_with_the_lp::<3, 8>(128);
    infeasible_agrees_with_the_lp::<6, 8>(128);
    infeasible_agrees_with_the_lp::<6, 10>(128);
    infeasible_agrees_with_the_lp::<6, 12>(128);
}

/// Statuses and tensions of every method on suspended-8 at a pose, with the
/// limits and the wrench scaled by `s`.
fn scaled<T: Real>(robot: &Robot<T, 6, 8>, pose: &SVector<T, 6>, s: T) -> Vec<Result<SVector<T, 8>, Error>> {
    let w = robot.wrench_matrix(pose).unwrap();
    let f = robot.required_wrench(pose, &SVector::zeros(), None).unwrap() * s;
    let limits = TensionLimits::new(robot.limits().min() * s, robot.limits().max() * s).unwrap();
    Method::ALL
        .iter()
        .map(|&m| solve(m, &w, &f, &limits, &PreviousCycle::NONE).map(|sol| sol.tensions))
        .collect()
}

fn same_answer_at_every_scale<T: Real + std::fmt::Debug>(exponents: std::ops::RangeInclusive<i32>, rel: f64) {
    let robot: Robot<T, 6, 8> = shipped_robot("suspended-8");
    let range = robot.limits().max()[0] - robot.limits().min()[0];
    for pose in [
        SVector::<T, 6>::from_fn(|i, _| T::lit([0.0, 0.0, 1.8, 0.0, 0.0, 0.0][i])),
        SVector::<T, 6>::from_fn(|i, _| T::lit([0.4, -0.3, 1.5, 0.05, -0.05, 0.1][i])),
    ] {
        let unit = scaled(&robot, &pose, T::one());
        assert!(unit.iter().any(|r| r.is_ok()));
        for k in exponents.clone() {
            let s = T::lit(10f64.powi(k));
            for (m, (a, b)) in Method::ALL.iter().zip(unit.iter().zip(scaled(&robot, &pose, s))) {
                match (a, b) {
                    (Ok(a), Ok(b)) => {
                        let d = (b / s - a).amax();
                        assert!(d <= T::lit(rel) * range, "{m:?} at 1e{k}: |t/s - t| = {d:?}");
                        // The limits hold relative to their scale.
                        for i in 0..8 {
                            assert!(
                                b[i] >= robot.limits().min()[i] * s * T::lit(1.0 - rel),
                                "{m:?} at 1e{k}: {b:?}"
                            );
                        }
                    }
                    (a, b) => assert_eq!(a.map(|_| ()), b.map(|_| ()), "{m:?} at 1e{k}"),
                }
            }
        }
    }
}

#[test]
fn f64_answers_scale_from_1e_minus_30_to_1e30() {
    same_answer_at_every_scale::<f64>(-30..=30, 1e-9);
}

#[test]
fn f32_answers_scale_from_1e_minus_12_to_1e16() {
    same_answer_at_every_scale::<f32>(-12..=16, 1e-3);
}

/// A pose table in random order (no smoothness for the warm start to use),
/// solved warm down the rows and cold row by row: the same statuses.
fn warm_never_fails_where_cold_succeeds<const M: usize>(
    robot: &Robot<f64, 6, M>,
    centre: [f64; 3],
    half_size: [f64; 4],
    count: usize,
    seed: u64,
) {
    let poses = cdpr_integration_tests::frame_poses(centre, half_size, count, seed);
    for method in Method::ALL.into_iter().filter(|m| m.warm_starts() && m.supports(6, M)) {
        let mut warm = TensionSolver::<f64, M>::new(method);
        let mut cold_ok = 0;
        for pose in &poses {
            let (Ok(w), Ok(f)) =
                (robot.wrench_matrix(pose), robot.required_wrench(pose, &SVector::zeros(), None))
            else {
                continue;
            };
            let cold = solve(method, &w, &f, robot.limits(), &PreviousCycle::NONE);
            let hot = warm.solve(&w, &f, robot.limits());
            cold_ok += cold.is_ok() as usize;
            assert_eq!(cold.map(|_| ()), hot.map(|_| ()), "{method:?} at {pose:?}");
        }
        assert!(cold_ok >= 40, "{method:?}: only {cold_ok} feasible poses");
    }
}

#[test]
fn warm_starts_never_fail_where_the_cold_start_succeeds() {
    // The whole frame of IPAnema 1 (1-10 N): the analytic centre's warm start
    // failed (no-convergence, singular) on about one pose in 2000 of these.
    let ipanema: Robot<f64, 6, 8> = shipped_robot("ipanema1");
    warm_never_fails_where_cold_succeeds(&ipanema, [0.0, 0.0, 1.0], [1.8, 1.4, 0.9, 0.4], 20_000, 7);
    let suspended: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    warm_never_fails_where_cold_succeeds(&suspended, [0.0, 0.0, 1.6], [1.5, 1.2, 1.0, 0.3], 4000, 2);
    let ten: Robot<f64, 6, 10> = shipped_robot("spatial6-10");
    warm_never_fails_where_cold_succeeds(&ten, [0.0, 0.0, 1.2], [1.0, 1.0, 0.8, 0.3], 4000, 3);
}

/// At `m = n` the tensions are `W^-1 f`: warm or cold, the analytic centre
/// meets `W t = f` to rounding.
fn square_meets_the_wrench<T: Real + std::fmt::Debug>(tol: f64) {
    let w = SMatrix::<T, 2, 2>::from_fn(|i, j| T::lit([[1.0, 0.3], [-0.2, 0.9]][i][j]));
    let t0 = SVector::<T, 2>::from_fn(|i, _| T::lit([400.0, 650.0][i]));
    let f = w * t0;
    let limits = TensionLimits::uniform(T::lit(10.0), T::lit(1000.0)).unwrap();
    // A warm start 0.05 N off the solution (the previous cycle's tensions).
    let nearby = t0 + SVector::repeat(T::lit(0.05));
    for previous in [PreviousCycle::NONE, PreviousCycle::tensions(Some(nearby))] {
        let t = solve(Method::AnalyticCentre, &w, &f, &limits, &previous).unwrap().tensions;
        let residual = (w * t - f).amax();
        assert!(residual <= T::lit(tol) * f.amax(), "residual {residual:?}");
    }
    // The only solution 0.03 N beyond t_max, the warm start inside within
    // the old `W t = f` tolerance (0.19 N in f32): no tensions exist.
    let outside = SVector::<T, 2>::from_fn(|i, _| T::lit([1000.03, 650.0][i]));
    let f = w * outside;
    let inside = SVector::<T, 2>::from_fn(|i, _| T::lit([999.99, 650.0][i]));
    for previous in [PreviousCycle::NONE, PreviousCycle::tensions(Some(inside))] {
        let result = solve(Method::AnalyticCentre, &w, &f, &limits, &previous);
        assert_eq!(result.map(|s| s.tensions), Err(Error::Infeasible), "{previous:?}");
    }
}

#[test]
fn analytic_centre_square_meets_the_wrench() {
    square_meets_the_wrench::<f64>(1e-12);
    square_meets_the_wrench::<f32>(1e-5);
}

/// The analytic centre against the barycenter (exact for `r = 2`) on random
/// problems, feasible or not, in `f32` and `f64`: never `singular` for a
/// well-conditioned `W`, never `infeasible` where the polygon has tensions,
/// never tensions where it has none.
fn analytic_centre_agrees_with_the_polygon<T: Real + std::fmt::Debug, const N: usize, const M: usize>(
    cases: u32,
) {
    let mut runner = proptest::test_runner::TestRunner::new(cdpr_integration_tests::persisted_config(
        cdpr_integration_tests::campaign_cases(cases),
        file!(),
    ));
    let compared = std::cell::Cell::new(0usize);
    runner
        .run(&cdpr_integration_tests::random_problem::<N, M>(0.3), |(w, f, limits)| {
            let w = w.map(T::lit);
            let f = f.map(T::lit);
            let limits = TensionLimits::new(limits.min().map(T::lit), limits.max().map(T::lit)).unwrap();
            let polygon = solve(Method::Barycenter, &w, &f, &limits, &PreviousCycle::NONE);
            let centre = solve(Method::AnalyticCentre, &w, &f, &limits, &PreviousCycle::NONE);
            prop_assert_ne!(centre.map(|_| ()), Err(Error::Singular));
            match (&polygon, &centre) {
                (Ok(_), Err(Error::Infeasible)) | (Err(Error::Infeasible), Ok(_)) => {
                    prop_assert!(false, "{N}x{M}: barycenter {:?}, analytic centre {:?}", polygon, centre)
                }
                _ => compared.set(compared.get() + 1),
            }
            Ok(())
        })
        .unwrap();
    // The cases, plus the seeds of the file's regression file replayed first.
    assert!(compared.get() >= cdpr_integration_tests::campaign_cases(cases) as usize);
}

#[test]
fn analytic_centre_decides_like_the_polygon() {
    analytic_centre_agrees_with_the_polygon::<f32, 2, 4>(3000);
    analytic_centre_agrees_with_the_polygon::<f64, 2, 4>(1000);
    analytic_centre_agrees_with_the_polygon::<f32, 6, 8>(1000);
    analytic_centre_agrees_with_the_polygon::<f64, 6, 8>(1000);
}

/// Found by a random search: an infeasible `f32` 2 x 4 problem where a
/// rounding-indefinite reduced Hessian made the analytic centre say
/// `singular` instead of deciding.
#[test]
fn analytic_centre_decides_where_its_hessian_rounds_indefinite() {
    let columns = [
        [-0.07912796f32, 0.18682583],
        [-0.33859015, 0.79899037],
        [-0.4676536, -0.07752465],
        [-0.24089077, 0.12380931],
    ];
    let w = SMatrix::<f32, 2, 4>::from_fn(|i, j| columns[j][i]);
    let f = SVector::<f32, 2>::new(-95.95416, 343.39328);
    let limits = TensionLimits::uniform(1.61762f32, 381.57007).unwrap();
    assert_eq!(
        solve(Method::Barycenter, &w, &f, &limits, &PreviousCycle::NONE).unwrap_err(),
        Error::Infeasible
    );
    assert_eq!(
        solve(Method::AnalyticCentre, &w, &f, &limits, &PreviousCycle::NONE).unwrap_err(),
        Error::Infeasible
    );
}

/// Found by the long campaign (`CDPR_HOSTILE_SCALE=30`), one case in about
/// 30 000: in `f32`, a feasible set thinner than the walk resolved, where
/// the analytic centre finds tensions 1.2e-4 inside every limit and the
/// barycenter said `infeasible`. The cause: the walk along cable 2's upper
/// limit took cable 0's lower one, 4.5e-3 rad from it (below
/// `tolerance::parallel`, 5.5e-3 in `f32`), as never reached; along the
/// 0.76-long edge it is, a vertex landed 1.7e-3 beyond it, and the
/// centroid's check called the pose infeasible. The walk now reaches a line
/// within the parallel threshold when it is well apart from the edge (more
/// than four slack tolerances). Every two-redundancy method: none says
/// `infeasible`, and what is found meets `W t = f` and the limits within
/// `f32` rounding.
#[test]
fn barycenter_f32_thin_sliver_is_not_infeasible() {
    let columns: [[f64; 6]; 8] = [
        [
            0.20171709191219642,
            -0.6998419605831429,
            -0.29032785534035477,
            0.2870638008741426,
            0.6882149320966248,
            0.6576455202501448,
        ],
        [
            -0.3091760917332201,
            0.38692581507184837,
            -0.5129704188316682,
            -0.8068994332358671,
            -0.6884144979504507,
            -0.03347154803417899,
        ],
        [
            0.14872838630162563,
            -0.2362834381911492,
            0.28957386376408134,
            -0.9130185641742641,
            -0.47911518146947485,
            -0.3997888535842228,
        ],
        [
            -0.25435792433455395,
            0.1264929705047678,
            0.6871709146246859,
            0.5372595924038783,
            -0.4115377698712669,
            0.10844068997644629,
        ],
        [
            -0.05419609124905241,
            0.9416534510922419,
            0.3014822196893252,
            -0.44039741249282705,
            -0.042633981680009994,
            -0.9848963033330776,
        ],
        [
            0.7127053838688437,
            0.22071489735610245,
            -0.3774059810006188,
            0.15517578162631687,
            0.9450720662116727,
            -0.15915500079696496,
        ],
        [
            0.8120629490755384,
            0.9683112167435003,
            0.9198072582857234,
            -0.4709397524992795,
            0.8489359595922702,
            -0.3832206407619902,
        ],
        [
            0.33900191844029176,
            0.9386601114927665,
            0.36040849935655794,
            0.9620425415261458,
            0.27052867183767987,
            -0.42255819341276873,
        ],
    ];
    let w = SMatrix::<f32, 6, 8>::from_fn(|i, j| columns[j][i] as f32);
    let f = SVector::<f64, 6>::from_row_slice(&[
        0.9665708181311481,
        0.9337680467589857,
        0.6645103168383575,
        -1.1311703307845686,
        0.3667504074713265,
        -0.9920441904896704,
    ])
    .map(|x| x as f32);
    let limits = TensionLimits::uniform(0.0f32, 1.0).unwrap();
    let centre = solve(Method::AnalyticCentre, &w, &f, &limits, &PreviousCycle::NONE).unwrap();
    assert!(centre.robustness > 0.0);
    let mut found = 0;
    for method in Method::ALL.into_iter().filter(|m| m.supports(6, 8)) {
        match solve(method, &w, &f, &limits, &PreviousCycle::NONE) {
            Ok(s) => {
                assert!(s.robustness > -1e-5, "{method:?}: robustness {}", s.robustness);
                assert!((w * s.tensions - f).amax() < 1e-5, "{method:?}: {}", (w * s.tensions - f).amax());
                found += 1;
            }
            Err(e) => assert_ne!(e, Error::Infeasible, "{method:?}"),
        }
    }
    // The polygon methods and the analytic centre at least.
    assert!(found >= 6, "{found}");
    assert!(solve(Method::Barycenter, &w, &f, &limits, &PreviousCycle::NONE).is_ok());
}
