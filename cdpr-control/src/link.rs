//! What the serial protocol's frames mean to the controller: bytes in,
//! [`Event`]s out. Framing, CRC and decoding are `cdpr-protocol`'s (only
//! canonical encodings pass); this layer adds the checks that need the
//! robot and the stream's history. Every rejection is counted
//! ([`Counters::reject`]) and a rejected setpoint never changes what the
//! link remembers, so no input can lock the link.
//!
//! * **Sequence rule.** The *reference* is the last accepted setpoint.
//!   While the link is *bound* (the robot is Enabled or Holding: setpoints
//!   drive the winches) a setpoint is in order only if its number is newer
//!   than the reference's in serial-number arithmetic (RFC 1982):
//!   `seq - last` (wrapping) in `1..=2^31 - 1`, so numbering runs through
//!   the `u32` wrap (49.7 days at 1 kHz) without a pause; anything else is
//!   out of order: rejected, counted and otherwise ignored (a duplicate or a
//!   late frame says nothing new). While the link is free (Disabled, Fault)
//!   every setpoint within range is accepted whatever its number and
//!   becomes the reference, so a host that (re)connects starts from any
//!   number; a `Disable` drops the reference at once, so a host may
//!   renumber right after it in the same burst.
//! * **Range.** A setpoint with a non-finite value or outside
//!   [`SetpointRange`] is rejected and counted, its values are never used,
//!   and it becomes [`Event::BadSetpoint`]: the stream has asked for
//!   something the robot must not do, so the supervisor holds and, if no
//!   good setpoint follows, faults.
//! * **Jumps.** While bound, a setpoint must follow from the reference by
//!   its declared velocity over at most the time since the reference
//!   arrived ([`JumpLimits`]): rejected, counted and [`Event::BadSetpoint`]
//!   otherwise.
//! * everything else becomes an event for the control loop.

use cdpr_protocol::{Counters, FrameDecoder, FrameError, HostMessage, LineFrame, Rejection};
use tension_core::Robot;

/// Limits on a setpoint's values (base frame; conventions "Poses").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SetpointRange {
    /// Smallest `x, y, z`, m.
    pub position_min: [f32; 3],
    /// Largest `x, y, z`, m.
    pub position_max: [f32; 3],
    /// Largest `|rx|, |ry|, |rz|`, rad.
    pub angle_max: f32,
    /// Largest `|dx/dt|` (each of x, y, z), m/s.
    pub speed_max: f32,
    /// Largest Euler-angle rate, rad/s.
    pub angular_speed_max: f32,
    /// Largest linear acceleration component, m/s^2.
    pub acceleration_max: f32,
    /// Largest Euler-angle acceleration, rad/s^2.
    pub angular_acceleration_max: f32,
}

impl SetpointRange {
    /// How far a position may lie outside the box of [`SetpointRange::for_robot`], m.
    pub const MARGIN: f32 = 0.5;

    /// The range for `robot`: positions within the box the platform can be
    /// in (`Robot::platform_region`: the anchors' bounding box, reaching
    /// along gravity to the base origin, the floor under a suspended robot,
    /// or for anchors in the origin's plane as far as the box is wide),
    /// widened by [`SetpointRange::MARGIN`]; Euler angles within 1 rad;
    /// speeds and accelerations a winch of the firmware's size can follow
    /// (5 m/s, 10 rad/s, 50 m/s^2, 100 rad/s^2).
    ///
    /// The range spanned the anchors and the base origin on every axis: a
    /// robot file whose frame lay 50 m beside the robot gave a range 50 m
    /// wide and a demo derived on it whose centre was 0.6 m off, and one
    /// framed on its ceiling a range that held no pose under the anchors.
    pub fn for_robot<const N: usize, const M: usize>(robot: &Robot<f32, N, M>) -> Self {
        let (lo, hi) = robot.platform_region();
        let (position_min, position_max) = ([lo.x, lo.y, lo.z], [hi.x, hi.y, hi.z]);
        Self {
            position_min: position_min.map(|p| p - Self::MARGIN),
            position_max: position_max.map(|p| p + Self::MARGIN),
            angle_max: 1.0,
            speed_max: 5.0,
            angular_speed_max: 10.0,
            acceleration_max: 50.0,
            angular_acceleration_max: 100.0,
        }
    }

