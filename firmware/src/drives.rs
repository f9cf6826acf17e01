//! The winch drives and the emergency stop.
//!
//! The QEMU board has no drives, so the commands are kept (the last one)
//! and counted. A board port puts its PWM timers and pins behind
//! [`cdpr_control::drives::PwmDrives`] (embedded-hal 1.0) or a CAN driver
//! here, and makes [`emergency_stop`] write zero torque and drop the brake
//! pin directly.

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use cdpr_control::{WinchDrives, CABLES};

/// Set once the emergency stop has run; the drives then refuse commands.
static STOPPED: AtomicBool = AtomicBool::new(false);
/// Bit pattern of every drive's last torque command (for the emergency
/// stop's report and the demo's printout).
static LAST_TORQUES: [AtomicU32; CABLES] = [const { AtomicU32::new(0) }; CABLES];
/// Whether the brakes were last commanded engaged.
static BRAKES: AtomicBool = AtomicBool::new(true);

/// The winch drives.
pub struct Drives {
    writes: u32,
}

impl Drives {
    /// No command yet (torques zero, brakes engaged).
    pub const fn new() -> Self {
        Self { writes: 0 }
    }

    /// Commands written so far.
    pub fn writes(&self) -> u32 {
        self.writes
    }
}

impl Default for Drives {
    fn default() -> Self {
        Self::new()
    }
}

/// Why a drive refused a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DrivesStopped;

impl WinchDrives for Drives {
    type Error = DrivesStopped;

    fn apply(&mut self, torques: &[f32; CABLES]) -> Result<(), DrivesStopped> {
        if STOPPED.load(Ordering::Relaxed) {
            return Err(DrivesStopped);
        }
        for (slot, t) in LAST_TORQUES.iter().zip(torques) {
            slot.store(t.to_bits(), Ordering::Relaxed);
        }
        self.writes = self.writes.wrapping_add(1);
        Ok(())
    }

    fn set_brakes(&mut self, engaged: bool) -> Result<(), DrivesStopped> {
        if STOPPED.load(Ordering::Relaxed) {
            return Err(DrivesStopped);
        }
        BRAKES.store(engaged, Ordering::Relaxed);
        Ok(())
    }
}

/// The torques and brake state last written to the drives.
pub fn drive_outputs() -> ([f32; CABLES], bool) {
    (
        LAST_TORQUES.each_ref().map(|t| f32::from_bits(t.load(Ordering::Relaxed))),
        BRAKES.load(Ordering::Relaxed),
    )
}

/// Stops the motors: zero torque on every drive and the brakes engaged,
/// written directly (no task, no lock: callable from the panic and
/// HardFault handlers), after which the drives refuse further commands.
pub fn emergency_stop() {
    STOPPED.store(true, Ordering::Relaxed);
    for slot in &LAST_TORQUES {
        slot.store(0.0f32.to_bits(), Ordering::Relaxed);
    }
    BRAKES.store(true, Ordering::Relaxed);
}
