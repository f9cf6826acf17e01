//! The messages: what the host sends ([`HostMessage`]) and what the
//! firmware sends back ([`DeviceMessage`]). Sizes are fixed to the firmware's
//! robot: [`DOF`] degrees of freedom, [`CABLES`] cables.

use serde::{Deserialize, Serialize};

/// Degrees of freedom of a pose (conventions, "Poses": `[x, y, z, rx, ry, rz]`).
pub const DOF: usize = 6;
/// Cables of the firmware's robot.
pub const CABLES: usize = 8;

/// A pose setpoint with its first two time derivatives (conventions, "Poses":
/// metres and radians, XYZ Euler angles; derivatives are the plain time
/// derivatives of those six numbers).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Setpoint {
    /// Sequence number. While the robot is Enabled or Holding each setpoint
    /// must be newer than the last accepted one in serial-number arithmetic
    /// (`seq - last`, wrapping, in `1..=2^31 - 1`; older ones are rejected as
    /// out of order); in Disabled and Fault, and after a `Disable`, any
    /// number starts the count afresh (see `cdpr-control`'s link layer).
    pub seq: u32,
    /// `[x, y, z, rx, ry, rz]`, m and rad.
    pub pose: [f32; DOF],
    /// Time derivative of `pose`, m/s and rad/s.
    pub velocity: [f32; DOF],
    /// Second time derivative of `pose`, m/s^2 and rad/s^2.
    pub acceleration: [f32; DOF],
}

/// A timed trajectory point for the board's buffer ([`HostMessage::Point`]):
/// the pose and its velocity at trajectory time `time_ms`. The board
/// interpolates between consecutive points with a cubic Hermite at every
/// control cycle (see `cdpr-control`'s `point_buffer`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrajectoryPoint {
    /// Trajectory time, ms (the stream's own clock: the board plays the
    /// stream's first point a fixed delay after it arrives and the others
    /// at their times from there; wraps like serial numbers).
    pub time_ms: u32,
    /// `[x, y, z, rx, ry, rz]`, m and rad.
    pub pose: [f32; DOF],
    /// Time derivative of `pose`, m/s and rad/s.
    pub velocity: [f32; DOF],
}

/// Host to firmware.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HostMessage {
    /// The newest pose setpoint (tag 0).
    Setpoint(Setpoint),
    /// Disabled -> enabled: start commanding torques (tag 1).
    Enable,
    /// Any state -> disabled: ramp the torques down and engage the brakes (tag 2).
    Disable,
    /// Fault -> disabled, once the fault ramp has finished (tag 3).
    ClearFault,
    /// Send telemetry every `period` control cycles; 0 stops it (tag 4).
    TelemetryPeriod(u16),
    /// Use this tension distribution method from now on (tag 5): its wire
    /// number `tension_core::Method::wire_id` (0 barycenter, 1 barycenter-brute,
    /// 2 analytic-centre, 3 closed-form, 4 improved-closed-form, 5 puncture,
    /// 6 improved-puncture, 7 min-2-norm, 8 min-1-norm, 9 optimally-safe).
    /// Accepted in Disabled only, and only for a method the receiver offers
    /// (the firmware: those whose worst case fits its step budget).
    SelectMethod(u8),
    /// "The platform is at this pose now" (tag 6): `[x, y, z, rx, ry, rz]`,
    /// m and rad. The receiver reads its winch encoders in the next cycle
    /// and sets each cable's offset so that the encoder lengths are the
    /// pose's inverse kinematics. Accepted in Disabled only (else
    /// [`Rejection::State`]); a non-finite pose or one outside the
    /// setpoint range is [`Rejection::Range`]; drives that cannot be read
    /// then are [`Rejection::Homing`]. `Enable` is refused until homed.
    Home([f32; DOF]),
    /// The feedback scheme from now on (tag 7): 0 feed-forward only (the
    /// default), 1 task-space PID on the estimated pose (its wrench added
    /// to the tension distribution's), 2 joint-space PD/PID on the cable
    /// lengths (added to the tension distribution's tensions). Accepted in
    /// Disabled only ([`Rejection::State`]); another number is
    /// [`Rejection::Range`].
    SelectFeedback(u8),
    /// "Which robot are you built for?" (tag 8): the receiver answers with
    /// [`DeviceMessage::Identity`] at its next cycle, in any state.
    Identify,
    /// A trajectory point for the board's buffer (tag 9): the link's
    /// budget (the firmware README) has room for points at 50-250 Hz, not
    /// for a [`HostMessage::Setpoint`] every millisecond. A point must be
    /// later than the one before it and not in the past of the buffer's
    /// play time ([`Rejection::Late`]), the buffer must have room
    /// ([`Rejection::BufferFull`]); a `Setpoint` empties the buffer.
    Point(TrajectoryPoint),
}