    /// The longest cable `robot` can have at a pose within the range: from
    /// each anchor to the farthest corner of the position box, plus the
    /// attachment's distance from the platform's origin (whatever the
    /// rotation), m. A bound: no pose the range accepts gives a longer one.
    pub fn longest_cable<const N: usize, const M: usize>(&self, robot: &Robot<f32, N, M>) -> f32 {
        let mut longest = 0.0f32;
        for (anchor, attach) in robot.anchors().iter().zip(robot.attachments()) {
            let mut far = 0.0f32;
            for k in 0..3 {
                let d = tension_core::max(
                    libm::fabsf(anchor[k] - self.position_min[k]),
                    libm::fabsf(self.position_max[k] - anchor[k]),
                );
                far += d * d;
            }
            longest = tension_core::max(longest, libm::sqrtf(far) + attach.norm());
        }
        longest
    }

    /// Whether a pose is finite with its position in the box and its
    /// angles within `angle_max` (none is when `angle_max` is NaN or below
    /// zero); [`SetpointRange::contains`]'s test of the pose.
    #[inline]
    pub fn contains_pose(&self, pose: &[f32; 6]) -> bool {
        let angle = magnitude_bound(self.angle_max);
        let mut ok = self.angle_max >= 0.0;
        for i in 0..3 {
            let p = pose[i];
            ok &= ((p.to_bits() & MAGNITUDE) < INFINITY_BITS)
                & (p >= self.position_min[i])
                & (p <= self.position_max[i])
                & within_magnitude(pose[i + 3], angle);
        }
        ok
    }

    /// Whether every value is finite and within range: `lo <= v <= hi` for
    /// the position, `-max <= v <= max` for the rest (no value is when a
    /// limit is NaN or below zero).
    ///
    /// Every setpoint is checked, so the symmetric limits are tested on the
    /// values' bit patterns (`within_magnitude`): one integer comparison
    /// per value and no branch, where two float comparisons and a
    /// finiteness test each cost a flag transfer on the Cortex-M4F.
    pub fn contains(&self, s: &cdpr_protocol::Setpoint) -> bool {
        let maxima =
            [self.speed_max, self.angular_speed_max, self.acceleration_max, self.angular_acceleration_max];
        let mut ok = maxima.iter().fold(self.contains_pose(&s.pose), |ok, &m| ok & (m >= 0.0));
        let [speed, angular_speed, acceleration, angular_acceleration] = maxima.map(magnitude_bound);
        for i in 0..3 {
            ok &= within_magnitude(s.velocity[i], speed)
                & within_magnitude(s.velocity[i + 3], angular_speed)
                & within_magnitude(s.acceleration[i], acceleration)
                & within_magnitude(s.acceleration[i + 3], angular_acceleration);
        }
        ok
    }
}

/// An `f32`'s bits without the sign.
const MAGNITUDE: u32 = 0x7FFF_FFFF;
/// The bits of infinity: a magnitude's at or above it are not finite.
const INFINITY_BITS: u32 = 0x7F80_0000;

/// A limit `max >= 0` as the bound of [`within_magnitude`]: its bits (`+
/// 0.0`: -0 is 0), at most `f32::MAX`'s (an infinite limit admits every
/// finite value, not infinity). A NaN or negative limit admits nothing:
/// the caller tests `max >= 0.0`.
#[inline]
fn magnitude_bound(max: f32) -> u32 {
    (max + 0.0).to_bits().min(f32::MAX.to_bits())
}

/// `|v| <= max` for `bound = magnitude_bound(max)`, `max >= 0`: IEEE 754
/// orders non-negative floats as their bits, and NaN and infinity lie above
/// every finite bound, so this is false for them.
#[inline]
fn within_magnitude(v: f32, bound: u32) -> bool {
    (v.to_bits() & MAGNITUDE) <= bound
}

