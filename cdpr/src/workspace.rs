//! `cdpr workspace`: the wrench-feasible workspace at a constant
//! orientation (static wrench: gravity only) on a grid over the frame.
//!
//! The frame is the bounding box of the anchors, reaching along gravity to
//! the base frame's origin (the floor under a suspended robot), or for
//! anchors in the origin's plane (a robot framed on its ceiling) as far as
//! the box is wide ([`frame_box`]). The grid has cells of about `--step`
//! metres; a cell counts as feasible when the method finds tensions within
//! the limits at its centre.
//! The volume is the number of feasible cells times the cell volume.

use std::fmt::Write as _;
use std::io::IsTerminal;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use robot_file::Readable;
use tension_core::{Error, Method, RobotKind};

use crate::output::{ensure_dir, num, write_bytes, write_csv};
use crate::robot::{load_robot, method_help, LoadedRobot, Model, Query, ShapeSolver};
use crate::CliError;
use cdpr_plot::{line_plot, slices_png, LinePlot, Series, Slice, PALETTE};

/// Most grid cells one run may have.
pub const MAX_CELLS: usize = 50_000_000;

/// Most worker threads `--threads` may ask for (a larger number is an
/// error, not clamped): more than any machine this runs on has cores, few
/// enough that the pool's stacks stay small.
pub const MAX_THREADS: usize = 256;

/// Arguments of `cdpr workspace`.
#[derive(Debug, Clone, clap::Args)]
pub struct WorkspaceArgs {
    /// Robot description file (TOML).
    #[arg(long)]
    pub robot: PathBuf,
    /// rx,ry,rz (spatial6) or theta (planar3), radians; default zero.
    #[arg(long, allow_hyphen_values = true)]
    pub orientation: Option<String>,
    /// Grid step in metres.
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true)]
    pub step: f64,
    /// Method name (default: barycenter where it applies, else improved-closed-form).
    #[arg(
        long,
        help = method_help("Method (default: barycenter where it applies, else improved-closed-form)")
    )]
    pub method: Option<String>,
    /// Payload sweep a:b:n, kg added to the platform mass.
    #[arg(long, allow_hyphen_values = true)]
    pub mass_sweep: Option<String>,
    /// Box x0:x1,y0:y1[,z0:z1] instead of the anchors' bounding box.
    #[arg(long, allow_hyphen_values = true)]
    pub bounds: Option<String>,
    /// Worker threads, 1 to 256 (default: every core).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Show a progress bar (only when stderr is a terminal; always asked
    /// for on the command line).
    #[arg(skip = true)]
    pub progress: bool,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
}

/// A regular grid of cells over a box; 2-D for planar robots.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Lower corner.
    pub lo: [f64; 3],
    /// Upper corner.
    pub hi: [f64; 3],
    /// Cells per axis (1 along z for planar robots).
    pub n: [usize; 3],
    /// `2` (planar) or `3`.
    pub dims: usize,
}

impl Grid {
    /// Cells of about `step` over the box (at least one per axis).
    pub fn new(lo: [f64; 3], hi: [f64; 3], step: f64, dims: usize) -> Self {
        let mut n = [1; 3];
        for k in 0..dims {
            n[k] = (((hi[k] - lo[k]) / step).round() as usize).max(1);
        }
        Self { lo, hi, n, dims }
    }

    /// [`Self::new`] for a step given by a user (`cdpr workspace --step`,
    /// Python's `Robot.workspace`): refused, with the reason after the
    /// step's value (the caller names the option), when the step is not a
    /// positive length or the grid would have more than [`MAX_CELLS`]
    /// cells.
    pub fn checked(lo: [f64; 3], hi: [f64; 3], step: f64, dims: usize) -> Result<Self, String> {
        if !(step.is_finite() && step > 0.0) {
            return Err(format!("{}: the grid step must be a positive length in metres", Readable(step)));
        }
        let estimate: f64 = (0..dims).map(|k| ((hi[k] - lo[k]) / step).round().max(1.0)).product();
        if estimate > MAX_CELLS as f64 {
            return Err(format!(
                "{}: {} cells is more than {MAX_CELLS}; use a larger step",
                Readable(step),
                Readable(estimate)
            ));
        }
        Ok(Self::new(lo, hi, step, dims))
    }

