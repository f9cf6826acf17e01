//! The winch drives and the emergency stop.
//!
//! On the real STM32F405 (`board` feature) the winches are CiA 402 servo
//! drives on CAN1 and CAN2 (`canopen_drives::CanDrives` over
//! `crate::can`): start-up, the state machine, torques out and
//! positions in every cycle, the drives' faults as `Reason::Drive`; the
//! brakes are the drives' brake outputs, and [`emergency_stop`] writes
//! quick stop, zero torque and NMT pre-operational straight into the
//! CAN mailboxes. With the `direct` feature they are PWM amplifiers and
//! quadrature counters instead (`crate::direct`, the one `BoardDrives`
//! of that build).
//!
//! The QEMU board has no drives (QEMU models no bxCAN), so the commands
//! are kept (the last one) and counted, and the encoders are a stand-in
//! ([`cdpr_demo::winches::LagWinches`]: the cables follow the tracked
//! setpoint with a 5 ms lag, read as counts), advanced by the program
//! outside the measured step ([`Drives::advance`]).

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use cdpr_control::setpoint::Pose6;
use cdpr_control::{WinchDrives, WinchReading, CABLES};

/// Set once the emergency stop has run; the drives then refuse commands.
static STOPPED: AtomicBool = AtomicBool::new(false);
/// Bit pattern of every drive's last torque command (for the emergency
/// stop's report and the demo's printout).
static LAST_TORQUES: [AtomicU32; CABLES] = [const { AtomicU32::new(0) }; CABLES];
/// Whether the brakes were last commanded engaged.
static BRAKES: AtomicBool = AtomicBool::new(true);

/// The CiA 402 drives on the board's two CAN controllers.
#[cfg(all(feature = "board", not(feature = "direct")))]
pub type BoardDrives = canopen_drives::CanDrives<
    crate::can::BoardPort<crate::can::Can1>,
    crate::can::BoardPort<crate::can::Can2>,
>;

/// The direct path: PWM amplifiers and quadrature counters (`direct`).
#[cfg(feature = "direct")]
pub type BoardDrives = crate::direct::DirectBoardDrives;

/// The winch drives.
pub struct Drives {
    writes: u32,
    /// The encoders' stand-in (QEMU only; `None` until placed).
    #[cfg(not(feature = "board"))]
    stand_in: Option<cdpr_demo::winches::LagWinches>,
    /// The board's drives (the CAN buses, or the direct path).
    #[cfg(feature = "board")]
    bus: Option<BoardDrives>,
}

impl Drives {
    /// No command yet (torques zero, brakes engaged), no encoders.
    pub const fn new() -> Self {
        Self {
            writes: 0,
            #[cfg(not(feature = "board"))]
            stand_in: None,
            #[cfg(feature = "board")]
            bus: None,
        }
    }

    /// The board's drives (the CAN buses, or with `direct` the PWM path).
    #[cfg(feature = "board")]
    pub fn on_board(bus: BoardDrives) -> Self {
        Self { writes: 0, bus: Some(bus) }
    }

    /// Commands written so far.
    pub fn writes(&self) -> u32 {
        self.writes
    }

    /// Puts the encoders' stand-in at rest at `pose` (QEMU; the real board
    /// has no stand-in: nothing happens). Returns whether it was placed.
    pub fn place_stand_in(&mut self, robot: &cdpr_control::ControlRobot, pose: &Pose6) -> bool {
        #[cfg(not(feature = "board"))]
        {
            let scale = match crate::robot::encoder_scale() {
                Ok(s) => s,
                Err(_) => return false,
            };
            self.stand_in = cdpr_demo::winches::LagWinches::at_pose(robot, scale, pose);
            self.stand_in.is_some()
        }
        #[cfg(feature = "board")]
        {
            let _ = (robot, pose);
            false
        }
    }

    /// One period of the stand-in towards the cable lengths `target` (the
    /// tracked setpoint's, `ControlLoop::last_feasible_lengths`); call
    /// outside the measured step. Nothing on the real board.
    pub fn advance(&mut self, target: Option<&[f32; cdpr_control::CABLES]>) {
        #[cfg(not(feature = "board"))]
        if let Some(w) = &mut self.stand_in {
            w.follow(target, 0.001);
        }
        #[cfg(feature = "board")]
        let _ = target;
    }
}

