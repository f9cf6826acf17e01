//! Robot files and the run-time dispatch from (degrees of freedom, cables)
//! to `tension-core`'s const-generic robots.
//!
//! Each supported shape is monomorphised once, behind the object-safe
//! [`Model`] and [`ShapeSolver`] traits, so that the subcommands themselves
//! are ordinary (non-generic) code working on slices.

use std::path::{Path, PathBuf};

use nalgebra::SVector;
use robot_file::{RobotFile, RobotFileError, RobotFileErrorKind};
use tension_core::{
    methods::Workspace, Error, ForwardError, ForwardSettings, Method, Motion, Pose, Robot, RobotKind,
    TensionSolver, Winch,
};

use crate::CliError;

/// The conventions' method names, from [`Method::ALL`], comma-separated.
pub fn method_names() -> String {
    Method::ALL.map(Method::name).join(", ")
}

/// A `--method` help text: `what`, then every method's name, so that a
/// method added to `tension-core` appears in the help by itself.
pub fn method_help(what: &str) -> String {
    format!("{what}: {}", method_names())
}

/// A robot file as read, with its path (for messages).
#[derive(Debug, Clone)]
pub struct LoadedRobot {
    /// The file.
    pub path: PathBuf,
    /// Its contents.
    pub file: RobotFile,
}

impl LoadedRobot {
    /// Number of cables `m`.
    pub fn cables(&self) -> usize {
        self.file.cables.len()
    }

    /// Degrees of freedom `n`.
    pub fn dof(&self) -> usize {
        self.file.dof()
    }

    /// The robot's kind.
    pub fn kind(&self) -> RobotKind {
        self.file.kind
    }

    /// The methods that apply to this robot's shape, in the conventions' order.
    pub fn methods(&self) -> Vec<Method> {
        Method::ALL.into_iter().filter(|m| m.supports(self.dof(), self.cables())).collect()
    }

    /// Parses a method name and checks it applies to this robot.
    pub fn method(&self, name: &str) -> Result<Method, CliError> {
        let method = Method::from_name(name).ok_or_else(|| {
            CliError::input(format!("--method: unknown method `{name}` (expected one of {})", method_names()))
        })?;
        if !method.supports(self.dof(), self.cables()) {
            return Err(CliError::input(format!(
                "method {} needs m = n + 2 cables; {} has {} DOF and {} cables (use one of {})",
                method.name(),
                self.path.display(),
                self.dof(),
                self.cables(),
                self.methods().iter().map(|m| m.name()).collect::<Vec<_>>().join(", ")
            )));
        }
        Ok(method)
    }

    /// Parses a list of method names (each may be a comma-separated list);
    /// empty: every method that applies.
    pub fn method_list(&self, names: &[String]) -> Result<Vec<Method>, CliError> {
        let mut out = Vec::new();
        for name in names.iter().flat_map(|n| n.split(',')) {
            let name = name.trim();
            if name.is_empty() {
                continue;
            }
            let m = self.method(name)?;
            if !out.contains(&m) {
                out.push(m);
            }
        }
        if out.is_empty() {
            out = self.methods();
        }
        Ok(out)
    }

    /// The robot of fixed size behind the [`Model`] interface.
    pub fn model(&self) -> Result<Box<dyn Model>, CliError> {
        build_model(self)
    }
}

/// Reads a robot file; every error is one line naming the file and, where
/// known, the line and column (`robot-file` keeps them from `toml`'s spans
/// and from the part `tension-core` rejects).
pub fn load_robot(path: &Path) -> Result<LoadedRobot, CliError> {
    let file = RobotFile::load(path).map_err(|e| robot_file_error(path, &e))?;
    let (n, m) = (file.dof(), file.cables.len());
    if !SHAPES.contains(&(n, m)) {
        return Err(CliError::at(
            path,
            Some(file.kind_at.line),
            None,
            &format!(
                "a {} robot with {m} cables is not supported (supported: {})",
                file.kind.name(),
                supported_shapes()
            ),
        ));
    }
    Ok(LoadedRobot { path: path.to_path_buf(), file })
}

