//! The link's rules against hostile streams (the issue's findings): the
//! sequence rule cannot be locked, setpoints that jump are rejected, the
//! receive work per cycle is bounded, methods over the budget are refused,
//! and bursts of commands take only the diagram's edges.

use crate::common;

use common::{low, IdealDrives};

use cdpr_control::protocol::{encode, HostMessage, Reason, Rejection, Setpoint, State, MAX_FRAME};
use cdpr_control::protocol::{FrameDecoder, LineFrame};
use cdpr_control::supervisor::SafetyLimits;
use cdpr_control::{ControlLoop, MethodSet, NoClock, SliceFrames, StepReport, FRAME_BUDGET, RECEIVE_BUDGET};
use tension_core::Method;

const LIMITS: SafetyLimits = SafetyLimits::DEFAULT;

/// Cycle `k` of a straight line at 1 m/s in x from the low pose.
fn moving(seq: u32, k: u32) -> Setpoint {
    common::moving_x(seq, k, 1.0)
}

fn bytes(message: &HostMessage) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let n = encode(message, &mut out).unwrap();
    out[..n].to_vec()
}

struct Rig {
    control: ControlLoop,
    drives: IdealDrives,
}

impl Rig {
    fn new() -> Self {
        let mut control =
            ControlLoop::new(common::suspended8(), Method::Barycenter, common::setpoint_range(), LIMITS)
                .unwrap();
        control.set_tracking_limit(None);
        let mut drives = IdealDrives { readings: common::readings_at(&control, low(0).pose) };
        common::home(&mut control, &mut drives, low(0).pose);
        Self { control, drives }
    }

    fn send(&mut self, message: HostMessage) {
        self.send_raw(&bytes(&message));
    }

    fn send_raw(&mut self, raw: &[u8]) {
        for &b in raw {
            self.control.receive_byte(b);
        }
    }

    fn step(&mut self) -> StepReport {
        common::follow(&self.control, &mut self.drives.readings);
        self.control.step(&NoClock, &mut self.drives, false)
    }

    /// Setpoint `seq`, Enable, one step: Enabled.
    fn enabled_at(seq: u32) -> Self {
        let mut rig = Self::new();
        rig.send(HostMessage::Setpoint(low(seq)));
        rig.send(HostMessage::Enable);
        assert_eq!(rig.step().state, State::Enabled);
        rig
    }

    /// Runs the ramp out (Disabled or Fault) with fresh setpoints of `seq`, `seq + 1`, ...
    fn wait_ramp(&mut self, seq: &mut u32) {
        for _ in 0..=LIMITS.ramp_cycles {
            *seq += 1;
            self.send(HostMessage::Setpoint(low(*seq)));
            self.step();
        }
    }
}

/// The issue's frame: a setpoint with seq 0xFFFFFFFF, x NaN, z 1.8, the
/// rest zero (between the head and the CRC 59 bytes `01`: the count whose
/// payload has the frame's CRC `4daafacc`).
const POISON: [u8; 84] = {
    let head = [
        0x01, 0x06, 0xff, 0xff, 0xff, 0xff, 0x0f, 0x01, 0x03, 0xc0, 0x7f, 0x01, 0x01, 0x01, 0x05, 0x66, 0x66,
        0xe6, 0x3f,
    ];
    let tail = [0x05, 0xcc, 0xfa, 0xaa, 0x4d, 0x00];
    let mut out = [0x01u8; 84];
    let mut i = 0;
    while i < head.len() {
        out[i] = head[i];
        i += 1;
    }
    let mut j = 0;
    while j < tail.len() {
        out[78 + j] = tail[j];
        j += 1;
    }
    out
};

