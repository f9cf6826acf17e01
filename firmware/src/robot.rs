//! The robot the firmware drives, as constants generated at build time
//! from its robot file (`robots/suspended-8.toml` unless `CDPR_ROBOT` names
//! another; see `build.rs`): its numbers, its identity ([`IDENTITY`], the
//! answer to `HostMessage::Identify`), its static workspace's centre
//! ([`CENTRE`]), its demo trajectory (`DEMO`, when one derives from the
//! file) and the product's start pose in QEMU ([`HOME`]),
//! and the control loop's setpoint range and feedback bounds for it.

use cdpr_control::control_loop::{DEFAULT_FEEDBACK_LIMITS, DEFAULT_JOINT_INTEGRAL_MAX};
use cdpr_control::encoder::{EncoderScale, ScaleError};
use cdpr_control::feedback::FeedbackLimits;
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

/// The platform's weight against the one the control loop's default
/// feedback bounds were set for ([`cdpr_control::control_loop::weight_scale`]).
pub fn weight_scale() -> f32 {
    cdpr_control::control_loop::weight_scale(MASS, GRAVITY)
}

/// The task-space PID's bounds for this robot: the control loop's defaults
/// (a third of suspended-8's weight as the force, 2 N m, the integrals)
/// scaled by [`weight_scale`], so that a light platform's feedback wrench
/// stays as small against its weight and its tension range.
pub fn feedback_limits() -> FeedbackLimits {
    let k = weight_scale();
    let d = DEFAULT_FEEDBACK_LIMITS;
    FeedbackLimits {
        force_max: d.force_max * k,
        moment_max: d.moment_max * k,
        integral_max: d.integral_max.map(|x| x * k),
    }
}

/// The joint-space PID's integral bound per cable, N: the default scaled by
/// [`weight_scale`].
pub fn joint_integral_max() -> f32 {
    DEFAULT_JOINT_INTEGRAL_MAX * weight_scale()
}

/// The robot's number of cables is the protocol's.
const _: () = assert!(ANCHORS.len() == CABLES);

/// The winch drives on the CAN buses: the robot file's node ids, buses,
/// rated torque and torque limit.
pub fn drive_configs() -> [canopen_drives::DriveConfig; CABLES] {
    core::array::from_fn(|i| canopen_drives::DriveConfig {
        bus: DRIVE_BUSES[i],
        node: DRIVE_NODES[i],
        rated_torque: RATED_TORQUE,
        torque_max: TORQUE_MAX,
    })
}
