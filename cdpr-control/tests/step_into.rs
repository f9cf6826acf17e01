//! `ControlLoop::step_into` writes every field of the report it is given:
//! the firmware keeps one report in place from cycle to cycle, so a field
//! the step forgot would carry the last cycle's value. Two loops receive
//! the same messages; one returns its reports (`step`, a fresh report a
//! cycle), the other writes into a report filled with other values before
//! every cycle, and the two must print the same.

use crate::common;

use common::{low, moving_x, IdealDrives};

use cdpr_control::estimator::EstimateError;
use cdpr_control::protocol::{DriveFault, DriveFaultCause, HostMessage, Reason, State};
use cdpr_control::{ControlLoop, NoClock, StepReport};

fn rig() -> (ControlLoop, IdealDrives) {
    let mut control = common::control_loop();
    control.set_tracking_limit(None);
    let mut drives = IdealDrives { readings: common::readings_at(&control, low(0).pose) };
    common::home(&mut control, &mut drives, low(0).pose);
    (control, drives)
}

/// A report whose every field differs from what a cycle of the script
/// below writes (taken from a solved cycle with telemetry, then changed).
fn other_than_any_cycle(template: &StepReport) -> StepReport {
    let mut r = *template;
    r.cycle = 0xDEAD_BEEF;
    r.state = State::Fault;
    r.reason = Reason::Tracking;
    r.torques = [9.5; 8];
    r.brakes = !r.brakes;
    r.estimate = Some(Err(EstimateError::Correction));
    r.feedback = cdpr_control::controller::Wrench::repeat(7.25);
    r.offsets = [3.5; 8];
    r.unreadable_drive = Some(5);
    r.drive_fault = Some(DriveFault { drive: 6, cause: DriveFaultCause::Emergency, code: 0x2310 });
    if let Some(t) = &mut r.telemetry {
        t.cycle = 0xDEAD_BEEF;
        t.step_cost = 123_456;
    }
    if let Some(c) = &mut r.solved {
        c.ticks.solver = 0xFFFF;
    }
    r
}

#[test]
fn every_field_of_the_report_is_written_each_cycle() {
    let (mut returned, mut drives_a) = rig();
    let (mut in_place, mut drives_b) = rig();
    // A template with telemetry and a solved cycle.
    let template = {
        let (mut c, mut d) = rig();
        c.receive(HostMessage::TelemetryPeriod(1));
        c.receive(HostMessage::Setpoint(low(1)));
        c.receive(HostMessage::Enable);
        common::follow(&c, &mut d.readings);
        c.step(&NoClock, &mut d, false)
    };
    assert!(template.telemetry.is_some() && template.solved.is_some());
    let mut report = other_than_any_cycle(&template);

    let (mut with_telemetry, mut without_telemetry, mut solved, mut unsolved, mut estimated) =
        (0, 0, 0, 0, 0);
    let mut states = Vec::new();
    let mut seq = 0;
    for k in 0..400u32 {
        // The script: telemetry every third cycle; at rest, Enable, a
        // line, a pause (no setpoints: stale, Holding), ClearFault (refused).
        let mut messages = Vec::new();
        if k == 0 {
            messages.push(HostMessage::TelemetryPeriod(3));
        }
        if k < 250 {
            seq += 1;
            messages.push(HostMessage::Setpoint(if k < 50 { low(seq) } else { moving_x(seq, k - 50, 0.2) }));
        }
        if k == 10 {
            messages.push(HostMessage::Enable);
        }
        if k == 380 {
            messages.push(HostMessage::ClearFault);
        }
        for m in &messages {
            returned.receive(*m);
            in_place.receive(*m);
        }
        common::follow(&returned, &mut drives_a.readings);
        common::follow(&in_place, &mut drives_b.readings);
        let expected = returned.step(&NoClock, &mut drives_a, false);
        report = other_than_any_cycle(&report);
        in_place.step_into(&NoClock, &mut drives_b, false, &mut report);
        assert_eq!(format!("{report:?}"), format!("{expected:?}"), "cycle {k}");

        if expected.telemetry.is_some() {
            with_telemetry += 1;
        } else {
            without_telemetry += 1;
        }
        if expected.solved.is_some() {
            solved += 1;
        } else {
            unsolved += 1;
        }
        estimated += usize::from(expected.estimate.is_some());
        if states.last() != Some(&expected.state) {
            states.push(expected.state);
        }
    }
    eprintln!(
        "400 cycles compared: telemetry {with_telemetry} / none {without_telemetry}, solved {solved} / not {unsolved}, estimated {estimated}, states {states:?}"
    );
    // The comparisons covered both sides of every optional field.
    assert!(with_telemetry > 100 && without_telemetry > 200, "{with_telemetry} {without_telemetry}");
    assert!(solved >= 250 && unsolved >= 50, "{solved} {unsolved}");
    assert!(estimated > 300, "{estimated}");
    assert!(states.contains(&State::Enabled) && states.contains(&State::Holding), "{states:?}");
}
