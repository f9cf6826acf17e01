//! One winch drive as the board sees it: its start-up (boot-up, the SDO
//! configuration of [`crate::config::configuration`], NMT start), its CiA
//! 402 state driven towards what the board wants, its cyclic data
//! (position from TPDO1, statusword from TPDO2) and the faults it can
//! show. Time is counted in control cycles; every wait has its timeout
//! ([`Timing`]).

use canopen_rs::emcy::EmergencyMessage;
use canopen_rs::sdo::{SdoClient, SdoEvent};
use canopen_rs::{Address, DataType, NodeId, Value};
use cdpr_control::protocol::DriveFaultCause;

use crate::cia402::{controlword, step_towards, DriveState, Target};
use crate::config::{
    configuration, ConfigStep, DriveConfig, Timing, CONFIG_OBJECTS, CONFIG_STEPS, TORQUE_MODE,
};
use crate::frame::{RawFrame, EMCY, HEARTBEAT, NMT, RPDO1, RPDO2, SDO_REQUEST, SDO_RESPONSE, TPDO1, TPDO2};

/// Where a drive's start-up is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Waiting for its boot-up (or a pre-operational heartbeat) after the
    /// board's NMT reset.
    WaitBoot,
    /// Writing its configuration by SDO (the step's index).
    Configure(u8),
    /// NMT start sent; waiting for "operational".
    Start,
    /// Operational: PDOs flow.
    Operational,
}

/// Frames to send, in order (a bounded list: a node sends at most two per
/// call, a bus at most [`Outbox::CAPACITY`]).
#[derive(Debug, Clone, Copy)]
pub struct Outbox {
    frames: [RawFrame; Outbox::CAPACITY],
    len: usize,
    /// Frames that did not fit (an error of the caller's bookkeeping; the
    /// bus reports it as a transmit failure).
    pub overflowed: u32,
}

impl Outbox {
    /// Frames an outbox holds: a bus's 4 drives' RPDO1 and RPDO2 and the
    /// SYNC, or its start-up frames, with room to spare.
    pub const CAPACITY: usize = 24;

    /// Empty.
    pub const fn new() -> Self {
        Self { frames: [RawFrame { id: 0, len: 0, data: [0; 8] }; Self::CAPACITY], len: 0, overflowed: 0 }
    }

    /// Appends `frame` (counted in `overflowed` if full).
    pub fn push(&mut self, frame: RawFrame) {
        if self.len < Self::CAPACITY {
            self.frames[self.len] = frame;
            self.len += 1;
        } else {
            self.overflowed = self.overflowed.wrapping_add(1);
        }
    }

    /// The frames, in order.
    pub fn frames(&self) -> &[RawFrame] {
        &self.frames[..self.len]
    }

    /// Empties it.
    pub fn clear(&mut self) {
        self.len = 0;
        self.overflowed = 0;
    }
}

impl Default for Outbox {
    fn default() -> Self {
        Self::new()
    }
}

/// What a received frame was to its node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Received {
    /// Used.
    Used,
    /// Wrong length, or unexpected in this stage (an SDO response nobody
    /// asked for): counted and dropped.
    Garbage,
}

/// One drive.
#[derive(Debug)]
pub struct Node {
    config: DriveConfig,
    /// Thousandths of the rated torque per N m, and the largest magnitude
    /// (0x6072), for the cyclic target torque.
    permille_per_nm: f32,
    permille_max: f32,
    timing: Timing,
    stage: Stage,
    /// The cycle the stage, or the pending SDO, started.
    since: u32,
    sdo: Option<SdoClient>,
    sdo_pending: bool,
    sdo_retried: bool,
    fault: Option<(DriveFaultCause, u32)>,
    statusword: Option<u16>,
    /// The state `statusword` shows, decoded once when it arrives.
    state: Option<DriveState>,
    position: Option<i32>,
    /// The position of the last fresh TPDO1 and the cycles since it.
    speed_from: Option<(i32, u32)>,
    speed: i32,
    pdo_fresh: bool,
    sync_sent: bool,
    missed: u32,
    last_heartbeat: u32,
    target: Target,
    controlword: u16,
    transition: Option<(DriveState, u32)>,
    reached_operate: bool,
    fault_reset: bool,
    boots: u8,
    /// The values the configuration's reads took: the mode display 0x6061
    /// and the rated torque 0x6076 (a second answer that differs
    /// contradicts them: [`Node::contradiction`]).
    mode_read: Option<u32>,
    rated_read: Option<u32>,
}

