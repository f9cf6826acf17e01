//! One control cycle: setpoint -> wrench matrix -> required wrench (with the
//! d'Alembert terms from the setpoint's derivatives) -> tensions -> motor
//! torques, optionally with the winches' friction compensated
//! ([`FrictionCompensation`]).

use tension_core::linalg::WrenchFactorization;
use tension_core::methods::Workspace;
use tension_core::nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use tension_core::{Error, Method, Motion, Real, Robot, RobotKind, Solution, TensionSolver, WarmStart};

use crate::robot::{CABLES, DOF};
use crate::setpoint::Setpoint;
use crate::TickCounter;

/// Wrench matrix `W` (6 x `M`, by default the firmware's 8 cables).
pub type WrenchMatrix<const M: usize = CABLES> = SMatrix<f32, DOF, M>;
/// Wrench `f` the cables must produce (`W t = f`).
pub type Wrench = SVector<f32, DOF>;

/// Which cables' torques were limited to `torque_max`, one flag per cable
/// (sized by the robot, so any number of cables fits).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Saturation<const M: usize = CABLES>(pub [bool; M]);

impl<const M: usize> Saturation<M> {
    /// No cable saturated.
    pub const NONE: Self = Self([false; M]);

    /// Whether any cable's torque was limited.
    pub fn any(&self) -> bool {
        self.0.iter().any(|&s| s)
    }

    /// Whether cable `i`'s torque was limited (`false` past the last cable).
    pub fn cable(&self, i: usize) -> bool {
        self.0.get(i).copied().unwrap_or(false)
    }

    /// How many cables' torques were limited.
    pub fn count(&self) -> usize {
        self.0.iter().filter(|&&s| s).count()
    }
}

/// The result of a successful cycle (for `M` cables, by default the
/// firmware's 8).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command<const M: usize = CABLES> {
    /// Cable tensions, N.
    pub tensions: [f32; M],
    /// Motor torques, N m (within `+-torque_max`).
    pub torques: [f32; M],
    /// The cables whose torque was limited to `torque_max`.
    pub saturated: Saturation<M>,
    /// The cables whose tension the joint-space feedback's change would
    /// have taken outside `t_min..t_max`: limited to the bound
    /// (`tensions` are the limited ones).
    pub limited: Saturation<M>,
    /// Smallest distance of a tension to its limits, N.
    pub robustness: f32,
    /// Vertices of the feasible polygon (barycenter methods).
    pub vertices: u8,
    /// Whether the solver's warm start held.
    pub warm_start: WarmStart,
}

/// Ticks spent in each phase of a cycle (0 for a phase that did not run).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PhaseTicks {
    /// Kinematics: the wrench matrix and the required wrench (gravity and
    /// the d'Alembert wrench of the setpoint's motion), in one pass.
    pub kinematics: u32,
    /// The tension distribution.
    pub solver: u32,
    /// Motor torques.
    pub torques: u32,
    /// Reading the drives (set by the control loop).
    pub read: u32,
    /// The pose estimator (set by the control loop).
    pub estimator: u32,
    /// The feedback law (set by the control loop).
    pub feedback: u32,
}

/// A setpoint's kinematics, computed once per cycle and shared by the
/// tension distribution, the estimator and the feedback.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SetpointKinematics<const M: usize = CABLES> {
    /// The inverse kinematics: cable lengths, m.
    pub lengths: SVector<f32, M>,
    /// The wrench matrix.
    pub w: WrenchMatrix<M>,
    /// The wrench the cables must produce (gravity, d'Alembert), no feedback.
    pub f: Wrench,
    /// The sines and cosines of the setpoint's Euler angles.
    pub trig: Trig,
    /// The setpoint's angular velocity, base frame, rad/s.
    pub omega: Vector3<f32>,
}

/// The sines and cosines of a pose's Euler angles `rx, ry, rz`
/// (conventions: `R = Rx(rx) Ry(ry) Rz(rz)`), computed once per cycle and
/// shared by the kinematics, the estimator and the feedback.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trig {
    /// `sin rx`, `cos rx`.
    pub sa: f32,
    /// `cos rx`.
    pub ca: f32,
    /// `sin ry`.
    pub sb: f32,
    /// `cos ry`.
    pub cb: f32,
    /// `sin rz`.
    pub sc: f32,
    /// `cos rz`.
    pub cc: f32,
}

