//! What the firmware's demo run and `cargo xtask` share: the scripted
//! setpoint trajectory the demo follows and the end-to-end test streams
//! ([`trajectory`]).
//!
//! `no_std`: the firmware builds it for the board, `xtask` for the host.

#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod trajectory;
