//! The feedback module and the cable-length supervision through the
//! control loop.

use crate::common;

use common::IdealDrives;

use cdpr_control::feedback::{extrapolate, pose_error};
use cdpr_control::protocol::{HostMessage, Reason, Setpoint, State};
use cdpr_control::setpoint::Pose6;
use cdpr_control::{ControlLoop, NoClock};

const POSE: [f32; 6] = [0.1, -0.2, 1.9, 0.02, -0.01, 0.05];

#[test]
fn pose_error_is_the_difference_for_small_errors() {
    let robot = common::suspended8();
    let desired = Pose6::from(POSE);
    let mut measured = desired;
    measured[0] -= 0.003;
    measured[5] -= 0.002;
    let e = pose_error(&robot, &desired, &measured).unwrap();
    assert!((e[0] - 0.003).abs() < 1e-6 && e[1].abs() < 1e-6 && e[2].abs() < 1e-6, "{e:?}");
    // A small rotation about z: the rotation vector is (almost) along base z.
    assert!((e[5] - 0.002).abs() < 1e-4 && e[3].abs() < 1e-4 && e[4].abs() < 1e-4, "{e:?}");
}

#[test]
fn extrapolation_is_constant_acceleration() {
    let s = cdpr_control::Setpoint {
        seq: 1,
        pose: Pose6::from(POSE),
        velocity: Pose6::from([0.3, -0.2, 0.1, 0.05, -0.04, 0.2]),
        acceleration: Pose6::from([-1.2, 0.8, 2.0, -0.3, 0.1, 0.5]),
    };
    let e = extrapolate(&s, 0.01);
    for k in 0..6 {
        let p = s.pose[k] + s.velocity[k] * 0.01 + 0.5 * s.acceleration[k] * 1e-4;
        assert!((e.pose[k] - p).abs() < 1e-6);
        assert!((e.velocity[k] - (s.velocity[k] + s.acceleration[k] * 0.01)).abs() < 1e-6);
    }
}

#[test]
fn lengths_off_the_setpoint_fault_only_when_enabled() {
    let mut control = common::control_loop();
    let setpoint = |seq| Setpoint { seq, pose: POSE, velocity: [0.0; 6], acceleration: [0.0; 6] };
    let mut null = IdealDrives { readings: common::readings_at(&control, POSE) };
    common::home(&mut control, &mut null, POSE);
    // The platform somewhere else along z: lengths that fit a pose (the
    // estimator accepts them), `dz` from the setpoint's.
    let platform_at = |control: &ControlLoop, dz: f32| {
        let mut pose = POSE;
        pose[2] += dz;
        let robot = control.controller().robot();
        let there = robot.cables(&Pose6::from(pose)).unwrap().lengths;
        let here = robot.cables(&Pose6::from(POSE)).unwrap().lengths;
        let worst = (there - here).amax();
        (common::readings_at(control, pose), worst)
    };
    let (far, far_worst) = platform_at(&control, 0.045);
    let (near, near_worst) = platform_at(&control, 0.03);
    assert!(far_worst > 0.02 && near_worst < 0.02, "{far_worst} {near_worst}");
    // Disabled: no fault, but Enable is refused where the platform is not.
    null.readings = far;
    control.receive(HostMessage::Setpoint(setpoint(1)));
    control.receive(HostMessage::Enable);
    let r = control.step(&NoClock, &mut null, false);
    assert_eq!((r.state, r.reason), (State::Disabled, Reason::None));
    assert_eq!(control.counters().faults, 0);
    null.readings = common::readings_at(&control, POSE);
    control.receive(HostMessage::Setpoint(setpoint(2)));
    control.receive(HostMessage::Enable);
    assert_eq!(control.step(&NoClock, &mut null, false).state, State::Enabled);
    // Within the limit: nothing; beyond it: Fault, tracking, this cycle.
    null.readings = near;
    control.receive(HostMessage::Setpoint(setpoint(3)));
    assert_eq!(control.step(&NoClock, &mut null, false).state, State::Enabled);
    null.readings = far;
    control.receive(HostMessage::Setpoint(setpoint(4)));
    let r = control.step(&NoClock, &mut null, false);
    assert!(matches!(r.estimate, Some(Ok(_))), "{:?}", r.estimate);
    assert_eq!((r.state, r.reason, r.brakes), (State::Fault, Reason::Tracking, true));
    assert_eq!(control.counters().faults, 1);
    // Latched: the next cycle does not count another fault.
    control.receive(HostMessage::Setpoint(setpoint(5)));
    assert_eq!(control.step(&NoClock, &mut null, false).state, State::Fault);
    assert_eq!(control.counters().faults, 1);
}

/// Bounds a configuration may carry: valid (zero, either sign of it,
/// finite, infinite) and invalid (NaN, below zero).
const BOUNDS: [f32; 9] = [0.0, -0.0, 1e-30, 0.5, 20.0, f32::MAX, f32::INFINITY, f32::NAN, -1.0];

