//! The Python class `cdpr.Robot`: a robot file (or dict) behind the `cdpr`
//! host tool's [`Model`], whose methods take and return numpy arrays.
//!
//! * One pose in, one answer out, or the core's typed exception.
//! * A batch (`(k, dof)` poses) in, `(k, m)` tensions and `k` status words
//!   out: a row that fails has NaN tensions and its word, and never raises;
//!   the rows are solved in order by one warm-started solver, as `cdpr
//!   solve` solves a pose table, with the GIL released.
//! * Bad arguments (shapes, dtypes, unknown methods, out-of-range settings)
//!   are `ValueError` / `TypeError` raised before anything is computed.

use std::path::PathBuf;

use cdpr::robot::{LoadedRobot, Model, Query, SHAPES};
use cdpr::workspace::{frame_box, scan, Grid, MAX_THREADS};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use robot_file::{Readable, RobotFile, RobotFileErrorKind};
use tension_core::{Error, Method, RobotKind};

use crate::convert::{array_out, dict_to_toml, real_array, shape_text, vector, Real};
use crate::errors::{core_error, forward_error, robot_file_error};

/// A cable-driven parallel robot, from a robot file (`Robot.from_toml`) or
/// a dict of the same keys (`Robot.from_dict`); see `docs/conventions.md`.
#[pyclass(frozen, module = "cdpr")]
pub struct Robot {
    loaded: LoadedRobot,
    model: Box<dyn Model>,
}

/// Per-row inputs of a batch: one row for every pose, or one row for all.
struct Rows {
    data: Vec<f64>,
    width: usize,
    broadcast: bool,
}

impl Rows {
    fn row(&self, r: usize) -> &[f64] {
        if self.broadcast {
            &self.data
        } else {
            &self.data[r * self.width..(r + 1) * self.width]
        }
    }
}

/// The words of a batch's statuses as a numpy array of strings
/// (`<U20`, the longest word's length), from each row's own word.
fn status_array<'py>(py: Python<'py>, words: &[&'static str]) -> PyResult<Bound<'py, PyAny>> {
    let mut table: Vec<&'static str> = Vec::new();
    // `isize`: numpy's index type (intp), which `take` accepts on every numpy.
    let codes: Vec<isize> = words
        .iter()
        .map(|w| match table.iter().position(|t| t == w) {
            Some(i) => i as isize,
            None => {
                table.push(w);
                table.len() as isize - 1
            }
        })
        .collect();
    let np = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "<U20")?;
    let table = np.call_method("asarray", (PyList::new(py, table)?,), Some(&kwargs))?;
    table.call_method1("take", (PyArray1::from_vec(py, codes),))
}

fn kind_pose_names(kind: RobotKind) -> &'static [&'static str] {
    match kind {
        RobotKind::Spatial6 => &["x", "y", "z", "rx", "ry", "rz"],
        RobotKind::Planar3 => &["x", "y", "theta"],
        RobotKind::Planar2 => &["x", "y"],
    }
}

fn supported_shapes() -> String {
    SHAPES.iter().map(|(n, m)| format!("{n}x{m}")).collect::<Vec<_>>().join(", ")
}

impl Robot {
    fn new(py: Python<'_>, file: RobotFile, path: PathBuf) -> PyResult<Self> {
        let (n, m) = (file.dof(), file.cables.len());
        if !SHAPES.contains(&(n, m)) {
            return Err(robot_file_error(
                py,
                format!(
                    "{}: a {} robot with {m} cables is not supported (DOF x cables supported: {})",
                    path.display(),
                    file.kind.name(),
                    supported_shapes()
                ),
                Some("unsupported-shape"),
            ));
        }
        let loaded = LoadedRobot { path, file };
        let model = loaded.model().map_err(|e| robot_file_error(py, e.to_string(), None))?;
        Ok(Self { loaded, model })
    }

    fn n(&self) -> usize {
        self.model.dof()
    }

