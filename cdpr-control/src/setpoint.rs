//! A pose setpoint as the controller uses it: the pose and its first two
//! time derivatives as vectors, with the sequence number it arrived with,
//! and its conversion from and to the protocol's message.

use tension_core::nalgebra::SVector;

/// A pose `[x, y, z, rx, ry, rz]` (conventions, "Poses") or one of its derivatives.
pub type Pose6 = SVector<f32, 6>;

/// A setpoint: pose and its first two time derivatives, with the sequence
/// number it arrived with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setpoint {
    /// Sequence number.
    pub seq: u32,
    /// Pose `[x, y, z, rx, ry, rz]`.
    pub pose: Pose6,
    /// Its time derivative.
    pub velocity: Pose6,
    /// Its second time derivative.
    pub acceleration: Pose6,
}

impl Setpoint {
    /// The protocol's form of this setpoint (what a host sends).
    pub fn to_wire(&self) -> cdpr_protocol::Setpoint {
        cdpr_protocol::Setpoint {
            seq: self.seq,
            pose: self.pose.into(),
            velocity: self.velocity.into(),
            acceleration: self.acceleration.into(),
        }
    }

    /// Writes the setpoint a protocol message carries over this one, field
    /// by field (what [`From`] builds, in place: a whole setpoint moved is a
    /// library copy of 72 bytes on the board, about 100 instructions;
    /// BENCHMARKS.md, session 32).
    #[inline]
    pub(crate) fn assign(&mut self, s: &cdpr_protocol::Setpoint) {
        self.seq = s.seq;
        self.pose = SVector::from(s.pose);
        self.velocity = SVector::from(s.velocity);
        self.acceleration = SVector::from(s.acceleration);
    }
}

impl From<&cdpr_protocol::Setpoint> for Setpoint {
    /// The setpoint a protocol message carries (unchecked: see `crate::link`).
    fn from(s: &cdpr_protocol::Setpoint) -> Self {
        Self {
            seq: s.seq,
            pose: SVector::from(s.pose),
            velocity: SVector::from(s.velocity),
            acceleration: SVector::from(s.acceleration),
        }
    }
}
