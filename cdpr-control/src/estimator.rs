//! The pose and twist estimate from the winch encoders' cable lengths.
//!
//! # Pose: one Gauss-Newton step a cycle
//!
//! The forward kinematics is solved by Gauss-Newton on the cable lengths,
//! one step per control cycle, about a *reference pose* whose cable
//! kinematics are already known. Near a pose `x_r` with lengths `L_r` and
//! wrench matrix `W_r`, a small displacement `delta = [dp; dtheta]`
//! (position, rotation vector, base frame) changes the lengths by
//! `dL = -W_r^T delta` (conventions: `u_i` points from the platform to
//! the anchor). With the measured lengths `L` and `b = L - L_r`, the step
//! is the least-squares solution of `-W_r^T delta = b`:
//!
//! ```text
//! delta = -(W_r W_r^T)^-1 W_r b,      residual r = b + W_r^T delta
//! ```
//!
//! (through `R` of the tension solver's `W_r^T = Q R` when the controller
//! shares it, `W_r W_r^T = R^T R`; otherwise `W_r W_r^T` formed and
//! factored as `L D L^T`; either way a pivot below `1e-6` of its diagonal
//! entry is ill-conditioned). The estimate is `x_r` moved by `delta` (position added; the rotation
//! vector mapped to Euler-angle increments through the inverse of the
//! Euler-rate matrix at `x_r`).
//!
//! * While a setpoint is solved, the reference is the setpoint: the
//!   controller has just computed its lengths and `W` for the tension
//!   distribution and factored `W` for the solver
//!   (`crate::controller::Controller::prepare`), so the step costs two
//!   6 x 6 triangular solves and no kinematics ([`Estimator::about`] with
//!   [`Reference::of_setpoint`]). The
//!   linearisation error is second order: about `|delta|^2 / L`, 0.2 mm
//!   at the 20 mm tracking limit with 2 m cables, 2 um at 2 mm.
//! * Otherwise (no setpoint, or none solved) the reference is the
//!   previous estimate ([`OwnedReference::at`] computes its kinematics): plain
//!   Gauss-Newton, one iteration a cycle, converging quadratically while
//!   the platform rests.
//!
//! The step is rejected ([`EstimateError`]) when the lengths are not
//! finite, when `W W^T` cannot be factorised, when its correction is
//! larger than `correction_max` (outside the linearisation's validity) or
//! when the worst residual exceeds `residual_max` (the lengths are not
//! those of any pose near the reference: a slack, broken or slipping
//! cable, or a wrong homing).
//!
//! # Speed: filtered finite difference
//!
//! The pose rate is the finite difference of successive estimates through
//! a first-order low-pass of cut-off `f_c`:
//! `v_k = v_(k-1) + alpha ((x_k - x_(k-1)) / T - v_(k-1))`, with
//! `alpha = T / (T + 1 / (2 pi f_c))`. At 50 Hz (`alpha = 0.24` at 1 kHz)
//! one encoder count (7.7 um on suspended-8) makes at most a 1.8 mm/s
//! blip, and the phase lag at the 5 Hz control bandwidth is 6 degrees.
//! Behind the CAN buses (0.83 ms more loop delay) the task-space D-term
//! through this 50 Hz filter feeds the drum-on-cable mode (about 100 Hz,
//! the winch's 0.56 kg on the cable's 2e5 N/m) back with more than 90
//! degrees of lag; there the speed is filtered at 10 Hz
//! ([`EstimatorSettings::FIELD_BUS`]; `hal-sim`'s `Config::can` and the
//! firmware's board build): a fifth of the 50 Hz filter's gain at 100 Hz
//! (0.10 against 0.45), for 27 degrees of lag at 5 Hz instead of 6.
//! Measured on `hal-sim`'s buses: at 15 Hz and 12 Hz a cable still went
//! slack near the top of the `track` loop, at 10 Hz none (tensions from
//! 6.6 N), at 8 Hz the loop's error grew to 1.46 mm.
//! After a gap (a failed step, a new homing) the first good estimate only
//! restarts the difference.

use tension_core::linalg::WrenchFactorization;
use tension_core::nalgebra::{Matrix3, SVector, Vector3};
use tension_core::Real;

use crate::controller::{Trig, WrenchMatrix};
use crate::robot::{ControlRobot, CABLES};
use crate::setpoint::Pose6;