/// Boot-ups a drive may send while being configured before it counts as
/// resetting by itself (a heartbeat fault).
const MAX_BOOTS: u8 = 3;

impl Node {
    /// A drive waiting for its boot-up since cycle `now`.
    pub fn new(config: DriveConfig, timing: Timing, now: u32) -> Self {
        Self {
            permille_per_nm: config.permille_per_nm(),
            permille_max: f32::from(config.max_torque_permille()),
            sdo: NodeId::new(config.node).ok().map(SdoClient::new),
            config,
            timing,
            stage: Stage::WaitBoot,
            since: now,
            sdo_pending: false,
            sdo_retried: false,
            fault: None,
            statusword: None,
            state: None,
            position: None,
            speed_from: None,
            speed: 0,
            pdo_fresh: false,
            sync_sent: false,
            missed: 0,
            last_heartbeat: now,
            target: Target::Hold,
            controlword: controlword::DISABLE_VOLTAGE,
            transition: None,
            reached_operate: false,
            fault_reset: false,
            boots: 0,
            mode_read: None,
            rated_read: None,
        }
    }

    /// The drive's configuration.
    pub fn config(&self) -> &DriveConfig {
        &self.config
    }

    /// Configuration step `i` (built when asked for: start-up only, and
    /// the node stays small: eight of them live on the board).
    fn config_step(&self, i: u8) -> Option<ConfigStep> {
        let steps: [ConfigStep; CONFIG_STEPS] = configuration(&self.config, &self.timing);
        steps.get(usize::from(i)).copied()
    }

    /// The layer's timing.
    pub fn timing(&self) -> &Timing {
        &self.timing
    }

    /// Its start-up stage.
    pub fn stage(&self) -> Stage {
        self.stage
    }

    /// Its latched fault: the cause and its code.
    pub fn fault(&self) -> Option<(DriveFaultCause, u32)> {
        self.fault
    }

    /// Its CiA 402 state, once a statusword came.
    pub fn state(&self) -> Option<DriveState> {
        self.state
    }

    /// The last statusword.
    pub fn statusword(&self) -> Option<u16> {
        self.statusword
    }

    /// Whether its reading is good: operational, no fault, a position and
    /// a statusword in "switched on" or "operation enabled".
    pub fn ready(&self) -> bool {
        matches!(self.stage, Stage::Operational)
            && self.fault.is_none()
            && self.position.is_some()
            && matches!(self.state(), Some(DriveState::SwitchedOn | DriveState::OperationEnabled))
    }

    /// Position actual (counts) and the speed from the positions (counts
    /// per second), once a position came. A position whose TPDO1 missed
    /// the last `missed` SYNCs' reads (a burst of heartbeats can push the
    /// last drive's past the next read) is extrapolated at that speed,
    /// `p + speed missed / cycle_hz`: the reader sees where the motor
    /// is, not a count frozen for a cycle and then jumping two (which a
    /// derivative term turns into a kick). At most `missing_pdo_cycles - 1`
    /// cycles: then the drive faults (`MissingPdo`).
    pub fn reading(&self) -> Option<(i32, i32)> {
        let p = self.position?;
        if self.missed == 0 {
            return Some((p, self.speed));
        }
        let hz = self.timing.cycle_hz.clamp(1, i32::MAX as u32) as i32;
        let missed = self.missed.min(self.timing.missing_pdo_cycles) as i32;
        Some((p.wrapping_add((self.speed / hz).wrapping_mul(missed)), self.speed))
    }

    fn latch(&mut self, cause: DriveFaultCause, code: u32) {
        if self.fault.is_none() {
            self.fault = Some((cause, code));
        }
    }