    fn m(&self) -> usize {
        self.model.cables()
    }

    fn pose_meaning(&self) -> String {
        format!(
            "{} for a {} robot",
            kind_pose_names(self.loaded.kind()).join(", "),
            self.loaded.kind().name()
        )
    }

    /// One pose of `n` numbers.
    fn pose(&self, py: Python<'_>, pose: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
        vector(py, pose, what, self.n(), &self.pose_meaning())
    }

    /// A method by name that serves this robot.
    fn method(&self, py: Python<'_>, name: &str) -> PyResult<Method> {
        let method = Method::from_name(name).ok_or_else(|| {
            PyValueError::new_err(format!(
                "method: unknown method `{name}` (expected one of {})",
                cdpr::robot::method_names()
            ))
        })?;
        if !method.supports(self.n(), self.m()) {
            let usable: Vec<&str> = self.loaded.methods().iter().map(|m| m.name()).collect();
            let message = format!(
                "method {} needs m = n + 2 cables; {} has {} DOF and {} cables (use one of {})",
                method.name(),
                self.loaded.file.name,
                self.n(),
                self.m(),
                usable.join(", ")
            );
            return Err(core_error(py, Error::UnsupportedShape, &message));
        }
        Ok(method)
    }

    /// Optional per-row inputs for `k` rows of `n` numbers: shape `(n,)`
    /// (every row), or `(k, n)` for a batch.
    fn rows(
        &self,
        py: Python<'_>,
        obj: Option<&Bound<'_, PyAny>>,
        what: &str,
        k: usize,
        single: bool,
    ) -> PyResult<Option<Rows>> {
        let Some(obj) = obj.filter(|o| !o.is_none()) else { return Ok(None) };
        let n = self.n();
        let a: Real = real_array(py, obj, what)?;
        let broadcast = match a.shape.as_slice() {
            [w] if *w == n => true,
            [r, w] if !single && *r == k && *w == n => false,
            _ => {
                let want = if single { format!("({n},)") } else { format!("({n},) or ({k}, {n})") };
                return Err(PyValueError::new_err(format!(
                    "{what}: expected shape {want} ({}), got shape {}",
                    self.pose_meaning(),
                    a.shape_text()
                )));
            }
        };
        Ok(Some(Rows { data: a.data, width: n, broadcast }))
    }

    fn pose_text(pose: &[f64]) -> String {
        format!("[{}]", pose.iter().map(|v| Readable(*v).to_string()).collect::<Vec<_>>().join(", "))
    }
}

#[pymethods]
impl Robot {
    /// Reads a robot file (TOML, `docs/conventions.md`).
    ///
    /// Raises `RobotFileError` naming the file, line and column of what is
    /// wrong (its `status` is the core's word when a value was rejected),
    /// or for a (DOF, cables) shape the package is not built for.
    #[staticmethod]
    fn from_toml(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let file = RobotFile::load(&path).map_err(|e| {
            let status = match e.kind {
                RobotFileErrorKind::Invalid(_, core) => Some(core.status()),
                _ => None,
            };
            robot_file_error(py, e.to_string(), status)
        })?;
        Self::new(py, file, path)
    }

    /// A robot from a dict with the robot file's keys (`name`, `kind`,
    /// `limits`, `platform`, optional `winch`, and `cable`: a list of dicts
    /// with `anchor` and `attach`). The dict is written as TOML and parsed
    /// by the same parser as a file, so every key a robot file takes works.
    ///
    /// Raises `TypeError` for a value that is no number, string, list or
    /// dict, and `RobotFileError` for what the parser rejects (the message
    /// quotes the line of the TOML it was written as).
    #[staticmethod]
    fn from_dict(py: Python<'_>, robot: &Bound<'_, PyAny>) -> PyResult<Self> {
        let table = dict_to_toml(robot)?;
        let text = toml::to_string(&table)
            .map_err(|e| PyValueError::new_err(format!("Robot.from_dict: cannot be written as TOML: {e}")))?;
        let file = RobotFile::parse(&text).map_err(|e| {
            let status = match e.kind {
                RobotFileErrorKind::Invalid(_, core) => Some(core.status()),
                _ => None,
            };
            let at =
                e.at.and_then(|at| text.lines().nth(at.line.saturating_sub(1)))
                    .map(|line| format!(" (at `{}` of the dict written as TOML)", line.trim()))
                    .unwrap_or_default();
            robot_file_error(py, format!("Robot.from_dict: {}{at}", e.kind), status)
        })?;
        let name = format!("robot `{}` (from a dict)", file.name);
        Self::new(py, file, PathBuf::from(name))
    }