#[test]
fn the_issues_frame_is_rejected_and_does_not_lock_the_link() {
    let mut rig = Rig::new();
    rig.send_raw(&POISON);
    let c = *rig.control.counters();
    assert_eq!(
        (c.rejected_range, c.rejected_crc, c.rejected_framing, c.rejected_decode),
        (1, 0, 0, 0),
        "{c:?}"
    );
    assert_eq!(c.last_rejection, Rejection::Range);
    rig.step();
    // The host goes on from 1: accepted, and Enable is granted.
    rig.send(HostMessage::Setpoint(low(1)));
    rig.send(HostMessage::Enable);
    assert_eq!(rig.step().state, State::Enabled);
    assert_eq!(rig.control.counters().rejected_order, 0);
}

#[test]
fn a_rejected_setpoint_never_moves_the_sequence() {
    let mut rig = Rig::enabled_at(10);
    // Out of range, with a far-ahead number, while bound: rejected, and
    // the next in-order number is still accepted.
    let mut bad = low(1_000_000);
    bad.pose[0] = f32::INFINITY;
    rig.send(HostMessage::Setpoint(bad));
    rig.send(HostMessage::Setpoint(low(11)));
    let r = rig.step();
    assert_eq!((r.state, rig.control.newest_setpoint().map(|s| s.seq)), (State::Enabled, Some(11)));
    assert_eq!(rig.control.counters().rejected_order, 0);
}

#[test]
fn a_host_may_restart_its_numbering_while_disabled() {
    let mut rig = Rig::new();
    for seq in 995..=1000 {
        rig.send(HostMessage::Setpoint(low(seq)));
        rig.step();
    }
    // A new host session from 1, still disabled.
    rig.send(HostMessage::Setpoint(low(1)));
    rig.send(HostMessage::Enable);
    assert_eq!(rig.step().state, State::Enabled);
    assert_eq!(rig.control.counters().rejected_order, 0);
    assert_eq!(rig.control.newest_setpoint().unwrap().seq, 1);
}

#[test]
fn disable_restarts_the_numbering_at_once_and_clear_fault_path_too() {
    let mut rig = Rig::enabled_at(500);
    // Disable and a renumbered setpoint in one burst.
    rig.send(HostMessage::Disable);
    rig.send(HostMessage::Setpoint(low(1)));
    assert_eq!(rig.step().state, State::Disabled);
    assert_eq!(rig.control.counters().rejected_order, 0);
    let mut seq = 1;
    rig.wait_ramp(&mut seq);
    rig.send(HostMessage::Enable);
    assert_eq!(rig.step().state, State::Enabled);

    // Fault (overruns), then a host that starts again from 1: accepted in
    // Fault and after ClearFault.
    for _ in 0..LIMITS.overrun_limit {
        rig.control.step(&NoClock, &mut rig.drives, true);
    }
    assert_eq!(rig.control.supervisor().state(), State::Fault);
    let mut seq = 0;
    rig.wait_ramp(&mut seq);
    rig.send(HostMessage::ClearFault);
    assert_eq!(rig.step().state, State::Disabled);
    rig.send(HostMessage::Setpoint(low(1)));
    rig.send(HostMessage::Enable);
    assert_eq!(rig.step().state, State::Enabled);
    assert_eq!(rig.control.counters().rejected_order, 0);
}

#[test]
fn numbering_runs_through_the_u32_wrap() {
    let start = u32::MAX - 20;
    let mut rig = Rig::enabled_at(start);
    for i in 1..=40u32 {
        rig.send(HostMessage::Setpoint(low(start.wrapping_add(i))));
        let r = rig.step();
        assert_eq!(r.state, State::Enabled, "seq {}", start.wrapping_add(i));
    }
    assert_eq!(rig.control.counters().rejected_order, 0);
    assert_eq!(rig.control.newest_setpoint().unwrap().seq, 19);
    // Behind by half the number space or less: still out of order.
    rig.send(HostMessage::Setpoint(low(u32::MAX - 5)));
    rig.send(HostMessage::Setpoint(low(19)));
    rig.step();
    assert_eq!(rig.control.counters().rejected_order, 2);
    assert!(cdpr_control::link::newer(0, u32::MAX) && !cdpr_control::link::newer(u32::MAX, 0));
    assert!(!cdpr_control::link::newer(5, 5) && !cdpr_control::link::newer(5 + (1 << 31), 5));
}