/// The estimator's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimatorSettings {
    /// The control period `T`, s.
    pub period_s: f32,
    /// The speed filter's cut-off `f_c`, Hz.
    pub cutoff_hz: f32,
    /// Largest worst-cable residual accepted, m.
    pub residual_max: f32,
    /// Largest correction `|delta|` (position part, m; rotation part, rad)
    /// one step may make.
    pub correction_max: f32,
}

impl EstimatorSettings {
    /// The firmware's: 1 ms, 50 Hz, 1 mm residual, 50 mm (0.05 rad)
    /// correction. The residual limit is 130 encoder counts (7.7 um each
    /// on suspended-8) and three times the residual that a calibrated
    /// frame's geometric errors leave: in `hal-sim`, the plant's anchors
    /// 2 mm off the robot file's give at most 0.36 mm over the tracking
    /// loop, with the linearisation error (`|delta|^2 / L`, 0.2 mm at the
    /// 20 mm tracking limit) inside it. A cable slack, broken or slipping
    /// by a few mm, an encoder that stops while the platform moves, or a
    /// homing some 15 mm off once the platform has moved half a metre,
    /// shows beyond it (the control loop faults: `Reason::Estimator`). A
    /// frame calibrated less well needs a larger limit
    /// (`ControlLoop::set_estimator`).
    pub const DEFAULT: Self =
        Self { period_s: 0.001, cutoff_hz: 50.0, residual_max: 0.001, correction_max: 0.05 };

    /// Behind a field bus (the board's CAN drives): [`Self::DEFAULT`] with
    /// the speed filtered at 10 Hz (module docs).
    pub const FIELD_BUS: Self = Self { cutoff_hz: 10.0, ..Self::DEFAULT };

    /// The filter's `alpha = T / (T + 1 / (2 pi f_c))`.
    pub fn alpha(&self) -> f32 {
        let tau = 1.0 / (2.0 * core::f32::consts::PI * self.cutoff_hz);
        self.period_s / (self.period_s + tau)
    }
}

impl Default for EstimatorSettings {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Why a step gave no estimate.
///
/// Four bytes wide (`repr(u32)`) so that a `Result<Estimate, Self>` keeps
/// both payloads word-aligned: with a one-byte error the control step
/// moved its estimate as 79 bytes from an odd address (two byte-wise
/// copies, about 730 instructions on the board).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum EstimateError {
    /// A length or the reference is not finite.
    NonFinite,
    /// `W W^T` is not positive definite (the reference is singular).
    IllConditioned,
    /// The correction exceeds `correction_max`.
    Correction,
    /// The worst residual exceeds `residual_max`.
    Residual,
    /// No reference pose (not homed).
    NoReference,
}

impl EstimateError {
    /// The error's name in logs (lower case).
    pub const fn status(self) -> &'static str {
        match self {
            EstimateError::NonFinite => "nonfinite",
            EstimateError::IllConditioned => "ill-conditioned",
            EstimateError::Correction => "correction-too-large",
            EstimateError::Residual => "residual",
            EstimateError::NoReference => "no-reference",
        }
    }
}

/// The reference pose of a step with its cable kinematics.
#[derive(Debug, Clone, Copy)]
pub struct Reference<'a> {
    /// The pose `x_r`.
    pub pose: &'a Pose6,
    /// Its cable lengths `L_r`, m.
    pub lengths: &'a SVector<f32, CABLES>,
    /// Its wrench matrix `W_r`.
    pub w: &'a WrenchMatrix,
    /// The sines and cosines of its angles.
    pub trig: &'a Trig,
    /// `W_r^T = Q R` when the controller has factored it for the tension
    /// solver ([`crate::controller::Controller::prepare`]): the step then
    /// solves its normal equations through `R` (`W W^T = R^T R`) instead
    /// of forming and factoring `W W^T`.
    pub factorization: Option<&'a WrenchFactorization<f32, 6, CABLES>>,
}

impl<'a> Reference<'a> {
    /// The setpoint's, as the controller computed them
    /// (`Controller::kinematics`), with the solver's factorisation of its
    /// `W` if there is one.
    pub fn of_setpoint(
        pose: &'a Pose6,
        k: &'a crate::controller::SetpointKinematics,
        factorization: Option<&'a WrenchFactorization<f32, 6, CABLES>>,
    ) -> Self {
        Self { pose, lengths: &k.lengths, w: &k.w, trig: &k.trig, factorization }
    }
}

