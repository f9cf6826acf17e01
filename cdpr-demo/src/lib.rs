//! What the firmware's demo run and `cargo xtask` share, defined once:
//!
//! * [`trajectory`]: the scripted setpoint trajectory the demo follows and
//!   the end-to-end test streams, as [`trajectory::Params`] per robot;
//! * `derive` (feature `std`, host only): those parameters from a robot,
//!   for the firmware's `build.rs` and for `xtask`;
//! * [`report`]: the typed records the demo logs, postcard-encoded, for
//!   `xtask` to decode;
//! * [`methods`]: which methods the board offers, from their measured
//!   worst cases against the [`BUDGET`];
//! * [`BUDGET`], [`EXPECTED_STATES`], the [`exit`] codes: what the demo's
//!   verdict is made of;
//! * [`stress`]: the stress set of hard poses for the board's worst-case
//!   measurement (`cargo xtask stress`);
//! * [`winches`]: the stand-in for the winch encoders on a board without
//!   winches (QEMU): cables that follow the setpoint with a lag;
//! * [`qemu`]: the emulator's machine and its `-icount` setting, which the
//!   firmware's tick conversion assumes.
//!
//! `no_std`: the firmware builds it for the board, `xtask` for the host.

#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

#[cfg(feature = "std")]
extern crate std;

#[cfg(feature = "std")]
pub mod derive;
pub mod methods;
pub mod report;
pub mod stress;
pub mod trajectory;
pub mod winches;

use cdpr_control::protocol::State;

/// Instruction budget of one control step (QEMU; cycles on the board):
/// the demo passes only when every step is within it.
pub const BUDGET: u32 = 20_000;

/// Instructions in one 1 ms period under QEMU (`-icount shift=3`: 8 ns
/// each): a step that takes longer overruns.
pub const PERIOD_INSTRUCTIONS: u32 = (1_000_000u64 >> qemu::ICOUNT_SHIFT) as u32;

/// What one cycle's receive work in the control step under any flood may
/// take (a cycle's `cdpr_control::FRAME_BUDGET` of frames), so that with a
/// step at the [`BUDGET`] the cycle stays within 3/4 of
/// [`PERIOD_INSTRUCTIONS`].
pub const RECEIVE_LIMIT: u32 = PERIOD_INSTRUCTIONS * 3 / 4 - BUDGET;

/// What the receive interrupt's framing of one byte may take (a frame's
/// hand-off at its delimiter included): at 460 800 baud (46 bytes a
/// millisecond) that is at most a twentieth of the period, and it delays
/// the control step by at most this much at a time.
pub const FRAMING_LIMIT: u32 = 1_000;

/// The states the demo goes through, in order: Enabled, Holding (the pose
/// leaves the workspace), Fault (held too long), Disabled (the scripted
/// operator clears the fault), Enabled.
pub const EXPECTED_STATES: [State; 6] =
    [State::Disabled, State::Enabled, State::Holding, State::Fault, State::Disabled, State::Enabled];

/// The cycle at which the fault-injection programs fault (enabled and
/// moving at that point).
pub const INJECT_AT: u32 = 1000;

/// Exit codes of the firmware's programs (semihosting, under QEMU).
pub mod exit {
    /// The demo's verdict: pass.
    pub const PASS: i32 = 0;
    /// Base of the demo's "fail" verdict; the low bits say why ([`fail`]).
    pub const FAIL: i32 = 32;
    /// After a panic (the drives stopped first).
    pub const PANIC: i32 = 101;
    /// After a HardFault (the drives stopped first).
    pub const HARDFAULT: i32 = 102;

    /// Failure flags, or-ed into [`FAIL`].
    pub mod fail {
        /// Some step took more than [`crate::BUDGET`].
        pub const BUDGET: i32 = 1;
        /// Some step missed its deadline.
        pub const OVERRUN: i32 = 2;
        /// The timer calibration disagrees with the icount relation.
        pub const CALIBRATION: i32 = 4;
        /// The trajectory never left the workspace, or a cycle failed with
        /// something other than `infeasible`.
        pub const STATUS: i32 = 8;
        /// The states differed from [`crate::EXPECTED_STATES`].
        pub const STATES: i32 = 16;

        /// Every flag with what it means.
        pub const ALL: [(i32, &str); 5] = [
            (BUDGET, "a control step over budget"),
            (OVERRUN, "deadline overruns"),
            (CALIBRATION, "the timer check failed"),
            (STATUS, "unexpected statuses"),
            (STATES, "unexpected state sequence"),
        ];
    }
}

/// The emulator the firmware runs in (`qemu-run`'s arguments).
pub mod qemu {
    /// QEMU's machine: an STM32F405 board.
    pub const MACHINE: &str = "netduinoplus2";
    /// Its core.
    pub const CPU: &str = "cortex-m4";
    /// `-icount shift=N`: every instruction advances virtual time by `2^N`
    /// ns (a deterministic 125 MIPS CPU at 3).
    pub const ICOUNT_SHIFT: u32 = 3;
}