    /// Cell size along axis `k`.
    pub fn h(&self, k: usize) -> f64 {
        (self.hi[k] - self.lo[k]) / self.n[k] as f64
    }

    /// Centre coordinate of cell `i` along axis `k`.
    pub fn centre(&self, k: usize, i: usize) -> f64 {
        if k >= self.dims {
            return 0.0;
        }
        self.lo[k] + (i as f64 + 0.5) * self.h(k)
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.n.iter().product()
    }

    /// Volume (area for planar robots) of one cell.
    pub fn cell_measure(&self) -> f64 {
        (0..self.dims).map(|k| self.h(k)).product()
    }

    /// Volume (area) of the box.
    pub fn measure(&self) -> f64 {
        (0..self.dims).map(|k| self.hi[k] - self.lo[k]).product()
    }
}

/// The frame: the box the platform can be in (`Robot::platform_region`):
/// the anchors' bounding box, reaching along gravity to the base origin,
/// the floor, or for anchors in the origin's plane as far as the box is
/// wide. An axis still without extent is an error. `model` is `robot`'s
/// (`LoadedRobot::model`), built once by the caller.
pub fn frame_box(robot: &LoadedRobot, model: &dyn Model) -> Result<([f64; 3], [f64; 3]), CliError> {
    let dims = if robot.kind() == RobotKind::Spatial6 { 3 } else { 2 };
    let (lo, hi) = model.platform_region();
    for k in 0..dims {
        if hi[k] - lo[k] <= 0.0 {
            return Err(CliError::at(
                &robot.path,
                None,
                None,
                &format!(
                    "every anchor has {} = {}, so the frame has no extent along it; give --bounds",
                    ["x", "y", "z"][k],
                    lo[k]
                ),
            ));
        }
    }
    Ok((lo, hi))
}

fn parse_number(text: &str, what: &str) -> Result<f64, CliError> {
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| CliError::input(format!("{what}: `{}` is not a number", text.trim())))?;
    if !v.is_finite() {
        return Err(CliError::input(format!("{what}: `{}` is not a finite number", text.trim())));
    }
    Ok(v)
}

/// Parses `--orientation` for a kind: 3 angles, 1 angle or none.
pub fn parse_orientation(text: Option<&str>, kind: RobotKind) -> Result<Vec<f64>, CliError> {
    let want = match kind {
        RobotKind::Spatial6 => 3,
        RobotKind::Planar3 => 1,
        RobotKind::Planar2 => 0,
    };
    let values: Vec<f64> = match text {
        None => vec![0.0; want],
        Some(t) if t.trim().is_empty() => vec![],
        Some(t) => t.split(',').map(|v| parse_number(v, "--orientation")).collect::<Result<_, _>>()?,
    };
    if values.len() != want {
        let form = match kind {
            RobotKind::Spatial6 => "rx,ry,rz in radians",
            RobotKind::Planar3 => "theta in radians",
            RobotKind::Planar2 => "nothing: a point mass has no orientation",
        };
        return Err(CliError::input(format!(
            "--orientation: {} value(s) given, a {} robot takes {form}",
            values.len(),
            kind.name()
        )));
    }
    Ok(values)
}

/// Parses `--mass-sweep a:b:n` into `n` payload values from `a` to `b`.
pub fn parse_sweep(text: &str) -> Result<Vec<f64>, CliError> {
    let parts: Vec<&str> = text.split(':').collect();
    if parts.len() != 3 {
        return Err(CliError::input(format!(
            "--mass-sweep `{text}`: expected a:b:n (payload from a kg to b kg in n steps)"
        )));
    }
    let a = parse_number(parts[0], "--mass-sweep")?;
    let b = parse_number(parts[1], "--mass-sweep")?;
    let n: usize = parts[2].trim().parse().map_err(|_| {
        CliError::input(format!("--mass-sweep: `{}` is not a whole number of steps", parts[2].trim()))
    })?;
    if n == 0 || n > 10_000 {
        return Err(CliError::input(format!("--mass-sweep: {n} steps (expected 1 to 10000)")));
    }
    Ok((0..n).map(|k| if n == 1 { a } else { a + (b - a) * k as f64 / (n - 1) as f64 }).collect())
}