/// How far a setpoint may depart from where the reference's motion puts
/// it. With the reference `(p0, v0)`, which arrived `n` cycles earlier, and
/// the new setpoint `(p1, v1)`, there must be one time `dt` between 0 and
/// `max(n, 1)` periods for which every coordinate satisfies
/// `|p1 - p0 - (v0 + v1) dt / 2| <= tolerance`: the trapezoid rule (exact
/// for constant acceleration) over the time the host's stream advanced,
/// which the board cannot know exactly but which cannot exceed the time
/// since the reference arrived. So setpoints that arrive together (`dt`
/// one host period, less than the board's cycle), late (`dt` the time
/// since), or after a pause from where the stream stopped (`dt` small
/// though much time passed) are accepted, while a change that no common
/// `dt` explains is a jump: the 1.1 m at zero velocity, or a far
/// pose whose velocity would need longer than has passed to get there.
/// The tolerance covers the host's rounding and its sampling of a curved
/// path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JumpLimits {
    /// The control period, s.
    pub period_s: f32,
    /// Largest departure of `x, y, z`, m.
    pub position: f32,
    /// Largest departure of `rx, ry, rz`, rad.
    pub angle: f32,
}

impl JumpLimits {
    /// The firmware's: 1 ms period, 50 mm, 0.1 rad.
    pub const DEFAULT: Self = Self { period_s: 0.001, position: 0.05, angle: 0.1 };

    /// Whether `(p1, v1)` follows from `(p0, v0)` exactly `dt` s later by
    /// the trapezoid rule, within the tolerances: how a trajectory point
    /// must follow the one before it (`crate::point_buffer`).
    pub fn follows(&self, p0: &[f32; 6], v0: &[f32; 6], p1: &[f32; 6], v1: &[f32; 6], dt: f32) -> bool {
        (0..6).all(|i| {
            let tolerance = if i < 3 { self.position } else { self.angle };
            let predicted = p0[i] + 0.5 * (v0[i] + v1[i]) * dt;
            libm::fabsf(p1[i] - predicted) <= tolerance
        })
    }

    /// Whether `s` follows from `reference`, `cycles` later. Bounded: six
    /// intervals intersected; the values are finite (range-checked first).
    fn consistent(&self, reference: &Reference, s: &cdpr_protocol::Setpoint, cycles: u32) -> bool {
        let elapsed = cycles.max(1) as f32 * self.period_s;
        // A stream in real time: `dt` is the time since the reference.
        let on_time = self.follows(&reference.pose, &reference.velocity, &s.pose, &s.velocity, elapsed);
        on_time || self.some_time_explains(reference, s, elapsed)
    }

    /// Whether one `dt` in `[0, elapsed]` explains every coordinate's change.
    fn some_time_explains(&self, reference: &Reference, s: &cdpr_protocol::Setpoint, elapsed: f32) -> bool {
        let (mut earliest, mut latest) = (0.0f32, elapsed);
        for i in 0..6 {
            let tolerance = if i < 3 { self.position } else { self.angle };
            let change = s.pose[i] - reference.pose[i];
            let rate = 0.5 * (reference.velocity[i] + s.velocity[i]);
            if rate == 0.0 {
                if libm::fabsf(change) > tolerance {
                    return false;
                }
                continue;
            }
            // rate * dt within change -+ tolerance.
            let (a, b) = ((change - tolerance) / rate, (change + tolerance) / rate);
            let (from, to) = if rate > 0.0 { (a, b) } else { (b, a) };
            if from > earliest {
                earliest = from;
            }
            if to < latest {
                latest = to;
            }
        }
        earliest <= latest
    }
}

/// The last accepted setpoint: what the next is checked against.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Reference {
    seq: u32,
    pose: [f32; 6],
    velocity: [f32; 6],
    /// The cycle it arrived in.
    cycle: u32,
}

/// Whether `seq` is newer than `last` in serial-number arithmetic.
pub fn newer(seq: u32, last: u32) -> bool {
    (1..=i32::MAX as u32).contains(&seq.wrapping_sub(last))
}