/// The safety state machine's states (see the firmware README's diagram).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum State {
    /// No torque commanded, brakes engaged (tag 0).
    Disabled,
    /// Tensions from the newest setpoint every cycle (tag 1).
    Enabled,
    /// The setpoint is unusable (infeasible, non-finite, out of range) or
    /// stale: the last feasible torques are held, for a bounded time (tag 2).
    Holding,
    /// Latched: torques ramp to zero with the brakes engaged, until
    /// `ClearFault` (tag 3).
    Fault,
}

/// Why the state machine is in [`State::Holding`] or [`State::Fault`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Reason {
    /// Nothing is wrong (tag 0).
    None,
    /// The setpoint's pose has no tensions within the limits (tag 1).
    Infeasible,
    /// The setpoint could not be used: non-finite, outside the allowed
    /// range, or the solver failed for another reason (tag 2).
    BadSetpoint,
    /// No setpoint frame for longer than the stale limit (tag 3).
    Stale,
    /// Holding lasted longer than the hold limit (tag 4). The reason that
    /// started the hold is in `Telemetry::hold_reason`.
    HoldTimeout,
    /// Deadline overruns past the threshold (tag 5).
    Overruns,
    /// The torque output reported an error (tag 6).
    Output,
    /// A measured cable length (winch encoder) departed from the length the
    /// setpoint asks for by more than the tracking limit: a broken or
    /// slipping cable, or a winch that cannot deliver its torque (tag 7).
    Tracking,
    /// The pose estimator (tag 8): its residual (how far the encoder
    /// lengths are from those of any pose) exceeded the limit, a fault at
    /// once (a broken, slack or slipping cable, a stopped encoder, a wrong
    /// homing); or its step failed otherwise (a correction too large, a
    /// singular geometry), a hold: the last feasible torques are held,
    /// feedback off, and a fault follows (`HoldTimeout`, `hold_reason` =
    /// this) if it lasts.
    Estimator,
    /// A winch drive's encoder could not be read (tag 9): a fault while
    /// Enabled or Holding; `Telemetry::unreadable_drive` names the drive.
    Encoder,
    /// A winch drive reported a fault or stopped answering (tag 10): an
    /// EMCY frame, a statusword showing fault or a lost "operation
    /// enabled", a missing process data object, a heartbeat timeout, a
    /// bus-off. A fault in any state; `Telemetry::drive_fault` names the
    /// drive, the cause and its code.
    Drive,
}

/// What a winch drive's fault was ([`DriveFault::cause`]); the meaning of
/// [`DriveFault::code`] depends on it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DriveFaultCause {
    /// The drive sent an emergency (EMCY) frame (tag 0); `code` is its
    /// CiA 301 emergency error code (e.g. 0x2310 over-current, 0x4310
    /// over-temperature, 0x7305 encoder).
    Emergency,
    /// The drive's statusword shows "fault" or "fault reaction active" (tag
    /// 1); `code` is the statusword (0x6041).
    StateFault,
    /// The drive left "operation enabled" by itself, or did not reach
    /// the state asked for within the transition timeout (tag 2); `code`
    /// is the statusword.
    StateLost,
    /// No position (TPDO) from the drive for the stated number of SYNC
    /// cycles in a row (tag 3); `code` is the number of cycles.
    MissingPdo,
    /// No heartbeat within the consumer time, or a heartbeat in another
    /// NMT state than operational (a reset or stopped drive) (tag 4);
    /// `code` is the NMT state byte, or 0xFFFF for the timeout.
    Heartbeat,
    /// The drive's bus went bus-off (tag 5); `code` is the bus (1 or 2).
    BusOff,
    /// The drive did not answer at start-up within the stated time (tag
    /// 6): no boot-up, or an SDO without response; `code` is the object
    /// index being written (0 for the boot-up).
    NoAnswer,
    /// The drive refused a configuration SDO (tag 7), or its rated torque
    /// (0x6076) differs from the robot file's; `code` is the SDO abort
    /// code (CiA 301), or 0x6076 for the rated torque.
    Configuration,
}

