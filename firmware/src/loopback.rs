//! The demo's winch drives: the board's [`Drives`] (the emergency stop's
//! latch, the last command, the encoders' stand-in) with the CiA 402 drive
//! layer in front of them, its frames looped back in memory to a drive
//! model per cable ([`LoopbackRig`]). The measured step then runs the
//! layer's `read` and `apply` (frames in, each drive's checks, the
//! torques, controlwords and SYNCs out) as the board with CAN drives does;
//! the models answer between steps, outside the measurement
//! ([`DemoDrives::advance`]), with the stand-in's counts as their position.
//!
//! The product (`firmware`) in QEMU keeps the board's drives alone, and so
//! does the demo unless built with `CDPR_DEMO_CAN_LAYER` set
//! ([`LAYER_IN_STEP`]). The test command runs that build for suspended-8
//! and ipanema1 and holds their steps to the 20 000-instruction budget
//! (19 561 and 19 719 worst: `BENCHMARKS.md`).

use canopen_drives::model::LoopbackRig;
use canopen_drives::{CanDrivesError, Timing};
use cdpr_control::protocol::DriveFault;
use cdpr_control::{WinchDrives, WinchReading, CABLES};

use crate::drives::{DriveError, Drives};

/// The control period, ns.
const PERIOD_NS: u64 = 1_000_000;

/// Cycles the drives' start-up may take (boot-up, the SDO configuration
/// and NMT start of eight drives: about 30 with the models answering every
/// cycle).
pub const START_CYCLES: u32 = 500;

/// Whether the demo's measured step runs the drive layer: set by building
/// with the environment variable `CDPR_DEMO_CAN_LAYER` (any value), e.g.
/// `CDPR_DEMO_CAN_LAYER=1 cargo xtask run`.
pub const LAYER_IN_STEP: bool = option_env!("CDPR_DEMO_CAN_LAYER").is_some();

/// The board's drives, behind the CiA 402 layer when there is one.
pub struct DemoDrives<'a> {
    /// The emergency stop's latch, the last command and the stand-in.
    pub board: &'a mut Drives,
    /// The layer and the drive models (`None`: the board's drives alone).
    pub rig: Option<&'a mut LoopbackRig>,
}

/// Why the demo's drives refused or could not be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DemoDriveError {
    /// The board's drives (the emergency stop has run; no stand-in).
    Board(DriveError),
    /// The drive layer.
    Can(CanDrivesError),
}

/// The layer and eight models for the robot file's drives (each model with
/// the file's rated torque; NaN gives 0, which fails the start-up check).
pub fn rig() -> LoopbackRig {
    let rated = crate::robot::RATED_TORQUE * 1000.0;
    let rated_mnm = if rated.is_finite() && rated > 0.0 { rated as u32 } else { 0 };
    LoopbackRig::new(crate::robot::drive_configs(), rated_mnm, Timing::DEFAULT)
}

/// The rig for the measured step, built in `slot` (a static of the
/// program's `init`, so that its 6.4 KB never sit on the control task's
/// stack), when the build asks for the layer in the step
/// ([`LAYER_IN_STEP`]); `None` otherwise. Not inlined: the rig is moved
/// through this function's frame only, never beside `init`'s others
/// (e.g. [`crate::Board::start_in`]'s).
#[inline(never)]
pub fn rig_for_the_step(slot: &'static mut Option<LoopbackRig>) -> Option<&'static mut LoopbackRig> {
    LAYER_IN_STEP.then(|| slot.insert(rig()))
}

impl DemoDrives<'_> {
    /// The drives' start-up, untimed (before the run: an operator homes
    /// and enables once the drives are up); whether every drive came up.
    pub fn start(&mut self) -> bool {
        self.sync_encoders();
        self.rig.as_mut().is_none_or(|rig| rig.start(START_CYCLES, PERIOD_NS))
    }

    /// One period outside the measured step: the stand-in follows
    /// `target`, the models take its counts and answer the layer's frames.
    pub fn advance(&mut self, target: Option<&[f32; CABLES]>) {
        self.board.advance(target);
        self.sync_encoders();
        if let Some(rig) = self.rig.as_mut() {
            rig.deliver(PERIOD_NS);
        }
    }

    fn sync_encoders(&mut self) {
        let Some(rig) = self.rig.as_mut() else { return };
        let mut readings = [WinchReading::default(); CABLES];
        if self.board.read(&mut readings).is_ok() {
            rig.set_positions(&readings.map(|r| r.counts));
        }
    }
}

impl WinchDrives for DemoDrives<'_> {
    type Error = DemoDriveError;

    fn apply(&mut self, torques: &[f32; CABLES]) -> Result<(), DemoDriveError> {
        self.board.apply(torques).map_err(DemoDriveError::Board)?;
        match self.rig.as_mut() {
            Some(rig) => rig.layer.apply(torques).map_err(DemoDriveError::Can),
            None => Ok(()),
        }
    }

    fn set_brakes(&mut self, engaged: bool) -> Result<(), DemoDriveError> {
        self.board.set_brakes(engaged).map_err(DemoDriveError::Board)?;
        match self.rig.as_mut() {
            Some(rig) => rig.layer.set_brakes(engaged).map_err(DemoDriveError::Can),
            None => Ok(()),
        }
    }

    /// The positions and speeds the drives reported over the layer (the
    /// stand-in's counts without one).
    fn read(&mut self, readings: &mut [WinchReading; CABLES]) -> Result<(), DemoDriveError> {
        match self.rig.as_mut() {
            Some(_) if crate::drives::stopped() => Err(DemoDriveError::Board(DriveError::Stopped)),
            Some(rig) => rig.layer.read(readings).map_err(DemoDriveError::Can),
            None => self.board.read(readings).map_err(DemoDriveError::Board),
        }
    }

    fn failed_drive(&self, error: &DemoDriveError) -> Option<usize> {
        match error {
            DemoDriveError::Can(e) => self.rig.as_ref().and_then(|r| r.layer.failed_drive(e)),
            DemoDriveError::Board(e) => self.board.failed_drive(e),
        }
    }

    fn drive_fault(&self, error: &DemoDriveError) -> Option<DriveFault> {
        match error {
            DemoDriveError::Can(e) => self.rig.as_ref().and_then(|r| r.layer.drive_fault(e)),
            DemoDriveError::Board(e) => self.board.drive_fault(e),
        }
    }

    fn clear_faults(&mut self) {
        self.board.clear_faults();
        if let Some(rig) = self.rig.as_mut() {
            rig.layer.clear_faults();
        }
    }
}
