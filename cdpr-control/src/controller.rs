//! One control cycle: setpoint -> wrench matrix -> required wrench (with the
//! d'Alembert terms from the setpoint's derivatives) -> tensions -> motor
//! torques, optionally with the winches' friction compensated
//! ([`FrictionCompensation`]).

use tension_core::nalgebra::{SMatrix, SVector};
use tension_core::{Error, Method, Motion, Robot, RobotKind, Solution, TensionSolver, WarmStart};

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

/// The controller: the robot (6 DOF, `M` cables, by default the firmware's
/// 8) and a warm-started tension solver. What reaches the winches is the
/// [`crate::supervisor`]'s decision.
pub struct Controller<const M: usize = CABLES> {
    robot: Robot<f32, DOF, M>,
    solver: TensionSolver<f32, M>,
    friction: Option<FrictionCompensation>,
}

impl<const M: usize> Controller<M> {
    /// A controller for `robot` (6 DOF, `M` cables, with a winch) using `method`.
    pub fn new(robot: Robot<f32, DOF, M>, method: Method) -> Result<Self, Error> {
        if robot.winch().is_none() {
            return Err(Error::UnsupportedShape);
        }
        Ok(Self { robot, solver: TensionSolver::new(method), friction: None })
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
        if out.iter().all(|f| f.is_finite()) {
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
        self.solver.solve(w, f, self.robot.limits())
    }

    /// Motor torques for a tension solution (no friction compensation).
    pub fn command(&self, solution: &Solution<f32, M>) -> Result<Command<M>, Error> {
        self.command_with(solution, &[0.0; M])
    }

    /// Motor torques for a tension solution, each cable's tension lowered
    /// by `friction` (N) before the conversion.
    fn command_with(&self, solution: &Solution<f32, M>, friction: &[f32; M]) -> Result<Command<M>, Error> {
        let winch = self.robot.winch().ok_or(Error::UnsupportedShape)?;
        let mut torques = [0.0; M];
        let mut saturated = Saturation::NONE;
        for (i, torque) in torques.iter_mut().enumerate() {
            let m = winch.motor_torque(solution.tensions[i] - friction[i])?;
            *torque = m.torque;
            saturated.0[i] = m.saturated;
        }
        let mut tensions = [0.0; M];
        tensions.copy_from_slice(solution.tensions.as_slice());
        Ok(Command {
            tensions,
            torques,
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
        let command = self.command_with(&solution?, &friction);
        ticks.torques = clock.since(t3);
        command
    }
}