impl DriveFaultCause {
    /// The cause's name in logs and tables (lower case, words joined by `-`).
    pub const fn name(self) -> &'static str {
        match self {
            DriveFaultCause::Emergency => "emergency",
            DriveFaultCause::StateFault => "state-fault",
            DriveFaultCause::StateLost => "state-lost",
            DriveFaultCause::MissingPdo => "missing-pdo",
            DriveFaultCause::Heartbeat => "heartbeat",
            DriveFaultCause::BusOff => "bus-off",
            DriveFaultCause::NoAnswer => "no-answer",
            DriveFaultCause::Configuration => "configuration",
        }
    }
}

/// A winch drive's fault, as telemetry reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DriveFault {
    /// The drive: its cable's index (0-based, file order).
    pub drive: u8,
    /// What happened.
    pub cause: DriveFaultCause,
    /// The cause's code (see [`DriveFaultCause`]).
    pub code: u32,
}

impl State {
    /// The state's name in logs and tables (lower case).
    pub const fn name(self) -> &'static str {
        match self {
            State::Disabled => "disabled",
            State::Enabled => "enabled",
            State::Holding => "holding",
            State::Fault => "fault",
        }
    }
}

impl Reason {
    /// The reason's name in logs and tables (lower case, words joined by `-`).
    pub const fn name(self) -> &'static str {
        match self {
            Reason::None => "none",
            Reason::Infeasible => "infeasible",
            Reason::BadSetpoint => "bad-setpoint",
            Reason::Stale => "stale",
            Reason::HoldTimeout => "hold-timeout",
            Reason::Overruns => "overruns",
            Reason::Output => "drive-error",
            Reason::Tracking => "tracking",
            Reason::Estimator => "estimator",
            Reason::Encoder => "encoder",
            Reason::Drive => "drive",
        }
    }
}

/// Why the receiver last rejected a frame or refused a request
/// ([`Counters::last_rejection`]); each has its counter in [`Counters`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Rejection {
    /// Nothing rejected yet (tag 0).
    #[default]
    None,
    /// Bad COBS or too long (tag 1, `rejected_framing`).
    Framing,
    /// CRC mismatch or too short (tag 2, `rejected_crc`).
    Crc,
    /// Good CRC, but not the canonical encoding of a message (tag 3,
    /// `rejected_decode`).
    Decode,
    /// A setpoint not newer than the last accepted (tag 4, `rejected_order`).
    Order,
    /// A non-finite or out-of-range setpoint, or an unknown method number
    /// (tag 5, `rejected_range`).
    Range,
    /// A setpoint whose change from the last accepted one disagrees with
    /// its velocity (tag 6, `rejected_jump`).
    Jump,
    /// A command not allowed in the current state (tag 7, `rejected_state`).
    State,
    /// `SelectMethod` of a method whose worst case does not fit the board's
    /// budget (tag 8, `rejected_method`).
    MethodOverBudget,
    /// `Enable` before the board is homed, or a `Home` it could not carry
    /// out because a drive could not be read (tag 9; counted in
    /// `rejected_state`, which keeps the counters' layout).
    Homing,
    /// A trajectory point not later than the buffer's last, or whose time
    /// the buffer has already played (tag 10; counted in `rejected_order`).
    Late,
    /// A trajectory point for a full buffer, or more than the longest
    /// segment after the one before it (tag 11; counted in
    /// `rejected_order`).
    BufferFull,
}

