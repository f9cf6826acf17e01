//! Every field of an accepted setpoint frame reaches the cycle that uses
//! it. The loop keeps the newest good setpoint in place and writes a new
//! one over it field by field (a move of the whole setpoint was a library
//! copy on the board: BENCHMARKS.md, session 32), so a field the write
//! forgot would keep the last setpoint's value. Setpoints whose sequence
//! number, pose, velocity and acceleration all differ from the one before,
//! through both ways into the kept slot (over a good setpoint, and after
//! none or a bad one): the kept setpoint must be the frame's, bit for bit,
//! and the cycle's tensions a fresh controller's for it.

use crate::common;

use common::{low, IdealDrives};

use cdpr_control::controller::{Controller, Wrench};
use cdpr_control::protocol::{HostMessage, Setpoint as WireSetpoint};
use cdpr_control::setpoint::Setpoint;
use cdpr_control::NoClock;

/// Setpoint `k`: every component of pose, velocity and acceleration moved
/// from the last one, within suspended-8's setpoint range.
fn varied(k: u32) -> WireSetpoint {
    let mut s = low(k);
    let sign = if k.is_multiple_of(2) { 1.0 } else { -1.0 };
    for i in 0..6 {
        let step = (k as f32) * (i as f32 + 1.0);
        s.pose[i] += 1e-3 * step * if i < 3 { 1.0 } else { 0.5 };
        s.velocity[i] = sign * 0.02 * (i as f32 + 1.0) + 1e-3 * k as f32;
        s.acceleration[i] = -sign * 0.3 * (i as f32 + 1.0) + 1e-2 * k as f32;
    }
    s
}

#[test]
fn every_field_of_a_new_setpoint_is_kept_and_solved() {
    let mut control = common::control_loop();
    let mut drives = IdealDrives { readings: common::readings_at(&control, low(0).pose) };
    common::home(&mut control, &mut drives, low(0).pose);
    let range = common::setpoint_range();
    let robot = common::suspended8();
    let span = robot.limits().max()[0] - robot.limits().min()[0];
    let mut fresh =
        Controller::new(robot, tension_core::Method::Barycenter).expect("suspended-8's controller");
    let (mut kept, mut compared, mut after_bad) = (0, 0, 0);
    let mut worst = 0.0f32;
    for k in 1..=40u32 {
        // Every tenth frame bad (a NaN): the next good one is written into
        // a slot that holds no setpoint.
        if k.is_multiple_of(10) {
            let mut bad = varied(k);
            bad.pose[0] = f32::NAN;
            control.receive(HostMessage::Setpoint(bad));
            assert!(control.newest_setpoint().is_none(), "the bad frame {k} was kept");
            control.step(&NoClock, &mut drives, false);
            continue;
        }
        let wire = varied(k);
        assert!(range.contains(&wire), "setpoint {k} outside the range: {wire:?}");
        let was_good = control.newest_setpoint().is_some();
        control.receive(HostMessage::Setpoint(wire));
        let expected = Setpoint::from(&wire);
        assert_eq!(control.newest_setpoint(), Some(&expected), "setpoint {k} as kept");
        assert_eq!(control.newest_setpoint_age(), Some(0), "setpoint {k}'s arrival");
        kept += 1;
        if !was_good {
            after_bad += 1;
        }
        let report = control.step(&NoClock, &mut drives, false);
        let solved = report.solved.expect("a solved cycle").result.expect("a feasible setpoint");
        let reference =
            fresh.step(&expected, &Wrench::zeros(), &NoClock).result.expect("a feasible setpoint");
        for i in 0..8 {
            worst = worst.max((solved.tensions[i] - reference.tensions[i]).abs());
        }
        compared += 1;
    }
    // The acceleration alone moves the required force by several newtons
    // (6.34 kg at up to 1.8 m/s^2); the warm and the cold solve agree to
    // rounding.
    assert!(worst <= 1e-4 * span, "tensions differ from a fresh solve by {worst} N (range {span} N)");
    assert_eq!((kept, after_bad, compared), (36, 4, 36), "cases reached");
}