    /// The robot file's `name`.
    #[getter]
    fn name(&self) -> &str {
        &self.loaded.file.name
    }

    /// `spatial6`, `planar3` or `planar2`.
    #[getter]
    fn kind(&self) -> &'static str {
        self.loaded.kind().name()
    }

    /// Degrees of freedom `n` (the pose's length).
    #[getter]
    fn dof(&self) -> usize {
        self.n()
    }

    /// Number of cables `m`.
    #[getter]
    fn cables(&self) -> usize {
        self.m()
    }

    /// The pose's coordinate names, in order (`x, y, z, rx, ry, rz`, ...).
    #[getter]
    fn pose_names(&self) -> Vec<&'static str> {
        kind_pose_names(self.loaded.kind()).to_vec()
    }

    /// The methods that serve this robot's shape, in `METHODS` order.
    #[getter]
    fn methods(&self) -> Vec<&'static str> {
        self.loaded.methods().iter().map(|m| m.name()).collect()
    }

    /// Base anchors `a_i`, base frame, m: shape `(m, 3)`.
    #[getter]
    fn anchors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let data = self.loaded.file.cables.iter().flat_map(|c| c.anchor).collect();
        array_out(py, data, &[self.m(), 3])
    }

    /// Platform attachments `b_i`, platform frame, m: shape `(m, 3)`.
    #[getter]
    fn attachments<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let data = self.loaded.file.cables.iter().flat_map(|c| c.attach).collect();
        array_out(py, data, &[self.m(), 3])
    }

    /// Lower tension limits, N: shape `(m,)`.
    #[getter]
    fn t_min<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        array_out(py, self.model.t_min(), &[self.m()])
    }

    /// Upper tension limits, N: shape `(m,)`.
    #[getter]
    fn t_max<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        array_out(py, self.model.t_max(), &[self.m()])
    }

    /// The limits as one array, shape `(m, 2)`: columns `t_min`, `t_max`, N.
    #[getter]
    fn limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let data = self.model.t_min().into_iter().zip(self.model.t_max()).flat_map(|(a, b)| [a, b]).collect();
        array_out(py, data, &[self.m(), 2])
    }

    /// Platform mass, kg.
    #[getter]
    fn mass(&self) -> f64 {
        self.model.mass()
    }

    /// Centre of mass in the platform frame, m: shape `(3,)`.
    #[getter]
    fn com<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        array_out(py, self.loaded.file.com.to_vec(), &[3])
    }

    /// Gravity in the base frame, m/s^2: shape `(3,)`.
    #[getter]
    fn gravity<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        array_out(py, self.loaded.file.gravity.to_vec(), &[3])
    }

    /// Inertia about the centre of mass, platform axes, kg m^2: `(3, 3)`
    /// (zero when the file has none).
    #[getter]
    fn inertia<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        array_out(py, self.loaded.file.inertia.iter().flatten().copied().collect(), &[3, 3])
    }

    /// The `[winch]` data as a dict (`drum_radius`, `gear_ratio`,
    /// `efficiency`, `torque_max`), or None.
    #[getter]
    fn winch<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(w) = self.model.winch() else { return Ok(None) };
        let d = PyDict::new(py);
        d.set_item("drum_radius", w.drum_radius)?;
        d.set_item("gear_ratio", w.gear_ratio)?;
        d.set_item("efficiency", w.efficiency)?;
        d.set_item("torque_max", w.torque_max)?;
        Ok(Some(d))
    }

    fn __repr__(&self) -> String {
        format!(
            "Robot({:?}, kind={:?}, dof={}, cables={})",
            self.loaded.file.name,
            self.kind(),
            self.n(),
            self.m()
        )
    }

    /// The wrench matrix `W` at one pose: shape `(dof, m)`; column `i` is
    /// cable `i`'s unit wrench (conventions). Raises the core's error
    /// (`NonFiniteError`, `DegenerateCableError`).
    fn wrench_matrix<'py>(&self, py: Python<'py>, pose: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let pose = self.pose(py, pose, "pose")?;
        let mut out = vec![0.0; self.n() * self.m()];
        self.model
            .wrench_matrix(&pose, &mut out)
            .map_err(|e| core_error(py, e, &format!("wrench_matrix at pose {}", Self::pose_text(&pose))))?;
        array_out(py, out, &[self.n(), self.m()])
    }

    /// The cable lengths `|a_i - p - R b_i|` at one pose, m: shape `(m,)`.
    fn cable_lengths<'py>(&self, py: Python<'py>, pose: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let pose = self.pose(py, pose, "pose")?;
        let mut out = vec![0.0; self.m()];
        self.model
            .cable_lengths(&pose, &mut out)
            .map_err(|e| core_error(py, e, &format!("cable_lengths at pose {}", Self::pose_text(&pose))))?;
        array_out(py, out, &[self.m()])
    }

    /// The wrench the cables must produce at one pose, `f = -w_e`
    /// (gravity at the centre of mass, plus `wrench`, plus with `velocity`
    /// / `acceleration`, the pose's time derivatives, the d'Alembert
    /// wrench): shape `(dof,)`, so that `W t = f`.
    #[pyo3(signature = (pose, wrench=None, velocity=None, acceleration=None))]
    fn required_wrench<'py>(
        &self,
        py: Python<'py>,
        pose: &Bound<'py, PyAny>,
        wrench: Option<&Bound<'py, PyAny>>,
        velocity: Option<&Bound<'py, PyAny>>,
        acceleration: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let pose = self.pose(py, pose, "pose")?;
        let wrench = self.rows(py, wrench, "wrench", 1, true)?;
        let velocity = self.rows(py, velocity, "velocity", 1, true)?;
        let acceleration = self.rows(py, acceleration, "acceleration", 1, true)?;
        let zeros = vec![0.0; self.n()];
        let motion = match (&velocity, &acceleration) {
            (None, None) => None,
            (v, a) => Some((
                v.as_ref().map_or(&zeros[..], |v| v.row(0)),
                a.as_ref().map_or(&zeros[..], |a| a.row(0)),
            )),
        };
        let query = Query { pose: &pose, extra: wrench.as_ref().map(|w| w.row(0)), motion };
        let mut out = vec![0.0; self.n()];
        self.model
            .required_wrench(&query, &mut out)
            .map_err(|e| core_error(py, e, &format!("required_wrench at pose {}", Self::pose_text(&pose))))?;
        array_out(py, out, &[self.n()])
    }

    /// Forward kinematics: the pose whose cable lengths are `lengths`
    /// (`(m,)`, m), from `guess` (`(dof,)`) or from the cold starts.
    /// Raises `NonFiniteError`, `NoConvergenceError`, `IllConditionedError`
    /// or `InconsistentLengthsError` (the message gives the worst residual).
    #[pyo3(signature = (lengths, guess=None))]
    fn forward<'py>(
        &self,
        py: Python<'py>,
        lengths: &Bound<'py, PyAny>,
        guess: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let lengths = vector(py, lengths, "lengths", self.m(), "one length per cable, m")?;
        let guess = match guess.filter(|g| !g.is_none()) {
            Some(g) => Some(self.pose(py, g, "guess")?),
            None => None,
        };
        let model = &*self.model;
        let row = py.detach(|| model.forward(&lengths, guess.as_deref()));
        match row.pose {
            Ok(pose) => array_out(py, pose, &[self.n()]),
            Err(e) => {
                let residual =
                    row.residual.map(|r| format!(" (worst residual {r:.3e} m)")).unwrap_or_default();
                Err(forward_error(py, e, &format!("forward kinematics{residual}")))
            }
        }
    }

    /// Tensions by `method` (one of `METHODS` that serves the robot).
    ///
    /// `poses` is one pose `(dof,)` or a batch `(k, dof)`; `wrenches`
    /// (extra external wrench), `velocities` and `accelerations` (the
    /// pose's time derivatives, for the d'Alembert wrench; a missing one of
    /// the two is zero) are `(dof,)` for every pose or `(k, dof)`.
    ///
    /// One pose: returns the tensions `(m,)`, or raises the core's error
    /// (`InfeasibleError`, ...). A batch: returns `(tensions, status)`,
    /// `(k, m)` float64 with NaN rows where the status is not `ok`, and
    /// `(k,)` status words; no row raises. The rows are solved in order
    /// with one solver, each warm-started from the previous row, as along
    /// a trajectory (and as `cdpr solve` does), with the GIL released.
    #[pyo3(signature = (poses, method="barycenter", wrenches=None, velocities=None, accelerations=None))]
    fn solve<'py>(
        &self,
        py: Python<'py>,
        poses: &Bound<'py, PyAny>,
        method: &str,
        wrenches: Option<&Bound<'py, PyAny>>,
        velocities: Option<&Bound<'py, PyAny>>,
        accelerations: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let method = self.method(py, method)?;
        let (n, m) = (self.n(), self.m());
        let poses = real_array(py, poses, "poses")?;
        let (single, k) = match poses.shape.as_slice() {
            [w] if *w == n => (true, 1),
            [k, w] if *w == n => (false, *k),
            _ => {
                return Err(PyValueError::new_err(format!(
                    "poses: expected shape ({n},) or (k, {n}) ({}), got shape {}",
                    self.pose_meaning(),
                    poses.shape_text()
                )))
            }
        };
        let wrenches = self.rows(py, wrenches, "wrenches", k, single)?;
        let velocities = self.rows(py, velocities, "velocities", k, single)?;
        let accelerations = self.rows(py, accelerations, "accelerations", k, single)?;
        let model = &*self.model;
        let (tensions, results) = py.detach(|| {
            let zeros = vec![0.0; n];
            let mut solver = model.solver(method);
            let mut tensions = vec![f64::NAN; k * m];
            let mut results = Vec::with_capacity(k);
            for (r, out) in tensions.chunks_exact_mut(m).enumerate() {
                let motion = match (&velocities, &accelerations) {
                    (None, None) => None,
                    (v, a) => Some((
                        v.as_ref().map_or(&zeros[..], |v| v.row(r)),
                        a.as_ref().map_or(&zeros[..], |a| a.row(r)),
                    )),
                };
                let query = Query {
                    pose: &poses.data[r * n..(r + 1) * n],
                    extra: wrenches.as_ref().map(|w| w.row(r)),
                    motion,
                };
                let result = solver.solve(&query, out).map(|_| ());
                if result.is_err() {
                    out.fill(f64::NAN);
                }
                results.push(result);
            }
            (tensions, results)
        });
        if single {
            return match results[0] {
                Ok(()) => array_out(py, tensions, &[m]),
                Err(e) => Err(core_error(
                    py,
                    e,
                    &format!("{} at pose {}", method.name(), Self::pose_text(&poses.data)),
                )),
            };
        }
        let words: Vec<&'static str> =
            results.iter().map(|r| r.map_or_else(|e| e.status(), |()| "ok")).collect();
        let tensions = array_out(py, tensions, &[k, m])?;
        let status = status_array(py, &words)?;
        Ok(PyTuple::new(py, [tensions, status])?.into_any())
    }

    /// Motor torques for tensions `(m,)` or `(k, m)` (N), N m:
    /// `tau = t r / (G eta)`, limited to `+-torque_max` (conventions,
    /// `[winch]`). NaN where a tension is not finite (a failed row of
    /// `solve`). Raises `ValueError` when the robot has no `[winch]`.
    /// With `return_saturated=True`, `(torques, saturated)`: `saturated`
    /// a bool array of the same shape, `True` where the limit cut the
    /// torque (the board's `Saturation`), so that no limited torque passes
    /// for the one asked.
    #[pyo3(signature = (tensions, return_saturated=false))]
    fn motor_torques<'py>(
        &self,
        py: Python<'py>,
        tensions: &Bound<'py, PyAny>,
        return_saturated: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let winch = self.model.winch().ok_or_else(|| {
            PyValueError::new_err(format!(
                "motor_torques: robot {} has no [winch] (drum_radius, gear_ratio, efficiency, torque_max)",
                self.loaded.file.name
            ))
        })?;
        let t = real_array(py, tensions, "tensions")?;
        let m = self.m();
        match t.shape.as_slice() {
            [w] | [_, w] if *w == m => {}
            _ => {
                return Err(PyValueError::new_err(format!(
                    "tensions: expected shape ({m},) or (k, {m}) (one tension per cable, N), got shape {}",
                    t.shape_text()
                )))
            }
        }
        let commands: Vec<_> = t.data.iter().map(|&x| winch.motor_torque(x).ok()).collect();
        let torques = commands.iter().map(|c| c.map_or(f64::NAN, |tau| tau.torque)).collect();
        let torques = array_out(py, torques, &t.shape)?;
        if !return_saturated {
            return Ok(torques);
        }
        let saturated: Vec<bool> = commands.iter().map(|c| c.is_some_and(|tau| tau.saturated)).collect();
        let saturated = PyArray1::from_vec(py, saturated).reshape(t.shape.clone())?.into_any();
        Ok(PyTuple::new(py, [torques, saturated])?.into_any())
    }

    /// The grid `workspace(step, bounds)` scans: the cell centres along
    /// each axis, `(x, y, z)` (spatial6) or `(x, y)` (planar).
    #[pyo3(signature = (step, bounds=None))]
    fn workspace_axes<'py>(
        &self,
        py: Python<'py>,
        step: f64,
        bounds: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let grid = self.grid(py, step, bounds)?;
        let axes: Vec<Bound<'py, PyAny>> = (0..grid.dims)
            .map(|k| array_out(py, (0..grid.n[k]).map(|i| grid.centre(k, i)).collect(), &[grid.n[k]]))
            .collect::<PyResult<_>>()?;
        PyTuple::new(py, axes)
    }

    /// The wrench-feasible workspace at a constant orientation (static
    /// wrench: gravity only), as `cdpr workspace`: cells of about `step`
    /// metres over `bounds` (`(dims, 2)`: lo, hi per axis; default the
    /// anchors' bounding box reaching along gravity to the floor, the base
    /// origin: `cdpr workspace`'s frame), a cell feasible when `method` (default
    /// `barycenter` where it applies, else `improved-closed-form`) finds
    /// tensions at its centre; `threads` workers (default every core), the
    /// GIL released.
    ///
    /// Returns `(feasible, volume)`: a bool array `(nz, ny, nx)` (spatial6)
    /// or `(ny, nx)` (planar), `x` fastest, cell centres as
    /// `workspace_axes` gives them; and the feasible cells' volume (m^3; the
    /// area in m^2 for planar robots).
    #[pyo3(signature = (step, method=None, orientation=None, bounds=None, threads=None))]
    fn workspace<'py>(
        &self,
        py: Python<'py>,
        step: f64,
        method: Option<&str>,
        orientation: Option<&Bound<'py, PyAny>>,
        bounds: Option<&Bound<'py, PyAny>>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let kind = self.loaded.kind();
        let method = match method {
            Some(name) => self.method(py, name)?,
            None if Method::Barycenter.supports(self.n(), self.m()) => Method::Barycenter,
            None => Method::ImprovedClosedForm,
        };
        let angles = match kind {
            RobotKind::Spatial6 => 3,
            RobotKind::Planar3 => 1,
            RobotKind::Planar2 => 0,
        };
        let orientation = match orientation.filter(|o| !o.is_none()) {
            Some(o) => {
                let v = vector(py, o, "orientation", angles, "the pose's angles, rad")?;
                if v.iter().any(|x| !x.is_finite()) {
                    return Err(PyValueError::new_err("orientation: the angles must be finite"));
                }
                v
            }
            None => vec![0.0; angles],
        };
        let threads = match threads {
            Some(t) if (1..=MAX_THREADS).contains(&t) => t,
            Some(t) => {
                return Err(PyValueError::new_err(format!(
                    "threads: {t}; expected 1 to {MAX_THREADS} worker threads"
                )))
            }
            None => std::thread::available_parallelism().map_or(1, |n| n.get()).min(MAX_THREADS),
        };
        let grid = self.grid(py, step, bounds)?;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| PyValueError::new_err(format!("threads: cannot start the workers: {e}")))?;
        let model = &*self.model;
        let result = py
            .detach(|| scan(model, method, &grid, &orientation, None, &pool, false))
            .map_err(|e| PyValueError::new_err(format!("workspace: {e}")))?;
        let feasible: Vec<bool> = result.values.iter().map(|v| v.is_finite()).collect();
        let volume = result.feasible as f64 * grid.cell_measure();
        let shape: Vec<usize> =
            if grid.dims == 3 { vec![grid.n[2], grid.n[1], grid.n[0]] } else { vec![grid.n[1], grid.n[0]] };
        let feasible = PyArray1::from_vec(py, feasible).reshape(shape)?.into_any();
        PyTuple::new(py, [feasible, volume.into_pyobject(py)?.into_any()])
    }
}