    /// A frame whose COB-ID names this drive (`function` is the COB-ID's
    /// function code, `id & 0x780`; `data` its data bytes), received in
    /// cycle `now`.
    pub fn on_frame(&mut self, function: u16, data: &[u8], now: u32) -> Received {
        match (function, data.len()) {
            (EMCY, 8) => {
                if let Ok(m) = EmergencyMessage::decode(data) {
                    if !m.is_error_reset() {
                        self.latch(DriveFaultCause::Emergency, u32::from(m.error_code));
                    }
                }
                Received::Used
            }
            (TPDO1, 4) => {
                self.position = Some(i32::from_le_bytes([data[0], data[1], data[2], data[3]]));
                self.pdo_fresh = true;
                if matches!(self.stage, Stage::Start) {
                    self.enter_operational(now);
                }
                Received::Used
            }
            (TPDO2, 2) => {
                let sw = u16::from_le_bytes([data[0], data[1]]);
                self.statusword = Some(sw);
                self.state = Some(DriveState::of_statusword(sw));
                Received::Used
            }
            (SDO_RESPONSE, 8) => {
                let mut payload = [0u8; 8];
                payload.copy_from_slice(data);
                if self.sdo_pending {
                    self.on_sdo_response(&payload, now)
                } else {
                    self.on_other_answer(&payload)
                }
            }
            (HEARTBEAT, 1) => {
                self.on_heartbeat(data[0] & 0x7F, now);
                Received::Used
            }
            _ => Received::Garbage,
        }
    }

    fn on_heartbeat(&mut self, state: u8, now: u32) {
        self.last_heartbeat = now;
        match (self.stage, state) {
            // Boot-up, or already pre-operational (booted before the board).
            (Stage::WaitBoot, 0x00 | 0x7F) => self.enter(Stage::Configure(0), now),
            (Stage::WaitBoot, _) => {}
            (Stage::Start, 0x05) => self.enter_operational(now),
            (Stage::Configure(_) | Stage::Start, 0x7F) => {}
            // A boot-up before it runs: the drive reset (e.g. the board's
            // NMT reset crossed its power-on boot-up); its communication
            // objects are the defaults again, so configure from the start,
            // a few times at most.
            (Stage::Configure(_) | Stage::Start, 0x00) if self.boots < MAX_BOOTS => {
                self.boots += 1;
                self.sdo_pending = false;
                self.sdo_retried = false;
                self.enter(Stage::Configure(0), now);
            }
            (Stage::Operational, 0x05) => {}
            // Boot-up (a reset drive) or another state mid-configuration
            // or operation: the drive is not what was configured.
            (_, s) => self.latch(DriveFaultCause::Heartbeat, u32::from(s)),
        }
    }

    /// The answer to the pending request. An answer (or abort) for another
    /// object than the one asked for is not this request's: the late
    /// answer to a request sent again after its timeout (both arrive), or
    /// a stranger on the channel. It is dropped (garbage) and the request
    /// waits on: taken, it would complete a write the drive never
    /// acknowledged (`canopen-rs`'s client does not compare the
    /// multiplexer, which CiA 301 puts in every answer, bytes 1-3).
    fn on_sdo_response(&mut self, payload: &[u8; 8], now: u32) -> Received {
        let Stage::Configure(step) = self.stage else { return self.on_other_answer(payload) };
        let Some(&asked) = CONFIG_OBJECTS.get(usize::from(step)) else {
            return self.on_other_answer(payload);
        };
        if (u16::from_le_bytes([payload[1], payload[2]]), payload[3]) != asked {
            return self.on_other_answer(payload);
        }
        let current = self.config_step(step);
        let Some(client) = &mut self.sdo else { return Received::Garbage };
        self.sdo_pending = false;
        match client.on_response(payload) {
            SdoEvent::Complete(value) => {
                if current == Some(ConfigStep::CheckRatedTorque) {
                    let expected = self.config.rated_torque * 1000.0;
                    let matches = match value {
                        Some(Value::Unsigned32(mnm)) => {
                            self.rated_read = Some(mnm);
                            libm::fabsf(mnm as f32 - expected) <= 0.005 * expected
                        }
                        _ => false,
                    };
                    if !matches {
                        self.latch(DriveFaultCause::Configuration, 0x6076);
                        return Received::Used;
                    }
                }
                if current == Some(ConfigStep::CheckMode) {
                    let mode = match value {
                        Some(Value::Integer8(m)) => Some(m as u8),
                        Some(Value::Unsigned8(m)) => Some(m),
                        _ => None,
                    };
                    self.mode_read = mode.map(u32::from);
                    if mode != Some(TORQUE_MODE) {
                        self.latch(DriveFaultCause::Configuration, 0x6061);
                        return Received::Used;
                    }
                }
                self.sdo_retried = false;
                self.enter(Stage::Configure(step.saturating_add(1)), now);
            }
            SdoEvent::Aborted(code) => self.latch(DriveFaultCause::Configuration, code),
            // Only expedited transfers are used: a segmented answer is not
            // what was asked for.
            SdoEvent::Send(_) => self.latch(DriveFaultCause::Configuration, 0x0800_0000),
        }
        Received::Used
    }

