//! A buffered trajectory through the control loop: points in, the
//! interpolated setpoint solved every cycle, the stale rule on the buffer,
//! its fill in telemetry, and what ends a stream.

use crate::common;

use common::IdealDrives;

use cdpr_control::point_buffer::START_DELAY_CYCLES;
use cdpr_control::protocol::{HostMessage, Reason, Rejection, Setpoint, State, TrajectoryPoint};
use cdpr_control::supervisor::SafetyLimits;
use cdpr_control::{ControlLoop, NoClock, StepReport};

const POSE: [f32; 6] = [0.1, -0.2, 1.9, 0.02, -0.01, 0.05];

struct Rig {
    control: ControlLoop,
    plant: IdealDrives,
}

impl Rig {
    fn homed() -> Self {
        let mut control = common::control_loop();
        let mut plant = IdealDrives { readings: common::readings_at(&control, POSE) };
        common::home(&mut control, &mut plant, POSE);
        control.receive(HostMessage::TelemetryPeriod(1));
        Self { control, plant }
    }

    /// Homed, 300 ms of points at rest at `POSE` played past the start
    /// delay, and enabled on them.
    fn enabled_on_a_resting_stream() -> Self {
        let mut rig = Self::homed();
        for k in 0..=30 {
            rig.control.receive(HostMessage::Point(along_x(10 * k, 0.0)));
        }
        for _ in 0..=START_DELAY_CYCLES {
            rig.step();
        }
        rig.control.receive(HostMessage::Enable);
        assert_eq!(rig.step().state, State::Enabled);
        rig
    }

    fn step(&mut self) -> StepReport {
        let r = self.control.step(&NoClock, &mut self.plant, false);
        common::follow(&self.control, &mut self.plant.readings);
        r
    }
}

/// Moving along x at `v` m/s from `POSE`, a point at `t` ms.
fn along_x(t: u32, v: f32) -> TrajectoryPoint {
    let mut pose = POSE;
    pose[0] += v * t as f32 * 1e-3;
    TrajectoryPoint { time_ms: t, pose, velocity: [v, 0.0, 0.0, 0.0, 0.0, 0.0] }
}

#[test]
fn a_buffered_stream_enables_tracks_and_goes_stale_when_dry() {
    let mut rig = Rig::homed();
    // 200 ms of points at 100 Hz, 0.2 m/s along x.
    let v = 0.2;
    for k in 0..=20 {
        rig.control.receive(HostMessage::Point(along_x(10 * k, v)));
    }
    let t = rig.step().telemetry.unwrap();
    assert_eq!((t.buffer_fill, t.buffer_lead_ms), (21, 200 + START_DELAY_CYCLES as u16));
    // Nothing to solve during the start delay: Enable is refused (stale).
    rig.control.receive(HostMessage::Enable);
    assert_eq!(rig.step().state, State::Disabled);
    for _ in 0..START_DELAY_CYCLES {
        rig.step();
    }
    rig.control.receive(HostMessage::Enable);
    let r = rig.step();
    assert_eq!(r.state, State::Enabled, "{:?}", r.reason);
    // The stream plays one ms a cycle: the telemetry's setpoint number is
    // the play time.
    let t = r.telemetry.unwrap();
    assert_eq!(t.setpoint_seq, 2);
    // Points 10 ms apart, sent 30-40 ms ahead of the play time (the
    // host's lead), for 300 ms; the setpoint is the line, exactly.
    let mut sent = 200;
    for _ in 0..300 {
        let play = rig.control.newest_setpoint().map_or(0, |s| s.seq);
        while sent < play + 40 {
            sent += 10;
            rig.control.receive(HostMessage::Point(along_x(sent, v)));
        }
        let r = rig.step();
        assert_eq!(r.state, State::Enabled, "{:?} at {play}", r.reason);
        let s = rig.control.newest_setpoint().unwrap();
        let expected = POSE[0] + v * s.seq as f32 * 1e-3;
        assert!((s.pose[0] - expected).abs() < 1e-5, "{} vs {expected}", s.pose[0]);
        assert!((s.velocity[0] - v).abs() < 1e-3 && s.acceleration[0].abs() < 0.5, "{s:?}");
        assert!(r.telemetry.unwrap().buffer_fill >= 2);
    }
    assert_eq!(rig.control.counters().rejected_order, 0);
    // The host stops: the buffer plays out, then the stale rule counts
    // from the last point played (not from the last frame's arrival).
    let last = sent;
    let mut played_out = None;
    for k in 0..200 {
        let r = rig.step();
        let seq = rig.control.newest_setpoint().unwrap().seq;
        if played_out.is_none() && seq == last {
            played_out = Some(k);
        }
        if r.state == State::Holding {
            assert_eq!(r.reason, Reason::Stale);
            let since = k - played_out.expect("the buffer played out first");
            assert_eq!(since, SafetyLimits::DEFAULT.stale_cycles as usize + 1, "held at {k}");
            assert_eq!((r.telemetry.unwrap().buffer_fill, r.telemetry.unwrap().buffer_lead_ms), (0, 0));
            return;
        }
    }
    panic!("never stale");
}