/// What an accepted frame asks for (borrowing the decoded message `'m`: a
/// setpoint, about 80 bytes, is copied once, where the control loop keeps
/// it, not through the event).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event<'m> {
    /// A new setpoint, in range and in order.
    Setpoint(&'m cdpr_protocol::Setpoint),
    /// A setpoint arrived in order but with a non-finite or out-of-range
    /// value, or a jump from the last accepted one; it is not used.
    BadSetpoint,
    /// `Enable`.
    Enable,
    /// `Disable`.
    Disable,
    /// `ClearFault`.
    ClearFault,
    /// Telemetry every this many cycles (0: none).
    TelemetryPeriod(u16),
    /// Switch to this method (already checked to exist).
    SelectMethod(tension_core::Method),
    /// "The platform is at this pose now" (finite, within the range's
    /// position box and angle limit).
    Home(crate::setpoint::Pose6),
    /// Switch to this feedback scheme (already checked to exist).
    SelectFeedback(crate::feedback::Scheme),
    /// `Identify`: answer with the robot's identity.
    Identify,
    /// A trajectory point for the buffer (finite, within the range's
    /// pose and speed limits); the buffer applies its own rules
    /// (`crate::point_buffer`).
    Point(cdpr_protocol::TrajectoryPoint),
    /// A trajectory point with a non-finite or out-of-range value; it is
    /// not used (the buffer marks its stream: `PointBuffer::refuse`).
    BadPoint,
}

/// The receiving side of the serial link.
#[derive(Debug, Clone)]
pub struct Link {
    decoder: FrameDecoder,
    range: SetpointRange,
    jumps: Option<JumpLimits>,
    reference: Option<Reference>,
    bound: bool,
}

impl Link {
    /// A link that accepts setpoints within `range`, with the jump check of
    /// [`JumpLimits::DEFAULT`]; free (as in Disabled).
    pub const fn new(range: SetpointRange) -> Self {
        Self {
            decoder: FrameDecoder::new(),
            range,
            jumps: Some(JumpLimits::DEFAULT),
            reference: None,
            bound: false,
        }
    }

    /// Takes one received byte, kept inline in a receive loop: whether
    /// `byte` ended a frame, after which [`Link::finish`] gives it.
    #[inline(always)]
    pub fn take_byte(&mut self, byte: u8) -> bool {
        self.decoder.push_byte(byte)
    }

    /// Bytes from `next` up to the end of a frame, at most `limit`
    /// ([`cdpr_protocol::FrameDecoder::take_bytes`]): how many it took and
    /// whether the last ended a frame, after which [`Link::finish`] gives
    /// it.
    #[inline(always)]
    pub fn take_bytes(&mut self, next: &mut impl FnMut() -> Option<u8>, limit: usize) -> (usize, bool) {
        self.decoder.take_bytes(next, limit)
    }

    /// After a delimiter ([`Link::take_byte`]): the frame it ended, checked
    /// and decoded (`None`: an empty frame, nothing to judge), for
    /// [`Link::judge`].
    pub fn finish(&mut self) -> Option<Result<HostMessage, FrameError>> {
        self.decoder.finish::<HostMessage>()
    }

    /// A frame the receive interrupt reassembled ([`LineFrame`]), checked
    /// and decoded, for [`Link::judge`]: the same outcome as its bytes
    /// through [`Link::take_byte`] and [`Link::finish`].
    pub fn decode(frame: &LineFrame) -> Result<HostMessage, FrameError> {
        frame.message::<HostMessage>()
    }