#[test]
fn a_jump_that_its_velocity_does_not_explain_is_rejected() {
    let mut rig = Rig::enabled_at(1);
    // A stream at 1 m/s, one setpoint a cycle, sometimes two in a cycle
    // and sometimes one late: accepted.
    let mut seq = 1;
    let mut k = 0;
    for cycle in 0..200u32 {
        let per_cycle = match cycle % 10 {
            3 => 2,
            7 => 0,
            _ => 1,
        };
        for _ in 0..per_cycle {
            seq += 1;
            k += 1;
            rig.send(HostMessage::Setpoint(moving(seq, k)));
        }
        if cycle % 10 == 7 {
            k += 1; // one the host never sent
        }
        assert_eq!(rig.step().state, State::Enabled, "cycle {cycle}");
    }
    assert_eq!(rig.control.counters().rejected_jump, 0);
    let last = *rig.control.newest_setpoint().unwrap();

    // The issue's case: 1.1 m away with zero velocity.
    let mut jump = low(seq + 1);
    jump.pose[0] = last.pose[0] + 1.1;
    rig.send(HostMessage::Setpoint(jump));
    let r = rig.step();
    assert_eq!((r.state, r.reason), (State::Holding, Reason::BadSetpoint));
    let c = rig.control.counters();
    assert_eq!((c.rejected_jump, c.last_rejection), (1, Rejection::Jump));
    assert!(rig.control.newest_setpoint().is_none(), "its values are never used");
    // The reference did not move: the stream's next setpoint is accepted.
    rig.send(HostMessage::Setpoint(moving(seq + 2, k + 2)));
    assert_eq!(rig.step().state, State::Enabled);

    // Far, with a velocity that would need 0.35 s to get there: a jump.
    let mut fake = moving(seq + 3, k + 3);
    fake.pose[0] += 1.1;
    fake.velocity[0] = 5.0;
    rig.send(HostMessage::Setpoint(fake));
    assert_eq!(rig.step().reason, Reason::BadSetpoint);
    assert_eq!(rig.control.counters().rejected_jump, 2);
    rig.send(HostMessage::Setpoint(moving(seq + 4, k + 4)));
    assert_eq!(rig.step().state, State::Enabled);
    let (seq, k) = (seq + 2, k + 2);

    // An angle jump too (0.3 rad with no rate).
    let mut turn = moving(seq + 3, k + 3);
    turn.pose[5] = 0.3;
    rig.send(HostMessage::Setpoint(turn));
    assert_eq!(rig.step().reason, Reason::BadSetpoint);
    assert_eq!(rig.control.counters().rejected_jump, 3);
}

#[test]
fn a_stream_that_pauses_and_resumes_where_it_stopped_is_no_jump() {
    let mut rig = Rig::enabled_at(1);
    for k in 1..=20 {
        rig.send(HostMessage::Setpoint(moving(k + 1, k)));
        rig.step();
    }
    // 60 cycles of silence: Holding (stale) after 50.
    for _ in 0..60 {
        rig.step();
    }
    assert_eq!(rig.control.supervisor().state(), State::Holding);
    // The host resumes from the next point of its path (its time paused
    // too), and a host that kept its clock running would be accepted as
    // well (that is what the late setpoint of the other test checks).
    rig.send(HostMessage::Setpoint(moving(22, 21)));
    assert_eq!(rig.step().state, State::Enabled);
    assert_eq!(rig.control.counters().rejected_jump, 0);
}

#[test]
fn jumps_are_free_while_disabled() {
    let mut rig = Rig::new();
    rig.send(HostMessage::Setpoint(low(1)));
    rig.step();
    let mut far = low(2);
    far.pose[0] = 0.8;
    rig.send(HostMessage::Setpoint(far));
    rig.send(HostMessage::Enable);
    assert_eq!(rig.step().state, State::Enabled);
    assert_eq!(rig.control.counters().rejected_jump, 0);
}

