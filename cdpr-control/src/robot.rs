//! The suspended-8 robot (`robots/suspended-8.toml`) as Rust
//! constants: 8 cables, every anchor 3.5 m up on a 4 m x 3 m frame, 6 DOF,
//! 2 degrees of redundancy. Keep these numbers in step with the TOML file
//! (`cdpr-control/tests/robot_constants.rs` checks them against it).

use tension_core::nalgebra::{Matrix3, Vector3};
use tension_core::{Error, Platform, Robot, RobotKind, TensionLimits, Winch};

/// Degrees of freedom (spatial6), as the protocol's messages carry them.
pub const DOF: usize = cdpr_protocol::DOF;
/// Number of cables, as the protocol's messages carry them.
pub const CABLES: usize = cdpr_protocol::CABLES;

/// The robot type the firmware runs: `f32`, 6 DOF, 8 cables.
pub type Suspended8 = Robot<f32, DOF, CABLES>;

/// Base anchors `a_i`, base frame, m (TOML `[[cable]] anchor`).
pub const ANCHORS: [[f32; 3]; CABLES] = [
    [-2.0, -1.4, 3.5],
    [-1.9, -1.5, 3.5],
    [1.9, -1.5, 3.5],
    [2.0, -1.4, 3.5],
    [2.0, 1.4, 3.5],
    [1.9, 1.5, 3.5],
    [-1.9, 1.5, 3.5],
    [-2.0, 1.4, 3.5],
];

/// Platform attachments `b_i`, platform frame, m (TOML `[[cable]] attach`).
pub const ATTACHMENTS: [[f32; 3]; CABLES] = [
    [0.2, -0.15, 0.15],
    [-0.15, 0.2, 0.15],
    [-0.2, -0.15, 0.15],
    [0.15, 0.2, 0.15],
    [-0.2, 0.15, 0.15],
    [0.15, -0.2, 0.15],
    [0.2, 0.15, 0.15],
    [-0.15, -0.2, 0.15],
];

/// `[limits] t_min`, N.
pub const T_MIN: f32 = 5.0;
/// `[limits] t_max`, N.
pub const T_MAX: f32 = 350.0;

/// `[platform] mass`, kg.
pub const MASS: f32 = 6.34;
/// `[platform] com`, platform frame, m.
pub const COM: [f32; 3] = [0.0, 0.0, -0.1];
/// `[platform] gravity`, base frame, m/s^2.
pub const GRAVITY: [f32; 3] = [0.0, 0.0, -9.81];
/// `[platform] inertia` about the centre of mass, platform axes, kg m^2.
pub const INERTIA: [[f32; 3]; 3] = [[0.05, 0.0, 0.0], [0.0, 0.05, 0.0], [0.0, 0.0, 0.08]];

/// `[winch] drum_radius`, m.
pub const DRUM_RADIUS: f32 = 0.04;
/// `[winch] gear_ratio`, motor turns per drum turn.
pub const GEAR_RATIO: f32 = 8.0;
/// `[winch] efficiency`.
pub const EFFICIENCY: f32 = 0.9;
/// `[winch] torque_max`, N m at the motor.
pub const TORQUE_MAX: f32 = 2.5;

fn vector(p: [f32; 3]) -> Vector3<f32> {
    Vector3::new(p[0], p[1], p[2])
}

/// The robot, validated by `tension-core`.
pub fn suspended8() -> Result<Suspended8, Error> {
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
        RobotKind::Spatial6,
        ANCHORS.map(vector),
        ATTACHMENTS.map(vector),
        TensionLimits::uniform(T_MIN, T_MAX)?,
        platform,
        Some(Winch::new(DRUM_RADIUS, GEAR_RATIO, EFFICIENCY, TORQUE_MAX)?),
    )
}

/// The range a setpoint must lie in to be acted on (the link rejects the
/// rest as out of range): the anchors' bounding box widened by 0.5 m,
/// Euler angles within 1 rad, and speeds and accelerations a winch of this
/// size can follow.
pub const SETPOINT_RANGE: crate::link::SetpointRange = crate::link::SetpointRange {
    position_min: [-2.5, -2.0, -0.5],
    position_max: [2.5, 2.0, 4.0],
    angle_max: 1.0,
    speed_max: 5.0,
    angular_speed_max: 10.0,
    acceleration_max: 50.0,
    angular_acceleration_max: 100.0,
};
