//! The torque-saturation flags on a robot with more than 8 cables
//! (`robots/spatial6-10.toml`, 10 cables): one flag per cable, each set
//! exactly when that cable's torque was limited to `torque_max`.

use cdpr_control::controller::{Controller, Wrench};
use cdpr_control::setpoint::{Pose6, Setpoint};
use cdpr_control::NoClock;
use robot_file::RobotFile;
use tension_core::Method;

const DRUM_RADIUS: f64 = 0.04;
const GEAR_RATIO: f64 = 8.0;
const EFFICIENCY: f64 = 0.9;

/// spatial6-10 with a winch of the given torque limit (the file has none).
fn controller(torque_max: f64) -> Controller<10> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../robots/spatial6-10.toml");
    let mut file = RobotFile::load(path).expect("robot file");
    file.winch = Some([DRUM_RADIUS, GEAR_RATIO, EFFICIENCY, torque_max]);
    let robot = file.to_robot::<f32, 6, 10>().expect("6 x 10 robot");
    Controller::new(robot, Method::AnalyticCentre).expect("controller")
}

fn centre() -> Setpoint {
    Setpoint {
        seq: 1,
        pose: Pose6::from([0.1, -0.1, 1.0, 0.0, 0.0, 0.05]),
        velocity: Pose6::zeros(),
        acceleration: Pose6::zeros(),
    }
}

#[test]
fn every_cable_of_ten_has_its_own_saturation_flag() {
    // Unlimited in practice: no flag.
    let cycle = controller(1.0e3).step(&centre(), &Wrench::zeros(), &NoClock);
    let free = cycle.result.expect("feasible pose");
    assert!(!free.saturated.any());

    // A limit between the smallest and the largest tension: exactly the
    // cables above it are flagged, including those past the eighth.
    let mut sorted = free.tensions;
    sorted.sort_by(f32::total_cmp);
    let threshold = 0.5 * (sorted[4] + sorted[5]);
    let torque_max = f64::from(threshold) * DRUM_RADIUS / (GEAR_RATIO * EFFICIENCY);
    let limited =
        controller(torque_max).step(&centre(), &Wrench::zeros(), &NoClock).result.expect("feasible");
    for i in 0..10 {
        assert_eq!(limited.saturated.cable(i), limited.tensions[i] > threshold, "cable {i}");
    }
    assert_eq!(limited.saturated.count(), 5);

    // A limit below every tension: all ten flagged.
    let all = controller(1.0e-3).step(&centre(), &Wrench::zeros(), &NoClock).result.expect("feasible");
    assert_eq!(all.saturated.count(), 10);
    assert!(all.saturated.cable(8) && all.saturated.cable(9));
}