#[test]
fn the_receive_work_per_cycle_is_bounded() {
    let mut rig = Rig::enabled_at(1);
    // A flood: back-to-back valid setpoints, zero bytes, oversize 0xFF runs
    // and pseudo-random bytes, far more than one cycle's budget.
    let mut flood = Vec::new();
    for seq in 2..40 {
        flood.extend(bytes(&HostMessage::Setpoint(low(seq))));
    }
    flood.extend([0u8; 3000]);
    flood.extend([0xFFu8; 3000]);
    let mut x = 0x1234_5678u32;
    for _ in 0..3000 {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        flood.push(x as u8);
    }
    let mut at = 0;
    let mut cycles = 0;
    while at < flood.len() {
        let taken = rig.control.receive_bytes(|| {
            let b = flood.get(at).copied();
            at += usize::from(b.is_some());
            b
        });
        assert!(taken <= RECEIVE_BUDGET);
        assert_eq!(taken, RECEIVE_BUDGET.min(flood.len() - (at - taken)));
        let r = rig.step();
        assert_ne!(r.state, State::Fault);
        cycles += 1;
    }
    assert_eq!(cycles, flood.len().div_ceil(RECEIVE_BUDGET));
    // The valid setpoints went through.
    assert!(rig.control.counters().accepted >= 2 + 38);
}

/// The same flood as reassembled frames (the board's receive interrupt
/// does the framing): at most `FRAME_BUDGET` a cycle, the rest left for
/// the next, and the same counters as the flood's bytes one by one.
#[test]
fn the_frames_per_cycle_are_bounded_and_judged_as_their_bytes() {
    let mut flood = Vec::new();
    for seq in 2..40 {
        flood.extend(bytes(&HostMessage::Setpoint(low(seq))));
        if seq % 5 == 0 {
            // A CRC error, a framing error, an oversize frame.
            let mut bad = bytes(&HostMessage::Setpoint(low(seq)));
            bad[10] ^= 0x40;
            flood.extend(bad);
            flood.extend([0x05, 0x01, 0x02, 0x00]);
            flood.extend([0x11u8; 400]);
            flood.push(0);
        }
    }
    let mut frames: Vec<LineFrame> = Vec::new();
    let mut decoder = FrameDecoder::new();
    for &b in &flood {
        if decoder.push_byte(b) {
            frames.extend(decoder.finish_line());
        }
    }
    let mut by_frames = Rig::enabled_at(1);
    let mut source = SliceFrames::new(&frames);
    let mut cycles = 0;
    while source.remaining() > 0 {
        let before = source.remaining();
        let taken = by_frames.control.receive_frames(&mut source);
        assert_eq!(taken, FRAME_BUDGET.min(before));
        assert_eq!(source.remaining(), before - taken);
        assert_ne!(by_frames.step().state, State::Fault);
        cycles += 1;
    }
    assert_eq!(cycles, frames.len().div_ceil(FRAME_BUDGET));
    let mut by_bytes = Rig::enabled_at(1);
    by_bytes.send_raw(&flood);
    let (f, b) = (*by_frames.control.counters(), *by_bytes.control.counters());
    // Home, the first setpoint and Enable, then the 38 good setpoints.
    assert_eq!(f.accepted, 3 + 38, "{f:?}");
    assert!(f.rejected_crc >= 7 && f.rejected_framing >= 7, "{f:?}");
    assert_eq!(
        (f.accepted, f.rejected_crc, f.rejected_framing, f.rejected_decode, f.rejected_order),
        (b.accepted, b.rejected_crc, b.rejected_framing, b.rejected_decode, b.rejected_order)
    );
}