fn parse_bounds(
    text: &str,
    dims: usize,
    frame: ([f64; 3], [f64; 3]),
) -> Result<([f64; 3], [f64; 3]), CliError> {
    let (mut lo, mut hi) = frame;
    let parts: Vec<&str> = text.split(',').collect();
    if parts.len() != dims {
        return Err(CliError::input(format!(
            "--bounds `{text}`: expected {} ranges lo:hi separated by commas",
            dims
        )));
    }
    for (k, p) in parts.iter().enumerate() {
        let (a, b) = p
            .split_once(':')
            .ok_or_else(|| CliError::input(format!("--bounds: `{p}` is not a range lo:hi")))?;
        lo[k] = parse_number(a, "--bounds")?;
        hi[k] = parse_number(b, "--bounds")?;
        if hi[k] <= lo[k] {
            return Err(CliError::input(format!("--bounds: empty range `{p}`")));
        }
    }
    Ok((lo, hi))
}

/// The result of one pass over the grid.
#[derive(Debug, Clone)]
pub struct GridResult {
    /// Robustness per cell (`x` fastest, then `y`, then `z`); `NaN` where
    /// no tension was found.
    pub values: Vec<f32>,
    /// Feasible cells.
    pub feasible: usize,
    /// Cells certified infeasible.
    pub infeasible: usize,
    /// Cells where the method failed otherwise (feasibility unknown).
    pub other_failures: usize,
}

/// Cells by outcome, summed over the lines of a grid.
#[derive(Debug, Clone, Copy, Default)]
struct CellCounts {
    feasible: usize,
    infeasible: usize,
    other_failures: usize,
}

impl std::ops::Add for CellCounts {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            feasible: self.feasible + o.feasible,
            infeasible: self.infeasible + o.infeasible,
            other_failures: self.other_failures + o.other_failures,
        }
    }
}

/// Lines of the grid done so far, for the progress bar.
struct Progress {
    done: AtomicUsize,
    total: usize,
    start: Instant,
}

impl Progress {
    fn line(&self) -> String {
        let done = self.done.load(Ordering::Relaxed).min(self.total);
        let frac = done as f64 / self.total.max(1) as f64;
        let width = 40;
        let filled = (frac * width as f64) as usize;
        format!(
            "\rworkspace [{}{}] {:5.1}% {:6.1} s",
            "#".repeat(filled),
            "-".repeat(width - filled),
            frac * 100.0,
            self.start.elapsed().as_secs_f64()
        )
    }

    /// Redraws the bar on stderr every 200 ms until `finished`.
    fn show_until(&self, finished: &AtomicBool) {
        let mut err = std::io::stderr();
        while !finished.load(Ordering::Relaxed) {
            let _ = write!(err, "{}", self.line());
            let _ = err.flush();
            std::thread::sleep(Duration::from_millis(200));
        }
        let _ = writeln!(err, "{}", self.line());
    }
}

/// Solves the cells of line `line` (along `x`) of the grid, warm-started
/// from cell to cell, writing each robustness into `cells`.
fn scan_line(
    solver: &mut dyn ShapeSolver,
    cables: usize,
    grid: &Grid,
    orientation: &[f64],
    line: usize,
    cells: &mut [f32],
) -> CellCounts {
    let (j, k) = (line % grid.n[1], line / grid.n[1]);
    let mut tensions = vec![0.0; cables];
    // The position's coordinates, then the orientation.
    let mut pose = vec![0.0; grid.dims + orientation.len()];
    pose[grid.dims..].copy_from_slice(orientation);
    pose[1] = grid.centre(1, j);
    if grid.dims == 3 {
        pose[2] = grid.centre(2, k);
    }
    let mut counts = CellCounts::default();
    solver.reset();
    for (i, cell) in cells.iter_mut().enumerate() {
        pose[0] = grid.centre(0, i);
        match solver.solve(&Query::pose(&pose), &mut tensions) {
            Ok(r) => {
                *cell = r as f32;
                counts.feasible += 1;
            }
            Err(Error::Infeasible) => counts.infeasible += 1,
            Err(_) => counts.other_failures += 1,
        }
    }
    counts
}