fn supported_shapes() -> String {
    let mut parts = Vec::new();
    for kind in [RobotKind::Spatial6, RobotKind::Planar3, RobotKind::Planar2] {
        let ms: Vec<String> =
            SHAPES.iter().filter(|(n, _)| *n == kind.dof()).map(|(_, m)| m.to_string()).collect();
        parts.push(format!("{} with {} cables", kind.name(), ms.join("/")));
    }
    parts.join("; ")
}

/// The `robot-file` crate's error as one line: `FILE, line L, column C
/// (kind): MESSAGE`, the value's name only for `kind`.
fn robot_file_error(path: &Path, e: &RobotFileError) -> CliError {
    let name = match e.kind {
        RobotFileErrorKind::UnknownKind(_) => "kind",
        _ => "",
    };
    let line = e.at.map(|at| at.line);
    let column = e.at.and_then(|at| at.column).map(|c| (c, name));
    CliError::at(path, line, column, &e.kind.to_string())
}

/// One pose to solve: the pose, an optional extra external wrench and
/// optional pose velocity and acceleration (for the d'Alembert wrench).
#[derive(Debug, Clone, Copy)]
pub struct Query<'a> {
    /// Pose, `n` numbers in the conventions' order.
    pub pose: &'a [f64],
    /// Extra external wrench, `n` numbers (conventions: column order).
    pub extra: Option<&'a [f64]>,
    /// First and second time derivatives of the pose.
    pub motion: Option<(&'a [f64], &'a [f64])>,
}

impl<'a> Query<'a> {
    /// A static pose without extra wrench.
    pub fn pose(pose: &'a [f64]) -> Self {
        Self { pose, extra: None, motion: None }
    }
}

