//! The safety state machine driven through the control loop, frames in as
//! bytes, against the behaviour documented in `supervisor.rs` (timings from
//! `SafetyLimits::DEFAULT`: stale after 50 cycles, fault after 100 cycles of
//! holding, 200-cycle torque ramp, fault at the 5th overrun in a row).

use crate::common;

use common::low;

use cdpr_control::drives::WinchDrives;
use cdpr_control::link::SetpointRange;
use cdpr_control::protocol::{encode, HostMessage, Reason, Setpoint, State, MAX_FRAME};
use cdpr_control::supervisor::SafetyLimits;
use cdpr_control::{ControlLoop, NoClock, StepReport, WinchReading, CABLES};
use proptest::prelude::*;
use tension_core::Method;

const LIMITS: SafetyLimits = SafetyLimits::DEFAULT;

/// Drives that record what they were told, and can be made to fail.
#[derive(Default)]
struct Recorder {
    torques: Vec<[f32; CABLES]>,
    brakes: Vec<bool>,
    fail: bool,
    readings: [WinchReading; CABLES],
}

impl WinchDrives for Recorder {
    type Error = ();
    fn apply(&mut self, torques: &[f32; CABLES]) -> Result<(), ()> {
        self.torques.push(*torques);
        if self.fail {
            Err(())
        } else {
            Ok(())
        }
    }
    fn set_brakes(&mut self, engaged: bool) -> Result<(), ()> {
        self.brakes.push(engaged);
        if self.fail {
            Err(())
        } else {
            Ok(())
        }
    }
    fn read(&mut self, readings: &mut [WinchReading; CABLES]) -> Result<(), ()> {
        *readings = self.readings;
        Ok(())
    }
}

/// In range, but near the anchors' height: no tensions within the limits.
fn high(seq: u32) -> Setpoint {
    Setpoint { pose: [0.0, 0.0, 3.4, 0.0, 0.0, 0.0], ..low(seq) }
}

fn bytes(message: &HostMessage) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let n = encode(message, &mut out).unwrap();
    out[..n].to_vec()
}

struct Rig {
    control: ControlLoop,
    drives: Recorder,
}

impl Rig {
    fn new() -> Self {
        let mut control =
            ControlLoop::new(common::suspended8(), Method::Barycenter, common::setpoint_range(), LIMITS)
                .unwrap();
        // These tests jump to infeasible poses on purpose; the jump check
        // has its own tests (`link.rs`).
        control.set_jump_limits(None);
        // The ideal plant follows even infeasible setpoints: no length check.
        control.set_tracking_limit(None);
        let mut drives =
            Recorder { readings: common::readings_at(&control, low(0).pose), ..Default::default() };
        common::home(&mut control, &mut drives, low(0).pose);
        Self { control, drives }
    }

    fn send(&mut self, message: HostMessage) {
        for b in bytes(&message) {
            self.control.receive_byte(b);
        }
    }

    fn send_raw(&mut self, raw: &[u8]) {
        for &b in raw {
            self.control.receive_byte(b);
        }
    }

    fn step(&mut self) -> StepReport {
        self.step_overrun(false)
    }

    fn step_overrun(&mut self, overrun: bool) -> StepReport {
        common::follow(&self.control, &mut self.drives.readings);
        let report = self.control.step(&NoClock, &mut self.drives, overrun);
        // What reached the drives is what the report says.
        assert_eq!(self.drives.torques.last(), Some(&report.torques));
        assert_eq!(self.drives.brakes.last(), Some(&report.brakes));
        report
    }

    /// Setpoint seq 1 at the low pose, Enable, one step: Enabled.
    fn enabled() -> (Self, [f32; CABLES]) {
        let mut rig = Self::new();
        rig.send(HostMessage::Setpoint(low(1)));
        rig.send(HostMessage::Enable);
        let r = rig.step();
        assert_eq!(r.state, State::Enabled);
        assert!(!r.brakes);
        (rig, r.torques)
    }
}