/// Solves every cell centre of the grid on `pool`, one line along `x` per
/// task, each line warm-started from its previous cell; `mass` replaces
/// the platform mass (payload sweeps).
pub fn scan(
    model: &dyn Model,
    method: Method,
    grid: &Grid,
    orientation: &[f64],
    mass: Option<f64>,
    pool: &rayon::ThreadPool,
    progress: bool,
) -> Result<GridResult, CliError> {
    let mut values = vec![f32::NAN; grid.cells()];
    let status = Progress { done: AtomicUsize::new(0), total: grid.n[1] * grid.n[2], start: Instant::now() };
    let finished = AtomicBool::new(false);
    let new_solver = || -> Result<Box<dyn ShapeSolver>, Error> {
        let mut solver = model.solver(method);
        if let Some(mass) = mass {
            solver.set_mass(mass)?;
        }
        Ok(solver)
    };
    let counts = std::thread::scope(|scope| {
        if progress {
            scope.spawn(|| status.show_until(&finished));
        }
        let counts = pool.install(|| {
            values
                .par_chunks_mut(grid.n[0])
                .enumerate()
                .map_init(new_solver, |solver, (line, cells)| {
                    let solver = solver.as_mut().map_err(|e| *e)?;
                    let counts = scan_line(solver.as_mut(), model.cables(), grid, orientation, line, cells);
                    status.done.fetch_add(1, Ordering::Relaxed);
                    Ok(counts)
                })
                .try_reduce(CellCounts::default, |a, b| Ok(a + b))
        });
        finished.store(true, Ordering::Relaxed);
        counts
    });
    let counts = counts.map_err(|e: Error| {
        CliError::input(format!("platform mass {}: {}", Readable(mass.unwrap_or(f64::NAN)), e.status()))
    })?;
    Ok(GridResult {
        values,
        feasible: counts.feasible,
        infeasible: counts.infeasible,
        other_failures: counts.other_failures,
    })
}

/// What `cdpr workspace` found.
#[derive(Debug, Clone)]
pub struct WorkspaceReport {
    /// The summary (also in `summary.txt`).
    pub summary: String,
    /// Volume (m^3) or area (m^2, planar) of the feasible cells.
    pub measure: f64,
    /// Share of the frame's box.
    pub share: f64,
    /// The grid.
    pub grid: Grid,
    /// Payload sweep: payload, total mass, volume, share.
    pub sweep: Vec<(f64, f64, f64, f64)>,
    /// Seconds spent scanning.
    pub seconds: f64,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// A workspace run with its arguments checked: what to scan and how.
struct Plan {
    robot: LoadedRobot,
    model: Box<dyn Model>,
    method: Method,
    orientation: Vec<f64>,
    /// Payloads of the sweep, kg (empty: no sweep).
    payloads: Vec<f64>,
    grid: Grid,
    threads: usize,
}

impl Plan {
    /// `3` for spatial robots, `2` for planar ones.
    fn dims(&self) -> usize {
        self.grid.dims
    }

    /// `volume` or `area`, and its unit.
    fn measure_name(&self) -> (&'static str, &'static str) {
        if self.dims() == 3 {
            ("volume", "m^3")
        } else {
            ("area", "m^2")
        }
    }

