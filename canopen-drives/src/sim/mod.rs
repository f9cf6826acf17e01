//! A CAN bus and CiA 402 drives to run [`CanDrives`](crate::CanDrives)
//! against without hardware (feature `sim`, std): the tests of this crate
//! and `hal-sim` use them.
//!
//! * [`SimDrive`] ([`crate::model`]): the CiA 402 drive model;
//! * [`SimBus`]: one bus at a bit rate, frames delivered at the end of
//!   their worst-case transmission time, the lowest identifier winning
//!   arbitration among the frames ready when the bus goes idle;
//! * [`SimNetwork`]: a bus with its drives, and [`SimPort`], the board's
//!   controller on it (an `embedded-can` port with a bounded transmit
//!   queue sent in order, as bxCAN's transmit FIFO mode does);
//! * [`SimRig`]: eight drives on two such buses and the board's layer.

mod bus;
mod rig;

pub use crate::model::{Nmt, SimDrive, SimDriveFaults, SimFrame, SimPortError};
pub use bus::{SimBus, SimNetwork, SimPort};
pub use rig::{SimCanDrives, SimRig};
