//! The winches behind simulated CiA 402 drives on two simulated 1 Mbit/s
//! CAN buses (`canopen_drives::sim`), the control loop's `WinchDrives`
//! being the board's `canopen_drives::CanDrives`: the same start-up,
//! latency and quantisation as on the board.
//!
//! Within each 1 ms cycle the control step runs at its start; its frames
//! go on the bus [`STEP_NS`] later (the step's length on the board, about
//! 17 000 cycles at 168 MHz); then the cycle is integrated in 0.1 ms
//! pieces: before each, every drive takes its motor's position from the
//! plant (so a SYNC samples a position at most 0.1 ms old); the buses
//! run 0.1 ms (the drives apply the torques at the SYNC, answer with
//! positions and statuswords); the plant integrates 0.1 ms with each
//! drive's torque, the brakes engaged while any drive's is (a drive keeps
//! its torque for the brake's 20 ms engagement time after it is disabled,
//! unless it faulted).

use canopen_drives::sim::{SimCanDrives, SimRig};
use canopen_drives::{DriveConfig, Timing};
use cdpr_control::{WinchDrives, WinchReading, CABLES};

use crate::plant::Plant;

/// When in a cycle the board's frames go out, ns.
pub const STEP_NS: u64 = 100_000;

/// Pieces a cycle is integrated in.
const PIECES: u64 = 10;

/// A fault of the drives or the buses, injected at the scenario's event.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CanFault {
    /// Cable `cable`'s drive faults with EMCY `code` (e.g. 0x2310
    /// over-current).
    DriveFault {
        /// The cable.
        cable: usize,
        /// The EMCY error code.
        code: u16,
    },
    /// Cable `cable`'s drive drops off its bus (sends and hears nothing).
    DropOff {
        /// The cable.
        cable: usize,
    },
    /// Bus `bus` (0 CAN1, 1 CAN2) goes bus-off at the board.
    BusOff {
        /// The bus.
        bus: usize,
    },
}

/// The buses, their drives and the board's layer.
#[derive(Debug)]
pub struct CanWinches {
    /// The simulated buses and drives.
    pub rig: SimRig,
    /// The board's layer (the control loop's `WinchDrives`).
    pub layer: SimCanDrives,
}

impl CanWinches {
    /// The drives of the robot file's `[winch]` (node ids, buses, rated
    /// torque, `torque_max`); refused as the board's build refuses them
    /// when a bus has more drives than it serves
    /// (`canopen_drives::check_layout`).
    pub fn for_robot_file(file: &robot_file::RobotFile) -> Result<Self, String> {
        let winch = file.winch.ok_or("the robot file has no [winch]")?;
        let rated = file.drives.rated_torque.ok_or("the robot file's [winch] has no rated_torque")?;
        if file.cables.len() != CABLES {
            return Err(format!("{} cables, the board has {CABLES}", file.cables.len()));
        }
        let buses = file.drives.bus_indices();
        canopen_drives::check_layout(&buses).map_err(|e| format!("[winch] can_bus: {e}"))?;
        let configs: [DriveConfig; CABLES] = core::array::from_fn(|i| DriveConfig {
            bus: buses[i],
            node: file.drives.node_ids[i],
            rated_torque: rated as f32,
            torque_max: winch[3] as f32,
        });
        let (mut rig, layer) = SimRig::new(configs, Timing::DEFAULT, None);
        rig.step_ns = STEP_NS;
        Ok(Self { rig, layer })
    }

    /// Before the control step: the board's frames of this cycle go out
    /// [`STEP_NS`] into it.
    pub fn before_step(&mut self) {
        self.rig.before_step();
    }

    /// Whether every drive's brake is engaged (one bit per cable).
    pub fn brakes(&self) -> u8 {
        (0..CABLES).fold(0u8, |b, i| b | (u8::from(self.rig.drive(i).brake_engaged()) << i))
    }

    /// Injects `fault` now.
    pub fn inject(&mut self, fault: CanFault) {
        match fault {
            CanFault::DriveFault { cable, code } => {
                self.rig.drive_sends(cable, |d, _, out| d.fail(code, out))
            }
            CanFault::DropOff { cable } => self.rig.cut_off(cable),
            CanFault::BusOff { bus } => self.rig.net(bus).bus_off = true,
        }
    }

    /// One cycle of the buses and the plant after the control step
    /// (`period` s).
    pub fn advance(&mut self, plant: &mut Plant, period: f64) {
        let piece_ns = (period * 1e9).round() as u64 / PIECES;
        let mut readings = [WinchReading::default(); CABLES];
        for _ in 0..PIECES {
            // An injected unreadable drive's readings are still written.
            let _ = plant.read(&mut readings);
            for (i, r) in readings.iter().enumerate() {
                self.rig.drive(i).set_position(r.counts);
            }
            self.rig.advance(piece_ns);
            let now = self.rig.now_ns;
            let torques: [f32; CABLES] = core::array::from_fn(|i| self.rig.drive(i).torque_nm(now) as f32);
            let _ = plant.set_brakes(self.brakes() != 0);
            let _ = plant.apply(&torques);
            plant.advance(piece_ns as f64 * 1e-9);
        }
    }
}
