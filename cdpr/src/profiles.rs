//! `cdpr trajectory` and `cdpr compare`: tensions along a smooth trajectory
//! through timed waypoints, with the dynamic (d'Alembert) wrench.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use tension_core::{Error, Method};

use crate::output::{ensure_dir, num, time as fmt_time, write_bytes, write_csv};
use crate::robot::{load_robot, method_help, LoadedRobot, Model, Query};
use crate::solve::{count_failure, tension_columns, tension_row};
use crate::table::{pose_columns, wrench_columns};
use crate::trajectory::{Sample, Waypoints};
use crate::CliError;
use cdpr_plot::{line_plot, LinePlot, Series, PALETTE};

pub use crate::trajectory::MAX_SAMPLES;

/// Arguments of `cdpr trajectory`.
#[derive(Debug, Clone, clap::Args)]
pub struct TrajectoryArgs {
    /// Robot description file (TOML).
    #[arg(long)]
    pub robot: PathBuf,
    /// Waypoint table: time, then the pose columns.
    #[arg(long)]
    pub waypoints: PathBuf,
    /// Methods (empty: every method that applies).
    #[arg(
        long = "method",
        help = method_help("Methods (repeat or separate by commas; default: every method that applies)")
    )]
    pub methods: Vec<String>,
    /// Sample rate in Hz.
    #[arg(long, default_value_t = 1000.0, allow_hyphen_values = true)]
    pub rate: f64,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
}

/// The tensions of one method along the samples.
#[derive(Debug, Clone)]
pub struct MethodRun {
    /// The method.
    pub method: Method,
    /// Tensions, `m` per sample (meaningless where the result is an error).
    pub tensions: Vec<f64>,
    /// Robustness per sample, or why no tension was found.
    pub results: Vec<Result<f64, Error>>,
    /// Time of every solve, s.
    pub seconds: Vec<f64>,
}

/// Statistics of a [`MethodRun`].
#[derive(Debug, Clone, PartialEq)]
pub struct RunStats {
    /// Samples.
    pub samples: usize,
    /// Samples solved.
    pub ok: usize,
    /// Failures per status.
    pub failures: Vec<(&'static str, usize)>,
    /// Largest change of a tension between consecutive solved samples, N,
    /// and the time it happened.
    pub largest_step: Option<(f64, f64)>,
    /// Smallest robustness and its time.
    pub min_robustness: Option<(f64, f64)>,
    /// Mean robustness over the solved samples.
    pub mean_robustness: Option<f64>,
    /// Median and largest time per solve, s.
    pub solve_time: (f64, f64),
    /// Time intervals with no tension (first and last failing sample).
    pub failed_intervals: Vec<(f64, f64)>,
}

impl MethodRun {
    /// Statistics against the sample times.
    pub fn stats(&self, times: &[f64], m: usize) -> RunStats {
        let mut failures = vec![];
        let mut largest_step: Option<(f64, f64)> = None;
        let mut min_rob: Option<(f64, f64)> = None;
        let mut sum_rob = 0.0;
        let mut ok = 0;
        let mut intervals: Vec<(f64, f64)> = vec![];
        let mut in_gap = false;
        for (k, r) in self.results.iter().enumerate() {
            match r {
                Ok(rob) => {
                    ok += 1;
                    sum_rob += rob;
                    if min_rob.is_none_or(|(v, _)| *rob < v) {
                        min_rob = Some((*rob, times[k]));
                    }
                    if k > 0 && self.results[k - 1].is_ok() {
                        let step = (0..m)
                            .map(|i| (self.tensions[k * m + i] - self.tensions[(k - 1) * m + i]).abs())
                            .fold(0.0, f64::max);
                        if largest_step.is_none_or(|(v, _)| step > v) {
                            largest_step = Some((step, times[k]));
                        }
                    }
                    in_gap = false;
                }
                Err(e) => {
                    count_failure(&mut failures, e.status());
                    if in_gap {
                        intervals.last_mut().expect("open gap").1 = times[k];
                    } else {
                        intervals.push((times[k], times[k]));
                        in_gap = true;
                    }
                }
            }
        }
        let mut sorted = self.seconds.clone();
        sorted.sort_by(f64::total_cmp);
        let solve_time =
            if sorted.is_empty() { (0.0, 0.0) } else { (sorted[sorted.len() / 2], sorted[sorted.len() - 1]) };
        RunStats {
            samples: self.results.len(),
            ok,
            failures,
            largest_step,
            min_robustness: min_rob,
            mean_robustness: (ok > 0).then(|| sum_rob / ok as f64),
            solve_time,
            failed_intervals: intervals,
        }
    }
}

/// Samples the trajectory, refusing absurd sample counts.
pub fn sample_trajectory(
    waypoints: &Waypoints,
    rate: f64,
    path: &Path,
) -> Result<(Vec<f64>, Vec<Sample>), CliError> {
    // A bad rate names the option; too many samples, the file.
    let times = waypoints.sample_times(rate).map_err(|e| {
        if rate.is_finite() && rate > 0.0 {
            CliError::at(path, None, None, &e.message)
        } else {
            e
        }
    })?;
    let samples = times.iter().map(|&t| waypoints.sample(t)).collect();
    Ok((times, samples))
}

fn query(s: &Sample) -> Query<'_> {
    Query { pose: &s.pose, extra: s.extra.as_deref(), motion: Some((&s.velocity, &s.acceleration)) }
}