    /// The orientation as text for titles, empty for a point mass.
    fn orientation_text(&self) -> String {
        self.orientation.iter().map(|v| num(*v)).collect::<Vec<_>>().join(", ")
    }
}

/// Reads the robot and checks every argument before anything is scanned.
fn plan(args: &WorkspaceArgs) -> Result<Plan, CliError> {
    let robot = load_robot(&args.robot)?;
    let kind = robot.kind();
    let method = match &args.method {
        Some(name) => robot.method(name)?,
        None if Method::Barycenter.supports(robot.dof(), robot.cables()) => Method::Barycenter,
        None => Method::ImprovedClosedForm,
    };
    let orientation = parse_orientation(args.orientation.as_deref(), kind)?;
    let threads = match args.threads {
        Some(n) if (1..=MAX_THREADS).contains(&n) => n,
        Some(n) => {
            return Err(CliError::input(format!("--threads {n}: expected 1 to {MAX_THREADS} worker threads")))
        }
        None => std::thread::available_parallelism().map_or(1, |n| n.get()).min(MAX_THREADS),
    };
    let payloads = match &args.mass_sweep {
        Some(s) => parse_sweep(s)?,
        None => vec![],
    };
    let dims = if kind == RobotKind::Spatial6 { 3 } else { 2 };
    let model = robot.model()?;
    let frame = frame_box(&robot, &*model)?;
    let (lo, hi) = match &args.bounds {
        Some(b) => parse_bounds(b, dims, frame)?,
        None => frame,
    };
    let grid =
        Grid::checked(lo, hi, args.step, dims).map_err(|why| CliError::input(format!("--step {why}")))?;
    let base_mass = model.mass();
    for p in &payloads {
        if base_mass + p < 0.0 {
            return Err(CliError::input(format!(
                "--mass-sweep: payload {} kg makes the mass {} kg negative",
                Readable(*p),
                Readable(base_mass + p)
            )));
        }
    }
    Ok(Plan { robot, model, method, orientation, payloads, grid, threads })
}

/// The scans of a run: the nominal robot, then one per payload.
struct Scans {
    nominal: GridResult,
    /// Payload, total mass, volume (area), share of the frame.
    sweep: Vec<(f64, f64, f64, f64)>,
    /// Seconds for the nominal grid, and for every grid.
    seconds: f64,
    total_seconds: f64,
}

fn scan_all(plan: &Plan, progress: bool) -> Result<Scans, CliError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(plan.threads)
        .build()
        .map_err(|e| CliError::other(format!("worker threads: {e}")))?;
    let (grid, model, base_mass) = (&plan.grid, plan.model.as_ref(), plan.model.mass());
    let scan_with = |mass| scan(model, plan.method, grid, &plan.orientation, mass, &pool, progress);
    let start = Instant::now();
    let nominal = scan_with(None)?;
    let seconds = start.elapsed().as_secs_f64();
    let cells = grid.cells() as f64;
    let mut sweep = vec![];
    for &p in &plan.payloads {
        // Payload 0 is the nominal robot, already scanned.
        let feasible = if p == 0.0 { nominal.feasible } else { scan_with(Some(base_mass + p))?.feasible };
        let feasible = feasible as f64;
        sweep.push((p, base_mass + p, feasible * grid.cell_measure(), feasible / cells));
    }
    Ok(Scans { nominal, sweep, seconds, total_seconds: start.elapsed().as_secs_f64() })
}

