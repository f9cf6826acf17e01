//! The cable robot's per-cycle control logic, free of hardware: it names no
//! PAC, RTIC or cortex-m item, so the firmware runs it on the board and
//! `hal-sim` runs the same code on the host.
//!
//! * [`controller`]: setpoint -> wrench matrix and required wrench ->
//!   barycenter tensions (warm-started) -> motor torques;
//! * [`supervisor`]: the safety state machine (disabled, enabled, holding,
//!   fault) that decides what reaches the winches;
//! * [`link`]: what the serial protocol's frames mean (sequence order,
//!   value ranges) and the counters of rejected frames;
//! * [`control_loop`]: the three together, one call per millisecond;
//! * [`feedback`]: the two feedback schemes (task-space PID on the
//!   estimated pose, joint-space PID on the cable lengths);
//! * [`point_buffer`]: timed trajectory points in, one cubic Hermite
//!   setpoint per cycle out (what the link's budget allows);
//! * [`drives`]: the winch trait (torques and brakes out, encoder
//!   readings in), with an embedded-hal 1.0 PWM adapter;
//! * [`quadrature`]: 16-bit quadrature counters extended to 32-bit counts
//!   and a speed, and the direct path (`DirectDrives`: PWM amplifiers and a
//!   counter per cable) beside the CAN drives of `canopen-drives`;
//! * [`ls7366r`]: the LS7366R SPI quadrature counter chip, the direct
//!   path's counter for cables beyond the microcontroller's timers;
//! * [`encoder`]: encoder counts to cable lengths, and the homing offsets;
//! * [`estimator`]: the pose and twist estimate from the cable lengths (a
//!   Gauss-Newton step of the forward kinematics each cycle);
//! * [`setpoint`]: the setpoint the controller acts on;
//! * [`robot`]: the robot shape the loop runs (6 DOF, 8 cables; the robot
//!   itself comes from a robot file);
//! * [`stats`]: allocation-free cost statistics.
//!
//! The hardware this needs is behind two small traits: [`TickCounter`] (a
//! free-running counter to time code) and [`drives::WinchDrives`].

#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod control_loop;
pub mod controller;
pub mod drives;
pub mod encoder;
pub mod estimator;
pub mod feedback;
pub mod link;
pub mod ls7366r;
pub mod point_buffer;
pub mod quadrature;
pub mod robot;
pub mod setpoint;
pub mod stats;
pub mod supervisor;

pub use cdpr_protocol as protocol;
pub use control_loop::{
    BackOff, ControlLoop, FrameSource, MethodSet, SliceFrames, StepReport, FEEDBACK_RECOVERY_PER_CYCLE,
    FEEDBACK_SCALE_MIN, FRAME_BUDGET, RECEIVE_BUDGET,
};
pub use drives::{WinchDrives, WinchReading};
pub use robot::{ControlRobot, CABLES, DOF};
pub use setpoint::Setpoint;

/// A free-running counter (wrapping, 32 bits) used to time code.
pub trait TickCounter {
    /// The current count.
    fn ticks(&self) -> u32;

    /// Ticks elapsed since `start` (wrapping).
    fn since(&self, start: u32) -> u32 {
        self.ticks().wrapping_sub(start)
    }
}

/// A counter that never advances, for callers that do not time the step.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoClock;

impl TickCounter for NoClock {
    fn ticks(&self) -> u32 {
        0
    }
}
