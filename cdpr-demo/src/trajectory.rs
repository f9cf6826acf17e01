//! The demo's setpoint trajectory, derived from the firmware's robot: one
//! closed loop of `DURATION_S` seconds around the centre of the robot's
//! workspace, plus one excursion out of it, given analytically so that
//! velocity and acceleration are exact. Its numbers are a [`Params`]: the
//! firmware's `build.rs` derives them from the robot file
//! ([`crate::derive`], host side, `f64`, with `tension-core`) and emits
//! them as `firmware::robot::DEMO`; `cargo xtask` derives the same
//! parameters from the same file with the same function.
//!
//! With the phase `phi = 2 pi t / DURATION_S` and the loop's centre `c`
//! and amplitudes `A`:
//! * `x = c_x + A_x sin(phi)`, `y = c_y + A_y sin(2 phi)`: the platform
//!   crosses the workspace from side to side;
//! * `z = c_z - A_z cos(phi)`: it starts low (`c_z - A_z`), rises to
//!   `c_z + A_z` at mid-run and comes back;
//! * small rotations `rx = A_rx sin(2 phi)`, `ry = A_ry sin(phi)`,
//!   `rz = A_rz sin(phi)`.
//!
//! The loop stays feasible with a tension margin at every pose (with its
//! velocities and accelerations). The **excursion** adds the offset
//! `E b(t)` to the position, `E` = [`Params::excursion`], with
//! `b` rising from 0 to 1 over [`Params::excursion_ramp`] seconds
//! (`(1 - cos(pi u)) / 2`), staying at 1 for [`Params::excursion_hold`]
//! and falling back the same way, from [`Params::excursion_start`] on:
//! the pose leaves the wrench-feasible workspace (once, long enough for a
//! hold to time out), stays within the setpoint range, and the controller
//! must report `infeasible` there, not crash.
//!
//! The demo's cycle-time run ([`Params::script`]) puts two stretches before
//! the loop, both while the robot is still disabled (the solver runs every
//! cycle in every state, so they are timed like the rest):
//! * [`REST_CYCLES`] cycles at rest at the loop's centre
//!   ([`Params::centre_pose`]), on a symmetric robot a pose where pairs of
//!   cables are alike (the warm start must hold there);
//! * [`JUMP_CYCLES`] cycles that jump every cycle between the poses of
//!   [`JUMP_TIMES`] across the workspace, so that the warm start stops
//!   holding and the solver starts cold, ending with [`SETTLE_CYCLES`] at
//!   rest at the loop's first pose.
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

/// Cycles at rest at the centre at the start of [`Params::script`].
pub const REST_CYCLES: u32 = 300;
/// Cycles of jumps between poses after the rest (the last
/// [`SETTLE_CYCLES`] of them at rest at the loop's first pose).
pub const JUMP_CYCLES: u32 = 300;
/// Cycles at rest at the loop's first pose that end the jump stretch: the
/// encoders' stand-in (5 ms lag) and the pose estimate settle there, so
/// that the feedback does not start from the jumps' error when the loop
/// starts and the robot is enabled.
pub const SETTLE_CYCLES: u32 = 50;
/// Cycles before the loop starts in [`Params::script`].
pub const PRELUDE_CYCLES: u32 = REST_CYCLES + JUMP_CYCLES;
/// Cycles of the demo's whole run: the prelude, then one loop.
pub const SCRIPT_CYCLES: usize = PRELUDE_CYCLES as usize + CYCLES;
/// Times of the loop (s) whose setpoints the jump stretch visits in turn:
/// feasible poses far apart (both sides, low and halfway up), with their
/// velocities and accelerations: the loop's ([`Params::loop_at`]), without
/// the excursion.
pub const JUMP_TIMES: [f32; 6] = [0.0, 1.5, 0.5, 3.5, 1.0, 2.9];
/// The loop times (s) the excursion must lie within: after the stretch the
/// end-to-end test streams (its first 1.74 s at most) and 0.1 s before the
/// loop's end. The excursion is slow (a rise of about a second) so that
/// its accelerations stay well below gravity's: it leaves the workspace
/// by where it goes, not by how hard it brakes.
pub const EXCURSION_WINDOW: (f32, f32) = (1.75, 3.9);