/// Solves every sample with every method, interleaved (sample by sample,
/// as a controller would, so that timings see the same machine state).
pub fn solve_samples(model: &dyn Model, methods: &[Method], samples: &[Sample]) -> Vec<MethodRun> {
    let m = model.cables();
    let mut solvers: Vec<_> = methods.iter().map(|&me| model.solver(me)).collect();
    let mut runs: Vec<MethodRun> = methods
        .iter()
        .map(|&method| MethodRun {
            method,
            tensions: vec![0.0; samples.len() * m],
            results: Vec::with_capacity(samples.len()),
            seconds: Vec::with_capacity(samples.len()),
        })
        .collect();
    for (k, s) in samples.iter().enumerate() {
        let q = query(s);
        for (solver, run) in solvers.iter_mut().zip(runs.iter_mut()) {
            let out = &mut run.tensions[k * m..(k + 1) * m];
            let start = Instant::now();
            let r = solver.solve(&q, out);
            run.seconds.push(start.elapsed().as_secs_f64());
            run.results.push(r);
        }
    }
    runs
}

/// What `cdpr trajectory` wrote.
#[derive(Debug, Clone)]
pub struct TrajectoryReport {
    /// The summary text (also in `summary.txt`).
    pub summary: String,
    /// Files written.
    pub files: Vec<PathBuf>,
}

fn stats_text(s: &RunStats) -> String {
    let mut t = String::new();
    let _ = writeln!(t, "  samples solved:        {} of {}", s.ok, s.samples);
    match s.largest_step {
        Some((v, at)) => {
            let _ = writeln!(
                t,
                "  largest step:          {v:.6} N (between consecutive samples, at t = {} s)",
                fmt_time(at)
            );
        }
        None => {
            let _ = writeln!(t, "  largest step:          -");
        }
    }
    match s.min_robustness {
        Some((v, at)) => {
            let _ = writeln!(
                t,
                "  smallest robustness:   {v:.6} N (at t = {} s); mean {:.6} N",
                fmt_time(at),
                s.mean_robustness.unwrap_or(f64::NAN)
            );
        }
        None => {
            let _ = writeln!(t, "  smallest robustness:   -");
        }
    }
    let infeasible: usize = s.failures.iter().map(|(_, n)| n).sum();
    let detail: Vec<String> = s.failures.iter().map(|(st, n)| format!("{n} {st}")).collect();
    let _ = writeln!(
        t,
        "  samples without tension: {infeasible}{}",
        if detail.is_empty() { String::new() } else { format!(" ({})", detail.join(", ")) }
    );
    for (a, b) in s.failed_intervals.iter().take(10) {
        let _ = writeln!(t, "    from t = {} s to t = {} s", fmt_time(*a), fmt_time(*b));
    }
    if s.failed_intervals.len() > 10 {
        let _ = writeln!(t, "    ... {} more intervals", s.failed_intervals.len() - 10);
    }
    t
}

