//! The per-cycle control logic, free of hardware types (it names no PAC,
//! RTIC or cortex-m item), so that it can move into a shared crate and be
//! tested on the host. The hardware it needs is behind the small traits
//! below; `crate::board` implements them for the STM32F405.

pub mod controller;
pub mod robot;
pub mod stats;
pub mod trajectory;

/// A free-running counter (wrapping, 32 bits) used to time code.
pub trait TickCounter {
    /// The current count.
    fn ticks(&self) -> u32;

    /// Ticks elapsed since `start` (wrapping).
    fn since(&self, start: u32) -> u32 {
        self.ticks().wrapping_sub(start)
    }
}

/// Where the motor torque commands go (the winch drives).
pub trait TorqueOutput {
    /// Applies one torque command per cable, N m at the motor.
    fn apply(&mut self, torques: &[f32; robot::CABLES]);
}
