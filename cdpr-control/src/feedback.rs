//! Closed-loop terms on top of the feed-forward: a task-space PID around the
//! setpoint trajectory whose wrench the tension distribution (the
//! barycenter) shares among the cables, and the cable-length check that
//! turns a broken cable or a winch that cannot deliver its torque into a
//! fault.
//!
//! # Task-space PID ([`TaskPid`])
//!
//! With the pose error (base frame)
//!
//! * `e_p = p_d - p` (platform origin), `e_v = v_d - v`;
//! * `e_r`: the rotation vector of `R_d R^T`, taken as
//!   `vee(E - E^T) / 2` with `E = R_d R^T` (`sin(angle) axis`, exact
//!   enough for the small errors a tracking robot has), and
//!   `e_w = omega_d - omega` (`omega_d` from the setpoint's Euler rates,
//!   `tension_core::Motion::from_pose_derivatives`),
//!
//! the feedback force and moment are
//!
//! ```text
//! F = Kp e_p + Kd e_v + Ki integral(e_p)        (acting at the centre of mass)
//! M = Kp_r e_r + Kd_r e_w + Ki_r integral(e_r)
//! ```
//!
//! each gain a diagonal (per base axis), the integral terms each clamped to
//! `integral_max` (anti-windup) and accumulated only while the caller says
//! so (Enabled), and `|F|`, `|M|` scaled down to at most `force_max`,
//! `moment_max` so that the feedback cannot by itself push a feasible
//! setpoint out of the tension polygon. The wrench the cables must add is
//! `(F, M + R c x F)` about the platform origin (the force acts at the
//! centre of mass `R c`, so it does not tilt the platform).
//!
//! [`Gains::triple_pole`] places the three closed-loop poles of each axis
//! at `-omega` for a rigid body of the platform's mass and inertia:
//! `s^3 + (Kd/m) s^2 + (Kp/m) s + Ki/m = (s + omega)^3`, i.e.
//! `Kp = 3 m omega^2`, `Kd = 3 m omega`, `Ki = m omega^3` (and the inertia
//! about the centre of mass for the rotations). `hal-sim/README.md`
//! explains the bandwidth chosen.
//!
//! # Prediction over the loop delay ([`Prediction`], [`predict`])
//!
//! Behind a field bus the errors the PID computes are older than the
//! moment its wrench acts: on the board's CAN buses the positions are
//! 545 us old at the step and the torques are received 175-400 us into
//! it, `tau` = 0.83 ms more than with directly wired winches
//! (`canopen_drives::added_loop_delay_ns` computes it from the bus
//! schedule; the control loop takes it from its configuration,
//! `ControlLoop::set_loop_delay`, 0 for the direct path). The PID acts on
//! the errors predicted `tau` ahead for the rigid body it was designed
//! for. The feed-forward gives the setpoint's acceleration, so the rate
//! error changes only by the acceleration `a` of the feedback last carried
//! (`a = F / m` per base axis, `M / I` per rotation, moment about the
//! centre of mass):
//!
//! ```text
//! e(t + tau)  = e + e' tau - a tau^2 / 2
//! e'(t + tau) = e' - a tau
//! ```
//!
//! (`a` is held over `tau`: the torques are a zero-order hold). Its size
//! is modest by design: at the 5 Hz gains `Kp tau` is 16 N s/m beside
//! `Kd` = 598 N s/m and `Kd tau / m` = 0.08 of the last force, so it
//! corrects the phase the delay costs at the crossover (about 4 deg at
//! 94 rad/s) without a loop of its own (its gain on the last output is
//! far below 1). The bus's larger trouble, the drum-on-cable mode (about
//! 100 Hz) fed back through the D-term, is the speed filter's to keep out
//! (`EstimatorSettings::FIELD_BUS`: the speed at 10 Hz on the buses); see
//! `hal-sim/README.md`, "On the CAN buses".
//!
//! # Back-off
//!
//! The control loop scales the force and the moment separately
//! (`TaskPid::update_error`'s `scale`): where the feed-forward plus the
//! feedback has no feasible tensions it halves the force alone and keeps
//! the moment, so the orientation stays held near the tension floor
//! (`cdpr_control::BackOff::ForceFirst`); each part's integral advances
//! only while that part is carried whole.
//!
//! # Cable-length check
//!
//! `ControlLoop::step` compares the winch encoders' cable lengths with the
//! inverse kinematics of the last feasible setpoint and faults
//! (`Reason::Tracking`) when one is off by more than the tracking limit.