/// Runs `cdpr trajectory`: samples the trajectory, solves every sample with
/// every method, then writes the pose table, per method its tension table
/// and plot, the robustness of all, and the summary.
pub fn run_trajectory(args: &TrajectoryArgs) -> Result<TrajectoryReport, CliError> {
    let robot = load_robot(&args.robot)?;
    let methods = robot.method_list(&args.methods)?;
    let waypoints = Waypoints::read(&args.waypoints, robot.kind())?;
    let (times, samples) = sample_trajectory(&waypoints, args.rate, &args.waypoints)?;
    let model = robot.model()?;
    let m = model.cables();
    let runs = solve_samples(model.as_ref(), &methods, &samples);

    ensure_dir(&args.out)?;
    let name = &robot.file.name;
    let mut files = vec![write_poses(&args.out, &robot, waypoints.extras().is_some(), &samples)?];
    let mut summary = format!(
        "robot: {name} ({}, {} DOF, {m} cables) from {}\nwaypoints: {} ({} waypoints, t = {} s to {} s)\nsamples: {} at {} Hz; time law s(u) = 35u^4 - 84u^5 + 70u^6 - 20u^7 per segment, dynamic wrench\n",
        robot.kind().name(),
        robot.dof(),
        robot.path.display(),
        args.waypoints.display(),
        waypoints.times().len(),
        fmt_time(waypoints.start()),
        fmt_time(waypoints.end()),
        samples.len(),
        args.rate,
    );
    let limits = limit_lines(model.as_ref());
    for run in &runs {
        let stats = run.stats(&times, m);
        let _ = write!(summary, "\n{}\n{}", run.method.name(), stats_text(&stats));
        files.extend(write_method(&args.out, name, run, &stats, &times, m, &limits)?);
    }
    files.extend(write_robustness(&args.out, name, &runs, &times)?);

    let sum_path = args.out.join("summary.txt");
    write_bytes(&sum_path, summary.as_bytes())?;
    files.push(sum_path);
    Ok(TrajectoryReport { summary, files })
}

/// `poses.csv`: the sampled trajectory, a pose table (conventions).
fn write_poses(
    out: &Path,
    robot: &LoadedRobot,
    extras: bool,
    samples: &[Sample],
) -> Result<PathBuf, CliError> {
    let path = out.join("poses.csv");
    let mut cols = vec!["time"];
    cols.extend(pose_columns(robot.kind()));
    if extras {
        cols.extend(wrench_columns(robot.kind()));
    }
    write_csv(
        &path,
        cols,
        samples.iter().map(|s| {
            std::iter::once(fmt_time(s.time))
                .chain(s.pose.iter().chain(s.extra.iter().flatten()).map(|v| num(*v)))
        }),
    )?;
    Ok(path)
}

/// The dashed lines of the tension plots: each distinct `t_min` and
/// `t_max`, labelled with its value.
fn limit_lines(model: &dyn Model) -> Vec<(f64, String)> {
    let mut lines: Vec<(f64, String)> = vec![];
    let lower = model.t_min().into_iter().map(|v| (v, "t_min"));
    let upper = model.t_max().into_iter().map(|v| (v, "t_max"));
    for (v, label) in lower.chain(upper) {
        if !lines.iter().any(|(w, _)| *w == v) {
            lines.push((v, format!("{label} = {} N", num(v))));
        }
    }
    lines
}