/// The text of `summary.txt`.
fn summary_text(plan: &Plan, scans: &Scans) -> String {
    let (robot, grid, method, result) = (&plan.robot, &plan.grid, plan.method, &scans.nominal);
    let (what, unit) = plan.measure_name();
    let cells = grid.cells();
    let measure = result.feasible as f64 * grid.cell_measure();
    let share = result.feasible as f64 / cells as f64;
    let mut summary = format!(
        "robot: {} ({}, {} DOF, {} cables) from {}\nmethod: {} (static wrench: gravity, platform mass {} kg)\norientation: {}\n",
        robot.file.name,
        robot.kind().name(),
        robot.dof(),
        robot.cables(),
        robot.path.display(),
        method.name(),
        num(plan.model.mass()),
        if plan.orientation.is_empty() { "none (point mass)".to_string() } else { plan.orientation_text() }
    );
    for (k, axis) in ["x", "y", "z"].iter().enumerate().take(plan.dims()) {
        let _ = writeln!(
            summary,
            "{}: {} m to {} m, {} cells of {:.6} m",
            axis,
            num(grid.lo[k]),
            num(grid.hi[k]),
            grid.n[k],
            grid.h(k)
        );
    }
    let _ = writeln!(
        summary,
        "cells: {cells}; feasible {}, infeasible {}, method failed {}",
        result.feasible, result.infeasible, result.other_failures
    );
    let _ = writeln!(
        summary,
        "{what}: {measure:.6} {unit} = {:.2} % of the frame's {:.6} {unit}",
        share * 100.0,
        grid.measure()
    );
    if result.other_failures > 0 {
        let hint = if method == Method::AnalyticCentre {
            ""
        } else {
            " (--method analytic-centre certifies infeasibility where it converges)"
        };
        let _ = writeln!(
            summary,
            "note: the {} cells where {} failed without certifying infeasibility are counted as outside, so the {what} is a lower bound{hint}",
            result.other_failures,
            method.name()
        );
    }
    let _ = writeln!(
        summary,
        "time: {:.2} s for the grid on {} threads ({:.2} us per cell per thread)",
        scans.seconds,
        plan.threads,
        scans.seconds * 1e6 * plan.threads as f64 / cells as f64
    );
    if !scans.sweep.is_empty() {
        let _ = writeln!(
            summary,
            "payload sweep: {} grids, {:.2} s in all",
            scans.sweep.len(),
            scans.total_seconds
        );
        for (p, m, v, s) in &scans.sweep {
            let _ = writeln!(
                summary,
                "  payload {:>10} kg (mass {:>10} kg): {what} {v:.6} {unit}, {:.2} %",
                num(*p),
                num(*m),
                s * 100.0
            );
        }
    }
    summary
}

/// The colour scale of the slices: the 95th percentile of the robustness,
/// so that a few cells with large margins do not darken every other one.
fn colour_scale(values: &[f32]) -> f64 {
    let mut finite: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return 1.0;
    }
    let k = (finite.len() - 1) * 95 / 100;
    let (_, v, _) = finite.select_nth_unstable_by(k, f32::total_cmp);
    let scale = f64::from(*v);
    if scale > 0.0 {
        scale
    } else {
        1.0
    }
}

/// One PNG of workspace slices.
struct Picture {
    /// File name in the output directory.
    file: &'static str,
    title: String,
    /// Names of the horizontal and vertical axes.
    axes: (&'static str, &'static str),
    slices: Vec<Slice>,
}

/// The workspace pictures: six horizontal slices and a vertical one
/// (spatial), or the plane (planar).
fn write_slices(plan: &Plan, result: &GridResult, out: &Path) -> Result<Vec<PathBuf>, CliError> {
    let (grid, name, method) = (&plan.grid, &plan.robot.file.name, plan.method.name());
    let scale = colour_scale(&result.values);
    let anchors: Vec<[f64; 3]> = plan.robot.file.cables.iter().map(|c| c.anchor).collect();
    let (nx, ny, nz) = (grid.n[0], grid.n[1], grid.n[2]);
    let orient = if plan.orientation.is_empty() {
        String::new()
    } else {
        format!(", orientation ({})", plan.orientation_text())
    };
    let mut pictures: Vec<Picture> = vec![];
    if plan.dims() == 3 {
        let levels = nz.min(6);
        let horizontal = (0..levels)
            .map(|s| {
                let k = ((s as f64 + 0.5) * nz as f64 / levels as f64) as usize;
                let values = result.values[k * nx * ny..(k + 1) * nx * ny].to_vec();
                let feasible = values.iter().filter(|v| v.is_finite()).count();
                Slice {
                    title: format!(
                        "z = {:.3} m: {:.1} % feasible",
                        grid.centre(2, k),
                        100.0 * feasible as f64 / (nx * ny) as f64
                    ),
                    x: (grid.lo[0], grid.hi[0], nx),
                    y: (grid.lo[1], grid.hi[1], ny),
                    values,
                    marks: anchors.iter().map(|a| (a[0], a[1])).collect(),
                }
            })
            .collect();
        let title = format!("{name}: wrench-feasible workspace, horizontal slices ({method}{orient})");
        pictures.push(Picture { file: "slices-xy.png", title, axes: ("x", "y"), slices: horizontal });
        let j = ny / 2;
        let values: Vec<f32> = (0..nz)
            .flat_map(|k| {
                let row = (k * ny + j) * nx;
                result.values[row..row + nx].to_vec()
            })
            .collect();
        let vertical = Slice {
            title: format!("y = {:.3} m", grid.centre(1, j)),
            x: (grid.lo[0], grid.hi[0], nx),
            y: (grid.lo[2], grid.hi[2], nz),
            values,
            marks: anchors.iter().map(|a| (a[0], a[2])).collect(),
        };
        let title = format!("{name}: vertical slice ({method}{orient})");
        pictures.push(Picture { file: "slice-xz.png", title, axes: ("x", "z"), slices: vec![vertical] });
    } else {
        let measure = result.feasible as f64 * grid.cell_measure();
        let share = result.feasible as f64 / grid.cells() as f64;
        let plane = Slice {
            title: format!("area {measure:.4} m^2, {:.1} % of the frame", share * 100.0),
            x: (grid.lo[0], grid.hi[0], nx),
            y: (grid.lo[1], grid.hi[1], ny),
            values: result.values.clone(),
            marks: anchors.iter().map(|a| (a[0], a[1])).collect(),
        };
        let title = format!("{name}: wrench-feasible workspace ({method}{orient})");
        pictures.push(Picture { file: "workspace.png", title, axes: ("x", "y"), slices: vec![plane] });
    }
    let mut files = vec![];
    for p in pictures {
        let path = out.join(p.file);
        write_bytes(&path, &slices_png(&p.title, p.axes, &p.slices, scale)?)?;
        files.push(path);
    }
    Ok(files)
}

