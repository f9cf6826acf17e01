//! The winch drives on the board's CAN buses: CiA 402 servo drives in
//! cyclic synchronous torque mode (CSP's torque sibling, mode of operation
//! 0x6060 = 10), started and supervised by CANopen (CiA 301), behind
//! `cdpr-control`'s [`WinchDrives`](cdpr_control::WinchDrives). Hardware
//! free and `no_std`: the board gives it two [`CanPort`]s (bxCAN on CAN1
//! and CAN2, `embedded-can` at the boundary), the tests and `hal-sim` give
//! it the simulated bus of [`sim`].
//!
//! Its own crate rather than a module of `cdpr-control`: it depends on a
//! CANopen stack (`canopen-rs`) and on `embedded-can`, which the
//! control loop, the simulator's other users and the PWM path do not
//! need, and it is the one place that knows the CiA 301/402 objects.
//!
//! * [`frame`]: the frames (COB-IDs of the predefined connection set,
//!   [`RawFrame`]) and their worst-case length on the wire;
//! * [`cia402`]: the device state machine (statusword 0x6041 decoded,
//!   controlword 0x6040 commands);
//! * [`config`]: what a drive is set to (node id, rated torque, the PDO
//!   mappings) and the timing (timeouts in control cycles);
//! * [`node`]: one drive as the board sees it: start-up (boot-up, SDO
//!   configuration, NMT start), the state machine, the cyclic data and the
//!   faults;
//! * [`drives`]: [`CanDrives`], the eight drives on two buses as a
//!   `WinchDrives`, and the emergency stop's frames;
//! * [`model`] (feature `model`, no_std): a CiA 402 drive model at frame
//!   level and an in-memory loopback port;
//! * [`sim`] (feature `sim`, std): a 1 Mbit/s bus that delivers frames
//!   with their transmission time in arbitration order, and the eight
//!   drives on two of them.
//!
//! `canopen-rs` (no_std, no allocation) supplies the CiA 301 codecs used at
//! start-up: the SDO client, NMT commands, heartbeat states and EMCY
//! frames. The cyclic frames (one 2-byte RPDO and one 4-byte TPDO per drive
//! and cycle) are packed here directly: they are fixed by the mapping this
//! crate writes, and the generic mapping code would cost instructions in
//! every control step for nothing.

#![cfg_attr(not(feature = "sim"), no_std)]

pub mod cia402;
pub mod config;
pub mod drives;
pub mod frame;
#[cfg(feature = "model")]
pub mod model;
pub mod node;
#[cfg(feature = "sim")]
pub mod sim;

pub use config::{
    added_loop_delay_ns, check_layout, drives_per_bus_max, last_position_ns, DriveConfig, LayoutError,
    Timing, BOARD_DRIVES_PER_BUS, BOARD_LOOP_DELAY_NS,
};
pub use drives::{emergency_frames, CanDrives, CanDrivesError, CanPort, ENABLES_PER_CYCLE};
pub use frame::RawFrame;