fn valid(bound: f32) -> bool {
    // The rule, stated apart from the code: a bound admits `|x| <= bound`,
    // which some `x` satisfies exactly when the bound is zero or more.
    !bound.is_nan() && bound.is_sign_positive() || bound == 0.0
}

use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

/// Task-space cases refused when made (`InvalidLimits`) / cycles bounded.
static TASK_REFUSED: AtomicUsize = AtomicUsize::new(0);
static TASK_BOUNDED: AtomicUsize = AtomicUsize::new(0);

/// Hostile bounds never panic the task-space PID (`f32::clamp` did on a
/// NaN or negative integral bound) and never pass or flip the wrench: a PID
/// with an invalid bound is refused when made (`InvalidLimits`, where it
/// used to run and refuse every cycle); one with valid bounds bounds the
/// force, the moment (about the centre of mass) and each integral, every
/// cycle. Counts both outcomes (each case runs 1-40 cycles).
#[test]
fn task_pid_bounds_are_checked_never_trusted() {
    use cdpr_control::feedback::{FeedbackLimits, Gains, Prediction, TaskPid};
    use proptest::prelude::*;
    let strategy = (
        proptest::array::uniform8(0usize..BOUNDS.len()),
        proptest::array::uniform6(-2.0f32..2.0),
        proptest::array::uniform6(-5.0f32..5.0),
        1usize..40,
    );
    // A fixed seed, as the workspace's other campaigns (`PROPTEST_RNG_SEED`
    // explores others): from a random one, the count below (bounded
    // cycles, about 1 370 +- 180) fell under its old threshold of 1 000 in
    // about one run in 60, a CI failure with no defect.
    let rng_seed = match ProptestConfig::default().rng_seed {
        proptest::test_runner::RngSeed::Random => proptest::test_runner::RngSeed::Fixed(20_261_207),
        chosen => chosen,
    };
    let config = ProptestConfig { cases: 512, rng_seed, ..ProptestConfig::default() };
    let mut runner = proptest::test_runner::TestRunner::new(config);
    let result = runner.run(&strategy, |(picks, error, rates, cycles)| {
        let bound = picks.map(|i| BOUNDS[i]);
        let limits = FeedbackLimits {
            force_max: bound[0],
            moment_max: bound[1],
            integral_max: [bound[2], bound[3], bound[4], bound[5], bound[6], bound[7]],
        };
        let gains = Gains { kp: [400.0; 6], kd: [40.0; 6], ki: [4000.0; 6] };
        let all_valid = bound.iter().all(|b| valid(*b));
        let mut pid = match TaskPid::new(gains, limits) {
            Err(e) => {
                prop_assert!(!all_valid && e == tension_core::Error::InvalidLimits, "{e:?} {bound:?}");
                TASK_REFUSED.fetch_add(1, Relaxed);
                return Ok(());
            }
            Ok(pid) => pid,
        };
        prop_assert!(all_valid, "made with {bound:?}");
        let rc = tension_core::nalgebra::Vector3::new(0.01, -0.02, 0.03);
        for _ in 0..cycles {
            let w = pid.update_error(&error, &rates, &rc, 1e-3, true, [1.0; 2], &Prediction::NONE);
            prop_assert!(w.is_ok(), "{w:?} {bound:?}");
            let w = w.unwrap();
            let force = tension_core::nalgebra::Vector3::new(w[0], w[1], w[2]);
            // The moment about the centre of mass: less `rc x F`.
            let moment = tension_core::nalgebra::Vector3::new(w[3], w[4], w[5]) - rc.cross(&force);
            let slack = |b: f32| b * (1.0 + 1e-5) + 1e-6;
            prop_assert!(force.norm() <= slack(bound[0]), "{force:?} {bound:?}");
            prop_assert!(moment.norm() <= slack(bound[1]), "{moment:?} {bound:?}");
            for k in 0..6 {
                prop_assert!(pid.integral()[k].abs() <= limits.integral_max[k], "{k} {:?}", pid.integral());
            }
            TASK_BOUNDED.fetch_add(1, Relaxed);
        }
        Ok(())
    });
    assert!(result.is_ok(), "{result:?}");
    let (refused, bounded) = (TASK_REFUSED.load(Relaxed), TASK_BOUNDED.load(Relaxed));
    eprintln!("task-space PID: {refused} cases refused when made (InvalidLimits), {bounded} cycles bounded");
    // About 443 +- 8 refused (7 of the 9 bounds valid, all 8 valid in
    // 13 % of the cases) and 1 370 +- 180 cycles: both well clear of
    // these, whatever the seed.
    assert!(refused > 300 && bounded > 500, "{refused} {bounded}");
}

