//! The scripted setpoint trajectory: one closed loop of `DURATION_S` seconds,
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

use tension_core::nalgebra::SVector;

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

/// A pose `[x, y, z, rx, ry, rz]` (SPEC "Poses") or one of its derivatives.
pub type Pose6 = SVector<f32, 6>;

/// One cycle's setpoint: pose and its first two time derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setpoint {
    /// Time since the start of the loop, s.
    pub time: f32,
    /// Pose `[x, y, z, rx, ry, rz]`.
    pub pose: Pose6,
    /// Its time derivative.
    pub velocity: Pose6,
    /// Its second time derivative.
    pub acceleration: Pose6,
}

/// The setpoint of control cycle `k` (`t = k PERIOD_S`).
pub fn setpoint(k: u32) -> Setpoint {
    setpoint_at(k as f32 * PERIOD_S)
}

/// The setpoint at time `t`, s.
pub fn setpoint_at(t: f32) -> Setpoint {
    let w = 2.0 * core::f32::consts::PI / DURATION_S;
    let phi = w * t;
    let (s1, c1) = sin_cos(phi);
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
    Setpoint { time: t, pose, velocity, acceleration }
}

/// `(sin x, cos x)` in `f32` arithmetic only; absolute error below `2e-7`
/// for `|x| <= 2 pi` and below `1e-6` for `|x| <= 20` (checked against
/// `f64` on the host). libm's `sinf`/`cosf` compute in
/// `f64`, which the M4F's single-precision FPU emulates in software: about
/// 1.2k instructions per call against some 40 here.
///
/// `x = k pi/2 + r` with `|r| <= pi/4` (Cody-Waite: `pi/2` split in two
/// `f32` parts), then Taylor polynomials of degree 9 (sin) and 10 (cos) in
/// `r` (truncation below `3e-8` on `|r| <= pi/4`), then the quadrant.
pub fn sin_cos(x: f32) -> (f32, f32) {
    const PI_2_HI: f32 = 1.570_796_4; // f32 nearest pi/2
    const PI_2_LO: f32 = -4.371_139e-8; // pi/2 - PI_2_HI
    let k = libm::roundf(x * core::f32::consts::FRAC_2_PI);
    let r = (x - k * PI_2_HI) - k * PI_2_LO;
    let r2 = r * r;
    let s =
        r * (1.0 + r2 * (-1.0 / 6.0 + r2 * (1.0 / 120.0 + r2 * (-1.0 / 5040.0 + r2 * (1.0 / 362_880.0)))));
    let c = 1.0
        + r2 * (-0.5
            + r2 * (1.0 / 24.0 + r2 * (-1.0 / 720.0 + r2 * (1.0 / 40_320.0 + r2 * (-1.0 / 3_628_800.0)))));
    match (k as i32) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}
