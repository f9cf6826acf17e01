//! The demo's setpoint trajectory: one closed loop of `DURATION_S` seconds,
//! given analytically so that velocity and acceleration are exact.
//!
//! With the phase `phi = 2 pi t / DURATION_S`:
//! * `x = AX sin(phi)`, `y = AY sin(2 phi)`: the platform crosses the
//!   workspace from side to side (`x` from `+AX` to `-AX`);
//! * `z = ZC - AZ cos(phi)`: it starts low (`ZC - AZ`), rises to `ZC + AZ`
//!   at mid-run and comes back. Near the top the attachment points climb to
//!   the anchors' height, so no tensions within `[t_min, t_max]` balance the
//!   weight: the pose leaves the wrench-feasible workspace (once), and the
//!   controller must report `infeasible` there, not crash;
//! * small rotations `rx = RX sin(2 phi)`, `ry = RY sin(phi)`, `rz = RZ sin(phi)`.
//!
//! The peak accelerations stay a few m/s^2, so the d'Alembert wrench matters
//! but does not dominate gravity.
//!
//! The demo's cycle-time run ([`script`]) puts two stretches before the
//! loop, both while the robot is still disabled (the solver runs every
//! cycle in every state, so they are timed like the rest):
//! * [`REST_CYCLES`] cycles at rest at suspended-8's centre [`CENTRE`], a
//!   symmetric pose where pairs of cables are alike (the warm start must hold
//!   there);
//! * [`JUMP_CYCLES`] cycles that jump every cycle between the poses of
//!   [`JUMP_TIMES`] across the workspace, so that the warm start stops
//!   holding and the solver starts cold.
//!
//! The robot is enabled at the loop's start ([`PRELUDE_CYCLES`]); the jumps
//! happen before, because the link rejects a jump in motion (its change is
//! not what its velocity says).

use cdpr_control::setpoint::{Pose6, Setpoint};
use tension_core::Real;

/// Control period, s.
pub const PERIOD_S: f32 = 0.001;
/// Length of the loop, s.
pub const DURATION_S: f32 = 4.0;
/// Number of control cycles in the loop (`DURATION_S / PERIOD_S`).
pub const CYCLES: usize = 4000;

/// Amplitude of `x`, m.
pub const AX: f32 = 0.9;
/// Amplitude of `y`, m.
pub const AY: f32 = 0.4;
/// Centre of `z`, m.
pub const ZC: f32 = 2.57;
/// Amplitude of `z`, m (top at `ZC + AZ` = 3.32 m, above the feasible region).
pub const AZ: f32 = 0.75;
/// Amplitude of `rx`, rad.
pub const RX: f32 = 0.1;
/// Amplitude of `ry`, rad.
pub const RY: f32 = 0.08;
/// Amplitude of `rz`, rad.
pub const RZ: f32 = 0.2;

/// Cycles at rest at [`CENTRE`] at the start of [`script`].
pub const REST_CYCLES: u32 = 300;
/// Cycles of jumps between poses after the rest.
pub const JUMP_CYCLES: u32 = 300;
/// Cycles before the loop starts in [`script`].
pub const PRELUDE_CYCLES: u32 = REST_CYCLES + JUMP_CYCLES;
/// Cycles of the demo's whole run: the prelude, then one loop.
pub const SCRIPT_CYCLES: usize = PRELUDE_CYCLES as usize + CYCLES;
/// suspended-8's centre: `(0, 0, 1.8)` m, no rotation.
pub const CENTRE: [f32; 6] = [0.0, 0.0, 1.8, 0.0, 0.0, 0.0];
/// Times of the loop (s) whose setpoints the jump stretch visits in turn:
/// feasible poses far apart (both sides, low and halfway up), with their
/// velocities and accelerations.
pub const JUMP_TIMES: [f32; 6] = [0.0, 1.5, 0.5, 3.5, 1.0, 2.9];

/// The demo's setpoint of cycle `k` (sequence number `k + 1`): at rest at
/// [`CENTRE`] for [`REST_CYCLES`], jumping between the poses of
/// [`JUMP_TIMES`] for [`JUMP_CYCLES`], then the loop ([`setpoint`]).
pub fn script(k: u32) -> Setpoint {
    let seq = k.wrapping_add(1);
    if k < REST_CYCLES {
        let zero = Pose6::zeros();
        Setpoint { seq, pose: Pose6::from(CENTRE), velocity: zero, acceleration: zero }
    } else if k < PRELUDE_CYCLES {
        let t = JUMP_TIMES[(k - REST_CYCLES) as usize % JUMP_TIMES.len()];
        Setpoint { seq, ..setpoint_at(t) }
    } else {
        Setpoint { seq, ..setpoint(k - PRELUDE_CYCLES) }
    }
}

/// The setpoint of control cycle `k` (`t = k PERIOD_S`, sequence number `k + 1`).
pub fn setpoint(k: u32) -> Setpoint {
    Setpoint { seq: k.wrapping_add(1), ..setpoint_at(k as f32 * PERIOD_S) }
}

/// The setpoint at time `t`, s (sequence number 0).
pub fn setpoint_at(t: f32) -> Setpoint {
    let w = 2.0 * core::f32::consts::PI / DURATION_S;
    let phi = w * t;
    let (s1, c1) = phi.sin_cos_native();
    let (s2, c2) = (2.0 * s1 * c1, c1 * c1 - s1 * s1);
    let w2 = w * w;
    // Each coordinate is `A sin(n phi)` or `C - A cos(n phi)`.
    let pose = Pose6::from([AX * s1, AY * s2, ZC - AZ * c1, RX * s2, RY * s1, RZ * s1]);
    let velocity = Pose6::from([
        AX * w * c1,
        2.0 * AY * w * c2,
        AZ * w * s1,
        2.0 * RX * w * c2,
        RY * w * c1,
        RZ * w * c1,
    ]);
    let acceleration = Pose6::from([
        -AX * w2 * s1,
        -4.0 * AY * w2 * s2,
        AZ * w2 * c1,
        -4.0 * RX * w2 * s2,
        -RY * w2 * s1,
        -RZ * w2 * s1,
    ]);
    Setpoint { seq: 0, pose, velocity, acceleration }
}
