//! The robot the tests drive: `robots/suspended-8.toml`, read by
//! `robot-file` (the file the firmware's constants are generated from).

use cdpr_control::link::SetpointRange;
use cdpr_control::ControlRobot;
use std::sync::OnceLock;

/// The robot file.
pub const ROBOT_FILE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../robots/suspended-8.toml");

/// suspended-8 as the control loop runs it (`f32`, 6 x 8).
pub fn suspended8() -> ControlRobot {
    static ROBOT: OnceLock<ControlRobot> = OnceLock::new();
    ROBOT
        .get_or_init(|| {
            robot_file::RobotFile::load(ROBOT_FILE)
                .and_then(|file| file.to_robot::<f32, 6, 8>())
                .unwrap_or_else(|e| panic!("{ROBOT_FILE}: {e}"))
        })
        .clone()
}

/// suspended-8's setpoint range.
#[allow(dead_code)]
pub fn setpoint_range() -> SetpointRange {
    SetpointRange::for_robot(&suspended8())
}

/// suspended-8's motor torque limit, N m.
#[allow(dead_code)]
pub fn torque_max() -> f32 {
    suspended8().winch().expect("suspended-8 has a winch").torque_max
}
