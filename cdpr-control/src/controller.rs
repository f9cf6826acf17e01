//! One control cycle: setpoint -> wrench matrix -> required wrench (with the
//! d'Alembert terms from the setpoint's derivatives) -> tensions -> motor
//! torques.

use tension_core::nalgebra::{SMatrix, SVector};
use tension_core::{Error, Method, Solution, TensionSolver, WarmStart};

use crate::robot::{Suspended8, CABLES, DOF};
use crate::trajectory::Setpoint;
use crate::TickCounter;

/// Wrench matrix `W` (6 x 8).
pub type WrenchMatrix = SMatrix<f32, DOF, CABLES>;
/// Wrench `f` the cables must produce (`W t = f`).
pub type Wrench = SVector<f32, DOF>;

/// The result of a successful cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    /// Cable tensions, N.
    pub tensions: [f32; CABLES],
    /// Motor torques, N m (within `+-torque_max`).
    pub torques: [f32; CABLES],
    /// Bit `i` set when cable `i`'s torque was limited to `torque_max`.
    pub saturated: u8,
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
pub struct Cycle {
    /// The command, or why there is none.
    pub result: Result<Command, Error>,
    /// Cost of each phase.
    pub ticks: PhaseTicks,
}

/// The controller: the robot and a warm-started tension solver. What
/// reaches the winches is the [`crate::supervisor`]'s decision.
pub struct Controller {
    robot: Suspended8,
    solver: TensionSolver<f32, CABLES>,
}

impl Controller {
    /// A controller for `robot` (6 DOF, 8 cables, with a winch) using `method`.
    pub fn new(robot: Suspended8, method: Method) -> Result<Self, Error> {
        if robot.winch().is_none() {
            return Err(Error::UnsupportedShape);
        }
        Ok(Self { robot, solver: TensionSolver::new(method) })
    }

    /// The robot.
    pub fn robot(&self) -> &Suspended8 {
        &self.robot
    }

    /// Kinematics and dynamics: the wrench matrix at the setpoint's pose and
    /// the wrench the cables must produce: gravity, the inertial wrench
    /// from the setpoint's velocity and acceleration, and `extra` (e.g. a
    /// feedback wrench from a pose controller, base frame, about the
    /// platform origin; zero for pure feed-forward).
    pub fn wrench(&self, setpoint: &Setpoint, extra: &Wrench) -> Result<(WrenchMatrix, Wrench), Error> {
        self.robot.wrench_problem(&setpoint.pose, extra, Some((&setpoint.velocity, &setpoint.acceleration)))
    }

    /// The tension distribution (warm-started from the previous success).
    pub fn solve(&mut self, w: &WrenchMatrix, f: &Wrench) -> Result<Solution<f32, CABLES>, Error> {
        self.solver.solve(w, f, self.robot.limits())
    }

    /// Motor torques for a tension solution.
    pub fn command(&self, solution: &Solution<f32, CABLES>) -> Result<Command, Error> {
        let winch = self.robot.winch().ok_or(Error::UnsupportedShape)?;
        let mut torques = [0.0; CABLES];
        let mut saturated = 0u8;
        for (i, torque) in torques.iter_mut().enumerate() {
            let m = winch.motor_torque(solution.tensions[i])?;
            *torque = m.torque;
            if m.saturated {
                saturated |= 1 << i;
            }
        }
        let mut tensions = [0.0; CABLES];
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
    pub fn step<C: TickCounter>(&mut self, setpoint: &Setpoint, extra: &Wrench, clock: &C) -> Cycle {
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
    ) -> Result<Command, Error> {
        let t0 = clock.ticks();
        let problem = self.wrench(setpoint, extra);
        let t2 = clock.ticks();
        ticks.kinematics = t2.wrapping_sub(t0);
        let (w, f) = problem?;
        let solution = self.solve(&w, &f);
        let t3 = clock.ticks();
        ticks.solver = t3.wrapping_sub(t2);
        let command = self.command(&solution?);
        ticks.torques = clock.since(t3);
        command
    }
}
