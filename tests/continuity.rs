//! Trajectories on the shipped robots: every answer is valid, consecutive
//! answers differ little for a small pose step, leaving the workspace gives a
//! clean `infeasible` (confirmed by the independent clipping reference), and
//! `f32` agrees with `f64`.
//!
//! Bounds stated and checked here, for a pose step of at most 1 mm and
//! 1 mrad (1 m/s and 1 rad/s at 1 kHz):
//! * while the robustness is at least 1 % of `t_max - t_min`, consecutive
//!   tensions differ by at most 1 % of `t_max - t_min` (barycenter, analytic
//!   centre, improved closed form);
//! * the last answer before `infeasible` has a robustness below 1 % of the
//!   range: the methods reach the border continuously, they do not jump from
//!   a comfortable answer to a failure;
//! * `f32` barycenter tensions are within 1e-4 of the range of the `f64` ones
//!   where the robustness is at least 1 % of the range. Rounding of `f32`
//!   (`eps = 1.2e-7`) in `W`, in its factorisation and in the vertices is
//!   amplified by the conditioning of `W` (about 10 on these poses) and by the
//!   sharpest angle between polygon edges; measured: 3.7e-6 of the range on
//!   suspended-8, so the bound leaves a margin of about 25.

use cdpr_integration_tests::{reference_barycenter, shipped_robot, trajectory, Sample};
use nalgebra::{Matrix3, SVector, Vector3};
use tension_core::{Error, Method, Motion, Platform, Robot, RobotKind, TensionLimits, TensionSolver};

struct Report {
    solved: usize,
    infeasible: usize,
    max_interior_step: f64,
    warm_held: usize,
}

fn run<const N: usize, const M: usize>(
    name: &str,
    robot: &Robot<f64, N, M>,
    samples: &[Sample<N>],
    method: Method,
    dynamic: bool,
) -> Report {
    let limits = robot.limits();
    let range = (0..M).map(|i| limits.max()[i] - limits.min()[i]).fold(f64::INFINITY, f64::min);
    let mut solver = TensionSolver::<f64, M>::new(method);
    let mut previous: Option<(SVector<f64, M>, f64, SVector<f64, N>)> = None;
    let mut report = Report { solved: 0, infeasible: 0, max_interior_step: 0.0, warm_held: 0 };
    for (k, sample) in samples.iter().enumerate() {
        let w = robot.wrench_matrix(&sample.pose).unwrap();
        let motion =
            Motion::from_pose_derivatives(robot.kind(), &sample.pose, &sample.velocity, &sample.acceleration)
                .unwrap();
        let f = robot.required_wrench(&sample.pose, &SVector::zeros(), dynamic.then_some(&motion)).unwrap();
        match solver.solve(&w, &f, limits) {
            Ok(sol) => {
                let t = sol.tensions;
                assert!(
                    (w * t - f).amax() < 1e-8 * (1.0 + f.amax()),
                    "{name} {method:?} sample {k}: W t != f"
                );
                for i in 0..M {
                    assert!(t[i] >= limits.min()[i] - 1e-9 * range && t[i] <= limits.max()[i] + 1e-9 * range);
                }
                if sol.diagnostics.warm_start == tension_core::WarmStart::Held {
                    report.warm_held += 1;
                }
                if let Some((tp, rp, pose_p)) = previous {
                    let pose_step = (sample.pose - pose_p).amax();
                    assert!(pose_step <= 1.0e-3 + 1e-12, "trajectory step too large: {pose_step}");
                    if rp >= 0.01 * range && sol.robustness >= 0.01 * range {
                        let step = (t - tp).amax();
                        report.max_interior_step = report.max_interior_step.max(step / range);
                        assert!(step <= 0.01 * range, "{name} {method:?} sample {k}: step {step} N");
                    }
                }
                previous = Some((t, sol.robustness, sample.pose));
                report.solved += 1;
            }
            Err(Error::Infeasible) | Err(Error::MethodFailed) | Err(Error::NoConvergence) => {
                if let Some((_, rp, _)) = previous {
                    assert!(
                        rp < 0.01 * range,
                        "{name} {method:?} sample {k}: jumped to a failure from robustness {rp}"
                    );
                }
                if M == N + 2 {
                    if let Some((_, area)) = reference_barycenter(&w, &f, limits) {
                        assert!(
                            area < 1e-4 || method != Method::Barycenter,
                            "{name} sample {k}: reference polygon has relative area {area}"
                        );
                    }
                }
                previous = None;
                report.infeasible += 1;
            }
            Err(e) => panic!("{name} {method:?} sample {k}: {e:?}"),
        }
    }
    report
}