/// The trajectory's numbers (m, rad, s), derived per robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// The loop's centre `x, y, z`, m (no rotation): the rest pose.
    pub centre: [f32; 3],
    /// The loop's amplitudes: `x, y, z` in m, `rx, ry, rz` in rad.
    pub amplitude: [f32; 6],
    /// The excursion's offset of `x, y, z` at its plateau, m.
    pub excursion: [f32; 3],
    /// When the excursion starts, s into the loop.
    pub excursion_start: f32,
    /// Its rise (and fall) time, s.
    pub excursion_ramp: f32,
    /// Its plateau, s.
    pub excursion_hold: f32,
}

impl Params {
    /// The loop's centre as a pose (no rotation).
    pub fn centre_pose(&self) -> [f32; 6] {
        let c = self.centre;
        [c[0], c[1], c[2], 0.0, 0.0, 0.0]
    }

    /// When the excursion ends, s into the loop.
    pub fn excursion_end(&self) -> f32 {
        self.excursion_start + 2.0 * self.excursion_ramp + self.excursion_hold
    }

    /// The demo's setpoint of cycle `k` (sequence number `k + 1`): at rest
    /// at the centre for [`REST_CYCLES`], jumping between the poses of
    /// [`JUMP_TIMES`] for [`JUMP_CYCLES`] (the last [`SETTLE_CYCLES`] at
    /// rest at the loop's first pose), then the loop ([`Params::setpoint`]).
    pub fn script(&self, k: u32) -> Setpoint {
        let seq = k.wrapping_add(1);
        if k < REST_CYCLES {
            let zero = Pose6::zeros();
            Setpoint { seq, pose: Pose6::from(self.centre_pose()), velocity: zero, acceleration: zero }
        } else if k < PRELUDE_CYCLES - SETTLE_CYCLES {
            let t = JUMP_TIMES[(k - REST_CYCLES) as usize % JUMP_TIMES.len()];
            Setpoint { seq, ..self.loop_at(t) }
        } else if k < PRELUDE_CYCLES {
            let zero = Pose6::zeros();
            Setpoint { seq, pose: self.setpoint_at(0.0).pose, velocity: zero, acceleration: zero }
        } else {
            Setpoint { seq, ..self.setpoint(k - PRELUDE_CYCLES) }
        }
    }

    /// The setpoint of control cycle `k` of the loop (`t = k PERIOD_S`,
    /// sequence number `k + 1`).
    pub fn setpoint(&self, k: u32) -> Setpoint {
        Setpoint { seq: k.wrapping_add(1), ..self.setpoint_at(k as f32 * PERIOD_S) }
    }

    /// The loop's setpoint at time `t`, s (sequence number 0), without the
    /// excursion.
    pub fn loop_at(&self, t: f32) -> Setpoint {
        let [ax, ay, az, rx, ry, rz] = self.amplitude;
        let [cx, cy, cz] = self.centre;
        let w = 2.0 * core::f32::consts::PI / DURATION_S;
        let phi = w * t;
        let (s1, c1) = phi.sin_cos_native();
        let (s2, c2) = (2.0 * s1 * c1, c1 * c1 - s1 * s1);
        let w2 = w * w;
        // Each coordinate is `C + A sin(n phi)` or `C - A cos(n phi)`.
        let pose = Pose6::from([cx + ax * s1, cy + ay * s2, cz - az * c1, rx * s2, ry * s1, rz * s1]);
        let velocity = Pose6::from([
            ax * w * c1,
            2.0 * ay * w * c2,
            az * w * s1,
            2.0 * rx * w * c2,
            ry * w * c1,
            rz * w * c1,
        ]);
        let acceleration = Pose6::from([
            -ax * w2 * s1,
            -4.0 * ay * w2 * s2,
            az * w2 * c1,
            -4.0 * rx * w2 * s2,
            -ry * w2 * s1,
            -rz * w2 * s1,
        ]);
        Setpoint { seq: 0, pose, velocity, acceleration }
    }