/// `mass-sweep.csv`, `.png` and `.svg`: the volume (area) against payload.
fn write_sweep(plan: &Plan, sweep: &[(f64, f64, f64, f64)], out: &Path) -> Result<Vec<PathBuf>, CliError> {
    let (what, unit) = plan.measure_name();
    let path = out.join("mass-sweep.csv");
    let col = if plan.dims() == 3 { "volume_m3" } else { "area_m2" };
    write_csv(
        &path,
        ["payload_kg", "mass_kg", col, "share"],
        sweep.iter().map(|(p, m, v, s)| [p, m, v, s].map(|x| num(*x))),
    )?;
    let mut files = vec![path];
    let mut series = Series::from_samples(what, PALETTE[0], sweep.iter().map(|r| (r.0, Some(r.2))));
    series.markers = true;
    let plot = LinePlot {
        title: format!("{}: {what} of the wrench-feasible workspace vs payload", plan.robot.file.name),
        x_label: format!("payload [kg] (platform {} kg)", num(plan.model.mass())),
        y_label: format!("{what} [{unit}]"),
        series: vec![series],
        include_zero: true,
        ..LinePlot::default()
    };
    let (png, svg) = line_plot(&plot, (900, 560))?;
    for (ext, bytes) in [("png", png), ("svg", svg.into_bytes())] {
        let path = out.join(format!("mass-sweep.{ext}"));
        write_bytes(&path, &bytes)?;
        files.push(path);
    }
    Ok(files)
}

/// Runs `cdpr workspace`: checks the arguments, scans the grid (and the
/// payload sweep), then writes the pictures, the sweep and the summary.
pub fn run(args: &WorkspaceArgs) -> Result<WorkspaceReport, CliError> {
    let plan = plan(args)?;
    let progress = args.progress && std::io::stderr().is_terminal();
    let scans = scan_all(&plan, progress)?;
    let summary = summary_text(&plan, &scans);

    ensure_dir(&args.out)?;
    let mut files = write_slices(&plan, &scans.nominal, &args.out)?;
    if !scans.sweep.is_empty() {
        files.extend(write_sweep(&plan, &scans.sweep, &args.out)?);
    }
    let path = args.out.join("summary.txt");
    write_bytes(&path, summary.as_bytes())?;
    files.push(path);

    let feasible = scans.nominal.feasible as f64;
    Ok(WorkspaceReport {
        summary,
        measure: feasible * plan.grid.cell_measure(),
        share: feasible / plan.grid.cells() as f64,
        grid: plan.grid,
        sweep: scans.sweep,
        seconds: scans.seconds,
        files,
    })
}