#[test]
fn late_points_are_rejected_while_enabled_and_a_setpoint_ends_the_stream() {
    let mut rig = Rig::enabled_on_a_resting_stream();
    let accepted = rig.control.counters().accepted;
    rig.control.receive(HostMessage::Point(along_x(300, 0.0)));
    assert_eq!(rig.control.counters().last_rejection, Rejection::Late);
    // A refused point is not also counted as accepted.
    assert_eq!(rig.control.counters().accepted, accepted);
    rig.control.receive(HostMessage::Point(along_x(290, 0.0)));
    assert_eq!(rig.control.counters().rejected_order, 2);
    // A point 1 m away 10 ms later: a jump.
    let mut far = along_x(310, 0.0);
    far.pose[0] += 1.0;
    rig.control.receive(HostMessage::Point(far));
    assert_eq!(
        (rig.control.counters().last_rejection, rig.control.counters().rejected_jump),
        (Rejection::Jump, 1)
    );
    // A setpoint of its own: the buffer is emptied, the setpoint is used.
    rig.control.receive(HostMessage::Setpoint(Setpoint {
        seq: 1,
        pose: POSE,
        velocity: [0.0; 6],
        acceleration: [0.0; 6],
    }));
    let r = rig.step();
    assert_eq!(r.state, State::Enabled);
    assert_eq!(rig.control.newest_setpoint().unwrap().seq, 1);
    assert_eq!(r.telemetry.unwrap().buffer_fill, 0);
}

#[test]
fn disable_ends_the_stream_and_a_new_one_starts_from_any_time() {
    let mut rig = Rig::enabled_on_a_resting_stream();
    rig.control.receive(HostMessage::Disable);
    let r = rig.step();
    assert_eq!((r.state, r.telemetry.unwrap().buffer_fill), (State::Disabled, 0));
    // Free again: a stream numbered from 0 starts.
    rig.control.receive(HostMessage::Point(along_x(0, 0.0)));
    rig.control.receive(HostMessage::Point(along_x(10, 0.0)));
    assert_eq!(rig.control.counters().rejected_order, 0);
    assert_eq!(rig.step().telemetry.unwrap().buffer_fill, 2);
}

#[test]
fn while_enabled_a_new_stream_must_start_where_the_winches_are() {
    let mut rig = Rig::homed();
    rig.control.receive(HostMessage::Setpoint(Setpoint {
        seq: 1,
        pose: POSE,
        velocity: [0.0; 6],
        acceleration: [0.0; 6],
    }));
    rig.control.receive(HostMessage::Enable);
    assert_eq!(rig.step().state, State::Enabled);
    // 0.2 m away at rest: refused as a jump; where the winches are: taken.
    let mut away = along_x(0, 0.0);
    away.pose[0] += 0.2;
    rig.control.receive(HostMessage::Point(away));
    assert_eq!(rig.control.counters().last_rejection, Rejection::Jump);
    rig.control.receive(HostMessage::Point(along_x(0, 0.0)));
    assert_eq!(rig.control.counters().rejected_jump, 1);
    assert_eq!(rig.step().telemetry.unwrap().buffer_fill, 1);
}