use tension_core::nalgebra::{Matrix3, Vector3};
use tension_core::{Error, Motion, Real, RobotKind};

use crate::controller::Wrench;
use crate::robot::{ControlRobot, CABLES};
use crate::setpoint::{Pose6, Setpoint};

/// Per-axis gains of the task-space PID: `[x, y, z]` for the force (N/m,
/// N s/m, N/(m s)), `[rx, ry, rz]` for the moment (N m/rad, N m s/rad,
/// N m/(rad s)), all about base axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains {
    /// Proportional: `[Kp x3, Kp_r x3]`.
    pub kp: [f32; 6],
    /// Derivative: `[Kd x3, Kd_r x3]`.
    pub kd: [f32; 6],
    /// Integral: `[Ki x3, Ki_r x3]`.
    pub ki: [f32; 6],
}

impl Gains {
    /// The three closed-loop poles of every axis at `-omega_t` (translation)
    /// and `-omega_r` (rotation), rad/s, for a rigid body of `mass` (kg) and
    /// principal `inertia` about its centre of mass (kg m^2, per axis).
    pub fn triple_pole(mass: f32, inertia: [f32; 3], omega_t: f32, omega_r: f32) -> Self {
        let mut g = Self { kp: [0.0; 6], kd: [0.0; 6], ki: [0.0; 6] };
        for k in 0..6 {
            let (m, w) = if k < 3 { (mass, omega_t) } else { (inertia[k - 3], omega_r) };
            g.kp[k] = 3.0 * m * w * w;
            g.kd[k] = 3.0 * m * w;
            g.ki[k] = m * w * w * w;
        }
        g
    }
}

/// Bounds on the feedback wrench.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeedbackLimits {
    /// Largest feedback force `|F|`, N.
    pub force_max: f32,
    /// Largest feedback moment `|M|`, N m.
    pub moment_max: f32,
    /// Largest `|Ki integral(e)|` per axis: N for the forces, N m for the moments.
    pub integral_max: [f32; 6],
}

/// The platform's measured motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// Pose `[x, y, z, rx, ry, rz]` (conventions, "Poses").
    pub pose: Pose6,
    /// Velocity of the platform origin, base frame, m/s.
    pub velocity: Vector3<f32>,
    /// Angular velocity, base frame, rad/s.
    pub angular_velocity: Vector3<f32>,
}

/// The pose error `[e_p; e_r]` of `measured` from `desired` (base frame, m
/// and rad): position difference and the rotation vector taking the
/// measured orientation to the desired one (`sin(angle) axis`).
pub fn pose_error(robot: &ControlRobot, desired: &Pose6, measured: &Pose6) -> Result<[f32; 6], Error> {
    let (pd, rd) = robot.frame(desired)?;
    let (p, r) = robot.frame(measured)?;
    let ep = pd - p;
    let er = rotation_error(&rd, &r);
    Ok([ep.x, ep.y, ep.z, er.x, er.y, er.z])
}

/// `vee(E - E^T) / 2` with `E = R_d R^T`.
fn rotation_error(rd: &Matrix3<f32>, r: &Matrix3<f32>) -> Vector3<f32> {
    let e = rd * r.transpose();
    Vector3::new(e[(2, 1)] - e[(1, 2)], e[(0, 2)] - e[(2, 0)], e[(1, 0)] - e[(0, 1)]) * 0.5
}

/// Scales `v` down to at most `max` in length. The length is compared
/// squared and its square root taken only to scale (`Vector3::norm` is
/// libm's software `sqrtf` on the board, about 50 instructions a call;
/// `sqrt_native` is the FPU's `vsqrt.f32`).
fn limit(v: Vector3<f32>, max: f32) -> Vector3<f32> {
    let n2 = v.norm_squared();
    if n2 > max * max && n2 > 0.0 {
        v * (max / n2.sqrt_native())
    } else {
        v
    }
}