impl Trig {
    /// Of `pose`'s angles.
    pub fn of(pose: &crate::setpoint::Pose6) -> Self {
        let (sa, ca) = pose[3].sin_cos_native();
        let (sb, cb) = pose[4].sin_cos_native();
        let (sc, cc) = pose[5].sin_cos_native();
        Self { sa, ca, sb, cb, sc, cc }
    }

    /// `R = Rx Ry Rz`.
    pub fn rotation(&self) -> Matrix3<f32> {
        let Self { sa, ca, sb, cb, sc, cc } = *self;
        Matrix3::new(
            cb * cc,
            -cb * sc,
            sb,
            ca * sc + sa * sb * cc,
            ca * cc - sa * sb * sc,
            -sa * cb,
            sa * sc - ca * sb * cc,
            sa * cc + ca * sb * sc,
            ca * cb,
        )
    }

    /// The Euler-rate matrix `J`: `omega = J [rx' ry' rz']`.
    pub fn euler_rate_matrix(&self) -> Matrix3<f32> {
        let Self { sa, ca, sb, cb, .. } = *self;
        Matrix3::new(1.0, 0.0, sb, 0.0, ca, -sa * cb, 0.0, sa, ca * cb)
    }

    /// The Euler-angle increments of a small rotation vector `w` (the
    /// inverse of [`Trig::euler_rate_matrix`]; `cos ry` away from zero).
    pub fn euler_increment(&self, w: &Vector3<f32>) -> Vector3<f32> {
        let Self { sa, ca, sb, cb, .. } = *self;
        let db = ca * w.y + sa * w.z;
        let dc = (-sa * w.y + ca * w.z) / cb;
        Vector3::new(w.x - sb * dc, db, dc)
    }
}

/// One cycle's outcome and what each phase cost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cycle<const M: usize = CABLES> {
    /// The command, or why there is none.
    pub result: Result<Command<M>, Error>,
    /// Cost of each phase.
    pub ticks: PhaseTicks,
}

/// Winch friction the torques compensate (feed-forward), at the motor
/// shaft: `tau_f(w) = coulomb tanh(w / coulomb_speed) + viscous w`, with
/// `w` the motor speed that pays cable out (`l' G / r`, `l'` the cable's
/// length rate at the setpoint, `-(W^T [v; omega])_i`). Friction opposes
/// the motion, so the motor torque becomes
/// `tau = (t - tau_f G / r) r / (G eta) = t r / (G eta) - tau_f / eta`,
/// still limited to `+-torque_max`. The tensions reported are the solver's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionCompensation {
    /// Coulomb friction torque, N m.
    pub coulomb: f32,
    /// Motor speed over which the Coulomb term is smoothed, rad/s (> 0).
    pub coulomb_speed: f32,
    /// Viscous friction, N m s/rad.
    pub viscous: f32,
}

/// A cable whose winch cannot pull its upper tension limit: `t_max`
/// needs `torque` at the motor (conventions:
/// `tau = t r / (G eta)`), more than the winch's `torque_max`. The control
/// loop's tensions stay within `t_min..t_max`; such a winch would have
/// its torque cut below them, and the platform pulled off its setpoint,
/// whenever a solution came near `t_max`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WinchReachError {
    /// The cable, 0-based.
    pub cable: usize,
    /// Its upper tension limit, N.
    pub t_max: f32,
    /// The motor torque `t_max` needs, N m (infinite if it overflows).
    pub torque: f32,
    /// The winch's largest motor torque, N m.
    pub torque_max: f32,
    /// The largest tension the winch pulls, `torque_max G eta / r`, N,
    /// rounded down a little so that it passes this check.
    pub tension_max: f32,
}

impl core::fmt::Display for WinchReachError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "cable {}: t_max = {} N needs {:.4} N m at the motor (t r / (G eta)), over the winch's torque_max \
             = {} N m: its winch pulls at most {:.3} N; t_max must be at most that (or torque_max larger)",
            self.cable + 1,
            self.t_max,
            self.torque,
            self.torque_max,
            self.tension_max
        )
    }
}

