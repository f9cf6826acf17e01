//! The shape of robot the control loop runs: `f32`, [`DOF`] degrees of
//! freedom, [`CABLES`] cables, as the protocol's messages carry them. Which
//! robot (geometry, limits, platform, winch) is the caller's: the firmware
//! generates its constants from a robot file at build time, the host tools
//! read the file with `robot-file`.

use tension_core::Robot;

/// Degrees of freedom (spatial6), as the protocol's messages carry them.
pub const DOF: usize = cdpr_protocol::DOF;
/// Number of cables, as the protocol's messages carry them.
pub const CABLES: usize = cdpr_protocol::CABLES;

/// The robot type the control loop runs: `f32`, 6 DOF, 8 cables.
pub type ControlRobot = Robot<f32, DOF, CABLES>;