/// Whether `max` bounds a magnitude: zero or more (NaN is not).
const fn is_bound(max: f32) -> bool {
    max >= 0.0
}

/// `v` within `+-max` for a bound `max >= 0` (the constructors check it; NaN
/// `v` stays NaN): comparisons, where `f32::clamp` asserts its bounds'
/// order.
fn within(v: f32, max: f32) -> f32 {
    if v > max {
        max
    } else if v < -max {
        -max
    } else {
        v
    }
}

/// The loop delay the task-space PID predicts over, with the rigid body
/// the prediction uses (`TaskPid::update_error`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// The delay `tau`, s, beyond the direct path's: from the encoder
    /// sample to the moment the torque acts.
    pub delay_s: f32,
    /// `[1/m x3, 1/I_x, 1/I_y, 1/I_z]`: the platform's mass and principal
    /// inertia about its centre of mass (1/kg, 1/(kg m^2)).
    pub inv_mass: [f32; 6],
}

impl Prediction {
    /// No prediction (the directly wired winches).
    pub const NONE: Self = Self { delay_s: 0.0, inv_mass: [0.0; 6] };

    /// Over `delay_s` for a rigid body of `mass` and principal `inertia`
    /// (`NONE` if the delay is not positive or a mass not positive and
    /// finite).
    pub fn new(delay_s: f32, mass: f32, inertia: [f32; 3]) -> Self {
        let m = [mass, mass, mass, inertia[0], inertia[1], inertia[2]];
        if !(delay_s.is_finite() && delay_s > 0.0 && m.iter().all(|v| v.is_finite() && *v > 0.0)) {
            return Self::NONE;
        }
        Self { delay_s, inv_mass: m.map(|v| 1.0 / v) }
    }
}

/// The errors `tau` seconds on: with `e'' = -a` (`a = accel`, the
/// acceleration the last applied feedback gives; the feed-forward taken
/// as exact, so the rate error changes only by it),
/// `e(tau) = e + e' tau - a tau^2 / 2` and `e'(tau) = e' - a tau`.
pub fn predict(error: &[f32; 6], rates: &[f32; 6], accel: &[f32; 6], tau: f32) -> ([f32; 6], [f32; 6]) {
    let mut e = [0.0; 6];
    let mut r = [0.0; 6];
    for k in 0..6 {
        e[k] = error[k] + (rates[k] - 0.5 * accel[k] * tau) * tau;
        r[k] = rates[k] - accel[k] * tau;
    }
    (e, r)
}

/// The task-space PID with its integral state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaskPid {
    gains: Gains,
    limits: FeedbackLimits,
    /// `Ki integral(e)` per axis (already multiplied by the gain, so that a
    /// gain change does not jump the output).
    integral: [f32; 6],
    /// The last output `[F; M]` (moment about the centre of mass) as
    /// carried, for the prediction.
    output: [f32; 6],
}

impl TaskPid {
    /// A PID with zero integral state. Errors: [`Error::InvalidLimits`]
    /// when a bound of `limits` is NaN or below zero (it bounds nothing:
    /// `f32::clamp` would panic on it, the wrench's limit would pass or
    /// flip the wrench), so that a PID, once made, always bounds its
    /// output.
    pub const fn new(gains: Gains, limits: FeedbackLimits) -> Result<Self, Error> {
        let mut bounds = is_bound(limits.force_max) && is_bound(limits.moment_max);
        let mut k = 0;
        while k < 6 {
            bounds &= is_bound(limits.integral_max[k]);
            k += 1;
        }
        if !bounds {
            return Err(Error::InvalidLimits);
        }
        Ok(Self { gains, limits, integral: [0.0; 6], output: [0.0; 6] })
    }

    /// The gains.
    pub fn gains(&self) -> &Gains {
        &self.gains
    }

    /// Whether every axis has a positive proportional gain: not so for a
    /// platform without inertia ([`Gains::triple_pole`] of a zero inertia
    /// gives zero rotation gains), whose orientation this PID would leave
    /// to the feed-forward alone.
    pub fn acts_on_every_axis(&self) -> bool {
        self.gains.kp.iter().all(|&k| k > 0.0)
    }

