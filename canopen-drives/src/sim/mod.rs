//! A CAN bus and CiA 402 drives to run [`CanDrives`](crate::CanDrives)
//! against without hardware (feature `sim`, std): the tests of this crate
//! and `hal-sim` use them.
//!
//! * [`SimDrive`]: a CiA 402 servo drive at frame level, written from CiA
//!   301 and CiA 402 (not from this crate's board side): NMT, heartbeat
//!   and boot-up, an SDO server (expedited) over its object dictionary,
//!   PDO mapping and transmission types, SYNC, the device state machine,
//!   EMCY, and faults a test injects;
//! * [`SimBus`]: one bus at a bit rate, frames delivered at the end of
//!   their worst-case transmission time, the lowest identifier winning
//!   arbitration among the frames ready when the bus goes idle;
//! * [`SimNetwork`]: a bus with its drives, and [`SimPort`], the board's
//!   controller on it (an `embedded-can` port with a bounded transmit
//!   queue sent in order, as bxCAN's transmit FIFO mode does);
//! * [`SimRig`]: eight drives on two such buses and the board's layer.

mod bus;
mod drive;
mod rig;

pub use bus::{SimBus, SimFrame, SimNetwork, SimPort, SimPortError};
pub use drive::{Nmt, SimDrive, SimDriveFaults};
pub use rig::{SimCanDrives, SimRig};