    /// An answer that is not the pending request's: garbage, unless it
    /// contradicts the configuration ([`Node::contradiction`]), which
    /// then did not take: a configuration fault with the abort code (or
    /// the object read).
    fn on_other_answer(&mut self, payload: &[u8; 8]) -> Received {
        match self.contradiction(payload) {
            Some(code) => {
                self.latch(DriveFaultCause::Configuration, code);
                Received::Used
            }
            None => Received::Garbage,
        }
    }

    /// Whether `payload`, an answer that completes no pending request,
    /// says the configuration did not take: an abort of an object the
    /// configuration has already written or read (the code), or a read's
    /// answer with another value than the one taken (the object's index).
    /// Each request has one answer: a second one that differs is the
    /// drive's own, late behind a stranger's that completed the step (or
    /// a second drive at this node id). A duplicate of what was taken is
    /// not.
    fn contradiction(&self, payload: &[u8; 8]) -> Option<u32> {
        // An abort (0x80) or an expedited upload's answer with its size
        // (0x43, 0x47, 0x4B, 0x4F for 4, 3, 2, 1 bytes); anything else
        // (an acknowledgement) cannot contradict.
        let abort = payload[0] == 0x80;
        if !abort && payload[0] & 0xF3 != 0x43 {
            return None;
        }
        let object = (u16::from_le_bytes([payload[1], payload[2]]), payload[3]);
        let done = match self.stage {
            Stage::WaitBoot => 0,
            Stage::Configure(step) => usize::from(step),
            Stage::Start | Stage::Operational => CONFIG_STEPS,
        };
        // One look-up in the table of the steps' objects.
        CONFIG_OBJECTS.get(..done)?.iter().find(|&&o| o == object)?;
        let word = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        if abort {
            return Some(word(&payload[4..8]));
        }
        let bytes = 4 - usize::from((payload[0] >> 2) & 3);
        let mut value = [0u8; 4];
        value[..bytes].copy_from_slice(&payload[4..4 + bytes]);
        let taken = match object {
            (0x6061, 0) => self.mode_read,
            (0x6076, 0) => self.rated_read,
            // An upload's answer for a written object: not a read the
            // configuration made.
            _ => return None,
        };
        (taken != Some(word(&value))).then_some(u32::from(object.0))
    }

    fn enter(&mut self, stage: Stage, now: u32) {
        self.stage = stage;
        self.since = now;
    }

    fn enter_operational(&mut self, now: u32) {
        self.enter(Stage::Operational, now);
        self.last_heartbeat = now;
        self.missed = 0;
    }