    /// The excursion's profile at time `t`: `b`, `db/dt`, `d2b/dt2`.
    pub fn excursion_profile(&self, t: f32) -> (f32, f32, f32) {
        let (start, ramp, hold) = (self.excursion_start, self.excursion_ramp, self.excursion_hold);
        if ramp.is_nan() || ramp <= 0.0 || t <= start || t >= self.excursion_end() {
            return (0.0, 0.0, 0.0);
        }
        let pi = core::f32::consts::PI;
        let k = pi / ramp;
        let rising = |tau: f32| {
            let (s, c) = (k * tau).sin_cos_native();
            (0.5 * (1.0 - c), 0.5 * k * s, 0.5 * k * k * c)
        };
        let tau = t - start;
        if tau < ramp {
            rising(tau)
        } else if tau <= ramp + hold {
            (1.0, 0.0, 0.0)
        } else {
            // Falling: b(t) = 1 - rising(t - (start + ramp + hold)).
            let (b, db, ddb) = rising(tau - ramp - hold);
            (1.0 - b, -db, -ddb)
        }
    }

    /// The setpoint at time `t`, s (sequence number 0): the loop plus the
    /// excursion.
    pub fn setpoint_at(&self, t: f32) -> Setpoint {
        let mut s = self.loop_at(t);
        let (b, db, ddb) = self.excursion_profile(t);
        if b != 0.0 || db != 0.0 {
            for i in 0..3 {
                s.pose[i] += self.excursion[i] * b;
                s.velocity[i] += self.excursion[i] * db;
                s.acceleration[i] += self.excursion[i] * ddb;
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: Params = Params {
        centre: [0.1, -0.2, 1.5],
        amplitude: [0.5, 0.3, 0.4, 0.1, 0.08, 0.2],
        excursion: [0.0, 0.0, 1.0],
        excursion_start: 1.8,
        excursion_ramp: 0.4,
        excursion_hold: 0.3,
    };

    /// Velocities and accelerations are the derivatives of the poses
    /// (central differences), excursion included.
    #[test]
    fn derivatives_match_differences() {
        let h = 1e-3f32;
        for i in 0..400 {
            let t = 0.01 * i as f32 + 0.0013;
            let (a, s, b) = (P.setpoint_at(t - h), P.setpoint_at(t), P.setpoint_at(t + h));
            for j in 0..6 {
                let v = (b.pose[j] - a.pose[j]) / (2.0 * h);
                assert!((v - s.velocity[j]).abs() < 2e-2, "t {t} velocity {j}: {v} vs {}", s.velocity[j]);
                let acc = (b.velocity[j] - a.velocity[j]) / (2.0 * h);
                // The cosine ramp's acceleration jumps at its ends.
                let edge = [0.0, 0.4, 0.7, 1.1].iter().any(|e| (t - P.excursion_start - e).abs() < 2.0 * h);
                if !edge {
                    assert!((acc - s.acceleration[j]).abs() < 0.2, "t {t} acceleration {j}");
                }
            }
        }
    }

    #[test]
    fn excursion_reaches_its_offset_and_returns() {
        assert_eq!(P.excursion_profile(1.0), (0.0, 0.0, 0.0));
        assert_eq!(P.excursion_profile(2.3).0, 1.0);
        assert!((P.excursion_end() - 2.9).abs() < 1e-6);
        let top = P.setpoint_at(2.3);
        assert!((top.pose[2] - P.loop_at(2.3).pose[2] - 1.0).abs() < 1e-5);
        assert_eq!(P.setpoint_at(3.0), P.loop_at(3.0));
        assert_eq!(P.script(0).pose[2], 1.5);
        assert_eq!(P.script(PRELUDE_CYCLES).pose, P.setpoint(0).pose);
    }
}