impl Default for Drives {
    fn default() -> Self {
        Self::new()
    }
}

/// Why a drive refused a command or could not be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DriveError {
    /// The emergency stop has run.
    Stopped,
    /// No encoder to read (QEMU before the stand-in is placed; the board
    /// without its buses).
    NoEncoders,
    /// The board's drives' error (the CAN drives, or the direct path).
    #[cfg(feature = "board")]
    Board(<BoardDrives as WinchDrives>::Error),
}

impl WinchDrives for Drives {
    type Error = DriveError;

    fn apply(&mut self, torques: &[f32; CABLES]) -> Result<(), DriveError> {
        if STOPPED.load(Ordering::Relaxed) {
            return Err(DriveError::Stopped);
        }
        for (slot, t) in LAST_TORQUES.iter().zip(torques) {
            slot.store(t.to_bits(), Ordering::Relaxed);
        }
        self.writes = self.writes.wrapping_add(1);
        #[cfg(feature = "board")]
        if let Some(bus) = &mut self.bus {
            return bus.apply(torques).map_err(DriveError::Board);
        }
        Ok(())
    }

    fn set_brakes(&mut self, engaged: bool) -> Result<(), DriveError> {
        if STOPPED.load(Ordering::Relaxed) {
            return Err(DriveError::Stopped);
        }
        BRAKES.store(engaged, Ordering::Relaxed);
        #[cfg(feature = "board")]
        if let Some(bus) = &mut self.bus {
            return bus.set_brakes(engaged).map_err(DriveError::Board);
        }
        Ok(())
    }

    fn read(&mut self, readings: &mut [WinchReading; CABLES]) -> Result<(), DriveError> {
        if STOPPED.load(Ordering::Relaxed) {
            return Err(DriveError::Stopped);
        }
        #[cfg(not(feature = "board"))]
        if let Some(w) = &self.stand_in {
            *readings = *w.readings();
            return Ok(());
        }
        #[cfg(feature = "board")]
        if let Some(bus) = &mut self.bus {
            return bus.read(readings).map_err(DriveError::Board);
        }
        let _ = readings;
        Err(DriveError::NoEncoders)
    }

    fn failed_drive(&self, error: &DriveError) -> Option<usize> {
        match (error, self.board()) {
            #[cfg(feature = "board")]
            (DriveError::Board(e), Some(bus)) => bus.failed_drive(e),
            _ => None,
        }
    }

    fn drive_fault(&self, error: &DriveError) -> Option<cdpr_control::protocol::DriveFault> {
        match (error, self.board()) {
            #[cfg(feature = "board")]
            (DriveError::Board(e), Some(bus)) => bus.drive_fault(e),
            _ => None,
        }
    }

    fn clear_faults(&mut self) {
        #[cfg(feature = "board")]
        if let Some(bus) = &mut self.bus {
            bus.clear_faults();
        }
    }
}

impl Drives {
    /// The board's drives, if any (none under QEMU).
    #[cfg(feature = "board")]
    fn board(&self) -> Option<&BoardDrives> {
        self.bus.as_ref()
    }

    /// The board's drives, if any (none under QEMU).
    #[cfg(not(feature = "board"))]
    fn board(&self) -> Option<&()> {
        None
    }
}

/// Whether the emergency stop has run (the drives refuse commands since).
pub fn stopped() -> bool {
    STOPPED.load(Ordering::Relaxed)
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
    // The drives' quick stop over both buses (their brakes engage as they
    // leave "operation enabled"); a drive that misses it stops on its own
    // when its RPDO timeout passes with no board (5 ms).
    #[cfg(all(feature = "board", not(feature = "direct")))]
    crate::can::emergency_stop(&crate::robot::drive_configs());
    // The direct path: zero duty, brake pin engaged.
    #[cfg(feature = "direct")]
    crate::direct::emergency_stop();
}