    /// The limits.
    pub fn limits(&self) -> &FeedbackLimits {
        &self.limits
    }

    /// The integral terms `Ki integral(e)`, N and N m.
    pub fn integral(&self) -> &[f32; 6] {
        &self.integral
    }

    /// Forgets the integral (call whenever the loop is not closed: Disabled,
    /// Fault).
    pub fn reset(&mut self) {
        self.integral = [0.0; 6];
        self.output = [0.0; 6];
    }

    /// The last output `[F; M]` as carried (N, N m about the centre of
    /// mass).
    pub fn output(&self) -> &[f32; 6] {
        &self.output
    }

    /// The last output was not applied (the cycle held its torques).
    pub fn discard_output(&mut self) {
        self.output = [0.0; 6];
    }

    /// The wrench the cables must add to the feed-forward (base frame,
    /// about the platform origin) to bring `measured` onto `setpoint`;
    /// with `integrate`, the integral advances by `dt` seconds first.
    /// Pass its negative as `ControlLoop::step`'s `extra` (an external
    /// wrench the cables must balance).
    pub fn update(
        &mut self,
        robot: &ControlRobot,
        setpoint: &Setpoint,
        measured: &Measured,
        dt: f32,
        integrate: bool,
    ) -> Result<Wrench, Error> {
        let e = pose_error(robot, &setpoint.pose, &measured.pose)?;
        let motion = Motion::from_pose_derivatives(
            RobotKind::Spatial6,
            &setpoint.pose,
            &setpoint.velocity,
            &setpoint.acceleration,
        )?;
        let ev = Vector3::new(setpoint.velocity[0], setpoint.velocity[1], setpoint.velocity[2])
            - measured.velocity;
        let ew = motion.angular_velocity - measured.angular_velocity;
        let rates = [ev.x, ev.y, ev.z, ew.x, ew.y, ew.z];
        let (_, r) = robot.frame(&measured.pose)?;
        self.update_error(&e, &rates, &(r * robot.platform().com), dt, integrate, [1.0; 2], &Prediction::NONE)
    }

    /// The same from the errors themselves: `error = [e_p; e_r]` (m, rad),
    /// `rates = [e_v; e_w]` (m/s, rad/s), `rc` the centre of mass `R c`
    /// in base axes (m). The control loop's task-space scheme calls this
    /// with the estimator's correction (`e = -delta`), which costs no
    /// kinematics. `scale` is the fraction of the force and of the moment
    /// carried (the back-off; each part's integral advances only at 1);
    /// `prediction` the delay the errors are predicted over first.
    /// Errors: [`Error::NonFinite`] for a non-finite input.
    #[allow(clippy::too_many_arguments)]
    pub fn update_error(
        &mut self,
        error: &[f32; 6],
        rates: &[f32; 6],
        rc: &Vector3<f32>,
        dt: f32,
        integrate: bool,
        scale: [f32; 2],
        prediction: &Prediction,
    ) -> Result<Wrench, Error> {
        if !tension_core::all_finite(error.iter().chain(rates.iter()).chain(rc.iter()).copied())
            || !dt.is_finite()
        {
            return Err(Error::NonFinite);
        }
        let accel: [f32; 6] = core::array::from_fn(|k| self.output[k] * prediction.inv_mass[k]);
        let (e, rates) = predict(error, rates, &accel, prediction.delay_s);
        let g = &self.gains;
        let mut out = [0.0f32; 6];
        for k in 0..6 {
            if integrate && scale[k / 3] >= 1.0 {
                let max = self.limits.integral_max[k];
                self.integral[k] = within(self.integral[k] + g.ki[k] * e[k] * dt, max);
            }
            out[k] = g.kp[k] * e[k] + g.kd[k] * rates[k] + self.integral[k];
        }
        let force = limit(Vector3::new(out[0], out[1], out[2]), self.limits.force_max) * scale[0];
        let moment = limit(Vector3::new(out[3], out[4], out[5]), self.limits.moment_max) * scale[1];
        self.output = [force.x, force.y, force.z, moment.x, moment.y, moment.z];
        let moment = moment + rc.cross(&force);
        Ok(Wrench::from([force.x, force.y, force.z, moment.x, moment.y, moment.z]))
    }
}