/// Kinematics of a pose owned by the caller (for [`OwnedReference::at`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OwnedReference {
    pose: Pose6,
    lengths: SVector<f32, CABLES>,
    w: WrenchMatrix,
    trig: Trig,
}

impl OwnedReference {
    /// The kinematics at `pose`, or `None` if it has none (non-finite, a
    /// degenerate cable).
    pub fn at(robot: &ControlRobot, pose: &Pose6) -> Option<Self> {
        let cables = robot.cables(pose).ok()?;
        Some(Self {
            pose: *pose,
            lengths: cables.lengths,
            w: robot.wrench_matrix_of(&cables),
            trig: Trig::of(pose),
        })
    }

    /// As a [`Reference`].
    pub fn as_ref(&self) -> Reference<'_> {
        Reference {
            pose: &self.pose,
            lengths: &self.lengths,
            w: &self.w,
            trig: &self.trig,
            factorization: None,
        }
    }
}

/// One cycle's estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// The estimated pose `[x, y, z, rx, ry, rz]`.
    pub pose: Pose6,
    /// Its rate (filtered; the time derivative of the six numbers).
    pub velocity: Pose6,
    /// The step's correction from the reference, `[dp; dtheta]` (base
    /// frame, m and rad): with the setpoint as reference, minus the pose
    /// error.
    pub delta: [f32; 6],
    /// The worst `|r_i|`, m.
    pub residual: f32,
}

/// The estimator's state: the last estimate (the next step's warm start
/// when no setpoint is solved) and the speed filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimator {
    settings: EstimatorSettings,
    last: Option<Pose6>,
    /// Whether `last` is from the previous cycle (the difference may run).
    fresh: bool,
    velocity: Pose6,
}

/// The Euler-rate matrix `J` of `R = Rx(a) Ry(b) Rz(c)`: `omega = J [a' b' c']`.
pub fn euler_rate_matrix(a: f32, b: f32) -> Matrix3<f32> {
    let (sa, ca) = a.sin_cos_native();
    let (sb, cb) = b.sin_cos_native();
    Matrix3::new(1.0, 0.0, sb, 0.0, ca, -sa * cb, 0.0, sa, ca * cb)
}

impl Estimator {
    /// No estimate yet.
    pub const fn new(settings: EstimatorSettings) -> Self {
        Self { settings, last: None, fresh: false, velocity: Pose6::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0) }
    }

    /// The settings.
    pub fn settings(&self) -> &EstimatorSettings {
        &self.settings
    }

    /// Starts from `pose` at rest (a homing).
    pub fn reset(&mut self, pose: &Pose6) {
        self.last = Some(*pose);
        self.fresh = false;
        self.velocity = Pose6::zeros();
    }

    /// Forgets everything (homing lost).
    pub fn forget(&mut self) {
        self.last = None;
        self.fresh = false;
        self.velocity = Pose6::zeros();
    }

    /// The last good estimate's pose.
    pub fn last(&self) -> Option<&Pose6> {
        self.last.as_ref()
    }

    /// The filtered pose rate.
    pub fn velocity(&self) -> &Pose6 {
        &self.velocity
    }

    /// A cycle without an estimate (the difference restarts at the next).
    pub fn skip(&mut self) {
        self.fresh = false;
    }

    /// One Gauss-Newton step from `reference` to the measured `lengths`;
    /// on success the estimate becomes the last and the speed advances.
    pub fn about(
        &mut self,
        reference: Reference<'_>,
        lengths: &[f32; CABLES],
    ) -> Result<Estimate, EstimateError> {
        let mut out = None;
        self.about_into(reference, lengths, &mut out);
        // `about_into` always writes `Some`.
        out.unwrap_or(Err(EstimateError::NoReference))
    }

    /// [`Estimator::about`] written into `out` (`Some` of its result),
    /// where the caller keeps it: an estimate is about 80 bytes, which a
    /// returned value would cost a library copy on the Cortex-M4.
    pub fn about_into(
        &mut self,
        reference: Reference<'_>,
        lengths: &[f32; CABLES],
        out: &mut Option<Result<Estimate, EstimateError>>,
    ) {
        let result = step(reference, lengths, &self.settings);
        *out = Some(match result {
            Ok((pose, delta, residual)) => {
                if let (Some(last), true) = (self.last, self.fresh) {
                    let alpha = self.settings.alpha();
                    let rate = (pose - last) / self.settings.period_s;
                    self.velocity += (rate - self.velocity) * alpha;
                }
                self.last = Some(pose);
                self.fresh = true;
                Ok(Estimate { pose, velocity: self.velocity, delta, residual })
            }
            Err(e) => {
                self.fresh = false;
                Err(e)
            }
        });
    }

    /// One plain Gauss-Newton iteration from the last estimate (its
    /// kinematics computed here).
    pub fn from_last(
        &mut self,
        robot: &ControlRobot,
        lengths: &[f32; CABLES],
    ) -> Result<Estimate, EstimateError> {
        let Some(last) = self.last else {
            return Err(EstimateError::NoReference);
        };
        match OwnedReference::at(robot, &last) {
            Some(reference) => self.about(reference.as_ref(), lengths),
            None => {
                self.fresh = false;
                Err(EstimateError::NonFinite)
            }
        }
    }
}

