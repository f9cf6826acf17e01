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

/// Encoder readings of cable lengths `lengths` (count 0 at length 0).
#[allow(dead_code)]
pub fn readings_of(control: &cdpr_control::ControlLoop, lengths: &[f32]) -> [cdpr_control::WinchReading; 8] {
    let mut out = [cdpr_control::WinchReading::default(); 8];
    for (i, r) in out.iter_mut().enumerate() {
        r.counts = control.encoder().counts_of(i, lengths[i], 0).expect("a cable's length");
    }
    out
}

/// The readings of an ideal plant that is at the newest good setpoint
/// (it stays where it was when there is none): what the tests that are
/// not about the estimator drive the loop with.
#[allow(dead_code)]
pub fn follow(control: &cdpr_control::ControlLoop, readings: &mut [cdpr_control::WinchReading; 8]) {
    if let Some(s) = control.newest_setpoint() {
        if let Ok(c) = control.controller().robot().cables(&s.pose) {
            *readings = readings_of(control, c.lengths.as_slice());
        }
    }
}

/// Homes `control` at `pose` through the link: `Home`, then one step
/// reading `readings` (the plant at `pose`), which must leave it homed.
#[allow(dead_code)]
pub fn home<D: cdpr_control::WinchDrives>(
    control: &mut cdpr_control::ControlLoop,
    drives: &mut D,
    pose: [f32; 6],
) {
    control.receive(cdpr_control::protocol::HostMessage::Home(pose));
    control.step(&cdpr_control::NoClock, drives, false);
    assert!(control.homed(), "not homed at {pose:?}");
}

/// The ideal plant's readings at `pose`.
#[allow(dead_code)]
pub fn readings_at(control: &cdpr_control::ControlLoop, pose: [f32; 6]) -> [cdpr_control::WinchReading; 8] {
    let c =
        control.controller().robot().cables(&cdpr_control::setpoint::Pose6::from(pose)).expect("kinematics");
    readings_of(control, c.lengths.as_slice())
}

/// suspended-8's control loop with the barycenter and the default safety
/// limits, as the firmware starts it.
#[allow(dead_code)]
pub fn control_loop() -> cdpr_control::ControlLoop {
    cdpr_control::ControlLoop::new(
        suspended8(),
        tension_core::Method::Barycenter,
        setpoint_range(),
        cdpr_control::supervisor::SafetyLimits::DEFAULT,
    )
    .expect("suspended-8's control loop")
}

/// Drives that take any command and whose encoders read `readings` (an
/// ideal plant the test moves, e.g. with [`follow`]).
#[allow(dead_code)]
pub struct IdealDrives {
    /// What the encoders read.
    pub readings: [cdpr_control::WinchReading; 8],
}

impl cdpr_control::WinchDrives for IdealDrives {
    type Error = ();
    fn apply(&mut self, _: &[f32; 8]) -> Result<(), ()> {
        Ok(())
    }
    fn set_brakes(&mut self, _: bool) -> Result<(), ()> {
        Ok(())
    }
    fn read(&mut self, readings: &mut [cdpr_control::WinchReading; 8]) -> Result<(), ()> {
        *readings = self.readings;
        Ok(())
    }
}

/// A feasible pose of suspended-8 at rest (low in the middle, as the demo
/// starts), setpoint `seq`.
#[allow(dead_code)]
pub fn low(seq: u32) -> cdpr_control::protocol::Setpoint {
    cdpr_control::protocol::Setpoint {
        seq,
        pose: [0.0, 0.0, 1.82, 0.0, 0.0, 0.0],
        velocity: [0.0; 6],
        acceleration: [0.0; 6],
    }
}

/// Cycle `k` of a straight line at `speed` m/s in x from [`low`] (the
/// step from rest to the speed is a constant acceleration in between).
#[allow(dead_code)]
pub fn moving_x(seq: u32, k: u32, speed: f32) -> cdpr_control::protocol::Setpoint {
    let mut s = low(seq);
    s.pose[0] = speed * 0.001 * k as f32;
    s.velocity[0] = speed;
    s
}
