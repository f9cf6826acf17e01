//! The analytic centre (Di Paola et al. 2024) against its optimality
//! conditions (Eq. 15), on random problems of many redundancies, with
//! weights, with the friction constraints of their Sect. 5.3, and against
//! hand-derived values of their motivating example (Sect. 3).

use std::sync::atomic::{AtomicUsize, Ordering};

use cdpr_integration_tests::{
    analytic_centre_residual, random_problem, shipped_robot, stationarity_residual,
};
use nalgebra::{DVector, SMatrix, SVector};
use proptest::{prelude::*, test_runner::TestRunner};
use tension_core::linalg::WrenchFactorization;
use tension_core::{
    solve, AnalyticCentre, BarrierWeights, ConvexConstraint, Error, Method, Motion, PreviousCycle, Problem,
    Robot, TensionLimits, WarmStart,
};

/// Random problems: every answer satisfies Eq. 15 and the limits; a warm
/// start from a nearby answer gives the same centre; failures are only
/// `infeasible` (checked against a feasible point when there was one) or,
/// near the border, `no-convergence`.
fn random_cases<const N: usize, const M: usize>(cases: u32) {
    let solved = AtomicUsize::new(0);
    let mut runner = TestRunner::new(cdpr_integration_tests::persisted_config(cases, file!()));
    runner
        .run(&random_problem::<N, M>(3.0), |(w, f, limits)| {
            match solve(Method::AnalyticCentre, &w, &f, &limits, &PreviousCycle::NONE) {
                Ok(sol) => {
                    let t = sol.tensions;
                    for i in 0..M {
                        prop_assert!(t[i] > limits.min()[i] && t[i] < limits.max()[i]);
                    }
                    let (stationarity, eq) = analytic_centre_residual(&w, &f, &limits, &t);
                    prop_assert!(stationarity < 1e-8, "Eq. 15 residual {stationarity}");
                    prop_assert!(eq < 1e-10, "W t - f: {eq}");
                    prop_assert!(sol.diagnostics.iterations <= 50);
                    // Warm start from a point nudged towards the box centre.
                    let nudged = t + (limits.middle() - t) * 1e-3;
                    let warm = solve(
                        Method::AnalyticCentre,
                        &w,
                        &f,
                        &limits,
                        &PreviousCycle::tensions(Some(nudged)),
                    )
                    .unwrap();
                    prop_assert!((warm.tensions - t).amax() < 1e-6 * limits.scale());
                    prop_assert_eq!(warm.diagnostics.warm_start, WarmStart::Held);
                    solved.fetch_add(1, Ordering::Relaxed);
                }
                Err(Error::Infeasible) => {
                    // A strictly feasible point would contradict the certificate:
                    // when the barycenter (r = 2) finds a polygon with room, fail.
                    if M == N + 2 {
                        if let Ok(b) = solve(Method::Barycenter, &w, &f, &limits, &PreviousCycle::NONE) {
                            prop_assert!(
                                b.robustness <= 1e-6 * limits.scale(),
                                "certified infeasible, barycenter robustness {}",
                                b.robustness
                            );
                        }
                    }
                }
                Err(Error::NoConvergence) => {
                    if M == N + 2 {
                        if let Ok(b) = solve(Method::Barycenter, &w, &f, &limits, &PreviousCycle::NONE) {
                            prop_assert!(
                                b.robustness <= 1e-3 * limits.scale(),
                                "no convergence though barycenter robustness {}",
                                b.robustness
                            );
                        }
                    }
                }
                Err(e) => prop_assert!(false, "unexpected {e:?}"),
            }
            Ok(())
        })
        .unwrap();
    assert!(solved.into_inner() >= cases as usize / 5);
}

#[test]
fn optimality_conditions_hold_6x7() {
    random_cases::<6, 7>(300);
}

#[test]
fn optimality_conditions_hold_6x8() {
    random_cases::<6, 8>(300);
}

#[test]
fn optimality_conditions_hold_6x9() {
    random_cases::<6, 9>(300);
}

#[test]
fn optimality_conditions_hold_6x10() {
    random_cases::<6, 10>(300);
}

#[test]
fn optimality_conditions_hold_3x6() {
    random_cases::<3, 6>(300);
}

#[test]
fn optimality_conditions_hold_2x4() {
    random_cases::<2, 4>(300);
}