impl Rejection {
    /// The rejection's name in logs and tables (lower case, words joined by `-`).
    pub const fn name(self) -> &'static str {
        match self {
            Rejection::None => "none",
            Rejection::Framing => "framing",
            Rejection::Crc => "crc",
            Rejection::Decode => "decode",
            Rejection::Order => "order",
            Rejection::Range => "range",
            Rejection::Jump => "jump",
            Rejection::State => "state",
            Rejection::MethodOverBudget => "method-over-budget",
            Rejection::Homing => "homing",
            Rejection::Late => "late",
            Rejection::BufferFull => "buffer-full",
        }
    }
}

/// Running counters of the link and the control loop (they wrap at `u32::MAX`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Counters {
    /// Frames accepted and acted on.
    pub accepted: u32,
    /// Frames rejected for framing: bad COBS or too long.
    pub rejected_framing: u32,
    /// Frames rejected for a CRC mismatch or too short.
    pub rejected_crc: u32,
    /// Frames with a good CRC that do not decode as a message.
    pub rejected_decode: u32,
    /// Setpoints whose sequence number is not larger than the last accepted.
    pub rejected_order: u32,
    /// Setpoints with a non-finite or out-of-range value.
    pub rejected_range: u32,
    /// Commands not allowed in the current state (e.g. `Enable` while in
    /// fault, or before homing: `last_rejection` tells which).
    pub rejected_state: u32,
    /// Control cycles that missed their deadline.
    pub overruns: u32,
    /// Control cycles whose setpoint was infeasible.
    pub infeasible: u32,
    /// Entries into the fault state.
    pub faults: u32,
    /// Setpoints whose change from the last accepted one disagrees with
    /// their velocity beyond the link's tolerance.
    pub rejected_jump: u32,
    /// `SelectMethod` requests for a method the board does not offer (its
    /// worst case does not fit the step budget).
    pub rejected_method: u32,
    /// Received bytes dropped before decoding (the receive queue was full:
    /// more arrived than the per-cycle receive budget drains).
    pub dropped_bytes: u32,
    /// Why the last rejection (any of the counters above but `accepted`,
    /// `overruns`, `infeasible`, `faults` and `dropped_bytes`) happened.
    pub last_rejection: Rejection,
}

impl Counters {
    /// Counts one rejection in its counter and records it as the last.
    pub fn reject(&mut self, why: Rejection) {
        let counter = match why {
            Rejection::None => return,
            Rejection::Framing => &mut self.rejected_framing,
            Rejection::Crc => &mut self.rejected_crc,
            Rejection::Decode => &mut self.rejected_decode,
            Rejection::Order | Rejection::Late | Rejection::BufferFull => &mut self.rejected_order,
            Rejection::Range => &mut self.rejected_range,
            Rejection::Jump => &mut self.rejected_jump,
            Rejection::State | Rejection::Homing => &mut self.rejected_state,
            Rejection::MethodOverBudget => &mut self.rejected_method,
        };
        *counter = counter.wrapping_add(1);
        self.last_rejection = why;
    }
}

