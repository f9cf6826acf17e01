//! The robot the firmware drives, as constants generated at build time
//! from its robot file (`robots/suspended-8.toml` unless `CDPR_ROBOT` names
//! another; see `build.rs`), and the control loop's setpoint range for it.

use cdpr_control::encoder::{EncoderScale, ScaleError};
use cdpr_control::link::SetpointRange;
use cdpr_control::{ControlRobot, CABLES};
use tension_core::nalgebra::{Matrix3, SVector, Vector3};
use tension_core::{Error, Platform, Robot, TensionLimits, Winch};

include!(concat!(env!("OUT_DIR"), "/robot.rs"));

fn vector(p: [f32; 3]) -> Vector3<f32> {
    Vector3::new(p[0], p[1], p[2])
}

/// The robot, validated by `tension-core`.
pub fn robot() -> Result<ControlRobot, Error> {
    let i = INERTIA;
    let platform = Platform {
        mass: MASS,
        com: vector(COM),
        gravity: vector(GRAVITY),
        inertia: Matrix3::new(
            i[0][0], i[0][1], i[0][2], i[1][0], i[1][1], i[1][2], i[2][0], i[2][1], i[2][2],
        ),
    };
    Robot::new(
        KIND,
        ANCHORS.map(vector),
        ATTACHMENTS.map(vector),
        TensionLimits::new(SVector::from(T_MIN), SVector::from(T_MAX))?,
        platform,
        Some(Winch::new(DRUM_RADIUS, GEAR_RATIO, EFFICIENCY, TORQUE_MAX)?),
    )
}

/// The winch encoders' scale: `[winch]`'s drum radius, gear ratio,
/// counts per revolution and signs.
pub fn encoder_scale() -> Result<EncoderScale, ScaleError> {
    EncoderScale::new(DRUM_RADIUS, GEAR_RATIO, COUNTS_PER_REVOLUTION, ENCODER_SIGNS)
}

/// The range a setpoint must lie in to be acted on (see
/// [`SetpointRange::for_robot`]).
pub fn setpoint_range(robot: &ControlRobot) -> SetpointRange {
    SetpointRange::for_robot(robot)
}

/// The robot's number of cables is the protocol's.
const _: () = assert!(ANCHORS.len() == CABLES);
