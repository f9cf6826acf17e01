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