/// Adds `c c^T` (lower triangle, packed by rows: `(0,0), (1,0), (1,1),
/// (2,0), ...`) to `a`: written out, so that the 21 sums stay in the
/// FPU's registers.
#[inline(always)]
fn accumulate(a: &mut [f32; 21], c: &[f32; 6]) {
    let [c0, c1, c2, c3, c4, c5] = *c;
    a[0] += c0 * c0;
    a[1] += c1 * c0;
    a[2] += c1 * c1;
    a[3] += c2 * c0;
    a[4] += c2 * c1;
    a[5] += c2 * c2;
    a[6] += c3 * c0;
    a[7] += c3 * c1;
    a[8] += c3 * c2;
    a[9] += c3 * c3;
    a[10] += c4 * c0;
    a[11] += c4 * c1;
    a[12] += c4 * c2;
    a[13] += c4 * c3;
    a[14] += c4 * c4;
    a[15] += c5 * c0;
    a[16] += c5 * c1;
    a[17] += c5 * c2;
    a[18] += c5 * c3;
    a[19] += c5 * c4;
    a[20] += c5 * c5;
}

/// Index of `(r, c)`, `c <= r`, in the packed lower triangle.
const fn at(r: usize, c: usize) -> usize {
    r * (r + 1) / 2 + c
}

/// The step: the pose, the correction and the worst residual. The
/// normal equations `A delta = -g` (`A = W W^T`, `g = W b`) are solved
/// through the shared factorisation's `R` (`A = R^T R`: about 140
/// multiply-adds with `g` and the residual) or, without one, by
/// [`normal_equations`] (about 330): a fixed count either way.
// Index loops the compiler unrolls; negated comparisons that also catch NaN.
#[allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]
fn step(
    reference: Reference<'_>,
    lengths: &[f32; CABLES],
    settings: &EstimatorSettings,
) -> Result<(Pose6, [f32; 6], f32), EstimateError> {
    let ws = reference.w.as_slice();
    let mut b = [0.0f32; CABLES];
    let mut g = [0.0f32; 6];
    let mut finite = true;
    for i in 0..CABLES {
        let bi = lengths[i] - reference.lengths[i];
        finite &= bi.is_finite();
        b[i] = bi;
        for (r, gr) in g.iter_mut().enumerate() {
            *gr += ws[6 * i + r] * bi;
        }
    }
    if !finite {
        return Err(EstimateError::NonFinite);
    }
    let delta = match reference.factorization {
        Some(qr) => {
            let minus_g = SVector::<f32, 6>::from_fn(|r, _| -g[r]);
            let d = qr
                .solve_gram(&minus_g, MIN_PIVOT, MIN_RELATIVE_PIVOT)
                .ok_or(EstimateError::IllConditioned)?;
            [d[0], d[1], d[2], d[3], d[4], d[5]]
        }
        None => normal_equations(ws, &g)?,
    };
    let max = settings.correction_max;
    // `!(|d| <= max)` also catches NaN.
    if delta.iter().any(|d| !(libm::fabsf(*d) <= max)) {
        return Err(if delta.iter().all(|d| d.is_finite()) {
            EstimateError::Correction
        } else {
            EstimateError::IllConditioned
        });
    }
    let mut worst = 0.0f32;
    for (i, bi) in b.iter().enumerate() {
        let c = &ws[6 * i..6 * i + 6];
        let r = bi
            + c[0] * delta[0]
            + c[1] * delta[1]
            + c[2] * delta[2]
            + c[3] * delta[3]
            + c[4] * delta[4]
            + c[5] * delta[5];
        // Not `f32::max`: a library call on the M4F; a NaN stays.
        let r = libm::fabsf(r);
        if !(r <= worst) {
            worst = r;
        }
    }
    if !(worst <= settings.residual_max) {
        return Err(EstimateError::Residual);
    }
    let x = reference.pose;
    let de = reference.trig.euler_increment(&Vector3::new(delta[3], delta[4], delta[5]));
    let pose =
        Pose6::new(x[0] + delta[0], x[1] + delta[1], x[2] + delta[2], x[3] + de.x, x[4] + de.y, x[5] + de.z);
    Ok((pose, delta, worst))
}