/// Writes a plot as `STEM.png` and `STEM.svg`; returns both paths.
fn write_plot(stem: PathBuf, plot: &LinePlot) -> Result<[PathBuf; 2], CliError> {
    let (png, svg) = line_plot(plot, (1100, 600))?;
    let (png_path, svg_path) = (stem.with_extension("png"), stem.with_extension("svg"));
    write_bytes(&png_path, &png)?;
    write_bytes(&svg_path, svg.as_bytes())?;
    Ok([png_path, svg_path])
}

/// One method's `tensions-METHOD.csv`, `.png` and `.svg`: the tension
/// profiles with the limits, shaded where no tension was found.
fn write_method(
    out: &Path,
    robot_name: &str,
    run: &MethodRun,
    stats: &RunStats,
    times: &[f64],
    m: usize,
    limits: &[(f64, String)],
) -> Result<Vec<PathBuf>, CliError> {
    let mname = run.method.name();
    let csv = out.join(format!("tensions-{mname}.csv"));
    write_tensions(&csv, times, run, m)?;
    let plot = LinePlot {
        title: format!("{robot_name}: {mname}"),
        x_label: "time [s]".into(),
        y_label: "tension [N]".into(),
        series: (0..m)
            .map(|i| {
                Series::from_samples(
                    format!("t{}", i + 1),
                    PALETTE[i % PALETTE.len()],
                    times
                        .iter()
                        .enumerate()
                        .map(|(k, &t)| (t, run.results[k].is_ok().then(|| run.tensions[k * m + i]))),
                )
            })
            .collect(),
        hlines: limits.to_vec(),
        bands: bands(&stats.failed_intervals, times),
        band_label: "no tension".into(),
        include_zero: false,
    };
    let mut files = vec![csv];
    files.extend(write_plot(out.join(format!("tensions-{mname}")), &plot)?);
    Ok(files)
}

/// `robustness.csv`, `.png` and `.svg`: every method's robustness over time.
fn write_robustness(
    out: &Path,
    robot_name: &str,
    runs: &[MethodRun],
    times: &[f64],
) -> Result<Vec<PathBuf>, CliError> {
    let csv = out.join("robustness.csv");
    write_csv(
        &csv,
        std::iter::once("time").chain(runs.iter().map(|r| r.method.name())),
        times.iter().enumerate().map(|(k, t)| {
            std::iter::once(fmt_time(*t))
                .chain(runs.iter().map(move |r| r.results[k].as_ref().map_or(String::new(), |v| num(*v))))
        }),
    )?;
    let plot = LinePlot {
        title: format!("{robot_name}: robustness (smallest distance to a limit)"),
        x_label: "time [s]".into(),
        y_label: "robustness [N]".into(),
        series: runs
            .iter()
            .enumerate()
            .map(|(j, r)| {
                let mut s = Series::from_samples(
                    r.method.name(),
                    PALETTE[j % PALETTE.len()],
                    times.iter().zip(&r.results).map(|(&t, res)| (t, res.ok())),
                );
                // Wider lines first, so that methods that agree stay visible.
                s.width = (runs.len() - j) as u32 + 1;
                s
            })
            .collect(),
        include_zero: true,
        ..LinePlot::default()
    };
    let mut files = vec![csv];
    files.extend(write_plot(out.join("robustness"), &plot)?);
    Ok(files)
}

/// Shaded intervals for the failed samples, widened by half a sample.
fn bands(intervals: &[(f64, f64)], times: &[f64]) -> Vec<(f64, f64)> {
    let half = if times.len() > 1 { (times[1] - times[0]) / 2.0 } else { 0.0 };
    intervals.iter().map(|&(a, b)| (a - half, b + half)).collect()
}

fn write_tensions(path: &Path, times: &[f64], run: &MethodRun, m: usize) -> Result<(), CliError> {
    write_csv(
        path,
        tension_columns(true, m),
        times.iter().enumerate().map(|(k, t)| {
            let result = run.results[k].map(|_| ());
            tension_row(Some(fmt_time(*t)), &run.tensions[k * m..(k + 1) * m], result)
        }),
    )
}