    /// A decoded frame's event in cycle `now`, if any ([`Link::accept`]);
    /// frames that failed their check or decoding, and rejected messages,
    /// are counted in `counters`.
    pub fn judge<'m>(
        &mut self,
        outcome: &'m Result<HostMessage, FrameError>,
        now: u32,
        counters: &mut Counters,
    ) -> Option<Event<'m>> {
        match outcome {
            Ok(message) => self.accept(message, now, counters),
            Err(e) => {
                counters.reject(match *e {
                    FrameError::Framing | FrameError::Oversize => Rejection::Framing,
                    FrameError::Crc => Rejection::Crc,
                    FrameError::Decode | FrameError::TrailingBytes | FrameError::BufferTooSmall => {
                        Rejection::Decode
                    }
                });
                None
            }
        }
    }

    /// Checks a decoded message (from [`Link::judge`], or from a local
    /// source such as the firmware's demo script) arriving in cycle `now`
    /// and returns its event.
    pub fn accept<'m>(
        &mut self,
        message: &'m HostMessage,
        now: u32,
        counters: &mut Counters,
    ) -> Option<Event<'m>> {
        // By reference: a setpoint (about 80 bytes) is not copied here.
        let event = match message {
            HostMessage::Setpoint(s) => {
                let bound = self.reference.filter(|_| self.bound);
                if bound.is_some_and(|r| !newer(s.seq, r.seq)) {
                    counters.reject(Rejection::Order);
                    return None;
                }
                if !self.range.contains(s) {
                    counters.reject(Rejection::Range);
                    return Some(Event::BadSetpoint);
                }
                if let (Some(r), Some(limits)) = (bound, self.jumps) {
                    if !limits.consistent(&r, s, now.wrapping_sub(r.cycle)) {
                        counters.reject(Rejection::Jump);
                        return Some(Event::BadSetpoint);
                    }
                }
                self.reference =
                    Some(Reference { seq: s.seq, pose: s.pose, velocity: s.velocity, cycle: now });
                Event::Setpoint(s)
            }
            HostMessage::Enable => Event::Enable,
            HostMessage::Disable => {
                self.reference = None;
                Event::Disable
            }
            HostMessage::ClearFault => Event::ClearFault,
            HostMessage::TelemetryPeriod(p) => Event::TelemetryPeriod(*p),
            HostMessage::SelectMethod(id) => match tension_core::Method::from_wire_id(*id) {
                Some(method) => Event::SelectMethod(method),
                None => {
                    counters.reject(Rejection::Range);
                    return None;
                }
            },
            HostMessage::Home(pose) => {
                if !self.range.contains_pose(pose) {
                    counters.reject(Rejection::Range);
                    return None;
                }
                Event::Home(crate::setpoint::Pose6::from(*pose))
            }
            HostMessage::Point(p) => {
                let as_setpoint = cdpr_protocol::Setpoint {
                    seq: 0,
                    pose: p.pose,
                    velocity: p.velocity,
                    acceleration: [0.0; 6],
                };
                if !self.range.contains(&as_setpoint) {
                    counters.reject(Rejection::Range);
                    return Some(Event::BadPoint);
                }
                // Not counted here: the buffer's own rules decide whether
                // the point is accepted (`ControlLoop` counts it).
                return Some(Event::Point(*p));
            }
            HostMessage::SelectFeedback(id) => match crate::feedback::Scheme::from_wire_id(*id) {
                Some(scheme) => Event::SelectFeedback(scheme),
                None => {
                    counters.reject(Rejection::Range);
                    return None;
                }
            },
            HostMessage::Identify => Event::Identify,
        };
        counters.accepted = counters.accepted.wrapping_add(1);
        Some(event)
    }

    /// Forgets the reference: the next setpoint may carry any number and
    /// any pose.
    pub fn restart_sequence(&mut self) {
        self.reference = None;
    }

    /// Binds the link (Enabled, Holding: the order and jump checks apply)
    /// or frees it (Disabled, Fault: any setpoint within range is accepted
    /// and becomes the reference).
    pub fn bind(&mut self, bound: bool) {
        self.bound = bound;
    }

    /// The jump check (`None`: off, e.g. for tests that jump on purpose).
    pub fn set_jump_limits(&mut self, limits: Option<JumpLimits>) {
        self.jumps = limits;
    }

    /// The jump check in use.
    pub fn jump_limits(&self) -> Option<&JumpLimits> {
        self.jumps.as_ref()
    }

    /// The range setpoints are checked against.
    pub fn range(&self) -> &SetpointRange {
        &self.range
    }
}
