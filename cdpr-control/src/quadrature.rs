//! The direct path for small winches: quadrature encoders counted by
//! 16-bit hardware counters ([`EncoderCounter`]: an STM32 timer in encoder
//! mode counts the A/B edges into `CNT`), extended to the 32-bit wrapping
//! counts [`WinchReading`] carries ([`Extender`]), with the speed from two
//! reads; and [`DirectDrives`]: the PWM amplifiers of [`PwmDrives`] plus one
//! counter per cable, the `WinchDrives` beside the CAN drives.
//!
//! The extension takes the counter's change since the last read as a
//! signed 16-bit number, so it is right while a cable's motor turns less
//! than 32 767 counts between two reads: at 1 kHz and 4096 counts per turn,
//! 8 000 turns per second.

use crate::drives::{PwmDriveError, PwmDrives, WinchDrives, WinchReading};
use crate::CABLES;
use embedded_hal::digital::OutputPin;
use embedded_hal::pwm::SetDutyCycle;

/// A hardware quadrature counter: its count, modulo 2^16.
pub trait EncoderCounter {
    /// Why the counter could not be read.
    type Error: core::fmt::Debug;
    /// The count now.
    fn count(&mut self) -> Result<u16, Self::Error>;
}

/// A 16-bit count extended to 32 bits (wrapping), and its speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Extender {
    last: Option<u16>,
    counts: i32,
    speed: i32,
}

impl Extender {
    /// Nothing read yet.
    pub const fn new() -> Self {
        Self { last: None, counts: 0, speed: 0 }
    }

    /// The reading of counter value `raw`, `reads_per_second` reads a
    /// second: the counts (the first read is the counter's value) and the
    /// speed from the change since the last read (0 at the first).
    pub fn update(&mut self, raw: u16, reads_per_second: u32) -> WinchReading {
        match self.last {
            None => self.counts = i32::from(raw as i16),
            Some(last) => {
                let delta = i32::from(raw.wrapping_sub(last) as i16);
                self.counts = self.counts.wrapping_add(delta);
                self.speed = delta.saturating_mul(reads_per_second.min(i32::MAX as u32) as i32);
            }
        }
        self.last = Some(raw);
        WinchReading { counts: self.counts, counts_per_second: self.speed }
    }

    /// Forgets the last read (after a counter error: the next change is
    /// unknown, so the next read starts a new count).
    pub fn forget(&mut self) {
        self.last = None;
        self.speed = 0;
    }
}

/// Why [`DirectDrives`] failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DirectDriveError {
    /// The PWM amplifiers' pins.
    Pwm(PwmDriveError),
    /// Cable `i`'s counter could not be read.
    Counter(usize),
}

/// PWM amplifiers and one quadrature counter per cable.
pub struct DirectDrives<P, D, B, E> {
    pwm: PwmDrives<P, D, B>,
    counters: [E; CABLES],
    extenders: [Extender; CABLES],
    reads_per_second: u32,
}

impl<P: SetDutyCycle, D: OutputPin, B: OutputPin, E: EncoderCounter> DirectDrives<P, D, B, E> {
    /// `pwm` with `counters`, read `reads_per_second` times a second (the
    /// control rate).
    pub fn new(pwm: PwmDrives<P, D, B>, counters: [E; CABLES], reads_per_second: u32) -> Self {
        Self { pwm, counters, extenders: [Extender::new(); CABLES], reads_per_second }
    }

    /// The counters (to set them up, e.g. [`crate::ls7366r::Ls7366r::configure`]).
    pub fn counters_mut(&mut self) -> &mut [E; CABLES] {
        &mut self.counters
    }
}

impl<P: SetDutyCycle, D: OutputPin, B: OutputPin, E: EncoderCounter> WinchDrives
    for DirectDrives<P, D, B, E>
{
    type Error = DirectDriveError;

    fn apply(&mut self, torques: &[f32; CABLES]) -> Result<(), DirectDriveError> {
        self.pwm.apply(torques).map_err(DirectDriveError::Pwm)
    }

    fn set_brakes(&mut self, engaged: bool) -> Result<(), DirectDriveError> {
        self.pwm.set_brakes(engaged).map_err(DirectDriveError::Pwm)
    }

    /// Every counter, extended; the first that fails is the error (the
    /// others are still read), and its count restarts.
    fn read(&mut self, readings: &mut [WinchReading; CABLES]) -> Result<(), DirectDriveError> {
        let mut result = Ok(());
        for (i, ((c, e), r)) in
            self.counters.iter_mut().zip(&mut self.extenders).zip(readings.iter_mut()).enumerate()
        {
            match c.count() {
                Ok(raw) => *r = e.update(raw, self.reads_per_second),
                Err(_) => {
                    e.forget();
                    if result.is_ok() {
                        result = Err(DirectDriveError::Counter(i));
                    }
                }
            }
        }
        result
    }

    fn failed_drive(&self, error: &DirectDriveError) -> Option<usize> {
        match *error {
            DirectDriveError::Counter(i)
            | DirectDriveError::Pwm(PwmDriveError::Duty(i) | PwmDriveError::Direction(i)) => Some(i),
            DirectDriveError::Pwm(_) => None,
        }
    }
}