impl Robot {
    /// The workspace grid for `step` over `bounds` (or the frame).
    fn grid(&self, py: Python<'_>, step: f64, bounds: Option<&Bound<'_, PyAny>>) -> PyResult<Grid> {
        let dims = if self.loaded.kind() == RobotKind::Spatial6 { 3 } else { 2 };
        let (mut lo, mut hi) = ([0.0; 3], [0.0; 3]);
        match bounds.filter(|b| !b.is_none()) {
            Some(b) => {
                let b = real_array(py, b, "bounds")?;
                if b.shape != [dims, 2] {
                    return Err(PyValueError::new_err(format!(
                        "bounds: expected shape {} (lo, hi for each of {}), got shape {}",
                        shape_text(&[dims, 2]),
                        ["x", "y", "z"][..dims].join(", "),
                        b.shape_text()
                    )));
                }
                for k in 0..dims {
                    (lo[k], hi[k]) = (b.data[2 * k], b.data[2 * k + 1]);
                    if !(lo[k].is_finite() && hi[k].is_finite() && hi[k] > lo[k]) {
                        return Err(PyValueError::new_err(format!(
                            "bounds: {} from {} to {} is not a finite, non-empty range",
                            ["x", "y", "z"][k],
                            Readable(lo[k]),
                            Readable(hi[k])
                        )));
                    }
                }
            }
            None => {
                (lo, hi) = frame_box(&self.loaded, &*self.model)
                    .map_err(|e| PyValueError::new_err(format!("workspace: {e}")))?;
            }
        }
        Grid::checked(lo, hi, step, dims).map_err(|why| PyValueError::new_err(format!("step: {why}")))
    }
}