    /// The cycle's checks and start-up frames, after the cycle's frames
    /// were received (`now` is the cycle).
    pub fn poll(&mut self, now: u32, out: &mut Outbox) {
        // The positions of the SYNC sent last cycle.
        if matches!(self.stage, Stage::Operational) && self.sync_sent {
            self.sync_sent = false;
            if self.pdo_fresh {
                if let (Some(p), Some((from, cycles))) = (self.position, self.speed_from) {
                    // In 32 bits while the product fits (always, for a
                    // real encoder at 1 kHz: 2^31 counts a second), in 64
                    // and saturated otherwise; one cycle apart (the rule):
                    // no division.
                    let counts = p.wrapping_sub(from);
                    let cycles = cycles.clamp(1, i32::MAX as u32);
                    self.speed = match i32::try_from(self.timing.cycle_hz)
                        .ok()
                        .and_then(|hz| counts.checked_mul(hz))
                    {
                        Some(v) if cycles == 1 => v,
                        Some(v) => v / cycles as i32,
                        None => {
                            let s = i64::from(counts) * i64::from(self.timing.cycle_hz) / i64::from(cycles);
                            s.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
                        }
                    };
                }
                self.speed_from = self.position.map(|p| (p, 1));
                self.missed = 0;
            } else {
                self.missed += 1;
                if let Some((_, c)) = &mut self.speed_from {
                    *c = c.saturating_add(1);
                }
                if self.missed >= self.timing.missing_pdo_cycles {
                    self.latch(DriveFaultCause::MissingPdo, self.missed);
                }
            }
        }
        self.pdo_fresh = false;
        if self.fault.is_some() {
            return;
        }
        let elapsed = now.wrapping_sub(self.since);
        match self.stage {
            Stage::WaitBoot if elapsed > self.timing.boot_cycles => self.latch(DriveFaultCause::NoAnswer, 0),
            Stage::WaitBoot => {}
            Stage::Configure(step) => match self.config_step(step) {
                None => {
                    out.push(RawFrame::new(NMT, &[0x01, self.config.node]));
                    self.enter(Stage::Start, now);
                }
                Some(s) if !self.sdo_pending => self.send_sdo(s, now, out),
                Some(s) if elapsed > self.timing.sdo_cycles && !self.sdo_retried => {
                    self.sdo_retried = true;
                    self.send_sdo(s, now, out);
                }
                Some(s) if elapsed > self.timing.sdo_cycles => {
                    self.latch(DriveFaultCause::NoAnswer, u32::from(s.object().0));
                }
                Some(_) => {}
            },
            Stage::Start if elapsed > self.timing.start_cycles => self.latch(DriveFaultCause::NoAnswer, 1),
            Stage::Start => {}
            Stage::Operational => self.check_operation(now),
        }
    }

    fn send_sdo(&mut self, step: ConfigStep, now: u32, out: &mut Outbox) {
        let Some(client) = &mut self.sdo else { return };
        let payload = match step {
            ConfigStep::Write { index, sub, size, value } => {
                let v = match size {
                    1 => Value::Unsigned8(value as u8),
                    2 => Value::Unsigned16(value as u16),
                    _ => Value::Unsigned32(value),
                };
                client.write(Address::new(index, sub), v)
            }
            ConfigStep::CheckMode => client.read(Address::new(0x6061, 0), DataType::Integer8),
            ConfigStep::CheckRatedTorque => client.read(Address::new(0x6076, 0), DataType::Unsigned32),
        };
        out.push(RawFrame::new(SDO_REQUEST + u16::from(self.config.node), &payload));
        self.sdo_pending = true;
        self.since = now;
    }

    fn check_operation(&mut self, now: u32) {
        if now.wrapping_sub(self.last_heartbeat) > self.timing.heartbeat_timeout_cycles {
            self.latch(DriveFaultCause::Heartbeat, 0xFFFF);
            return;
        }
        let (Some(sw), Some(state)) = (self.statusword, self.state()) else {
            // No statusword yet: the event timer sends one within its period.
            if now.wrapping_sub(self.since) > self.timing.transition_cycles {
                self.latch(DriveFaultCause::StateLost, 0xFFFF_FFFF);
            }
            return;
        };
        if state.is_fault()
            && !self.fault_reset
            && !matches!(self.transition, Some((DriveState::SwitchOnDisabled, _)))
        {
            self.latch(DriveFaultCause::StateFault, u32::from(sw));
            return;
        }
        if let Some((expected, since)) = self.transition {
            if state == expected {
                self.transition = None;
                if expected == DriveState::OperationEnabled {
                    self.reached_operate = true;
                }
            } else if now.wrapping_sub(since) > self.timing.transition_cycles {
                self.latch(DriveFaultCause::StateLost, u32::from(sw));
            }
        } else if self.target == Target::Operate
            && self.reached_operate
            && state != DriveState::OperationEnabled
        {
            self.latch(DriveFaultCause::StateLost, u32::from(sw));
        }
    }