/// The smallest pivot `d_j` of `W W^T = L D L^T` accepted (`W`'s rows
/// are unit vectors and moment arms in m).
const MIN_PIVOT: f32 = 1e-12;

/// The smallest pivot accepted relative to its diagonal entry
/// `(W W^T)_jj`: below it the reference is too close to singular for a
/// step.
const MIN_RELATIVE_PIVOT: f32 = 1e-6;

/// `delta` of `A delta = -g` (`A = W W^T`, formed cable by cable: its
/// lower triangle, 21 entries) by `L D L^T` without square roots, about
/// 250 multiply-adds: when no factorisation of `W` is shared.
// Index loops the compiler unrolls; negated comparisons that also catch NaN.
#[allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]
fn normal_equations(ws: &[f32], g: &[f32; 6]) -> Result<[f32; 6], EstimateError> {
    let mut a = [0.0f32; 21];
    for i in 0..CABLES {
        let c = [ws[6 * i], ws[6 * i + 1], ws[6 * i + 2], ws[6 * i + 3], ws[6 * i + 4], ws[6 * i + 5]];
        accumulate(&mut a, &c);
    }
    // A = L D L^T in place: L below the diagonal, D on it. Every loop
    // runs to the constant 6 with its condition inside, so the compiler
    // unrolls them into straight-line code.
    let mut l = [[0.0f32; 6]; 6];
    for r in 0..6 {
        for c in 0..6 {
            if c <= r {
                l[r][c] = a[at(r, c)];
            }
        }
    }
    let mut inv_d = [0.0f32; 6];
    for j in 0..6 {
        let mut d = l[j][j];
        for k in 0..6 {
            if k < j {
                d -= l[j][k] * l[j][k] * l[k][k];
            }
        }
        // Positive definite, with a margin for the rounding of A's entries.
        if !(d > MIN_RELATIVE_PIVOT * libm::fabsf(l[j][j]) && d > MIN_PIVOT) {
            return Err(EstimateError::IllConditioned);
        }
        l[j][j] = d;
        inv_d[j] = 1.0 / d;
        for i in 0..6 {
            if i > j {
                let mut x = l[i][j];
                for k in 0..6 {
                    if k < j {
                        x -= l[i][k] * l[j][k] * l[k][k];
                    }
                }
                l[i][j] = x * inv_d[j];
            }
        }
    }
    // L y = -g, then D z = y, then L^T delta = z.
    let mut delta = [0.0f32; 6];
    for i in 0..6 {
        let mut y = -g[i];
        for k in 0..6 {
            if k < i {
                y -= l[i][k] * delta[k];
            }
        }
        delta[i] = y;
    }
    for i in 0..6 {
        delta[i] *= inv_d[i];
    }
    for ii in 0..6 {
        let i = 5 - ii;
        let mut x = delta[i];
        for k in 0..6 {
            if k > i {
                x -= l[k][i] * delta[k];
            }
        }
        delta[i] = x;
    }
    Ok(delta)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn euler_increment_inverts_the_rate_matrix() {
        let pose = Pose6::new(0.0, 0.0, 0.0, 0.3, -0.4, 0.7);
        let trig = Trig::of(&pose);
        let rates = Vector3::new(0.1, -0.2, 0.05);
        let w = euler_rate_matrix(0.3, -0.4) * rates;
        assert!((trig.euler_rate_matrix() * rates - w).amax() < 1e-6);
        let back = trig.euler_increment(&w);
        assert!((back - rates).amax() < 1e-6, "{back:?}");
    }

    #[test]
    fn filter_alpha() {
        let s = EstimatorSettings::DEFAULT;
        // T = 1 ms, tau = 1 / (2 pi 50) = 3.183 ms.
        assert!((s.alpha() - 0.001 / (0.001 + 0.003_183_1)).abs() < 1e-5);
    }
}
