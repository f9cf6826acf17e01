//! Robot files and the run-time dispatch from (degrees of freedom, cables)
//! to `tension-core`'s const-generic robots.
//!
//! Each supported shape is monomorphised once, behind the object-safe
//! [`Model`] and [`ShapeSolver`] traits, so that the subcommands themselves
//! are ordinary (non-generic) code working on slices.

use std::path::{Path, PathBuf};

use nalgebra::SVector;
use robot_file::{RobotFile, RobotFileError};
use tension_core::{Error, Method, Motion, Robot, RobotKind, TensionSolver};

use crate::CliError;

/// The (degrees of freedom, cables) shapes this tool is built for.
pub const SHAPES: &[(usize, usize)] = &[
    (6, 6),
    (6, 7),
    (6, 8),
    (6, 9),
    (6, 10),
    (6, 11),
    (6, 12),
    (3, 3),
    (3, 4),
    (3, 5),
    (3, 6),
    (3, 7),
    (3, 8),
    (2, 2),
    (2, 3),
    (2, 4),
    (2, 5),
    (2, 6),
    (2, 8),
];

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
            CliError::input(format!(
                "--method: unknown method `{name}` (expected one of {})",
                Method::ALL.map(Method::name).join(", ")
            ))
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
/// known, the line and column.
pub fn load_robot(path: &Path) -> Result<LoadedRobot, CliError> {
    let text = std::fs::read_to_string(path).map_err(|e| CliError::at(path, None, None, &e.to_string()))?;
    let file = RobotFile::load(path).map_err(|e| robot_file_error(path, &text, &e))?;
    validate(path, &text, &file)?;
    let (n, m) = (file.dof(), file.cables.len());
    if !SHAPES.contains(&(n, m)) {
        let line = find_line(&text, |l| l.starts_with("kind"));
        return Err(CliError::at(
            path,
            line,
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

/// 1-based number of the first line for which `pred(trimmed line)` holds.
fn find_line(text: &str, pred: impl Fn(&str) -> bool) -> Option<usize> {
    text.lines().position(|l| pred(l.trim())).map(|i| i + 1)
}

/// Line of the `k`-th (0-based) `[[cable]]` header.
fn cable_line(text: &str, k: usize) -> Option<usize> {
    text.lines().enumerate().filter(|(_, l)| l.trim().starts_with("[[cable]]")).nth(k).map(|(i, _)| i + 1)
}

/// Line of a `t_min` or `t_max` override inside the `k`-th cable's table.
fn cable_key_line(text: &str, k: usize) -> Option<usize> {
    let start = cable_line(text, k)?;
    text.lines()
        .enumerate()
        .skip(start)
        .take_while(|(_, l)| !l.trim().starts_with('['))
        .find(|(_, l)| {
            let l = l.trim();
            ["t_min", "t_max"]
                .iter()
                .any(|key| l.strip_prefix(key).is_some_and(|r| r.trim_start().starts_with('=')))
        })
        .map(|(i, _)| i + 1)
}

fn key_line(text: &str, key: &str) -> Option<usize> {
    find_line(text, |l| l.strip_prefix(key).is_some_and(|rest| rest.trim_start().starts_with('=')))
}

/// Turns the `robot-file` crate's error into one line with a position.
fn robot_file_error(path: &Path, text: &str, e: &RobotFileError) -> CliError {
    match e {
        RobotFileError::Io(_, io) => CliError::at(path, None, None, &io.to_string()),
        RobotFileError::Format(msg) => {
            let prefix = format!("{}: ", path.display());
            let msg = msg.strip_prefix(&prefix).unwrap_or(msg);
            if let Some(pos) = toml_position(msg) {
                // toml: "TOML parse error at line L, column C", a source
                // excerpt ("  |", "3 | ...", "  | ^^^"), then the message.
                let what: Vec<&str> =
                    msg.lines().skip(1).map(str::trim).filter(|l| !l.is_empty() && !is_excerpt(l)).collect();
                CliError::at(path, Some(pos.0), Some((pos.1, "")), &what.join("; "))
            } else if msg.starts_with("unknown kind") {
                let line = key_line(text, "kind");
                // 1-based column of the value after `kind =`.
                let col = line.and_then(|l| {
                    let s = text.lines().nth(l - 1)?;
                    let eq = s.find('=')?;
                    let value = s[eq + 1..].find(|c: char| !c.is_whitespace())?;
                    Some(s[..eq + 1 + value].chars().count() + 1)
                });
                CliError::at(
                    path,
                    line,
                    col.map(|c| (c, "kind")),
                    &format!("{msg} (expected spatial6, planar3 or planar2)"),
                )
            } else {
                CliError::at(path, None, None, msg)
            }
        }
        RobotFileError::Invalid(what, err) => {
            CliError::at(path, None, None, &format!("{what}: {}", err.status()))
        }
        RobotFileError::Shape { .. } => CliError::at(path, None, None, &e.to_string()),
    }
}

fn is_excerpt(line: &str) -> bool {
    if line.starts_with('|') {
        return true;
    }
    let digits = line.trim_start_matches(|c: char| c.is_ascii_digit());
    digits.len() < line.len() && digits.trim_start().starts_with('|')
}

fn toml_position(msg: &str) -> Option<(usize, usize)> {
    let first = msg.lines().next()?;
    let rest = &first[first.find("at line ")? + 8..];
    let (line, rest) = rest.split_once(", column ")?;
    let col: String = rest.chars().take_while(char::is_ascii_digit).collect();
    Some((line.trim().parse().ok()?, col.parse().ok()?))
}

/// Checks the numbers `tension-core` would reject, to say where they are.
fn validate(path: &Path, text: &str, file: &RobotFile) -> Result<(), CliError> {
    let bad = |line: Option<usize>, msg: String| Err(CliError::at(path, line, None, &msg));
    if !file.mass.is_finite() || file.mass < 0.0 {
        return bad(
            key_line(text, "mass"),
            format!("[platform] mass = {} must be finite and >= 0", file.mass),
        );
    }
    let finite3 = |v: &[f64; 3]| v.iter().all(|x| x.is_finite());
    if !finite3(&file.com) || !finite3(&file.gravity) || !file.inertia.iter().all(finite3) {
        return bad(
            find_line(text, |l| l.starts_with("[platform]")),
            "[platform] holds a number that is not finite".into(),
        );
    }
    if let Some(w) = file.winch {
        if !w.iter().all(|x| x.is_finite() && *x > 0.0) || w[2] > 1.0 {
            return bad(
                find_line(text, |l| l.starts_with("[winch]")),
                "[winch]: drum_radius, gear_ratio, efficiency, torque_max must be positive, efficiency at most 1".into(),
            );
        }
    }
    for (k, c) in file.cables.iter().enumerate() {
        if !finite3(&c.anchor) || !finite3(&c.attach) {
            return bad(cable_line(text, k), format!("cable {}: anchor and attach must be finite", k + 1));
        }
        if !(c.t_min.is_finite() && c.t_max.is_finite() && c.t_min >= 0.0 && c.t_min < c.t_max) {
            let msg = format!("limits t_min = {}, t_max = {} need 0 <= t_min < t_max", c.t_min, c.t_max);
            return match cable_key_line(text, k) {
                Some(line) => bad(Some(line), format!("cable {}: {msg}", k + 1)),
                None => bad(find_line(text, |l| l.starts_with("[limits]")), format!("[limits]: {msg}")),
            };
        }
    }
    if file.cables.len() < file.dof() {
        return bad(
            None,
            format!(
                "a {} robot needs at least {} cables, the file has {}",
                file.kind.name(),
                file.dof(),
                file.cables.len()
            ),
        );
    }
    Ok(())
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
    fn solver(&self, method: Method) -> Box<dyn ShapeSolver> {
        Box::new(ShapedSolver { robot: self.robot.clone(), solver: TensionSolver::<f64, M>::new(method) })
    }
}

impl<const N: usize, const M: usize> ShapeSolver for ShapedSolver<N, M> {
    fn solve(&mut self, q: &Query<'_>, out: &mut [f64]) -> Result<f64, Error> {
        if q.pose.len() != N || out.len() != M {
            return Err(Error::UnsupportedShape);
        }
        let pose = SVector::<f64, N>::from_column_slice(q.pose);
        let extra = match q.extra {
            Some(e) if e.len() == N => SVector::<f64, N>::from_column_slice(e),
            Some(_) => return Err(Error::UnsupportedShape),
            None => SVector::zeros(),
        };
        let motion = match q.motion {
            Some((v, a)) if v.len() == N && a.len() == N => Some(Motion::from_pose_derivatives(
                self.robot.kind(),
                &pose,
                &SVector::<f64, N>::from_column_slice(v),
                &SVector::<f64, N>::from_column_slice(a),
            )?),
            Some(_) => return Err(Error::UnsupportedShape),
            None => None,
        };
        let w = self.robot.wrench_matrix(&pose)?;
        let f = self.robot.required_wrench(&pose, &extra, motion.as_ref())?;
        let sol = self.solver.solve(&w, &f, self.robot.limits())?;
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

macro_rules! dispatch {
    ($loaded:expr; $(($n:literal, $m:literal)),* $(,)?) => {{
        let loaded = $loaded;
        match (loaded.dof(), loaded.cables()) {
            $(
                ($n, $m) => {
                    let robot = loaded
                        .file
                        .to_robot::<f64, $n, $m>()
                        .map_err(|e| robot_file_error(&loaded.path, "", &e))?;
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
    }};
}

fn build_model(loaded: &LoadedRobot) -> Result<Box<dyn Model>, CliError> {
    dispatch!(loaded;
        (6, 6), (6, 7), (6, 8), (6, 9), (6, 10), (6, 11), (6, 12),
        (3, 3), (3, 4), (3, 5), (3, 6), (3, 7), (3, 8),
        (2, 2), (2, 3), (2, 4), (2, 5), (2, 6), (2, 8),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toml_positions_are_parsed() {
        let msg = "TOML parse error at line 3, column 7\n  |\n3 | mass = \"x\"\n  |       ^^^\ninvalid type: string \"x\", expected f64\n";
        assert_eq!(toml_position(msg), Some((3, 7)));
        assert!(is_excerpt("3 | mass = \"x\""));
        assert!(is_excerpt("|       ^^^"));
        assert!(!is_excerpt("invalid type: string \"x\", expected f64"));
    }

    #[test]
    fn every_shape_dispatches() {
        for &(n, m) in SHAPES {
            let kind = match n {
                6 => "spatial6",
                3 => "planar3",
                _ => "planar2",
            };
            let mut text = format!(
                "name = \"t\"\nkind = \"{kind}\"\n[limits]\nt_min = 1.0\nt_max = 10.0\n[platform]\nmass = 1.0\ngravity = [0.0, 0.0, -9.81]\n"
            );
            for i in 0..m {
                let a = i as f64 * std::f64::consts::TAU / m as f64;
                text.push_str(&format!(
                    "[[cable]]\nanchor = [{}, {}, 1.0]\nattach = [0.0, 0.0, 0.0]\n",
                    a.cos(),
                    a.sin()
                ));
            }
            let file = RobotFile::parse(&text).unwrap();
            let loaded = LoadedRobot { path: PathBuf::from("t.toml"), file };
            let model = loaded.model().unwrap();
            assert_eq!((model.dof(), model.cables()), (n, m));
        }
    }
}