    /// Where the board wants the drive ([`Target::Hold`]: brake engaged, no
    /// torque; [`Target::Operate`]: torque control).
    pub fn set_target(&mut self, target: Target) {
        if target == Target::Hold {
            self.reached_operate = false;
        }
        self.target = target;
    }

    /// The cycle's process data (`torque` N m) and the controlword when a
    /// transition is due, into `out`; whether the drive takes part in the
    /// bus's SYNC (it is starting or operational). `enables`: how many
    /// drives of the bus may still be sent "enable operation" this cycle
    /// (taken from when this one is; at zero its enabling waits for a later
    /// cycle, while every other transition, towards the brake or out of a
    /// fault, goes at once).
    pub fn cyclic(&mut self, torque: f32, now: u32, out: &mut Outbox, enables: &mut u8) -> bool {
        if !matches!(self.stage, Stage::Start | Stage::Operational) {
            return false;
        }
        let n = u16::from(self.config.node);
        if matches!(self.stage, Stage::Operational) && self.fault.is_none() {
            if let Some(state) = self.state() {
                let mut command = if self.fault_reset && state.is_fault() {
                    self.fault_reset = false;
                    // The bit's rising edge: the previous controlword had it clear.
                    Some((controlword::FAULT_RESET, DriveState::SwitchOnDisabled))
                } else if self.transition.is_none() {
                    step_towards(state, self.target)
                } else {
                    None
                };
                // Enabling paced: `enables` left for the bus this cycle.
                if matches!(command, Some((controlword::ENABLE_OPERATION, _))) {
                    match enables.checked_sub(1) {
                        Some(left) => *enables = left,
                        None => command = None,
                    }
                }
                if let Some((cw, expected)) = command {
                    self.controlword = cw;
                    self.transition = Some((expected, now));
                    out.push(RawFrame::new(RPDO2 + n, &cw.to_le_bytes()));
                }
            }
        }
        let commanded = if self.target == Target::Operate && self.fault.is_none() { torque } else { 0.0 };
        out.push(RawFrame::new(RPDO1 + n, &self.permille(commanded).to_le_bytes()));
        self.sync_sent = true;
        true
    }

    /// [`DriveConfig::permille`] with its constants computed once (no
    /// division, no `ceilf` in the cycle).
    fn permille(&self, torque: f32) -> i16 {
        crate::config::permille_of(torque, self.permille_per_nm, self.permille_max)
    }

    /// Clears the latched fault: a fault reset of the drive where its
    /// state machine faulted (EMCY, statusword), a restart from its NMT
    /// reset otherwise (it stopped answering, its bus went off, its
    /// configuration failed).
    pub fn clear_fault(&mut self, now: u32, out: &mut Outbox) {
        let Some((cause, _)) = self.fault.take() else { return };
        self.target = Target::Hold;
        self.reached_operate = false;
        self.transition = None;
        match cause {
            DriveFaultCause::Emergency | DriveFaultCause::StateFault | DriveFaultCause::StateLost
                if matches!(self.stage, Stage::Operational) =>
            {
                self.fault_reset = true;
            }
            _ => self.restart(now, out),
        }
    }

    /// An NMT reset of the drive and its start-up from the boot-up.
    pub fn restart(&mut self, now: u32, out: &mut Outbox) {
        out.push(RawFrame::new(NMT, &[0x81, self.config.node]));
        *self = Node::new(self.config, self.timing, now);
    }

    /// Latches a bus-off of the drive's bus (`code` is the bus, 1 or 2).
    pub fn bus_off(&mut self) {
        self.latch(DriveFaultCause::BusOff, u32::from(self.config.bus) + 1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cyclic path's precomputed conversion is `DriveConfig::permille`.
    #[test]
    fn the_cyclic_permille_is_the_configs() {
        let config = DriveConfig { bus: 0, node: 1, rated_torque: 0.64, torque_max: 2.5 };
        let node = Node::new(config, Timing::DEFAULT, 0);
        let mut checked = 0;
        for k in -40_000..=40_000 {
            let torque = k as f32 * 1e-4;
            assert_eq!(node.permille(torque), config.permille(torque), "{torque}");
            checked += 1;
        }
        for t in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -1e30] {
            assert_eq!(node.permille(t), config.permille(t), "{t}");
        }
        assert_eq!(checked, 80_001);
    }
}
