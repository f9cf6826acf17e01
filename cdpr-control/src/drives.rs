//! The winches: the trait the control loop writes torques and brake
//! commands through and reads the motor encoders from ([`WinchDrives`]),
//! and an adapter that drives winches from embedded-hal 1.0 PWM channels
//! and pins ([`PwmDrives`]), for the common torque-mode servo amplifier
//! with a PWM torque input, a direction input and a brake input (it has
//! no encoder input: its [`WinchDrives::read`] is an error, which keeps
//! the loop unhomed and so out of Enabled).

use embedded_hal::digital::OutputPin;
use embedded_hal::pwm::SetDutyCycle;

use crate::protocol::DriveFault;
use crate::CABLES;

/// One winch's motor encoder: its count (wrapping 32-bit) and speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WinchReading {
    /// Motor encoder counts (wrapping 32-bit; differences are taken with
    /// `wrapping_sub`).
    pub counts: i32,
    /// Motor speed, counts per second (as the drive measures it).
    pub counts_per_second: i32,
}

/// Where the torque commands go and the encoder readings come from: one
/// winch drive per cable plus the winches' holding brakes.
pub trait WinchDrives {
    /// A drive's error (e.g. a bus write failed); the control loop faults on it.
    type Error: core::fmt::Debug;

    /// Commands one motor torque per cable, N m at the motor, each within
    /// `+-torque_max` (the control loop never asks for more).
    fn apply(&mut self, torques: &[f32; CABLES]) -> Result<(), Self::Error>;

    /// Engages (`true`) or releases (`false`) every winch's holding brake.
    fn set_brakes(&mut self, engaged: bool) -> Result<(), Self::Error>;

    /// Reads every winch's motor encoder (count and speed) into
    /// `readings`; an error when a drive cannot be read (the control loop
    /// then faults if Enabled, and forgets its homing).
    fn read(&mut self, readings: &mut [WinchReading; CABLES]) -> Result<(), Self::Error>;

    /// The drive (cable index) a read `error` names, if it names one:
    /// reported in telemetry (`unreadable_drive`). `None` by default.
    fn failed_drive(&self, error: &Self::Error) -> Option<usize> {
        let _ = error;
        None
    }

    /// The drive fault an error of [`WinchDrives::read`] or
    /// [`WinchDrives::apply`] reports, if it is one (a drive that faulted or
    /// dropped off its bus, rather than a reading that failed once): the
    /// control loop then goes to Fault `drive` from any state and reports
    /// it in telemetry (`drive_fault`). `None` by default.
    fn drive_fault(&self, error: &Self::Error) -> Option<DriveFault> {
        let _ = error;
        None
    }

    /// A `ClearFault` was granted (the board is Disabled again, brakes
    /// engaged): the drives may clear what they latched (a CiA 402 fault
    /// reset, a restart of a drive that dropped off its bus). A fault that
    /// is still there reports itself again. Nothing by default.
    fn clear_faults(&mut self) {}
}

/// Why [`PwmDrives`] failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PwmDriveError {
    /// Setting cable `i`'s duty cycle failed.
    Duty(usize),
    /// Setting cable `i`'s direction pin failed.
    Direction(usize),
    /// Setting the brake pin failed.
    Brake,
    /// The PWM amplifiers have no encoder input: the winches cannot be read.
    NoEncoder,
}

/// Winch drives behind embedded-hal 1.0 traits: per cable a PWM channel
/// whose duty is `|torque| / torque_max` of full scale and a direction pin
/// (high for a negative torque, i.e. paying cable out), plus one brake pin
/// (high = brake engaged). A non-finite torque is written as zero.
pub struct PwmDrives<P, D, B> {
    channels: [P; CABLES],
    directions: [D; CABLES],
    brake: B,
    torque_max: f32,
}

impl<P: SetDutyCycle, D: OutputPin, B: OutputPin> PwmDrives<P, D, B> {
    /// Drives with full-scale PWM at `torque_max` (N m, positive).
    pub fn new(channels: [P; CABLES], directions: [D; CABLES], brake: B, torque_max: f32) -> Self {
        Self { channels, directions, brake, torque_max }
    }

    /// The PWM channels, directions and brake pin back.
    pub fn release(self) -> ([P; CABLES], [D; CABLES], B) {
        (self.channels, self.directions, self.brake)
    }
}

/// Duty (0..=max) for `|torque|` with full scale at `torque_max`, rounded
/// to nearest; zero for a non-finite torque or limit.
pub fn duty_for(torque: f32, torque_max: f32, max_duty: u16) -> u16 {
    if !(torque.is_finite() && torque_max.is_finite() && torque_max > 0.0) {
        return 0;
    }
    let fraction = libm::fabsf(torque) / torque_max;
    let fraction = if fraction > 1.0 { 1.0 } else { fraction };
    libm::roundf(fraction * f32::from(max_duty)) as u16
}

impl<P: SetDutyCycle, D: OutputPin, B: OutputPin> WinchDrives for PwmDrives<P, D, B> {
    type Error = PwmDriveError;

    fn apply(&mut self, torques: &[f32; CABLES]) -> Result<(), PwmDriveError> {
        for (i, ((channel, direction), &torque)) in
            self.channels.iter_mut().zip(self.directions.iter_mut()).zip(torques).enumerate()
        {
            let duty = duty_for(torque, self.torque_max, channel.max_duty_cycle());
            let paying_out = torque.is_finite() && torque < 0.0;
            direction.set_state(paying_out.into()).map_err(|_| PwmDriveError::Direction(i))?;
            channel.set_duty_cycle(duty).map_err(|_| PwmDriveError::Duty(i))?;
        }
        Ok(())
    }

    fn set_brakes(&mut self, engaged: bool) -> Result<(), PwmDriveError> {
        self.brake.set_state(engaged.into()).map_err(|_| PwmDriveError::Brake)
    }

    /// Always [`PwmDriveError::NoEncoder`]: a PWM torque input reports no
    /// position. Pair the amplifiers with an encoder interface (a timer in
    /// encoder mode, a CAN drive) to close the loop.
    fn read(&mut self, _readings: &mut [WinchReading; CABLES]) -> Result<(), PwmDriveError> {
        Err(PwmDriveError::NoEncoder)
    }
}