/// The same for the joint-space PID's integral bound: every bound of
/// [`BOUNDS`] with random length errors, each over 1-40 cycles; and the
/// control loop's `set_joint_gains` refuses an invalid bound and keeps its
/// PID.
#[test]
fn joint_pid_bound_is_checked_never_trusted() {
    use cdpr_control::feedback::{JointGains, JointPid};
    let (mut refused, mut bounded) = (0, 0);
    let mut x = 0x2545_F491_u32;
    for &bound in &BOUNDS {
        let gains = JointGains { kp: 1e3, kd: 50.0, ki: 1e4, integral_max: bound };
        let mut pid = match JointPid::new(gains) {
            Err(e) => {
                assert!(!valid(bound) && e == tension_core::Error::InvalidLimits, "{e:?} {bound}");
                refused += 1;
                let mut control = common::control_loop();
                let before = control.joint_pid().copied();
                assert_eq!(control.set_joint_gains(Some(gains)), Err(tension_core::Error::InvalidLimits));
                assert_eq!(control.joint_pid().copied(), before);
                continue;
            }
            Ok(pid) => pid,
        };
        assert!(valid(bound), "{bound}");
        for case in 0..64 {
            let errors: [f32; 8] = core::array::from_fn(|_| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                (x as f32 / u32::MAX as f32 - 0.5) * 0.2
            });
            pid.reset();
            let lengths_d = [2.0f32; 8];
            let lengths: [f32; 8] = core::array::from_fn(|i| lengths_d[i] + errors[i]);
            for _ in 0..=case % 40 {
                let out = pid.update(&lengths, &[0.0; 8], &lengths_d, &[0.0; 8], 1e-3, true);
                assert!(out.is_ok(), "{out:?} {bound}");
                assert!(pid.integral().iter().all(|i| i.abs() <= bound), "{:?}", pid.integral());
                bounded += 1;
            }
        }
    }
    eprintln!(
        "joint-space PID: {refused} bounds refused when made (InvalidLimits), {bounded} cycles bounded"
    );
    assert!(refused >= 2 && bounded > 2_000, "{refused} {bounded}");
}

/// `ControlLoop::set_bandwidth` (the robot file's `[control] bandwidth`):
/// both schemes' gains are the triple pole at `-2 pi f` worked out here
/// from the formulas (`Kp = 3 m w^2`, `Kd = 3 m w`, `Ki = m w^3`; the
/// joint-space gains divided by the smallest `sum_i W_ki^2` of the
/// translations at the range's centre), the bounds stay, and a bandwidth
/// that is not finite and positive changes nothing.
#[test]
fn a_bandwidth_places_both_schemes_poles() {
    // The board's default is the robot file's.
    let default_hz = robot_file::RobotFile::DEFAULT_BANDWIDTH_HZ as f32;
    assert_eq!(cdpr_control::control_loop::DEFAULT_OMEGA, 2.0 * std::f32::consts::PI * default_hz);
    let robot = common::suspended8();
    let mut control = common::control_loop();
    let limits = *control.task_pid().limits();
    let integral_max = control.joint_pid().unwrap().gains().integral_max;
    let range = common::setpoint_range();
    let centre: [f32; 3] = core::array::from_fn(|k| 0.5 * (range.position_min[k] + range.position_max[k]));
    let w = robot.wrench_matrix(&Pose6::from([centre[0], centre[1], centre[2], 0.0, 0.0, 0.0])).unwrap();
    let s = (0..3)
        .map(|k| (0..8).map(|i| f64::from(w[(k, i)]).powi(2)).sum::<f64>())
        .fold(f64::INFINITY, f64::min);
    let m = f64::from(robot.platform().mass);
    let inertia = [0.05, 0.05, 0.08]; // suspended-8's file
    let close = |got: f32, want: f64| (f64::from(got) - want).abs() <= 1e-5 * want.abs();
    for hz in [0.5f32, 2.0, 5.0, 12.5, 20.0] {
        control.set_bandwidth(hz).unwrap();
        let o = 2.0 * std::f64::consts::PI * f64::from(hz);
        let g = control.task_pid().gains();
        for k in 0..6 {
            let mass = if k < 3 { m } else { inertia[k - 3] };
            assert!(close(g.kp[k], 3.0 * mass * o * o), "{hz} Hz kp[{k}] {}", g.kp[k]);
            assert!(close(g.kd[k], 3.0 * mass * o), "{hz} Hz kd[{k}] {}", g.kd[k]);
            assert!(close(g.ki[k], mass * o * o * o), "{hz} Hz ki[{k}] {}", g.ki[k]);
        }
        assert_eq!(control.task_pid().limits(), &limits);
        let j = control.joint_pid().unwrap().gains();
        assert!(
            close(j.kp, 3.0 * m * o * o / s)
                && close(j.kd, 3.0 * m * o / s)
                && close(j.ki, m * o * o * o / s),
            "{hz} Hz {j:?}"
        );
        assert_eq!(j.integral_max, integral_max);
    }
    let (task, joint) = (*control.task_pid(), control.joint_pid().copied());
    for bad in [0.0, -2.0, f32::NAN, f32::INFINITY, f32::MAX] {
        assert_eq!(control.set_bandwidth(bad), Err(tension_core::Error::InvalidLimits), "{bad}");
        assert_eq!((*control.task_pid(), control.joint_pid().copied()), (task, joint), "{bad}");
    }
}