#[test]
fn no_redundancy_gives_the_unique_solution() {
    let w = SMatrix::<f64, 2, 2>::new(1.0, 0.0, 0.0, 2.0);
    let f = SVector::<f64, 2>::new(5.0, 8.0);
    let limits = TensionLimits::uniform(1.0, 10.0).unwrap();
    let sol = solve(Method::AnalyticCentre, &w, &f, &limits, &PreviousCycle::NONE).unwrap();
    assert!((sol.tensions - SVector::<f64, 2>::new(5.0, 4.0)).amax() < 1e-12);
}

/// Di Paola et al. 2024, Sect. 3.1: `W = (-7, 20)`, `w_e = -1790`, box
/// `[10, 100]^2`. On the line `t_2 = (1790 + 7 t_1) / 20` the centre solves
/// `d/dt_1 phi = 0`, found here by bisection on the derivative written out
/// by hand (the barrier along the line, not the crate's code).
#[test]
fn motivating_example_black_case() {
    let w = SMatrix::<f64, 1, 2>::new(-7.0, 20.0);
    let f = SVector::<f64, 1>::new(1790.0);
    let limits = TensionLimits::uniform(10.0, 100.0).unwrap();
    let sol = solve(Method::AnalyticCentre, &w, &f, &limits, &PreviousCycle::NONE).unwrap();
    let t2 = |t1: f64| (1790.0 + 7.0 * t1) / 20.0;
    let dphi = |t1: f64| {
        let s = 7.0 / 20.0;
        -1.0 / (t1 - 10.0) + 1.0 / (100.0 - t1) - s / (t2(t1) - 10.0) + s / (100.0 - t2(t1))
    };
    // Feasible t1: t2 <= 100 gives t1 <= 30: segment t1 in (10, 30).
    let (mut lo, mut hi) = (10.0 + 1e-12, 30.0 - 1e-12);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if dphi(mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    assert!((sol.tensions[0] - lo).abs() < 1e-9, "{} vs {lo}", sol.tensions[0]);
    assert!((sol.tensions[1] - t2(lo)).abs() < 1e-9);
    // The paper's point: the closed form leaves the box here (Fig. 1-b),
    // (55, 55) + (-7, 20) 1075 / 449 = (38.24, 102.88), the centre does not.
    assert_eq!(
        solve(Method::ClosedForm, &w, &f, &limits, &PreviousCycle::NONE).unwrap_err(),
        Error::MethodFailed
    );
}

/// The blue and green cases of the same example are close data with close
/// answers (low sensitivity of the analytic centre, their Fig. 1-f).
#[test]
fn motivating_example_blue_and_green_are_close() {
    let limits = TensionLimits::uniform(10.0, 100.0).unwrap();
    let blue = solve(
        Method::AnalyticCentre,
        &SMatrix::<f64, 1, 2>::new(-1.0, 50.0),
        &SVector::<f64, 1>::new(945.0),
        &limits,
        &PreviousCycle::NONE,
    )
    .unwrap();
    let green = solve(
        Method::AnalyticCentre,
        &SMatrix::<f64, 1, 2>::new(1.0, 50.0),
        &SVector::<f64, 1>::new(1055.0),
        &limits,
        &PreviousCycle::NONE,
    )
    .unwrap();
    assert!((blue.tensions - green.tensions).amax() < 5.0, "{:?} {:?}", blue.tensions, green.tensions);
    // Closed form (hand-computed): blue (55.70, 20.01), green (54.30, 20.01).
    let cf = solve(
        Method::ClosedForm,
        &SMatrix::<f64, 1, 2>::new(-1.0, 50.0),
        &SVector::<f64, 1>::new(945.0),
        &limits,
        &PreviousCycle::NONE,
    )
    .unwrap();
    assert!((cf.tensions[0] - (55.0 + 1750.0 / 2501.0)).abs() < 1e-9);
    assert!((cf.tensions[1] - (55.0 - 50.0 * 1750.0 / 2501.0)).abs() < 1e-9);
}

#[test]
fn weights_push_away_from_their_bound() {
    let robot: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let pose = SVector::<f64, 6>::new(0.2, -0.1, 1.2, 0.05, -0.05, 0.1);
    let w = robot.wrench_matrix(&pose).unwrap();
    let f = robot.required_wrench(&pose, &SVector::zeros(), None).unwrap();
    let plain = solve(Method::AnalyticCentre, &w, &f, robot.limits(), &PreviousCycle::NONE).unwrap();
    let mut lower = SVector::<f64, 8>::repeat(1.0);
    lower[0] = 20.0;
    let centre = AnalyticCentre {
        weights: BarrierWeights::new(lower, SVector::repeat(1.0)).unwrap(),
        ..AnalyticCentre::default()
    };
    let fact = WrenchFactorization::new(&w).unwrap();
    let problem = Problem { w: &w, f: &f, limits: robot.limits(), factorization: &fact };
    let weighted = centre.solve(&problem, None).unwrap();
    assert!(weighted.tensions[0] > plain.tensions[0]);
    // Weighted Eq. 15.
    let t = weighted.tensions;
    let grad = DVector::from_fn(8, |i, _| -lower[i] / (t[i] - 5.0) + 1.0 / (350.0 - t[i]));
    let (stationarity, eq) = stationarity_residual(&w, &grad, robot.limits(), &t, &f);
    assert!(stationarity < 1e-8 && eq < 1e-10);
    assert_eq!(
        BarrierWeights::<f64, 8>::new(SVector::repeat(0.0), SVector::repeat(1.0)).unwrap_err(),
        Error::InvalidLimits
    );
}

/// Friction of a mobile base holding cables `a` and `b` (Di Paola et al.
/// 2024, Eq. 19): `|t_a u_a + t_b u_b|^2 - (m g mu)^2 < 0`.
struct Friction {
    a: usize,
    b: usize,
    ua: [f64; 2],
    ub: [f64; 2],
    limit: f64,
}

impl ConvexConstraint<f64, 4> for Friction {
    fn value(&self, t: &SVector<f64, 4>) -> f64 {
        let vx = t[self.a] * self.ua[0] + t[self.b] * self.ub[0];
        let vy = t[self.a] * self.ua[1] + t[self.b] * self.ub[1];
        vx * vx + vy * vy - self.limit * self.limit
    }
    fn gradient(&self, t: &SVector<f64, 4>) -> SVector<f64, 4> {
        let vx = t[self.a] * self.ua[0] + t[self.b] * self.ub[0];
        let vy = t[self.a] * self.ua[1] + t[self.b] * self.ub[1];
        let mut g = SVector::zeros();
        g[self.a] = 2.0 * (self.ua[0] * vx + self.ua[1] * vy);
        g[self.b] = 2.0 * (self.ub[0] * vx + self.ub[1] * vy);
        g
    }
    fn hessian(&self, _t: &SVector<f64, 4>) -> SMatrix<f64, 4, 4> {
        let mut h = SMatrix::zeros();
        let dot = self.ua[0] * self.ub[0] + self.ua[1] * self.ub[1];
        h[(self.a, self.a)] = 2.0;
        h[(self.b, self.b)] = 2.0;
        h[(self.a, self.b)] = 2.0 * dot;
        h[(self.b, self.a)] = 2.0 * dot;
        h
    }
}

/// Sect. 5.3: the planar point mass on two mobile bases (65 kg each,
/// `mu = 0.5`, load 5 kg, limits 50/400 N) along the circle of Eq. 17. With
/// friction the centre satisfies Eq. 15 including the constraint terms and
/// keeps both bases from sliding, where the centre without friction lets
/// them slide (their Fig. 10-b).
#[test]
fn friction_constraints_of_a_mobile_base() {
    let mut robot: Robot<f64, 2, 4> = shipped_robot("planar-point-4");
    let mut platform = *robot.platform();
    platform.mass = 5.0;
    robot.set_platform(platform).unwrap();
    let limit = 65.0 * 9.81 * 0.5;
    let mut slid_without = 0;
    let mut previous: Option<SVector<f64, 4>> = None;
    for step in 0..=100 {
        let s = step as f64 / 100.0;
        let angle = 2.0 * std::f64::consts::PI * s;
        let pose = SVector::<f64, 2>::new(0.5 * (angle.cos() + 1.75) + 0.2, 0.5 * (angle.sin() + 1.75) - 0.2);
        let cables = robot.cables(&pose).unwrap();
        let u = |i: usize| [-cables.directions[i].x, -cables.directions[i].y];
        // Base 1 holds cables 1 and 4 (indices 0, 3), base 2 cables 2 and 3.
        let base1 = Friction { a: 0, b: 3, ua: u(0), ub: u(3), limit };
        let base2 = Friction { a: 1, b: 2, ua: u(1), ub: u(2), limit };
        let constraints: [&dyn ConvexConstraint<f64, 4>; 2] = [&base1, &base2];
        let w = robot.wrench_matrix(&pose).unwrap();
        let f = robot.required_wrench(&pose, &SVector::zeros(), None).unwrap();
        let centre = AnalyticCentre { constraints: &constraints, ..AnalyticCentre::default() };
        let fact = WrenchFactorization::new(&w).unwrap();
        let problem = Problem { w: &w, f: &f, limits: robot.limits(), factorization: &fact };
        let sol = centre.solve(&problem, previous.as_ref()).unwrap();
        let t = sol.tensions;
        assert!(base1.value(&t) < 0.0 && base2.value(&t) < 0.0);
        let grad = DVector::from_fn(4, |i, _| {
            -1.0 / (t[i] - 50.0)
                + 1.0 / (400.0 - t[i])
                + base1.gradient(&t)[i] / -base1.value(&t)
                + base2.gradient(&t)[i] / -base2.value(&t)
        });
        let (stationarity, eq) = stationarity_residual(&w, &grad, robot.limits(), &t, &f);
        assert!(stationarity < 1e-8 && eq < 1e-10, "{stationarity} {eq}");
        let free = solve(Method::AnalyticCentre, &w, &f, robot.limits(), &PreviousCycle::NONE).unwrap();
        if base1.value(&free.tensions) > 0.0 || base2.value(&free.tensions) > 0.0 {
            slid_without += 1;
        }
        previous = Some(t);
    }
    assert!(slid_without > 0, "the example should show sliding without the friction constraints");
}

#[test]
fn symmetric_pose_gives_symmetric_answer() {
    // IPAnema 1 is symmetric under x -> -x and y -> -y; at the centre with no
    // gravity moment every cable pair mirrored has the same tension, and the
    // analytic centre and the barycenter agree on that.
    let robot: Robot<f64, 6, 8> = shipped_robot("ipanema1");
    let pose = SVector::<f64, 6>::new(0.0, 0.0, 1.0, 0.0, 0.0, 0.0);
    let w = robot.wrench_matrix(&pose).unwrap();
    let f = robot.required_wrench(&pose, &SVector::zeros(), None).unwrap();
    for t in [
        solve(Method::AnalyticCentre, &w, &f, robot.limits(), &PreviousCycle::NONE).unwrap().tensions,
        solve(Method::Barycenter, &w, &f, robot.limits(), &PreviousCycle::NONE).unwrap().tensions,
    ] {
        for i in 1..4 {
            assert!((t[i] - t[0]).abs() < 1e-9, "{t:?}");
            assert!((t[i + 4] - t[4]).abs() < 1e-9, "{t:?}");
        }
    }
    let _ = Motion::<f64>::rest();
}

/// Poses over the whole frame, the workspace border included, in `f64`: the
/// cold analytic centre converges wherever tensions exist (before the
/// stopping rule's rounding floor counted the iterate's own rounding,
/// `eps |H t|`, about one border pose in 1 000 ran out of iterations with
/// its reduced gradient stuck at a few times the old floor), and says
/// `infeasible` exactly where the minimum-norm search does. Counts the
/// poses that reached each assert.
fn border_sweep<const M: usize>(
    robot: &Robot<f64, 6, M>,
    centre: [f64; 3],
    half: [f64; 4],
    count: usize,
) -> usize {
    let mut solved = 0;
    for pose in cdpr_integration_tests::frame_poses(centre, half, count, 99) {
        let (Ok(w), Ok(f)) =
            (robot.wrench_matrix(&pose), robot.required_wrench(&pose, &SVector::zeros(), None))
        else {
            continue;
        };
        let limits = robot.limits();
        match solve(Method::AnalyticCentre, &w, &f, limits, &PreviousCycle::NONE) {
            Ok(sol) => {
                let (_, eq) = analytic_centre_residual(&w, &f, limits, &sol.tensions);
                assert!(eq < 1e-9, "W t - f {eq} at {pose:?}");
                assert!(
                    sol.diagnostics.iterations < 50,
                    "{} iterations at {pose:?}",
                    sol.diagnostics.iterations
                );
                solved += 1;
            }
            Err(e) => {
                assert_eq!(e, Error::Infeasible, "at {pose:?}");
                let exact = solve(Method::Min2Norm, &w, &f, limits, &PreviousCycle::NONE);
                assert_eq!(exact.map(|_| ()), Err(Error::Infeasible), "at {pose:?}");
            }
        }
    }
    solved
}

#[test]
fn border_poses_converge_in_f64() {
    let suspended: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let s8 = border_sweep(&suspended, [0.0, 0.0, 1.6], [1.5, 1.2, 1.0, 0.3], 30_000);
    let ten: Robot<f64, 6, 10> = shipped_robot("spatial6-10");
    let s10 = border_sweep(&ten, [0.0, 0.0, 1.2], [1.0, 1.0, 0.8, 0.3], 30_000);
    // About half of suspended-8's frame and a sixth of the ten-cable
    // robot's hold the platform.
    assert!(s8 >= 12_000 && s10 >= 4_000, "{s8} / {s10} poses solved");
}