/// A robot of a fixed shape, used through slices.
pub trait Model: Send + Sync {
    /// Degrees of freedom `n`.
    fn dof(&self) -> usize;
    /// Cables `m`.
    fn cables(&self) -> usize;
    /// Lower limits.
    fn t_min(&self) -> Vec<f64>;
    /// Upper limits.
    fn t_max(&self) -> Vec<f64>;
    /// Platform mass, kg.
    fn mass(&self) -> f64;
    /// A solver for one method, with its own warm-start state.
    fn solver(&self, method: Method) -> Box<dyn ShapeSolver>;
    /// The forward kinematics of `m` lengths, warm-started from `warm`
    /// (`n` numbers) with [`ForwardSettings::for_robot`]'s settings.
    fn forward(&self, lengths: &[f64], warm: Option<&[f64]>) -> ForwardRow;
    /// The wrench matrix `W` at a pose (`n` numbers), row by row (`n` rows
    /// of `m`) into `out` (`n m` numbers).
    fn wrench_matrix(&self, pose: &[f64], out: &mut [f64]) -> Result<(), Error>;
    /// The cable lengths `|l_i|` at a pose into `out` (`m` numbers).
    fn cable_lengths(&self, pose: &[f64], out: &mut [f64]) -> Result<(), Error>;
    /// The wrench the cables must produce for a query, `f = -w_e` (gravity,
    /// the extra wrench, the d'Alembert wrench), into `out` (`n` numbers).
    fn required_wrench(&self, query: &Query<'_>, out: &mut [f64]) -> Result<(), Error>;
    /// The winch data (for motor torques), when the robot file has it.
    fn winch(&self) -> Option<Winch<f64>>;
    /// The box the platform can be in, `(lo, hi)` (`Robot::platform_region`).
    fn platform_region(&self) -> ([f64; 3], [f64; 3]);
}

/// One row of `cdpr forward`: the pose or why not, and the worst residual
/// of the answer (or of the closest pose found, when there is one).
#[derive(Debug, Clone, PartialEq)]
pub struct ForwardRow {
    /// The pose (`n` numbers) or the reason.
    pub pose: Result<Vec<f64>, ForwardError>,
    /// Largest `|residual|`, m.
    pub residual: Option<f64>,
}

/// A warm-started solver for one robot and one method.
pub trait ShapeSolver: Send {
    /// Solves one pose: writes the `m` tensions into `out` and returns the
    /// robustness (smallest distance to a limit), or the reason why not.
    fn solve(&mut self, query: &Query<'_>, out: &mut [f64]) -> Result<f64, Error>;
    /// Forgets the warm start (after a jump).
    fn reset(&mut self);
    /// Sets the platform mass (payload sweeps).
    fn set_mass(&mut self, mass: f64) -> Result<(), Error>;
}

struct Shaped<const N: usize, const M: usize> {
    robot: Robot<f64, N, M>,
}

struct ShapedSolver<const N: usize, const M: usize> {
    robot: Robot<f64, N, M>,
    solver: TensionSolver<f64, M>,
    /// Kept from pose to pose, as a control loop keeps it: the polygon's
    /// room is not made anew for each pose, and the walk tries the last
    /// polygon's edges first.
    scratch: Workspace<f64, N, M>,
}

impl<const N: usize, const M: usize> Model for Shaped<N, M> {
    fn dof(&self) -> usize {
        N
    }
    fn cables(&self) -> usize {
        M
    }
    fn t_min(&self) -> Vec<f64> {
        self.robot.limits().min().iter().copied().collect()
    }
    fn t_max(&self) -> Vec<f64> {
        self.robot.limits().max().iter().copied().collect()
    }
    fn mass(&self) -> f64 {
        self.robot.platform().mass
    }
    fn platform_region(&self) -> ([f64; 3], [f64; 3]) {
        let (lo, hi) = self.robot.platform_region();
        (lo.into(), hi.into())
    }
    fn solver(&self, method: Method) -> Box<dyn ShapeSolver> {
        Box::new(ShapedSolver {
            robot: self.robot.clone(),
            solver: TensionSolver::<f64, M>::new(method),
            scratch: Workspace::new(),
        })
    }
    fn forward(&self, lengths: &[f64], warm: Option<&[f64]>) -> ForwardRow {
        if lengths.len() != M || warm.is_some_and(|w| w.len() != N) {
            return ForwardRow { pose: Err(ForwardError::UnsupportedShape), residual: None };
        }
        let l = SVector::<f64, M>::from_column_slice(lengths);
        let warm = warm.map(SVector::<f64, N>::from_column_slice);
        let settings = ForwardSettings::for_robot(&self.robot);
        match self.robot.forward_kinematics_attempt(&l, warm.as_ref(), &settings) {
            Ok(sol) => ForwardRow { pose: Ok(sol.pose.iter().copied().collect()), residual: Some(sol.worst) },
            Err(f) => ForwardRow { pose: Err(f.error), residual: f.closest.map(|c| c.worst) },
        }
    }
    fn wrench_matrix(&self, pose: &[f64], out: &mut [f64]) -> Result<(), Error> {
        let w = self.robot.wrench_matrix(&pose_of::<N>(pose)?)?;
        if out.len() != N * M {
            return Err(Error::UnsupportedShape);
        }
        for (r, row) in out.chunks_exact_mut(M).enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                *x = w[(r, c)];
            }
        }
        Ok(())
    }
    fn cable_lengths(&self, pose: &[f64], out: &mut [f64]) -> Result<(), Error> {
        let cables = self.robot.cables(&pose_of::<N>(pose)?)?;
        if out.len() != M {
            return Err(Error::UnsupportedShape);
        }
        out.copy_from_slice(cables.lengths.as_slice());
        Ok(())
    }
    fn required_wrench(&self, query: &Query<'_>, out: &mut [f64]) -> Result<(), Error> {
        let (pose, extra, motion) = query_parts(&self.robot, query)?;
        let f = self.robot.required_wrench(&pose, &extra, motion.as_ref())?;
        if out.len() != N {
            return Err(Error::UnsupportedShape);
        }
        out.copy_from_slice(f.as_slice());
        Ok(())
    }
    fn winch(&self) -> Option<Winch<f64>> {
        self.robot.winch().copied()
    }
}

