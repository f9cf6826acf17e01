//! `cdpr workspace`: the wrench-feasible workspace at a constant
//! orientation (static wrench: gravity only) on a grid over the frame.
//!
//! The frame is the bounding box of the anchors; along an axis where every
//! anchor is at the same coordinate (a suspended robot's anchors all at one
//! height) the box reaches down (or up) to the base frame's origin, the
//! floor. The grid has cells of about `--step` metres; a cell counts as
//! feasible when the method finds tensions within the limits at its centre.
//! The volume is the number of feasible cells times the cell volume.

use std::fmt::Write as _;
use std::io::IsTerminal;
use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use tension_core::{Error, Method, RobotKind};

use crate::output::{ensure_dir, num, write_bytes, write_csv};
use crate::robot::{load_robot, method_help, LoadedRobot, Model, Query};
use crate::CliError;
use cdpr_plot::{line_plot, slices_png, LinePlot, Series, Slice, PALETTE};

/// Most grid cells one run may have.
pub const MAX_CELLS: usize = 50_000_000;

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
    /// Worker threads (default: every core).
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

/// The frame: the anchors' bounding box, reaching to the origin along an
/// axis where the anchors have no extent.
pub fn frame_box(robot: &LoadedRobot) -> Result<([f64; 3], [f64; 3]), CliError> {
    let dims = if robot.kind() == RobotKind::Spatial6 { 3 } else { 2 };
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for c in &robot.file.cables {
        for k in 0..3 {
            lo[k] = lo[k].min(c.anchor[k]);
            hi[k] = hi[k].max(c.anchor[k]);
        }
    }
    for k in 0..3 {
        if k >= dims {
            lo[k] = 0.0;
            hi[k] = 0.0;
            continue;
        }
        if hi[k] - lo[k] <= 1e-9 * (1.0 + hi[k].abs()) {
            lo[k] = lo[k].min(0.0);
            hi[k] = hi[k].max(0.0);
        }
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
}

/// Solves every cell centre of the grid (in parallel over `threads`
/// threads, each line along `x` warm-started from its previous cell).
pub fn scan(
    model: &dyn Model,
    method: Method,
    grid: &Grid,
    orientation: &[f64],
    mass: Option<f64>,
    threads: usize,
    progress: bool,
) -> Result<GridResult, CliError> {
    let nx = grid.n[0];
    let mut values = vec![f32::NAN; grid.cells()];
    let lines = values.chunks_mut(nx).enumerate();
    let work = Mutex::new(lines);
    let status = Progress { done: AtomicUsize::new(0), total: grid.n[1] * grid.n[2], start: Instant::now() };
    let finished = AtomicBool::new(false);
    let counts = Mutex::new((0usize, 0usize, 0usize));
    let failure: Mutex<Option<Error>> = Mutex::new(None);
    let threads = threads.max(1);
    std::thread::scope(|scope| {
        if progress {
            scope.spawn(|| {
                let mut err = std::io::stderr();
                while !finished.load(Ordering::Relaxed) {
                    let _ = write!(err, "{}", status.line());
                    let _ = err.flush();
                    std::thread::sleep(Duration::from_millis(200));
                }
                let _ = writeln!(err, "{}", status.line());
            });
        }
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let mut solver = model.solver(method);
                    if let Some(mass) = mass {
                        if let Err(e) = solver.set_mass(mass) {
                            *failure.lock().expect("no panics") = Some(e);
                            return;
                        }
                    }
                    let m = model.cables();
                    let mut tensions = vec![0.0; m];
                    let mut pose = vec![0.0; model.dof()];
                    let (mut ok, mut inf, mut other) = (0, 0, 0);
                    loop {
                        let next = work.lock().expect("no panics").next();
                        let Some((line, cells)) = next else { break };
                        let (j, k) = (line % grid.n[1], line / grid.n[1]);
                        solver.reset();
                        for (i, cell) in cells.iter_mut().enumerate() {
                            pose[0] = grid.centre(0, i);
                            pose[1] = grid.centre(1, j);
                            let rest = if grid.dims == 3 {
                                pose[2] = grid.centre(2, k);
                                3
                            } else {
                                2
                            };
                            pose[rest..].copy_from_slice(orientation);
                            match solver.solve(&Query::pose(&pose), &mut tensions) {
                                Ok(r) => {
                                    *cell = r as f32;
                                    ok += 1;
                                }
                                Err(Error::Infeasible) => inf += 1,
                                Err(_) => other += 1,
                            }
                        }
                        status.done.fetch_add(1, Ordering::Relaxed);
                    }
                    let mut c = counts.lock().expect("no panics");
                    c.0 += ok;
                    c.1 += inf;
                    c.2 += other;
                })
            })
            .collect();
        for w in workers {
            let _ = w.join();
        }
        finished.store(true, Ordering::Relaxed);
    });
    if let Some(e) = failure.into_inner().expect("no panics") {
        return Err(CliError::input(format!("platform mass {}: {}", mass.unwrap_or(f64::NAN), e.status())));
    }
    let (feasible, infeasible, other_failures) = counts.into_inner().expect("no panics");
    Ok(GridResult { values, feasible, infeasible, other_failures })
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