/// The feedback scheme the control loop runs (`HostMessage::SelectFeedback`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scheme {
    /// Feed-forward only: the tension distribution of the setpoint's
    /// wrench (wire 0, the default).
    #[default]
    FeedForward,
    /// Task-space PID on the estimated pose ([`TaskPid`]): its wrench is
    /// added to the one the tension distribution shares (wire 1).
    TaskSpace,
    /// Joint-space PD/PID on the cable lengths ([`JointPid`]): its tension
    /// changes are added to the tension distribution's (wire 2).
    JointSpace,
}

impl Scheme {
    /// The wire number.
    pub const fn wire_id(self) -> u8 {
        match self {
            Scheme::FeedForward => 0,
            Scheme::TaskSpace => 1,
            Scheme::JointSpace => 2,
        }
    }

    /// The scheme of a wire number.
    pub const fn from_wire_id(id: u8) -> Option<Self> {
        match id {
            0 => Some(Scheme::FeedForward),
            1 => Some(Scheme::TaskSpace),
            2 => Some(Scheme::JointSpace),
            _ => None,
        }
    }

    /// The name in logs.
    pub const fn name(self) -> &'static str {
        match self {
            Scheme::FeedForward => "feed-forward",
            Scheme::TaskSpace => "task-space-pid",
            Scheme::JointSpace => "joint-space-pid",
        }
    }
}

/// Gains of the joint-space PID, the same for every cable: the tension
/// change of cable `i` is
/// `dt_i = kp (L_i - L_d_i) + kd (dL_i - dL_d_i) + ki integral(L_i - L_d_i)`
/// (a cable longer than desired pulls harder).
///
/// [`JointGains::triple_pole`] chooses them so that the platform's
/// translation in its *softest* direction has the task-space PID's triple
/// pole at `-omega`: with the same gain on every cable the task-space
/// stiffness is `kp W W^T` (from `dL = -W^T delta` and `f = W dt`), so
/// along base axis `k` it is `kp s_k`, `s_k = sum_i W_ki^2` (the sum of
/// the squared direction components); with `s = min(s_x, s_y, s_z)` at a
/// reference pose, `kp = 3 m omega^2 / s`, `kd = 3 m omega / s`,
/// `ki = m omega^3 / s`. Stiffer directions (suspended-8: vertical,
/// `s_z / s_x` about 3) are faster and better damped relative to their
/// stiffness. The control loop's default takes the reference pose at the
/// centre of the setpoint range's box, unrotated: on suspended-8
/// `(0, 0, 1.75)`, where `s_x, s_y, s_z = 3.60, 2.04, 2.35` (y is the
/// softest: the anchors are 4 m apart in x, 3 m in y), so with
/// `omega = 2 pi 5 Hz`: `kp` = 9 195 N/m, `kd` = 293 N s/m, `ki` =
/// 96 300 N/(m s) (`tests/closed_loop.rs` checks these). A 1 mm length
/// error is 9.2 N, one encoder count (7.7 um) 0.07 N; at the other
/// translations the poles are faster (`sqrt(s_k / s)` times) and less
/// damped relative to their speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointGains {
    /// Proportional, N/m.
    pub kp: f32,
    /// Derivative, N s/m.
    pub kd: f32,
    /// Integral, N/(m s).
    pub ki: f32,
    /// Largest `|ki integral(e)|` per cable, N (anti-windup).
    pub integral_max: f32,
}

impl JointGains {
    /// The triple pole at `-omega` (rad/s) in the softest translation at
    /// `pose`, for the robot's platform mass; `integral_max` N per cable.
    pub fn triple_pole(
        robot: &ControlRobot,
        pose: &Pose6,
        omega: f32,
        integral_max: f32,
    ) -> Result<Self, Error> {
        let w = robot.wrench_matrix(pose)?;
        let mut s = f32::INFINITY;
        for k in 0..3 {
            let sk: f32 = (0..CABLES).map(|i| w[(k, i)] * w[(k, i)]).sum();
            s = s.min(sk);
        }
        let m = robot.platform().mass;
        if !(s.is_finite() && s > 0.0 && omega.is_finite() && omega > 0.0) {
            return Err(Error::Singular);
        }
        Ok(Self {
            kp: 3.0 * m * omega * omega / s,
            kd: 3.0 * m * omega / s,
            ki: m * omega * omega * omega / s,
            integral_max,
        })
    }
}