/// A pose of `N` numbers from a slice ([`Error::UnsupportedShape`] for
/// another length).
fn pose_of<const N: usize>(pose: &[f64]) -> Result<Pose<f64, N>, Error> {
    if pose.len() != N {
        return Err(Error::UnsupportedShape);
    }
    Ok(SVector::<f64, N>::from_column_slice(pose))
}

/// A query's pose, extra wrench and motion, as `tension-core` takes them.
type QueryParts<const N: usize> = (Pose<f64, N>, SVector<f64, N>, Option<Motion<f64>>);

/// A query's pose, extra wrench (zero when absent) and motion (from the
/// pose's derivatives, when given), each checked for its length.
fn query_parts<const N: usize, const M: usize>(
    robot: &Robot<f64, N, M>,
    q: &Query<'_>,
) -> Result<QueryParts<N>, Error> {
    let pose = pose_of::<N>(q.pose)?;
    let extra = match q.extra {
        Some(e) => pose_of::<N>(e)?,
        None => SVector::zeros(),
    };
    let motion = match q.motion {
        Some((v, a)) => {
            Some(Motion::from_pose_derivatives(robot.kind(), &pose, &pose_of::<N>(v)?, &pose_of::<N>(a)?)?)
        }
        None => None,
    };
    Ok((pose, extra, motion))
}

impl<const N: usize, const M: usize> ShapeSolver for ShapedSolver<N, M> {
    fn solve(&mut self, q: &Query<'_>, out: &mut [f64]) -> Result<f64, Error> {
        if out.len() != M {
            return Err(Error::UnsupportedShape);
        }
        let (pose, extra, motion) = query_parts(&self.robot, q)?;
        let w = self.robot.wrench_matrix(&pose)?;
        let f = self.robot.required_wrench(&pose, &extra, motion.as_ref())?;
        let sol = self.solver.solve_with(&mut self.scratch, &w, &f, self.robot.limits())?;
        out.copy_from_slice(sol.tensions.as_slice());
        Ok(sol.robustness)
    }

    fn reset(&mut self) {
        self.solver.reset();
    }

    fn set_mass(&mut self, mass: f64) -> Result<(), Error> {
        let mut platform = *self.robot.platform();
        platform.mass = mass;
        self.robot.set_platform(platform)
    }
}

/// The shapes this tool is built for: [`SHAPES`], and [`build_model`]
/// with one monomorphised robot per shape, from one list.
macro_rules! shapes {
    ($(($n:literal, $m:literal)),* $(,)?) => {
        /// The (degrees of freedom, cables) shapes this tool is built for.
        pub const SHAPES: &[(usize, usize)] = &[$(($n, $m)),*];

        fn build_model(loaded: &LoadedRobot) -> Result<Box<dyn Model>, CliError> {
            match (loaded.dof(), loaded.cables()) {
                $(
                    ($n, $m) => {
                        let robot = loaded
                            .file
                            .to_robot::<f64, $n, $m>()
                            .map_err(|e| robot_file_error(&loaded.path, &e))?;
                        Ok(Box::new(Shaped::<$n, $m> { robot }) as Box<dyn Model>)
                    }
                )*
                (n, m) => Err(CliError::at(
                    &loaded.path,
                    None,
                    None,
                    &format!("{n} DOF with {m} cables is not supported (supported: {})", supported_shapes()),
                )),
            }
        }
    };
}

#[rustfmt::skip]
shapes!(
    (6, 6), (6, 7), (6, 8), (6, 9), (6, 10), (6, 11), (6, 12),
    (3, 3), (3, 4), (3, 5), (3, 6), (3, 7), (3, 8),
    (2, 2), (2, 3), (2, 4), (2, 5), (2, 6), (2, 8),
);