/// One telemetry sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Telemetry {
    /// Control cycle number since start.
    pub cycle: u32,
    /// Sequence number of the setpoint the tensions were computed for
    /// (0 before the first).
    pub setpoint_seq: u32,
    /// State after this cycle.
    pub state: State,
    /// Why the state is `Holding` or `Fault` (`None` otherwise).
    pub reason: Reason,
    /// What started the hold that led to a `HoldTimeout` fault (`None` otherwise).
    pub hold_reason: Reason,
    /// Whether this cycle's setpoint gave a feasible solution.
    pub solved: bool,
    /// The solver's tensions for `setpoint_seq`, N (valid when `solved`).
    pub tensions: [f32; CABLES],
    /// Motor torques commanded this cycle, N m.
    pub torques: [f32; CABLES],
    /// Brakes commanded engaged.
    pub brakes: bool,
    /// Instructions (cycles on the board) of the costliest control step
    /// since the previous sample (its receive and decoding included), so
    /// that a host sees the worst step, not one step in `period`.
    pub step_cost: u32,
    /// Counters.
    pub counters: Counters,
    /// The method in use (index as in [`HostMessage::SelectMethod`]).
    pub method: u8,
    /// The pose estimated from the winch encoders this cycle
    /// (`[x, y, z, rx, ry, rz]`, m and rad; the last good estimate when
    /// this cycle's failed, zeros before homing).
    pub estimate: [f32; DOF],
    /// The estimator's worst cable-length residual this cycle, m: how far
    /// the encoder lengths are from those of the estimated pose (NaN when
    /// there is no estimate: not homed, a drive unreadable, the forward
    /// kinematics failed).
    pub residual: f32,
    /// Whether the board is homed (`HostMessage::Home` carried out).
    pub homed: bool,
    /// The feedback scheme in use (as in [`HostMessage::SelectFeedback`]).
    pub feedback: u8,
    /// The drive whose encoder could not be read this cycle, if any.
    pub unreadable_drive: Option<u8>,
    /// Cables whose commanded tension the joint-space feedback would have
    /// taken outside `t_min..t_max`, one bit per cable (bit `i`: cable
    /// `i`); those tensions were limited to the bound.
    pub tension_limited: u8,
    /// How much of the task-space feedback wrench the tension distribution
    /// carried this cycle, percent (100 in the other schemes). 0 in a cycle
    /// whose feed-forward plus feedback had no feasible tensions (the last
    /// feasible torques held); the next cycles carry half as much each
    /// until it solves (nothing below 1/16), then 2 % more a cycle.
    pub feedback_scale: u8,
    /// Trajectory points waiting in the board's buffer (not yet played).
    pub buffer_fill: u8,
    /// How far the buffer's last point lies ahead of its play time, ms (0
    /// when it ran dry or holds no stream).
    pub buffer_lead_ms: u16,
    /// The first winch-drive fault since the last granted `ClearFault`
    /// (the one that put the board in Fault `drive`), if any.
    pub drive_fault: Option<DriveFault>,
}

/// Bytes of the robot's name in [`Identity`]; longer names are truncated
/// (at a character boundary).
pub const IDENTITY_NAME_LEN: usize = 24;

/// The robot a firmware was built for, as it answers
/// [`HostMessage::Identify`]: its robot file's `name` and the hash of the
/// file's parsed content (`robot_file::RobotFile::identity`: FNV-1a 64
/// over a canonical serialisation of every value the file sets, so
/// formatting and comments do not change it, any number does), with its
/// shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Identity {
    /// The name's UTF-8 bytes, zero padded.
    pub name: [u8; IDENTITY_NAME_LEN],
    /// How many of `name`'s bytes are the name (at most
    /// [`IDENTITY_NAME_LEN`]; a larger value is malformed).
    pub name_len: u8,
    /// The robot file's content hash.
    pub hash: u64,
    /// Degrees of freedom.
    pub dof: u8,
    /// Cables.
    pub cables: u8,
}

impl Identity {
    /// The identity of a robot named `name` (truncated to
    /// [`IDENTITY_NAME_LEN`] bytes at a character boundary).
    pub const fn new(name: &str, hash: u64, dof: u8, cables: u8) -> Self {
        let bytes = name.as_bytes();
        let mut len = if bytes.len() < IDENTITY_NAME_LEN { bytes.len() } else { IDENTITY_NAME_LEN };
        // Back to a character boundary: never cut a UTF-8 sequence.
        while len > 0 && len < bytes.len() && (bytes[len] & 0xC0) == 0x80 {
            len -= 1;
        }
        let mut out = [0u8; IDENTITY_NAME_LEN];
        let mut i = 0;
        while i < len {
            out[i] = bytes[i];
            i += 1;
        }
        Self { name: out, name_len: len as u8, hash, dof, cables }
    }

    /// The name, `None` when `name_len` is too large or the bytes are not
    /// UTF-8 (a malformed message).
    pub fn name(&self) -> Option<&str> {
        let bytes = self.name.get(..usize::from(self.name_len))?;
        core::str::from_utf8(bytes).ok()
    }
}

/// Firmware to host.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DeviceMessage {
    /// A telemetry sample (tag 0).
    Telemetry(Telemetry),
    /// The answer to [`HostMessage::Identify`] (tag 1).
    Identity(Identity),
}