/// The joint-space PID with its integral state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointPid {
    gains: JointGains,
    integral: [f32; CABLES],
}

impl JointPid {
    /// Zero integral. Errors: [`Error::InvalidLimits`] when the gains'
    /// `integral_max` is NaN or below zero (it bounds nothing).
    pub const fn new(gains: JointGains) -> Result<Self, Error> {
        if !is_bound(gains.integral_max) {
            return Err(Error::InvalidLimits);
        }
        Ok(Self { gains, integral: [0.0; CABLES] })
    }

    /// The gains.
    pub fn gains(&self) -> &JointGains {
        &self.gains
    }

    /// The integral terms, N.
    pub fn integral(&self) -> &[f32; CABLES] {
        &self.integral
    }

    /// Forgets the integral.
    pub fn reset(&mut self) {
        self.integral = [0.0; CABLES];
    }

    /// Per cable, the tension change (N) for measured `lengths` and
    /// `rates` against the desired `lengths_d`, `rates_d` (m, m/s; positive
    /// rates pay out); with `integrate` the integral advances by `dt`.
    /// Errors: [`Error::NonFinite`] for a non-finite error.
    pub fn update(
        &mut self,
        lengths: &[f32; CABLES],
        rates: &[f32; CABLES],
        lengths_d: &[f32; CABLES],
        rates_d: &[f32; CABLES],
        dt: f32,
        integrate: bool,
    ) -> Result<[f32; CABLES], Error> {
        let g = &self.gains;
        let mut out = [0.0; CABLES];
        for i in 0..CABLES {
            let e = lengths[i] - lengths_d[i];
            let de = rates[i] - rates_d[i];
            if !(e.is_finite() && de.is_finite()) {
                return Err(Error::NonFinite);
            }
            if integrate {
                let max = g.integral_max;
                self.integral[i] = within(self.integral[i] + g.ki * e * dt, max);
            }
            out[i] = g.kp * e + g.kd * de + self.integral[i];
        }
        Ok(out)
    }
}

/// The desired cable length rates `dL_d = -W^T [v; omega]` (m/s, positive
/// paying out) of a setpoint whose wrench matrix is `w`, with its pose
/// rate `velocity` (the first three are `v`) and angular velocity `omega`.
pub fn length_rates(
    w: &crate::controller::WrenchMatrix,
    velocity: &Pose6,
    omega: &Vector3<f32>,
) -> [f32; CABLES] {
    let twist = [velocity[0], velocity[1], velocity[2], omega.x, omega.y, omega.z];
    let mut out = [0.0; CABLES];
    for (i, o) in out.iter_mut().enumerate() {
        let col = w.column(i);
        let mut r = 0.0;
        for k in 0..6 {
            r += col[k] * twist[k];
        }
        *o = -r;
    }
    out
}