/// Arguments of `cdpr compare`.
#[derive(Debug, Clone, clap::Args)]
pub struct CompareArgs {
    /// Robot description file (TOML).
    #[arg(long)]
    pub robot: PathBuf,
    /// Waypoint table: time, then the pose columns.
    #[arg(long)]
    pub waypoints: PathBuf,
    /// Sample rate in Hz.
    #[arg(long, default_value_t = 1000.0, allow_hyphen_values = true)]
    pub rate: f64,
    /// CSV file to write the table to.
    #[arg(long, default_value = "compare.csv")]
    pub out: PathBuf,
}

/// What `cdpr compare` found: per method, its statistics.
#[derive(Debug, Clone)]
pub struct CompareReport {
    /// The table printed to stdout.
    pub table: String,
    /// Methods and their statistics.
    pub rows: Vec<(Method, RunStats)>,
}

/// Runs `cdpr compare`.
pub fn run_compare(args: &CompareArgs) -> Result<CompareReport, CliError> {
    let robot: LoadedRobot = load_robot(&args.robot)?;
    let waypoints = Waypoints::read(&args.waypoints, robot.kind())?;
    let (times, samples) = sample_trajectory(&waypoints, args.rate, &args.waypoints)?;
    let model = robot.model()?;
    let m = model.cables();
    let methods = robot.methods();
    let runs = solve_samples(model.as_ref(), &methods, &samples);
    let rows: Vec<(Method, RunStats)> = runs.iter().map(|r| (r.method, r.stats(&times, m))).collect();

    let mut table = format!(
        "{}: {} samples at {} Hz from {}\n\n",
        robot.file.name,
        samples.len(),
        args.rate,
        args.waypoints.display()
    );
    let _ = writeln!(
        table,
        "{:<22} {:>9} {:>9} {:>11} {:>11} {:>13} {:>11} {:>11}",
        "method", "solved", "failed", "rob. min", "rob. mean", "largest step", "median", "max"
    );
    let _ = writeln!(
        table,
        "{:<22} {:>9} {:>9} {:>11} {:>11} {:>13} {:>11} {:>11}",
        "", "", "", "[N]", "[N]", "[N]", "[us]", "[us]"
    );
    let opt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.4}"));
    for (method, s) in &rows {
        let _ = writeln!(
            table,
            "{:<22} {:>9} {:>9} {:>11} {:>11} {:>13} {:>11.2} {:>11.2}",
            method.name(),
            s.ok,
            s.samples - s.ok,
            opt(s.min_robustness.map(|x| x.0)),
            opt(s.mean_robustness),
            opt(s.largest_step.map(|x| x.0)),
            s.solve_time.0 * 1e6,
            s.solve_time.1 * 1e6
        );
    }
    for method in Method::ALL {
        if !methods.contains(&method) {
            let _ = writeln!(
                table,
                "{:<22} not applicable: needs m = n + 2 cables, the robot has n = {}, m = {}",
                method.name(),
                robot.dof(),
                m
            );
        }
    }

    let opt = |v: Option<f64>| v.map_or(String::new(), num);
    write_csv(
        &args.out,
        [
            "method",
            "samples",
            "solved",
            "failed",
            "robustness_min",
            "robustness_mean",
            "largest_step",
            "median_solve_us",
            "max_solve_us",
        ],
        rows.iter().map(|(method, s)| {
            [
                method.name().to_string(),
                s.samples.to_string(),
                s.ok.to_string(),
                (s.samples - s.ok).to_string(),
                opt(s.min_robustness.map(|x| x.0)),
                opt(s.mean_robustness),
                opt(s.largest_step.map(|x| x.0)),
                num(microseconds(s.solve_time.0)),
                num(microseconds(s.solve_time.1)),
            ]
        }),
    )?;
    Ok(CompareReport { table, rows })
}

/// A time measured in whole nanoseconds (`s` from a `Duration`), in
/// microseconds without the rounding noise of `s * 1e6` (1.983 us, not
/// 1.9829999999999999).
fn microseconds(s: f64) -> f64 {
    (s * 1e9).round() / 1e3
}
