//! The periodic release every program's control loop runs on: absolute
//! releases on the monotonic, `next = previous + 1 ms`, so that the loop's
//! period does not drift with the steps' cost.
//!
//! After an overrun (the cycle ended at or after its deadline) the next
//! release is a whole period from now, not the missed deadline: releasing
//! at once would run the late cycles back to back, each with less than a
//! period since the last, which the control step (its setpoint
//! extrapolation, the staleness count) takes to be 1 ms apart. A late
//! cycle is lost instead, and the state machine counts the overrun.

use rtic_monotonics::fugit::ExtU32;
use rtic_monotonics::Timebase;

use crate::mono::{Instant, Mono};

/// The control period, in monotonic ticks (ms).
pub const PERIOD_MS: u32 = 1;

/// Releases of a periodic loop.
pub struct Releases {
    release: Instant,
}

impl Releases {
    /// Waits for the next monotonic tick, so that the first cycle has a
    /// whole period, and returns the releases from it.
    pub async fn start() -> Self {
        let release = Mono::now() + PERIOD_MS.millis();
        Mono::delay_until(release).await;
        Self { release }
    }

    /// Ends the current cycle: whether it overran its deadline (the next
    /// release), then waits for the next release.
    pub async fn next(&mut self) -> bool {
        let deadline = self.release + PERIOD_MS.millis();
        let now = Mono::now();
        let overrun = now >= deadline;
        self.release = if overrun { now + PERIOD_MS.millis() } else { deadline };
        Mono::delay_until(self.release).await;
        overrun
    }
}