/// The setpoint `dt` seconds after it was meant for, with constant
/// acceleration: `pose + v dt + a dt^2 / 2`, `v + a dt`, `a` (sequence
/// number kept). A PID reference that keeps moving while the stream is
/// late, instead of stopping dead at the newest setpoint's pose.
pub fn extrapolate(setpoint: &Setpoint, dt: f32) -> Setpoint {
    Setpoint {
        seq: setpoint.seq,
        pose: setpoint.pose + setpoint.velocity * dt + setpoint.acceleration * (0.5 * dt * dt),
        velocity: setpoint.velocity + setpoint.acceleration * dt,
        acceleration: setpoint.acceleration,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The prediction against the body itself: a rigid body of mass `m`
    /// pushed by the constant feedback force `F` while the setpoint moves
    /// at constant speed, integrated in 10 000 small steps (independent
    /// of the closed form `predict` uses), over the board's 0.8325 ms.
    #[test]
    fn the_prediction_follows_a_body_under_the_feedback_force() {
        let (m, inertia) = (6.34f32, [0.05f32, 0.05, 0.08]);
        let tau = 832.5e-6f32;
        let p = Prediction::new(tau, m, inertia);
        let error = [1.0e-3, -2.0e-3, 0.5e-3, 0.01, -0.02, 0.005];
        let rates = [0.05, -0.02, 0.1, 0.3, -0.1, 0.2];
        let output = [40.0, -30.0, 25.0, 4.0, -3.0, 5.0];
        let accel: [f32; 6] = core::array::from_fn(|k| output[k] * p.inv_mass[k]);
        let (e, r) = predict(&error, &rates, &accel, tau);
        let mass = [m, m, m, inertia[0], inertia[1], inertia[2]];
        for k in 0..6 {
            // e = x_d - x, e' = v_d - v; x_d moves at v_d, x accelerates at F / m.
            let (mut x, mut v) = (0.0f64, f64::from(0.7 - rates[k]));
            let (mut xd, vd) = (f64::from(error[k]), 0.7f64);
            let n = 10_000;
            let h = f64::from(tau) / f64::from(n);
            let a = f64::from(output[k] / mass[k]);
            for _ in 0..n {
                x += v * h + 0.5 * a * h * h;
                v += a * h;
                xd += vd * h;
            }
            let (e_ref, r_ref) = (xd - x, vd - v);
            assert!((f64::from(e[k]) - e_ref).abs() < 1e-8 + 1e-5 * e_ref.abs(), "{k}: {} vs {e_ref}", e[k]);
            assert!((f64::from(r[k]) - r_ref).abs() < 1e-6 + 1e-5 * r_ref.abs(), "{k}: {} vs {r_ref}", r[k]);
        }
        // Against no prediction, the force's term is visible: 40 N on
        // 6.34 kg over 0.83 ms is 5.3 mm/s of rate.
        assert!((r[0] - rates[0]).abs() > 5.0e-3);
    }

    /// The PID applies its gains to the predicted errors, and predicts
    /// from the output it carried last.
    #[test]
    fn the_pid_acts_on_the_predicted_error() {
        let gains = Gains::triple_pole(6.34, [0.05, 0.05, 0.08], 31.4, 31.4);
        let limits = FeedbackLimits { force_max: 1e6, moment_max: 1e6, integral_max: [0.0; 6] };
        let mut pid = TaskPid::new(gains, limits).unwrap();
        let p = Prediction::new(1.0e-3, 6.34, [0.05, 0.05, 0.08]);
        let e = [1.0e-3, 0.0, 0.0, 0.0, 0.002, 0.0];
        let r = [0.01, 0.0, 0.0, 0.0, 0.0, 0.0];
        let rc = Vector3::zeros();
        let w1 = pid.update_error(&e, &r, &rc, 1e-3, false, [1.0; 2], &p).unwrap();
        // First call: nothing carried yet, so only the rate moves the error.
        let e0 = e[0] + r[0] * 1.0e-3;
        assert!((w1[0] - (gains.kp[0] * e0 + gains.kd[0] * r[0])).abs() < 1e-3, "{w1:?}");
        let w2 = pid.update_error(&e, &r, &rc, 1e-3, false, [1.0; 2], &p).unwrap();
        let a = w1[0] / 6.34;
        let (ep, rp) = predict(&e, &r, &[a, 0.0, 0.0, 0.0, w1[4] / 0.05, 0.0], 1.0e-3);
        assert!((w2[0] - (gains.kp[0] * ep[0] + gains.kd[0] * rp[0])).abs() < 1e-3, "{w2:?}");
        assert!((w2[4] - (gains.kp[4] * ep[4] + gains.kd[4] * rp[4])).abs() < 1e-4, "{w2:?}");
        // The back-off scales the force and the moment apart.
        let w3 = pid.update_error(&e, &r, &rc, 1e-3, false, [0.0, 1.0], &Prediction::NONE).unwrap();
        assert_eq!(w3[0], 0.0);
        assert!(w3[4] > 0.0);
    }
}