/// Whether every cable's winch pulls the cable's `t_max` without its
/// torque being limited ([`tension_core::Winch::motor_torque`], the
/// board's own arithmetic): the first cable that it does not, otherwise.
/// A robot without a winch has nothing to check. `ControlLoop::new`
/// refuses such a robot (`InvalidLimits`). Out of line: inlined into the
/// firmware's start-up it grew that frame (12 928 -> 14 528 bytes, as
/// `ControlLoop::reaches` had). Friction compensation
/// ([`FrictionCompensation`]) and the joint-space feedback's torque come
/// on top and are reported as saturation when they reach the limit.
#[inline(never)]
pub fn check_winch_reach<const M: usize>(robot: &Robot<f32, DOF, M>) -> Result<(), WinchReachError> {
    let Some(winch) = robot.winch() else {
        return Ok(());
    };
    for (cable, &t_max) in robot.limits().max().iter().enumerate() {
        let torque = match winch.motor_torque(t_max) {
            Ok(t) if !t.saturated => continue,
            // `Robot` holds finite limits; an overflow is out of reach.
            Ok(_) | Err(_) => t_max * winch.drum_radius / (winch.gear_ratio * winch.efficiency),
        };
        let exact = f64::from(winch.torque_max) * f64::from(winch.gear_ratio) * f64::from(winch.efficiency)
            / f64::from(winch.drum_radius);
        return Err(WinchReachError {
            cable,
            t_max,
            torque: if torque.is_finite() { torque } else { f32::INFINITY },
            torque_max: winch.torque_max,
            tension_max: (exact * (1.0 - 1e-6)) as f32,
        });
    }
    Ok(())
}

/// A setpoint's kinematics with their `W` factored by
/// [`Controller::prepare`] (or the error that stopped it), for
/// [`Controller::finish`]: made only there, used once, so the
/// factorisation the solver uses is that of these kinematics.
#[derive(Debug)]
pub struct Prepared<'k, const M: usize = CABLES> {
    kinematics: &'k SetpointKinematics<M>,
    factored: Result<(), Error>,
    /// The controller's factorisation count when this one was made: the
    /// workspace still holds it while the count is the same.
    generation: u32,
    /// The factorisation's time, counted as the solver's.
    ticks: u32,
}

/// The controller: the robot (6 DOF, `M` cables, by default the firmware's
/// 8) and a warm-started tension solver. What reaches the winches is the
/// [`crate::supervisor`]'s decision.
pub struct Controller<const M: usize = CABLES> {
    robot: Robot<f32, DOF, M>,
    solver: TensionSolver<f32, M>,
    /// The solver's factorisation and polygon, refilled every cycle.
    scratch: Workspace<f32, DOF, M>,
    /// Counts the factorisations written to `scratch` ([`Self::prepare`],
    /// [`Self::solve`]): a [`Prepared`] of another count is no longer there.
    generation: u32,
    /// The largest anchor coordinate's magnitude (the anchors' part of the
    /// robot's size for the degenerate-cable floor, which is constant).
    anchor_extent: f32,
    friction: Option<FrictionCompensation>,
}

impl<const M: usize> Controller<M> {
    /// A controller for `robot` (6 DOF, `M` cables, with a winch) using `method`.
    pub fn new(robot: Robot<f32, DOF, M>, method: Method) -> Result<Self, Error> {
        if robot.winch().is_none() {
            return Err(Error::UnsupportedShape);
        }
        let anchor_extent = robot.anchors().iter().flat_map(|a| a.iter()).fold(0.0f32, |m, x| {
            let x = libm::fabsf(*x);
            if x > m {
                x
            } else {
                m
            }
        });
        Ok(Self {
            robot,
            solver: TensionSolver::new(method),
            scratch: Workspace::new(),
            generation: 0,
            anchor_extent,
            friction: None,
        })
    }

    /// Compensates winch friction in the torques from now on (`None`, the
    /// default: no compensation).
    pub fn set_friction(&mut self, friction: Option<FrictionCompensation>) {
        self.friction = friction;
    }

    /// The friction compensation, if any.
    pub fn friction(&self) -> Option<&FrictionCompensation> {
        self.friction.as_ref()
    }

