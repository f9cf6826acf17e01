//! # hal-sim
//!
//! The firmware's per-cycle logic (`cdpr-control`: setpoint to torques,
//! the safety state machine, the serial link's meaning) in closed loop on
//! the host, against a simulated robot (suspended-8 by default; any
//! 6-DOF, 8-cable robot file with `--robot`, [`site`]):
//!
//! * [`plant`]: winches (current loop, torque limit, Coulomb and viscous
//!   friction, holding brake with an engagement delay, encoders) on
//!   elastic cables that only pull, and the platform as a 6-DOF rigid body
//!   (RK4 at 10 kHz); it implements `cdpr_control::WinchDrives`;
//! * [`link`]: the serial link (byte queues with a line rate) the host's
//!   `cdpr_protocol` frames cross, and the clocks (`TickCounter`);
//! * [`scenario`]: the scripted runs (static holds, tracking, faults) with
//!   the task-space PID of `cdpr_control::feedback`;
//! * [`can`]: the winches behind simulated CiA 402 drives on two
//!   simulated 1 Mbit/s CAN buses (`Config::can`), the control loop
//!   writing to the board's `canopen_drives::CanDrives`;
//! * [`output`]: a CSV table and a PNG plot of each run.
//!
//! * [`site`]: the robot file and the poses of its scenarios (suspended-8's
//!   hand-picked ones, or derived from another file's workspace).
//!
//! The models, gains, bounds and results are in `hal-sim/README.md`.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod can;
pub mod link;
pub mod output;
pub mod plant;
pub mod scenario;
pub mod site;

pub use scenario::{run, Config, Outcome, Row, Scenario};
pub use site::Site;
