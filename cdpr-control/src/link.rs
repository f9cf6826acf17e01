//! What the serial protocol's frames mean to the controller: bytes in,
//! [`Event`]s out. Framing, CRC and decoding are `cdpr-protocol`'s; this layer
//! adds the checks that need the robot and the stream's history:
//!
//! * a setpoint whose sequence number is not larger than the last accepted
//!   one is out of order: rejected, counted, and otherwise ignored (a
//!   duplicate or a late frame says nothing new);
//! * a setpoint with a non-finite value or outside [`SetpointRange`] is
//!   rejected and counted, its values are never used, and it becomes
//!   [`Event::BadSetpoint`]: the stream has asked for something the robot
//!   must not do, so the supervisor holds and, if no good setpoint follows,
//!   faults;
//! * everything else becomes an event for the control loop.
//!
//! The sequence check restarts ([`Link::restart_sequence`]) whenever the
//! robot is disabled, so a host may renumber from 1 after a disable.

use cdpr_protocol::{Counters, FrameDecoder, FrameError, HostMessage};
use tension_core::Robot;

use crate::setpoint::Setpoint;

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

    /// The range for `robot`: positions within the box spanned by the
    /// anchors and the base frame's origin (the floor under a suspended
    /// robot), widened by [`SetpointRange::MARGIN`]; Euler angles within
    /// 1 rad; speeds and accelerations a winch of the firmware's size can
    /// follow (5 m/s, 10 rad/s, 50 m/s^2, 100 rad/s^2).
    pub fn for_robot<const N: usize, const M: usize>(robot: &Robot<f32, N, M>) -> Self {
        let mut position_min = [0.0f32; 3];
        let mut position_max = [0.0f32; 3];
        for anchor in robot.anchors() {
            for (k, &a) in anchor.iter().enumerate() {
                position_min[k] = position_min[k].min(a);
                position_max[k] = position_max[k].max(a);
            }
        }
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

    /// Whether every value is finite and within range.
    pub fn contains(&self, s: &cdpr_protocol::Setpoint) -> bool {
        let within = |v: f32, lo: f32, hi: f32| v.is_finite() && v >= lo && v <= hi;
        let bounded = |v: f32, max: f32| within(v, -max, max);
        (0..3).all(|i| {
            within(s.pose[i], self.position_min[i], self.position_max[i])
                && bounded(s.pose[i + 3], self.angle_max)
                && bounded(s.velocity[i], self.speed_max)
                && bounded(s.velocity[i + 3], self.angular_speed_max)
                && bounded(s.acceleration[i], self.acceleration_max)
                && bounded(s.acceleration[i + 3], self.angular_acceleration_max)
        })
    }
}

/// What an accepted frame asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// A new setpoint, in range and in order.
    Setpoint(Setpoint),
    /// A setpoint arrived in order but with a non-finite or out-of-range
    /// value; it is not used.
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
}

/// The receiving side of the serial link.
#[derive(Debug, Clone)]
pub struct Link {
    decoder: FrameDecoder,
    range: SetpointRange,
    last_seq: Option<u32>,
}

impl Link {
    /// A link that accepts setpoints within `range`.
    pub const fn new(range: SetpointRange) -> Self {
        Self { decoder: FrameDecoder::new(), range, last_seq: None }
    }

    /// Takes one received byte; returns the event of a frame it completed.
    /// Rejected frames are counted in `counters`.
    pub fn receive(&mut self, byte: u8, counters: &mut Counters) -> Option<Event> {
        match self.decoder.push::<HostMessage>(byte)? {
            Ok(message) => self.accept(message, counters),
            Err(e) => {
                let counter = match e {
                    FrameError::Framing | FrameError::Oversize => &mut counters.rejected_framing,
                    FrameError::Crc => &mut counters.rejected_crc,
                    FrameError::Decode | FrameError::TrailingBytes | FrameError::BufferTooSmall => {
                        &mut counters.rejected_decode
                    }
                };
                *counter = counter.wrapping_add(1);
                None
            }
        }
    }

    /// Checks a decoded message (from [`Link::receive`], or from a local
    /// source such as the firmware's demo script) and returns its event.
    pub fn accept(&mut self, message: HostMessage, counters: &mut Counters) -> Option<Event> {
        let event = match message {
            HostMessage::Setpoint(s) => {
                if self.last_seq.is_some_and(|last| s.seq <= last) {
                    counters.rejected_order = counters.rejected_order.wrapping_add(1);
                    return None;
                }
                self.last_seq = Some(s.seq);
                if !self.range.contains(&s) {
                    counters.rejected_range = counters.rejected_range.wrapping_add(1);
                    return Some(Event::BadSetpoint);
                }
                Event::Setpoint(Setpoint::from(&s))
            }
            HostMessage::Enable => Event::Enable,
            HostMessage::Disable => Event::Disable,
            HostMessage::ClearFault => Event::ClearFault,
            HostMessage::TelemetryPeriod(p) => Event::TelemetryPeriod(p),
            HostMessage::SelectMethod(id) => match tension_core::Method::from_wire_id(id) {
                Some(method) => Event::SelectMethod(method),
                None => {
                    counters.rejected_range = counters.rejected_range.wrapping_add(1);
                    return None;
                }
            },
        };
        counters.accepted = counters.accepted.wrapping_add(1);
        Some(event)
    }

    /// Forgets the last sequence number: the next setpoint may carry any.
    pub fn restart_sequence(&mut self) {
        self.last_seq = None;
    }

    /// The range setpoints are checked against.
    pub fn range(&self) -> &SetpointRange {
        &self.range
    }
}