fn same(a: &[f32; CABLES], b: &[f32; CABLES]) -> bool {
    a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

#[test]
fn starts_disabled_and_enable_needs_a_feasible_setpoint() {
    let mut rig = Rig::new();
    let r = rig.step();
    assert_eq!((r.state, r.brakes, r.torques), (State::Disabled, true, [0.0; CABLES]));

    // Enable with no setpoint: refused.
    rig.send(HostMessage::Enable);
    assert_eq!(rig.step().state, State::Disabled);
    assert_eq!(rig.control.counters().rejected_state, 1);

    // Enable with an infeasible setpoint: refused.
    rig.send(HostMessage::Setpoint(high(1)));
    rig.send(HostMessage::Enable);
    assert_eq!(rig.step().state, State::Disabled);
    assert_eq!(rig.control.counters().rejected_state, 2);

    // Enable with a feasible one: granted; the torques are the controller's.
    rig.send(HostMessage::Setpoint(low(2)));
    rig.send(HostMessage::Enable);
    let r = rig.step();
    assert_eq!(r.state, State::Enabled);
    assert!(!r.brakes);
    let command = r.solved.unwrap().result.unwrap();
    assert!(same(&r.torques, &command.torques));
    // Every torque is the conventions' tau = t r / (G eta) of its tension (suspended-8: r 0.04, G 8, eta 0.9).
    for (tau, t) in r.torques.iter().zip(command.tensions) {
        assert!((tau - t * 0.04 / (8.0 * 0.9)).abs() <= 1e-6 * t.abs().max(1.0));
        assert!((5.0 - 1e-3..=350.0 + 1e-3).contains(&t));
    }
}

/// The ramp of the documented fault/disable behaviour: `from` scaled by
/// `1 - j / ramp_cycles` in the `j`-th cycle after entry, then zero.
fn check_ramp(rig: &mut Rig, first: &StepReport, from: &[f32; CABLES], state: State) {
    assert!(same(&first.torques, from), "the ramp starts from the applied torques");
    for j in 1..=LIMITS.ramp_cycles + 5 {
        let r = rig.step();
        assert_eq!(r.state, state);
        assert!(r.brakes);
        let scale = (1.0 - j as f32 / LIMITS.ramp_cycles as f32).max(0.0);
        for (t, f) in r.torques.iter().zip(from) {
            assert!((t - f * scale).abs() <= 1e-6, "cycle {j}: {t} vs {}", f * scale);
        }
    }
}

#[test]
fn infeasible_setpoint_holds_then_faults_and_ramps_down() {
    let (mut rig, feasible) = Rig::enabled();
    // Holding for hold_cycles cycles with the last feasible torques, while
    // fresh infeasible setpoints keep coming...
    for j in 0..LIMITS.hold_cycles {
        rig.send(HostMessage::Setpoint(high(j + 2)));
        let r = rig.step();
        assert_eq!((r.state, r.reason), (State::Holding, Reason::Infeasible), "cycle {j}");
        assert!(same(&r.torques, &feasible));
        assert!(!r.brakes);
        assert!(r.solved.unwrap().result.is_err());
    }
    // ...then Fault, brakes on, the torques ramp to zero.
    let r = rig.step();
    assert_eq!((r.state, r.reason), (State::Fault, Reason::HoldTimeout));
    assert_eq!(rig.control.supervisor().hold_reason(), Reason::Infeasible);
    assert!(r.brakes);
    check_ramp(&mut rig, &r, &feasible, State::Fault);
    let counters = rig.control.counters();
    assert_eq!(counters.faults, 1);
    assert!(counters.infeasible > LIMITS.hold_cycles);

    // Latched: a feasible setpoint does not re-enable by itself.
    rig.send(HostMessage::Setpoint(low(3)));
    assert_eq!(rig.step().state, State::Fault);
    // ClearFault (ramp done) -> Disabled; then Enable works again.
    rig.send(HostMessage::ClearFault);
    assert_eq!(rig.step().state, State::Disabled);
    rig.send(HostMessage::Setpoint(low(1))); // the sequence restarted on entering Disabled
    rig.send(HostMessage::Enable);
    assert_eq!(rig.step().state, State::Enabled);
}

#[test]
fn a_feasible_setpoint_ends_a_hold() {
    let (mut rig, _) = Rig::enabled();
    rig.send(HostMessage::Setpoint(high(2)));
    for _ in 0..10 {
        assert_eq!(rig.step().state, State::Holding);
    }
    rig.send(HostMessage::Setpoint(low(3)));
    let r = rig.step();
    assert_eq!((r.state, r.reason), (State::Enabled, Reason::None));
    // A new hold gets the whole hold time again.
    rig.send(HostMessage::Setpoint(high(4)));
    for _ in 0..LIMITS.hold_cycles {
        assert_eq!(rig.step().state, State::Holding);
    }
    assert_eq!(rig.step().state, State::Fault);
}

#[test]
fn a_nan_pose_is_rejected_never_used_and_holds() {
    let (mut rig, feasible) = Rig::enabled();
    let mut nan = low(2);
    nan.pose[2] = f32::NAN;
    rig.send(HostMessage::Setpoint(nan));
    let r = rig.step();
    assert_eq!((r.state, r.reason), (State::Holding, Reason::BadSetpoint));
    assert!(r.solved.is_none(), "the bad setpoint is not solved");
    assert!(same(&r.torques, &feasible));
    assert_eq!(rig.control.counters().rejected_range, 1);
    assert!(rig.control.newest_setpoint().is_none());
    for _ in 1..LIMITS.hold_cycles {
        assert_eq!(rig.step().state, State::Holding);
    }
    let r = rig.step();
    assert_eq!((r.state, r.reason), (State::Fault, Reason::HoldTimeout));
    assert_eq!(rig.control.supervisor().hold_reason(), Reason::BadSetpoint);
}

#[test]
fn out_of_range_values_are_rejected() {
    let range: SetpointRange = common::setpoint_range();
    let cases: [fn(&mut Setpoint); 7] = [
        |s| s.pose[0] = 9.0,
        |s| s.pose[2] = -3.0,
        |s| s.pose[4] = 1.5,
        |s| s.velocity[1] = 20.0,
        |s| s.velocity[5] = f32::INFINITY,
        |s| s.acceleration[2] = -80.0,
        |s| s.acceleration[3] = f32::NAN,
    ];
    for (i, change) in cases.iter().enumerate() {
        let (mut rig, _) = Rig::enabled();
        let mut s = low(2);
        change(&mut s);
        assert!(!range.contains(&s));
        rig.send(HostMessage::Setpoint(s));
        assert_eq!(rig.step().reason, Reason::BadSetpoint, "case {i}");
        assert_eq!(rig.control.counters().rejected_range, 1);
    }
}

#[test]
fn a_stale_stream_holds_then_faults() {
    let (mut rig, mut feasible) = Rig::enabled(); // setpoint arrived in cycle 0
                                                  // Fresh up to stale_cycles cycles after arrival (re-solved each cycle).
    for _ in 1..=LIMITS.stale_cycles {
        let r = rig.step();
        assert_eq!(r.state, State::Enabled);
        feasible = r.torques;
    }
    for j in 0..LIMITS.hold_cycles {
        let r = rig.step();
        assert_eq!((r.state, r.reason), (State::Holding, Reason::Stale), "cycle {j}");
        assert!(same(&r.torques, &feasible));
        assert!(r.solved.is_none());
    }
    let r = rig.step();
    assert_eq!((r.state, r.reason), (State::Fault, Reason::HoldTimeout));
    assert_eq!(rig.control.supervisor().hold_reason(), Reason::Stale);
    check_ramp(&mut rig, &r, &feasible, State::Fault);
}

#[test]
fn out_of_order_corrupt_and_truncated_frames_are_counted_and_ignored() {
    let (mut rig, _) = Rig::enabled();
    rig.send(HostMessage::Setpoint(low(10)));
    rig.step();
    // Old and duplicate sequence numbers.
    rig.send(HostMessage::Setpoint(high(9)));
    rig.send(HostMessage::Setpoint(high(10)));
    // A corrupted frame (one payload bit flipped) and a truncated one.
    let mut corrupt = bytes(&HostMessage::Setpoint(high(11)));
    corrupt[10] ^= 0x04;
    rig.send_raw(&corrupt);
    let truncated = bytes(&HostMessage::Setpoint(high(12)));
    rig.send_raw(&truncated[..truncated.len() - 6]);
    rig.send_raw(&[0]);
    // Noise, and a frame with a good CRC that is no message.
    rig.send_raw(&[0x13, 0x37, 0x00]);
    let r = rig.step();
    assert_eq!(r.state, State::Enabled);
    assert_eq!(rig.control.newest_setpoint().unwrap().seq, 10);
    let c = rig.control.counters();
    assert_eq!(c.rejected_order, 2);
    assert_eq!(c.rejected_crc + c.rejected_framing + c.rejected_decode, 3, "{c:?}");
    assert_eq!(c.accepted, 4); // Home, setpoint 1, Enable, setpoint 10
}

#[test]
fn overruns_past_the_limit_fault() {
    let (mut rig, _) = Rig::enabled();
    for _ in 1..LIMITS.overrun_limit {
        rig.send(HostMessage::Setpoint(low(rig.control.cycle() + 10)));
        assert_eq!(rig.step_overrun(true).state, State::Enabled);
    }
    let r = rig.step_overrun(true);
    assert_eq!((r.state, r.reason), (State::Fault, Reason::Overruns));
    assert_eq!(rig.control.counters().overruns, LIMITS.overrun_limit);
}

#[test]
fn overruns_that_are_not_in_a_row_do_not_fault() {
    let (mut rig, _) = Rig::enabled();
    for k in 0..10 * LIMITS.overrun_limit {
        rig.send(HostMessage::Setpoint(low(k + 10)));
        let late = k % LIMITS.overrun_limit != 0; // overrun_limit - 1 in a row, then one on time
        assert_eq!(rig.step_overrun(late).state, State::Enabled, "cycle {k}");
    }
    assert!(rig.control.counters().overruns >= 9 * (LIMITS.overrun_limit - 1));
}

#[test]
fn disable_ramps_down_and_enable_waits_for_the_ramp() {
    let (mut rig, feasible) = Rig::enabled();
    rig.send(HostMessage::Disable);
    let r = rig.step();
    assert_eq!(r.state, State::Disabled);
    // Renumbering from 1 is allowed after a disable.
    rig.send(HostMessage::Setpoint(low(1)));
    assert_eq!(rig.control.counters().rejected_order, 0);
    rig.send(HostMessage::Enable);
    // Refused during the ramp.
    let r2 = rig.step();
    assert_eq!(r2.state, State::Disabled);
    assert_eq!(rig.control.counters().rejected_state, 1);
    let _ = r;
    // Let the ramp finish (the setpoint stays fresh by resending).
    for k in 0..LIMITS.ramp_cycles {
        rig.send(HostMessage::Setpoint(low(k + 2)));
        rig.step();
    }
    rig.send(HostMessage::Enable);
    let r = rig.step();
    assert_eq!(r.state, State::Enabled);
    // The same pose as before the disable (solved cold then, warm now).
    for (a, b) in r.torques.iter().zip(&feasible) {
        assert!((a - b).abs() <= 1e-5 * common::torque_max(), "{a} vs {b}");
    }
}

#[test]
fn disable_ramp_is_linear() {
    let (mut rig, feasible) = Rig::enabled();
    rig.send(HostMessage::Disable);
    let r = rig.step();
    check_ramp(&mut rig, &r, &feasible, State::Disabled);
}

#[test]
fn clear_fault_is_refused_during_the_ramp() {
    let (mut rig, _) = Rig::enabled();
    for _ in 0..LIMITS.overrun_limit {
        rig.step_overrun(true);
    }
    assert_eq!(rig.control.supervisor().state(), State::Fault);
    rig.send(HostMessage::ClearFault);
    assert_eq!(rig.step().state, State::Fault);
    assert_eq!(rig.control.counters().rejected_state, 1);
    for _ in 0..LIMITS.ramp_cycles {
        rig.step();
    }
    rig.send(HostMessage::ClearFault);
    assert_eq!(rig.step().state, State::Disabled);
}

#[test]
fn a_drive_error_faults() {
    let (mut rig, _) = Rig::enabled();
    rig.drives.fail = true;
    let r = rig.control.step(&NoClock, &mut rig.drives, false);
    assert_eq!((r.state, r.reason), (State::Fault, Reason::Output));
    assert!(r.brakes);
    assert_eq!(rig.drives.brakes.last(), Some(&true));
}

#[test]
fn telemetry_period() {
    let (mut rig, _) = Rig::enabled();
    rig.send(HostMessage::TelemetryPeriod(3));
    let due: Vec<bool> = (0..9).map(|_| rig.step().telemetry.is_some()).collect();
    // Cycle 0 homed the rig, cycle 1 enabled it.
    let cycles: Vec<u32> = (2..11).collect();
    assert_eq!(due, cycles.iter().map(|c| c % 3 == 0).collect::<Vec<_>>());
    rig.send(HostMessage::TelemetryPeriod(0));
    assert!((0..10).all(|_| rig.step().telemetry.is_none()));
    rig.send(HostMessage::TelemetryPeriod(1));
    rig.send(HostMessage::Setpoint(low(50)));
    let t = rig.step().telemetry.unwrap();
    assert_eq!((t.state, t.setpoint_seq, t.solved, t.brakes), (State::Enabled, 50, true, false));
    assert!(t.tensions.iter().all(|&x| (5.0..=350.0).contains(&x)));
}

#[derive(Debug, Clone)]
enum Action {
    Feasible,
    Infeasible,
    Nan,
    OldSeq,
    Enable,
    Disable,
    ClearFault,
    Garbage(Vec<u8>),
    Quiet(u8),
    Overrun,
}

fn action() -> impl Strategy<Value = Action> {
    prop_oneof![
        6 => Just(Action::Feasible),
        2 => Just(Action::Infeasible),
        1 => Just(Action::Nan),
        1 => Just(Action::OldSeq),
        2 => Just(Action::Enable),
        1 => Just(Action::Disable),
        1 => Just(Action::ClearFault),
        1 => prop::collection::vec(any::<u8>(), 0..40).prop_map(Action::Garbage),
        2 => (0u8..120).prop_map(Action::Quiet),
        1 => Just(Action::Overrun),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 200,
        // Saved beside this file (`<name>.proptest-regressions`) and committed.
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]

    /// Whatever arrives: torques finite and within the winch limit, brakes
    /// engaged exactly in Disabled and Fault, Enabled only on a cycle that
    /// solved its setpoint feasibly, a fault's torques never grow.
    #[test]
    fn invariants_under_any_stream(actions in prop::collection::vec(action(), 1..60)) {
        let mut rig = Rig::new();
        let mut seq = 1u32;
        let mut previous: Option<StepReport> = None;
        for a in actions {
            let mut steps = 1;
            let mut overrun = false;
            match a {
                Action::Feasible => { seq += 1; rig.send(HostMessage::Setpoint(low(seq))) }
                Action::Infeasible => { seq += 1; rig.send(HostMessage::Setpoint(high(seq))) }
                Action::Nan => { seq += 1; let mut s = low(seq); s.pose[0] = f32::NAN; rig.send(HostMessage::Setpoint(s)) }
                Action::OldSeq => rig.send(HostMessage::Setpoint(high(0))),
                Action::Enable => rig.send(HostMessage::Enable),
                Action::Disable => rig.send(HostMessage::Disable),
                Action::ClearFault => rig.send(HostMessage::ClearFault),
                Action::Garbage(g) => rig.send_raw(&g),
                Action::Quiet(n) => steps = u32::from(n) + 1,
                Action::Overrun => overrun = true,
            }
            for _ in 0..steps {
                let r = rig.step_overrun(overrun);
                prop_assert!(r.torques.iter().all(|t| t.is_finite() && t.abs() <= common::torque_max()));
                prop_assert_eq!(r.brakes, matches!(r.state, State::Disabled | State::Fault));
                if r.state == State::Enabled {
                    prop_assert!(r.solved.is_some_and(|c| c.result.is_ok()));
                }
                if let Some(p) = &previous {
                    if p.state == State::Fault && r.state == State::Fault {
                        for (now, before) in r.torques.iter().zip(&p.torques) {
                            prop_assert!(now.abs() <= before.abs() + 1e-6);
                        }
                    }
                }
                previous = Some(r);
            }
        }
    }
}

#[test]
fn a_method_is_selected_only_while_disabled() {
    let min_2_norm = Method::Min2Norm.wire_id();
    assert_eq!(Method::from_wire_id(min_2_norm).unwrap(), Method::Min2Norm);

    // Enabled: refused, the barycenter stays.
    let (mut rig, barycenter) = Rig::enabled();
    rig.send(HostMessage::SelectMethod(min_2_norm));
    rig.send(HostMessage::TelemetryPeriod(1));
    rig.send(HostMessage::Setpoint(low(2)));
    let t = rig.step().telemetry.unwrap();
    assert_eq!(t.method, Method::Barycenter.wire_id());
    assert_eq!(rig.control.counters().rejected_state, 1);

    // Disabled: granted; an unknown number is out of range.
    let mut rig = Rig::new();
    rig.send(HostMessage::SelectMethod(Method::ALL.len() as u8));
    assert_eq!(rig.control.counters().rejected_range, 1);
    rig.send(HostMessage::SelectMethod(min_2_norm));
    rig.send(HostMessage::TelemetryPeriod(1));
    rig.send(HostMessage::Setpoint(low(1)));
    rig.send(HostMessage::Enable);
    let r = rig.step();
    assert_eq!((r.state, r.telemetry.unwrap().method), (State::Enabled, min_2_norm));
    // Minimum-norm tensions: no larger in norm than the barycenter's (which
    // is feasible too), and not the same point.
    let norm = |t: &[f32; CABLES]| t.iter().map(|x| x * x).sum::<f32>();
    assert!(norm(&r.torques) <= norm(&barycenter), "{:?} vs {barycenter:?}", r.torques);
    assert!(!same(&r.torques, &barycenter));
}