#[test]
fn a_method_the_board_does_not_offer_is_refused_with_its_reason() {
    let mut rig = Rig::new();
    rig.control.offer_only(MethodSet::EMPTY.with(Method::Barycenter).with(Method::Puncture));
    rig.send(HostMessage::SelectMethod(Method::OptimallySafe.wire_id()));
    let c = *rig.control.counters();
    assert_eq!((c.rejected_method, c.rejected_state, c.last_rejection), (1, 0, Rejection::MethodOverBudget));
    rig.send(HostMessage::TelemetryPeriod(1));
    rig.send(HostMessage::Setpoint(low(1)));
    let t = rig.step().telemetry.unwrap();
    assert_eq!(t.method, Method::Barycenter.wire_id());
    assert_eq!(t.counters.rejected_method, 1);
    // An offered one is granted.
    rig.send(HostMessage::SelectMethod(Method::Puncture.wire_id()));
    rig.send(HostMessage::Setpoint(low(2)));
    assert_eq!(rig.step().telemetry.unwrap().method, Method::Puncture.wire_id());
    assert_eq!(rig.control.counters().rejected_method, 1);
}

/// The edges of the diagram (supervisor.rs, firmware README).
fn is_edge(from: State, to: State) -> bool {
    use State::*;
    from == to
        || matches!(
            (from, to),
            (Disabled, Enabled)
                | (Enabled, Disabled)
                | (Holding, Disabled)
                | (Enabled, Holding)
                | (Holding, Enabled)
                | (Holding, Fault)
                | (Enabled, Fault)
                | (Fault, Disabled)
        )
}

#[test]
fn bursts_of_any_two_commands_take_one_edge_of_the_diagram() {
    let commands = [HostMessage::Enable, HostMessage::Disable, HostMessage::ClearFault];
    // Each starting state, after any ramp has finished.
    let start = |state: State| -> (Rig, u32) {
        let mut rig = Rig::enabled_at(1);
        let mut seq = 1;
        match state {
            State::Enabled => {}
            State::Holding => {
                let mut nan = low(2);
                nan.pose[0] = f32::NAN;
                rig.send(HostMessage::Setpoint(nan));
                assert_eq!(rig.step().state, State::Holding);
                seq = 2;
            }
            State::Disabled => {
                rig.send(HostMessage::Disable);
                rig.step();
                rig.wait_ramp(&mut seq);
            }
            State::Fault => {
                for _ in 0..LIMITS.overrun_limit {
                    rig.control.step(&NoClock, &mut rig.drives, true);
                }
                rig.wait_ramp(&mut seq);
            }
        }
        assert_eq!(rig.control.supervisor().state(), state);
        (rig, seq)
    };
    for state in [State::Disabled, State::Enabled, State::Holding, State::Fault] {
        for a in commands {
            for b in commands {
                let (mut rig, seq) = start(state);
                if state != State::Holding {
                    rig.send(HostMessage::Setpoint(low(seq + 1)));
                }
                rig.send(a);
                rig.send(b);
                let mut before = state;
                for j in 0..3 {
                    let r = rig.step();
                    assert!(
                        is_edge(before, r.state),
                        "{state:?} + {a:?}, {b:?}: cycle {j} {before:?} -> {:?}",
                        r.state
                    );
                    before = r.state;
                }
                // From Fault, ClearFault and Enable together: Disabled first.
                if state == State::Fault && [a, b].contains(&HostMessage::ClearFault) {
                    assert_ne!(before, State::Enabled, "{a:?}, {b:?}");
                }
            }
        }
    }
}

#[test]
fn clear_fault_and_enable_in_one_burst_show_disabled_and_restart_the_numbering() {
    let mut rig = Rig::enabled_at(1000);
    for _ in 0..LIMITS.overrun_limit {
        rig.control.step(&NoClock, &mut rig.drives, true);
    }
    let mut seq = 1000;
    rig.wait_ramp(&mut seq);
    rig.send(HostMessage::Setpoint(low(1)));
    rig.send(HostMessage::ClearFault);
    rig.send(HostMessage::Enable);
    assert_eq!(rig.step().state, State::Disabled);
    assert_eq!(rig.control.counters().rejected_state, 1, "the Enable of the same burst");
    // Renumbered from 1 in Fault: accepted; Enable now is granted.
    rig.send(HostMessage::Setpoint(low(2)));
    rig.send(HostMessage::Enable);
    assert_eq!(rig.step().state, State::Enabled);
    assert_eq!(rig.control.counters().rejected_order, 0);
}