    /// Per cable, the tension-equivalent friction force `tau_f G / r`, N,
    /// at the setpoint's motion (zero without compensation).
    fn friction_forces(&self, setpoint: &Setpoint, w: &WrenchMatrix<M>) -> Result<[f32; M], Error> {
        let mut out = [0.0; M];
        let (Some(fr), Some(winch)) = (self.friction, self.robot.winch()) else {
            return Ok(out);
        };
        let motion = Motion::from_pose_derivatives(
            RobotKind::Spatial6,
            &setpoint.pose,
            &setpoint.velocity,
            &setpoint.acceleration,
        )?;
        let v = &setpoint.velocity;
        let omega = motion.angular_velocity;
        let twist = SVector::<f32, DOF>::from([v[0], v[1], v[2], omega.x, omega.y, omega.z]);
        let rates = w.transpose() * twist;
        let ratio = winch.gear_ratio / winch.drum_radius;
        for (o, rate) in out.iter_mut().zip(rates.iter()) {
            // l' = -(W^T twist)_i; motor speed paying out.
            let speed = -rate * ratio;
            let x = speed / fr.coulomb_speed;
            // tanh without std: 1 - 2 / (exp(2x) + 1), saturated for large |x|.
            let tanh = if x > 20.0 {
                1.0
            } else if x < -20.0 {
                -1.0
            } else {
                1.0 - 2.0 / (libm::expf(2.0 * x) + 1.0)
            };
            *o = (fr.coulomb * tanh + fr.viscous * speed) * ratio;
        }
        if tension_core::all_finite(out.iter().copied()) {
            Ok(out)
        } else {
            Err(Error::NonFinite)
        }
    }

    /// The method in use.
    pub fn method(&self) -> Method {
        self.solver.method()
    }

    /// Switches to `method` with no warm start;
    /// [`Error::UnsupportedShape`] if it does not apply to 6 DOF x `M` cables.
    pub fn set_method(&mut self, method: Method) -> Result<(), Error> {
        if !method.supports(DOF, M) {
            return Err(Error::UnsupportedShape);
        }
        self.solver = TensionSolver::new(method);
        Ok(())
    }

    /// The robot.
    pub fn robot(&self) -> &Robot<f32, DOF, M> {
        &self.robot
    }

    /// Kinematics and dynamics: the wrench matrix at the setpoint's pose and
    /// the wrench the cables must produce: gravity, the inertial wrench
    /// from the setpoint's velocity and acceleration, and `extra` (e.g. a
    /// feedback wrench from a pose controller, base frame, about the
    /// platform origin; zero for pure feed-forward).
    pub fn wrench(&self, setpoint: &Setpoint, extra: &Wrench) -> Result<(WrenchMatrix<M>, Wrench), Error> {
        self.robot.wrench_problem(&setpoint.pose, extra, Some((&setpoint.velocity, &setpoint.acceleration)))
    }

    /// The tension distribution (warm-started from the previous success).
    pub fn solve(&mut self, w: &WrenchMatrix<M>, f: &Wrench) -> Result<Solution<f32, M>, Error> {
        self.generation = self.generation.wrapping_add(1);
        self.solver.solve_with(&mut self.scratch, w, f, self.robot.limits())
    }