/// Runs `cdpr workspace`.
pub fn run(args: &WorkspaceArgs) -> Result<WorkspaceReport, CliError> {
    let robot = load_robot(&args.robot)?;
    let kind = robot.kind();
    let method = match &args.method {
        Some(name) => robot.method(name)?,
        None if Method::Barycenter.supports(robot.dof(), robot.cables()) => Method::Barycenter,
        None => Method::ImprovedClosedForm,
    };
    let orientation = parse_orientation(args.orientation.as_deref(), kind)?;
    if !(args.step.is_finite() && args.step > 0.0) {
        return Err(CliError::input(format!(
            "--step {}: the grid step must be a positive length in metres",
            args.step
        )));
    }
    let sweep = match &args.mass_sweep {
        Some(s) => parse_sweep(s)?,
        None => vec![],
    };
    let dims = if kind == RobotKind::Spatial6 { 3 } else { 2 };
    let frame = frame_box(&robot)?;
    let (lo, hi) = match &args.bounds {
        Some(b) => parse_bounds(b, dims, frame)?,
        None => frame,
    };
    let estimate: f64 = (0..dims).map(|k| ((hi[k] - lo[k]) / args.step).round().max(1.0)).product();
    if estimate > MAX_CELLS as f64 {
        return Err(CliError::input(format!(
            "--step {}: {estimate:.0} cells is more than {MAX_CELLS}; use a larger step",
            args.step
        )));
    }
    let grid = Grid::new(lo, hi, args.step, dims);
    let model = robot.model()?;
    let base_mass = model.mass();
    for p in &sweep {
        if base_mass + p < 0.0 {
            return Err(CliError::input(format!(
                "--mass-sweep: payload {p} kg makes the mass {} kg negative",
                base_mass + p
            )));
        }
    }
    let threads =
        args.threads.unwrap_or_else(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1));
    let progress = args.progress && std::io::stderr().is_terminal();

    let start = Instant::now();
    let result = scan(model.as_ref(), method, &grid, &orientation, None, threads, progress)?;
    let seconds = start.elapsed().as_secs_f64();
    let cells = grid.cells();
    let measure = result.feasible as f64 * grid.cell_measure();
    let share = result.feasible as f64 / cells as f64;
    let mut sweep_rows = vec![];
    for &p in &sweep {
        // Payload 0 is the nominal robot, already scanned.
        let feasible = if p == 0.0 {
            result.feasible
        } else {
            scan(model.as_ref(), method, &grid, &orientation, Some(base_mass + p), threads, progress)?
                .feasible
        };
        sweep_rows.push((
            p,
            base_mass + p,
            feasible as f64 * grid.cell_measure(),
            feasible as f64 / cells as f64,
        ));
    }
    let total_seconds = start.elapsed().as_secs_f64();

    let unit = if dims == 3 { "m^3" } else { "m^2" };
    let what = if dims == 3 { "volume" } else { "area" };
    let axes = ["x", "y", "z"];
    let mut summary = format!(
        "robot: {} ({}, {} DOF, {} cables) from {}\nmethod: {} (static wrench: gravity, platform mass {} kg)\norientation: {}\n",
        robot.file.name,
        kind.name(),
        robot.dof(),
        robot.cables(),
        robot.path.display(),
        method.name(),
        num(base_mass),
        if orientation.is_empty() {
            "none (point mass)".to_string()
        } else {
            orientation.iter().map(|v| num(*v)).collect::<Vec<_>>().join(", ")
        }
    );
    for (k, axis) in axes.iter().enumerate().take(dims) {
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
        "time: {seconds:.2} s for the grid on {threads} threads ({:.2} us per cell per thread)",
        seconds * 1e6 * threads as f64 / cells as f64
    );
    if !sweep_rows.is_empty() {
        let _ = writeln!(summary, "payload sweep: {} grids, {total_seconds:.2} s in all", sweep_rows.len());
        for (p, m, v, s) in &sweep_rows {
            let _ = writeln!(
                summary,
                "  payload {:>10} kg (mass {:>10} kg): {what} {v:.6} {unit}, {:.2} %",
                num(*p),
                num(*m),
                s * 100.0
            );
        }
    }

    ensure_dir(&args.out)?;
    let mut files = vec![];
    // Colour scale: the 95th percentile of the robustness, so that a few
    // cells with large margins do not darken every other one.
    let mut finite: Vec<f32> = result.values.iter().copied().filter(|v| v.is_finite()).collect();
    let scale = if finite.is_empty() {
        1.0
    } else {
        let k = (finite.len() - 1) * 95 / 100;
        let (_, v, _) = finite.select_nth_unstable_by(k, f32::total_cmp);
        f64::from(*v)
    };
    let scale = if scale > 0.0 { scale } else { 1.0 };
    let anchors: Vec<[f64; 3]> = robot.file.cables.iter().map(|c| c.anchor).collect();
    let (nx, ny, nz) = (grid.n[0], grid.n[1], grid.n[2]);
    let orient_text = if orientation.is_empty() {
        String::new()
    } else {
        format!(", orientation ({})", orientation.iter().map(|v| num(*v)).collect::<Vec<_>>().join(", "))
    };
    if dims == 3 {
        let levels = nz.min(6);
        let slices: Vec<Slice> = (0..levels)
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
        let png = slices_png(
            &format!(
                "{}: wrench-feasible workspace, horizontal slices ({}{orient_text})",
                robot.file.name,
                method.name()
            ),
            ("x", "y"),
            &slices,
            scale,
        )?;
        let path = args.out.join("slices-xy.png");
        write_bytes(&path, &png)?;
        files.push(path);
        let j = ny / 2;
        let values: Vec<f32> = (0..nz)
            .flat_map(|k| {
                let row = (k * ny + j) * nx;
                result.values[row..row + nx].to_vec()
            })
            .collect();
        let slice = Slice {
            title: format!("y = {:.3} m", grid.centre(1, j)),
            x: (grid.lo[0], grid.hi[0], nx),
            y: (grid.lo[2], grid.hi[2], nz),
            values,
            marks: anchors.iter().map(|a| (a[0], a[2])).collect(),
        };
        let png = slices_png(
            &format!("{}: vertical slice ({}{orient_text})", robot.file.name, method.name()),
            ("x", "z"),
            &[slice],
            scale,
        )?;
        let path = args.out.join("slice-xz.png");
        write_bytes(&path, &png)?;
        files.push(path);
    } else {
        let slice = Slice {
            title: format!("area {measure:.4} m^2, {:.1} % of the frame", share * 100.0),
            x: (grid.lo[0], grid.hi[0], nx),
            y: (grid.lo[1], grid.hi[1], ny),
            values: result.values.clone(),
            marks: anchors.iter().map(|a| (a[0], a[1])).collect(),
        };
        let png = slices_png(
            &format!("{}: wrench-feasible workspace ({}{orient_text})", robot.file.name, method.name()),
            ("x", "y"),
            &[slice],
            scale,
        )?;
        let path = args.out.join("workspace.png");
        write_bytes(&path, &png)?;
        files.push(path);
    }
    if !sweep_rows.is_empty() {
        let path = args.out.join("mass-sweep.csv");
        let col = if dims == 3 { "volume_m3" } else { "area_m2" };
        write_csv(
            &path,
            ["payload_kg", "mass_kg", col, "share"],
            sweep_rows.iter().map(|(p, m, v, s)| [p, m, v, s].map(|x| num(*x))),
        )?;
        files.push(path);
        let mut series = Series::from_samples(what, PALETTE[0], sweep_rows.iter().map(|r| (r.0, Some(r.2))));
        series.markers = true;
        let plot = LinePlot {
            title: format!("{}: {what} of the wrench-feasible workspace vs payload", robot.file.name),
            x_label: format!("payload [kg] (platform {} kg)", num(base_mass)),
            y_label: format!("{what} [{unit}]"),
            series: vec![series],
            include_zero: true,
            ..LinePlot::default()
        };
        let (png, svg) = line_plot(&plot, (900, 560))?;
        for (ext, bytes) in [("png", png), ("svg", svg.into_bytes())] {
            let path = args.out.join(format!("mass-sweep.{ext}"));
            write_bytes(&path, &bytes)?;
            files.push(path);
        }
    }
    let path = args.out.join("summary.txt");
    write_bytes(&path, summary.as_bytes())?;
    files.push(path);
    Ok(WorkspaceReport { summary, measure, share, grid, sweep: sweep_rows, seconds, files })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_cells_cover_the_box() {
        let g = Grid::new([0.0, 0.0, 0.0], [3.0, 2.0, 0.0], 0.5, 2);
        assert_eq!(g.n, [6, 4, 1]);
        assert_eq!(g.cells(), 24);
        assert!((g.cell_measure() - 0.25).abs() < 1e-15);
        assert!((g.measure() - 6.0).abs() < 1e-15);
        assert!((g.centre(0, 0) - 0.25).abs() < 1e-15);
        assert_eq!(g.centre(2, 0), 0.0);
    }

    #[test]
    fn sweep_and_orientation_parsing() {
        assert_eq!(parse_sweep("0:10:3").unwrap(), vec![0.0, 5.0, 10.0]);
        assert_eq!(parse_sweep("2:9:1").unwrap(), vec![2.0]);
        assert!(parse_sweep("0:10").is_err());
        assert!(parse_sweep("0:x:3").is_err());
        assert!(parse_sweep("0:1:0").is_err());
        assert_eq!(
            parse_orientation(Some("0.1, 0, -0.2"), RobotKind::Spatial6).unwrap(),
            vec![0.1, 0.0, -0.2]
        );
        assert_eq!(parse_orientation(None, RobotKind::Planar3).unwrap(), vec![0.0]);
        assert!(parse_orientation(Some("0.1"), RobotKind::Spatial6).is_err());
        assert!(parse_orientation(Some("0.1"), RobotKind::Planar2).is_err());
    }
}