fn check_robot<const N: usize, const M: usize>(
    name: &str,
    robot: &Robot<f64, N, M>,
    waypoints: &[SVector<f64, N>],
) {
    let samples = trajectory(waypoints);
    let mut methods = vec![Method::AnalyticCentre, Method::ImprovedClosedForm];
    if M == N + 2 {
        methods.insert(0, Method::Barycenter);
    }
    for method in methods {
        for dynamic in [false, true] {
            let report = run(name, robot, &samples, method, dynamic);
            assert!(report.solved > samples.len() / 4, "{name} {method:?}: only {} solved", report.solved);
            assert!(report.infeasible > 0, "{name}: the trajectory must leave the workspace");
            if method == Method::Barycenter {
                // Warm start held on nearly every feasible sample after the first.
                assert!(
                    report.warm_held * 100 >= report.solved * 95,
                    "{name}: warm start held {} of {}",
                    report.warm_held,
                    report.solved
                );
            }
            eprintln!(
                "{name} {} dynamic={dynamic}: solved {}, infeasible {}, largest interior step {:.5} of range",
                method.name(),
                report.solved,
                report.infeasible,
                report.max_interior_step
            );
        }
    }
}

fn p6(x: f64, y: f64, z: f64, rx: f64, ry: f64, rz: f64) -> SVector<f64, 6> {
    SVector::<f64, 6>::new(x, y, z, rx, ry, rz)
}

#[test]
fn suspended_8_crossing_the_border() {
    let robot: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let waypoints = [
        p6(0.0, 0.0, 1.5, 0.0, 0.0, 0.0),
        p6(1.8, 0.3, 1.2, 0.05, 0.0, 0.1),
        p6(-0.5, -0.4, 2.0, -0.1, 0.1, -0.2),
        p6(0.0, 0.0, 1.5, 0.0, 0.0, 0.0),
    ];
    check_robot("suspended-8", &robot, &waypoints);
}

#[test]
fn ipanema1_crossing_the_border() {
    let robot: Robot<f64, 6, 8> = shipped_robot("ipanema1");
    let waypoints = [
        p6(0.0, 0.0, 1.0, 0.0, 0.0, 0.0),
        p6(1.6, 0.5, 0.8, 0.0, 0.1, 0.1),
        p6(-0.3, -0.3, 1.2, 0.1, 0.0, -0.1),
        p6(0.0, 0.0, 1.0, 0.0, 0.0, 0.0),
    ];
    check_robot("ipanema1", &robot, &waypoints);
}

#[test]
fn cogiro_crossing_the_border() {
    let robot: Robot<f64, 6, 8> = shipped_robot("cogiro");
    let waypoints = [
        p6(0.0, 0.0, 2.0, 0.0, 0.0, 0.0),
        p6(7.3, 2.0, 2.5, 0.0, 0.0, 0.2),
        p6(-3.0, -2.0, 1.5, 0.05, -0.05, 0.0),
        p6(0.0, 0.0, 2.0, 0.0, 0.0, 0.0),
    ];
    check_robot("cogiro", &robot, &waypoints);
}

#[test]
fn planar_point_mass_crossing_the_border() {
    let robot: Robot<f64, 2, 4> = shipped_robot("planar-point-4");
    let p = |x: f64, y: f64| SVector::<f64, 2>::new(x, y);
    check_robot("planar-point-4", &robot, &[p(1.5, 1.5), p(1.5, 2.97), p(2.2, 1.0), p(1.5, 1.5)]);
}