    /// Factors the setpoint's `W` for the solver (`W^T = Q R`, with the
    /// null space when the method reads it), once a cycle: the estimator
    /// reads it ([`Self::factorization`]) before [`Self::finish`] solves
    /// with it.
    pub fn prepare<'k, C: TickCounter>(
        &mut self,
        kinematics: &'k SetpointKinematics<M>,
        clock: &C,
    ) -> Prepared<'k, M> {
        let t0 = clock.ticks();
        self.generation = self.generation.wrapping_add(1);
        let method = self.solver.method();
        let factored = if method.supports(DOF, M) {
            let columns = method.null_columns(DOF, M);
            self.scratch.factorization.factor(&kinematics.w, &[true; M], columns)
        } else {
            Err(Error::UnsupportedShape)
        };
        Prepared { kinematics, factored, generation: self.generation, ticks: clock.since(t0) }
    }

    /// The factorisation [`Self::prepare`] made, if it succeeded and is
    /// still the one held (no other `prepare` or [`Self::solve`] since).
    pub fn factorization(&self, prepared: &Prepared<'_, M>) -> Option<&WrenchFactorization<f32, DOF, M>> {
        (prepared.factored.is_ok() && prepared.generation == self.generation)
            .then_some(&self.scratch.factorization)
    }

    /// Motor torques for a tension solution (no friction compensation).
    pub fn command(&self, solution: &Solution<f32, M>) -> Result<Command<M>, Error> {
        self.command_with(solution, &[0.0; M], None)
    }

    /// Motor torques for a tension solution plus `offsets` (N, the
    /// joint-space feedback; the sum limited to `t_min..t_max`, each
    /// limited cable flagged), each cable's tension lowered by `friction`
    /// (N) before the conversion.
    fn command_with(
        &self,
        solution: &Solution<f32, M>,
        friction: &[f32; M],
        offsets: Option<&[f32; M]>,
    ) -> Result<Command<M>, Error> {
        let winch = self.robot.winch().ok_or(Error::UnsupportedShape)?;
        let limits = self.robot.limits();
        let mut tensions = [0.0; M];
        let mut limited = Saturation::NONE;
        for (i, t) in tensions.iter_mut().enumerate() {
            *t = solution.tensions[i];
            if let Some(offsets) = offsets {
                let (lo, hi) = (limits.min()[i], limits.max()[i]);
                let wanted = *t + offsets[i];
                if !wanted.is_finite() {
                    return Err(Error::NonFinite);
                }
                *t = wanted.clamp(lo, hi);
                limited.0[i] = *t != wanted;
            }
        }
        let mut torques = [0.0; M];
        let mut saturated = Saturation::NONE;
        for (i, torque) in torques.iter_mut().enumerate() {
            let m = winch.motor_torque(tensions[i] - friction[i])?;
            *torque = m.torque;
            saturated.0[i] = m.saturated;
        }
        Ok(Command {
            tensions,
            torques,
            limited,
            saturated,
            robustness: solution.robustness,
            vertices: solution.diagnostics.vertices,
            warm_start: solution.diagnostics.warm_start,
        })
    }

    /// One whole cycle; `clock` times each phase.
    pub fn step<C: TickCounter>(&mut self, setpoint: &Setpoint, extra: &Wrench, clock: &C) -> Cycle<M> {
        let mut ticks = PhaseTicks::default();
        let result = self.run(setpoint, extra, clock, &mut ticks);
        Cycle { result, ticks }
    }

    /// The setpoint's kinematics in one pass (the frame's sines and
    /// cosines once): cable lengths, the wrench matrix and the required
    /// wrench with gravity and the d'Alembert terms of the setpoint's
    /// motion, as `Robot::cables`, `Robot::wrench_matrix_of` and
    /// `Robot::wrench_problem` define them (conventions; the tests compare
    /// them). Errors: [`Error::NonFinite`], [`Error::DegenerateCable`].
    pub fn kinematics(&self, setpoint: &Setpoint) -> Result<SetpointKinematics<M>, Error> {
        let (x, v, a) = (&setpoint.pose, &setpoint.velocity, &setpoint.acceleration);
        if !tension_core::all_finite(x.iter().chain(v.iter()).chain(a.iter()).copied()) {
            return Err(Error::NonFinite);
        }
        let trig = Trig::of(x);
        let rot = trig.rotation();
        let p = Vector3::new(x[0], x[1], x[2]);
        // The robot's size for the degenerate-cable floor (comparisons:
        // `f32::max` is a library call on the M4F).
        let bigger = |m: f32, v: &Vector3<f32>| {
            let mut m = m;
            for x in v.iter() {
                let x = libm::fabsf(*x);
                if x > m {
                    m = x;
                }
            }
            m
        };
        let anchors = self.robot.anchors();
        let attachments = self.robot.attachments();
        // Built element by element (`from_fn`): nothing is zeroed first.
        let rbs: [Vector3<f32>; M] = core::array::from_fn(|i| rot * attachments[i]);
        let vectors: [Vector3<f32>; M] = core::array::from_fn(|i| anchors[i] - p - rbs[i]);
        let lengths = SVector::<f32, M>::from_fn(|i, _| vectors[i].norm_squared().sqrt_native());
        let size = rbs.iter().fold(bigger(self.anchor_extent, &p), bigger);
        let floor = tension_core::tolerance::degenerate_length(size);
        for &length in lengths.iter() {
            if !(length.is_finite() && length > floor) {
                return Err(if length.is_finite() { Error::DegenerateCable } else { Error::NonFinite });
            }
        }
        let units: [Vector3<f32>; M] = core::array::from_fn(|i| vectors[i] / lengths[i]);
        let moments: [Vector3<f32>; M] = core::array::from_fn(|i| rbs[i].cross(&units[i]));
        let w = WrenchMatrix::<M>::from_fn(|k, i| if k < 3 { units[i][k] } else { moments[i][k - 3] });
        // Motion (`Motion::from_pose_derivatives` with the shared trig).
        let (da, db, dc) = (v[3], v[4], v[5]);
        let (sa, ca, sb, cb) = (trig.sa, trig.ca, trig.sb, trig.cb);
        let j2 = Vector3::new(0.0, ca, sa);
        let j3 = Vector3::new(sb, -sa * cb, ca * cb);
        let dj2 = Vector3::new(0.0, -sa, ca) * da;
        let dj3 = Vector3::new(db * cb, -da * ca * cb + db * sa * sb, -da * sa * cb - db * ca * sb);
        let omega = Vector3::new(da, 0.0, 0.0) + j2 * db + j3 * dc;
        let alpha = Vector3::new(a[3], 0.0, 0.0) + j2 * a[4] + j3 * a[5] + dj2 * db + dj3 * dc;
        // External wrench (gravity and d'Alembert at the centre of mass).
        let pf = self.robot.platform();
        let rc = rot * pf.com;
        let a_c = Vector3::new(a[0], a[1], a[2]) + alpha.cross(&rc) + omega.cross(&omega.cross(&rc));
        let force = (pf.gravity - a_c) * pf.mass;
        // I_w x = R (I (R^T x)): four products with a vector, not R I R^T.
        let rt = rot.transpose();
        let iw_alpha = rot * (pf.inertia * (rt * alpha));
        let iw_omega = rot * (pf.inertia * (rt * omega));
        let moment = rc.cross(&force) - (iw_alpha + omega.cross(&iw_omega));
        let f = -Wrench::new(force.x, force.y, force.z, moment.x, moment.y, moment.z);
        if !tension_core::all_finite(f.iter().copied()) {
            return Err(Error::NonFinite);
        }
        Ok(SetpointKinematics { lengths, w, f, trig, omega })
    }

    /// The rest of a cycle from [`Controller::kinematics`] and
    /// [`Controller::prepare`]: the tension distribution of `f + feedback`
    /// with the prepared factorisation (`feedback`: the wrench the cables
    /// add, base frame, about the platform origin), plus `offsets` per
    /// cable (N) if given, then the torques; `clock` times the solver and
    /// the torques into `ticks`.
    pub fn finish<C: TickCounter>(
        &mut self,
        setpoint: &Setpoint,
        prepared: Prepared<'_, M>,
        feedback: &Wrench,
        offsets: Option<&[f32; M]>,
        clock: &C,
        ticks: &mut PhaseTicks,
    ) -> Result<Command<M>, Error> {
        let t2 = clock.ticks();
        let kinematics = prepared.kinematics;
        let f = kinematics.f + feedback;
        let solution = match prepared.factored {
            // Another factorisation since `prepare`: factored anew.
            Ok(()) if prepared.generation != self.generation => self.solve(&kinematics.w, &f),
            Ok(()) => {
                let Workspace { factorization, polygon } = &mut self.scratch;
                self.solver.solve_factored(factorization, polygon, &kinematics.w, &f, self.robot.limits())
            }
            Err(e) => Err(e),
        };
        let t3 = clock.ticks();
        // The factorisation made by `prepare` counts as the solver's.
        ticks.solver = t3.wrapping_sub(t2).wrapping_add(prepared.ticks);
        let friction = self.friction_forces(setpoint, &kinematics.w)?;
        let command = self.command_with(&solution?, &friction, offsets);
        ticks.torques = clock.since(t3);
        command
    }

    fn run<C: TickCounter>(
        &mut self,
        setpoint: &Setpoint,
        extra: &Wrench,
        clock: &C,
        ticks: &mut PhaseTicks,
    ) -> Result<Command<M>, Error> {
        let t0 = clock.ticks();
        let problem = self.wrench(setpoint, extra);
        let t2 = clock.ticks();
        ticks.kinematics = t2.wrapping_sub(t0);
        let (w, f) = problem?;
        let solution = self.solve(&w, &f);
        let t3 = clock.ticks();
        ticks.solver = t3.wrapping_sub(t2);
        let friction = self.friction_forces(setpoint, &w)?;
        let command = self.command_with(&solution?, &friction, None);
        ticks.torques = clock.since(t3);
        command
    }
}
