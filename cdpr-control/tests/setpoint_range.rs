//! The setpoint range derived from suspended-8's anchors
//! (`robots/suspended-8.toml`) is the range the firmware has always used.

mod common;

use cdpr_control::link::SetpointRange;

#[test]
fn setpoint_range_of_suspended8() {
    let expected = SetpointRange {
        position_min: [-2.5, -2.0, -0.5],
        position_max: [2.5, 2.0, 4.0],
        angle_max: 1.0,
        speed_max: 5.0,
        angular_speed_max: 10.0,
        acceleration_max: 50.0,
        angular_acceleration_max: 100.0,
    };
    assert_eq!(common::setpoint_range(), expected);
}