/// A planar robot with orientation and five cables (3 DOF, r = 2).
pub fn planar3_five_cables() -> Robot<f64, 3, 5> {
    let anchors = [
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(3.0, 0.0, 0.0),
        Vector3::new(3.0, 2.0, 0.0),
        Vector3::new(1.5, 2.5, 0.0),
        Vector3::new(0.0, 2.0, 0.0),
    ];
    let attach = [
        Vector3::new(-0.1, -0.1, 0.0),
        Vector3::new(0.1, -0.1, 0.0),
        Vector3::new(0.1, 0.1, 0.0),
        Vector3::new(0.0, 0.12, 0.0),
        Vector3::new(-0.1, 0.1, 0.0),
    ];
    let platform = Platform {
        mass: 2.0,
        com: Vector3::new(0.0, 0.02, 0.0),
        gravity: Vector3::new(0.0, -9.81, 0.0),
        inertia: Matrix3::from_diagonal(&Vector3::new(0.0, 0.0, 0.01)),
    };
    Robot::new(
        RobotKind::Planar3,
        anchors,
        attach,
        TensionLimits::uniform(2.0, 80.0).unwrap(),
        platform,
        None,
    )
    .unwrap()
}

#[test]
fn planar3_five_cables_crossing_the_border() {
    let robot = planar3_five_cables();
    let p = |x: f64, y: f64, th: f64| SVector::<f64, 3>::new(x, y, th);
    check_robot(
        "planar3-5",
        &robot,
        &[p(1.5, 1.2, 0.0), p(1.5, 0.05, 0.1), p(2.0, 1.5, -0.2), p(1.5, 1.2, 0.0)],
    );
}

/// `f32` barycenter (as on the board) against `f64` along the suspended-8 trajectory.
#[test]
fn f32_agrees_with_f64() {
    let r64: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let r32: Robot<f32, 6, 8> = shipped_robot("suspended-8");
    let waypoints = [
        p6(0.0, 0.0, 1.5, 0.0, 0.0, 0.0),
        p6(1.8, 0.3, 1.2, 0.05, 0.0, 0.1),
        p6(-0.5, -0.4, 2.0, -0.1, 0.1, -0.2),
        p6(0.0, 0.0, 1.5, 0.0, 0.0, 0.0),
    ];
    let samples = trajectory(&waypoints);
    let range = 345.0;
    let mut s64 = TensionSolver::<f64, 8>::new(Method::Barycenter);
    let mut s32 = TensionSolver::<f32, 8>::new(Method::Barycenter);
    let (mut worst, mut compared) = (0.0f64, 0);
    for sample in &samples {
        let q32 = sample.pose.map(|x| x as f32);
        let w64 = r64.wrench_matrix(&sample.pose).unwrap();
        let f64_ = r64.required_wrench(&sample.pose, &SVector::zeros(), None).unwrap();
        let w32 = r32.wrench_matrix(&q32).unwrap();
        let f32_ = r32.required_wrench(&q32, &SVector::zeros(), None).unwrap();
        match (s64.solve(&w64, &f64_, r64.limits()), s32.solve(&w32, &f32_, r32.limits())) {
            (Ok(a), Ok(b)) if a.robustness >= 0.01 * range => {
                let diff = (a.tensions - b.tensions.map(|x| x as f64)).amax() / range;
                worst = worst.max(diff);
                compared += 1;
            }
            _ => {}
        }
    }
    eprintln!("f32 vs f64: worst {worst:.2e} of range over {compared} samples");
    assert!(compared > samples.len() / 3);
    assert!(worst <= 1e-4, "f32 deviates by {worst} of the range");
}

/// At IPAnema 1's symmetric centre pairs of polygon lines coincide; a pose
/// 1e-13 away makes them cross at an angle of about 1e-13, a crossing lost in
/// rounding. Such crossings are taken as parallel, so the answer does not jump.
#[test]
fn nearly_coincident_lines_do_not_make_a_jump() {
    let robot: Robot<f64, 6, 8> = shipped_robot("ipanema1");
    let centre = p6(0.0, 0.0, 1.0, 0.0, 0.0, 0.0);
    let nudged = centre + p6(2.4e-13, 7.6e-14, -3.0e-14, 0.0, 1.5e-14, 1.5e-14);
    let solve = |pose: &SVector<f64, 6>| {
        let w = robot.wrench_matrix(pose).unwrap();
        let f = robot.required_wrench(pose, &SVector::zeros(), None).unwrap();
        tension_core::solve(Method::Barycenter, &w, &f, robot.limits(), &tension_core::PreviousCycle::NONE)
            .unwrap()
            .tensions
    };
    let (a, b) = (solve(&centre), solve(&nudged));
    assert!((a - b).amax() < 1e-9, "{a:?} vs {b:?}");
}
