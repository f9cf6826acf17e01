//! The feedback module and the cable-length supervision through the
//! control loop.

mod common;

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
