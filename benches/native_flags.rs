//! What `-C target-cpu=native` does to the host's cost, beside the default
//! build, in one run (`cargo bench --bench native_flags`; issue 17).
//!
//! The bench measures its table (the default build), builds itself again
//! with `RUSTFLAGS="-C target-cpu=native"` in `target/native` and runs
//! that copy for the same table, and repeats the pair [`ALTERNATIONS`]
//! times; it prints both side by side with the ratio native / default and
//! f32 / f64, each taken within one alternation (the median of the
//! alternations' ratios, with their range). `CDPR_NATIVE_FLAGS_RUSTFLAGS`
//! builds the copy with other flags (e.g. `-C target-cpu=x86-64-v3`). The table, per robot (suspended-8, IPAnema 1)
//! and precision (`f64`, `f32`): the kinematics (`Robot::wrench_problem`:
//! `W` and `f` of a pose) and the methods a controller runs (barycenter
//! warm and cold, closed form, improved closed form, puncture, analytic
//! centre warm, minimum 2-norm, through `TensionSolver::solve`; the
//! barycenter warm and the closed form also through `solve_with` and a kept
//! `Workspace`, as a control loop and `cdpr` call them), each the median time per call over 1000
//! poses of a smooth 1 kHz path, 20 rounds. Criterion measures the same
//! calls in the default build (`cargo bench --bench native_flags -- NAME`
//! to filter).
//!
//! Ratios, not absolute times, carry over between machines; a native build
//! is only for the machine it was built on.

use std::{hint::black_box, process::Command, time::Duration};

use cdpr_integration_tests::{
    median_time_per_call, shipped_robot, smooth_path, IPANEMA1_PATH, SUSPENDED8_PATH,
};
use criterion::Criterion;
use nalgebra::SVector;
use tension_core::{methods::Workspace, Method, Real, Robot, TensionSolver};

/// Set in the native copy's environment: it prints its rows and exits.
const CHILD: &str = "CDPR_NATIVE_FLAGS_CHILD";

/// Rounds over the 1000 poses for each median.
const ROUNDS: usize = 20;

/// One timed method: `warm`, the solver's carried state (or reset before
/// each call); `kept`, through `solve_with` and a kept `Workspace`, as a
/// control loop calls it (or through `TensionSolver::solve`, the polygon's
/// room made anew each call).
#[derive(Clone, Copy)]
struct Timing {
    method: Method,
    warm: bool,
    kept: bool,
}

const fn timing(method: Method, warm: bool, kept: bool) -> Timing {
    Timing { method, warm, kept }
}

/// The methods timed.
const METHODS: [Timing; 9] = [
    timing(Method::Barycenter, true, false),
    timing(Method::Barycenter, true, true),
    timing(Method::Barycenter, false, false),
    timing(Method::ClosedForm, true, false),
    timing(Method::ClosedForm, true, true),
    timing(Method::ImprovedClosedForm, true, false),
    timing(Method::Puncture, true, false),
    timing(Method::AnalyticCentre, true, false),
    timing(Method::Min2Norm, true, false),
];

/// One row of a build's table: table (robot and precision), call, median
/// nanoseconds per call.
type Row = (String, String, f64);

/// The median of `rows`' `call` in table `label`, ns.
fn lookup(rows: &[Row], label: &str, call: &str) -> Option<f64> {
    rows.iter().find(|(l, c, _)| l == label && c == call).map(|r| r.2)
}

/// One timed thing: its name and a call over pose `k` (state carried).
type Timed<'a> = (String, Box<dyn FnMut(usize) + 'a>);

/// The kinematics and the methods of [`METHODS`] for `robot` along `path`.
fn timed<'a, T: Real>(robot: &'a Robot<T, 6, 8>, path: &'a [SVector<T, 6>]) -> Vec<Timed<'a>> {
    let problems: Vec<_> =
        path.iter().map(|p| robot.wrench_problem(p, &SVector::zeros(), None).expect("path pose")).collect();
    let mut all: Vec<Timed<'a>> = vec![(
        "kinematics (W and f)".into(),
        Box::new(move |k| {
            black_box(robot.wrench_problem(black_box(&path[k]), &SVector::zeros(), None).ok());
        }),
    )];
    for Timing { method, warm, kept } in METHODS {
        let problems = problems.clone();
        let mut solver = TensionSolver::<T, 8>::new(method);
        let mut scratch = Box::new(Workspace::<T, 6, 8>::new());
        let limits = *robot.limits();
        let mut name = if method.warm_starts() {
            format!("{} ({})", method.name(), if warm { "warm" } else { "cold" })
        } else {
            method.name().to_string()
        };
        if kept {
            name.push_str(", kept workspace");
        }
        all.push((
            name,
            Box::new(move |k| {
                if !warm {
                    solver.reset();
                }
                let (w, f) = &problems[k];
                if kept {
                    black_box(solver.solve_with(&mut scratch, w, f, &limits).ok());
                } else {
                    black_box(solver.solve(w, f, &limits).ok());
                }
            }),
        ));
    }
    all
}

/// The rows `(table, name, median)` of one robot in precision `T`; each
/// call measured by criterion too unless `child`.
fn rows<T: Real>(c: &mut Criterion, child: bool, label: &str, robot: &str, shape: [[f64; 3]; 3]) -> Vec<Row> {
    let robot: Robot<T, 6, 8> = shipped_robot(robot);
    let path = smooth_path::<T>(shape[0], shape[1], shape[2], 1000);
    let mut calls = timed(&robot, &path);
    if !child {
        let mut group = c.benchmark_group(format!("native-flags/{label}"));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(1));
        for (name, call) in calls.iter_mut() {
            group.bench_function(name.as_str(), |b| {
                b.iter(|| {
                    for k in 0..1000 {
                        call(k);
                    }
                })
            });
        }
        group.finish();
    }
    calls
        .iter_mut()
        .map(|(name, call)| {
            (
                label.to_string(),
                name.clone(),
                median_time_per_call(ROUNDS, 1000, call.as_mut()).as_secs_f64() * 1e9,
            )
        })
        .collect()
}

/// This build's table.
fn table(c: &mut Criterion, child: bool) -> Vec<Row> {
    let (suspended, ipanema) = (SUSPENDED8_PATH, IPANEMA1_PATH);
    let mut all = rows::<f64>(c, child, "suspended-8 f64", "suspended-8", suspended);
    all.extend(rows::<f32>(c, child, "suspended-8 f32", "suspended-8", suspended));
    all.extend(rows::<f64>(c, child, "ipanema1 f64", "ipanema1", ipanema));
    all.extend(rows::<f32>(c, child, "ipanema1 f32", "ipanema1", ipanema));
    all
}

/// Overrides the copy's `RUSTFLAGS` (e.g. `-C target-cpu=x86-64-v3`, or
/// `-C target-cpu=native -C target-feature=-avx512f`): the copy is then
/// built in its own `target/native-...` directory.
const FLAGS_VAR: &str = "CDPR_NATIVE_FLAGS_RUSTFLAGS";

/// The copy's `RUSTFLAGS`: [`FLAGS_VAR`], or `-C target-cpu=native`; and
/// whether they were given.
fn copy_flags() -> (String, bool) {
    match std::env::var(FLAGS_VAR) {
        Ok(flags) => (flags, true),
        Err(_) => ("-C target-cpu=native".into(), false),
    }
}

/// Builds and runs this bench with the copy's flags ([`copy_flags`]); its
/// rows, by table and name.
fn native_rows() -> Result<Vec<Row>, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let root = env!("CARGO_MANIFEST_DIR");
    let (flags, given) = copy_flags();
    let dir = if given {
        format!("target/native-{}", flags.replace(|c: char| !c.is_ascii_alphanumeric(), "_"))
    } else {
        "target/native".into()
    };
    let target = std::path::Path::new(root).join(dir);
    println!("building and running the copy (RUSTFLAGS=\"{flags}\", {})", target.display());
    let out = Command::new(cargo)
        .current_dir(root)
        .args(["bench", "--bench", "native_flags"])
        .env("RUSTFLAGS", &flags)
        .env("CARGO_TARGET_DIR", &target)
        .env(CHILD, "1")
        .output()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !out.status.success() {
        return Err(format!("the native build failed: {}", String::from_utf8_lossy(&out.stderr)));
    }
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| {
            let mut f = l.strip_prefix("row\t")?.split('\t');
            Some((f.next()?.to_string(), f.next()?.to_string(), f.next()?.parse().ok()?))
        })
        .collect())
}

/// The default table and the native copy's, measured alternately this many
/// times: this machine has slow spells (a whole process 1.2-1.3x slower
/// for a while), so a ratio is taken within one alternation and the
/// median of the alternations' ratios reported with their range.
const ALTERNATIONS: usize = 5;

/// The median of `values` (the upper one of an even count); `None` if empty.
fn median(values: &mut [f64]) -> Option<f64> {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied()
}

/// `median (min-max)` of the per-alternation ratios `a / b`, `-` when a
/// row is missing from one of them.
fn ratios(a: &[Option<f64>], b: &[Option<f64>]) -> String {
    let mut r: Vec<f64> = a.iter().zip(b).filter_map(|(&a, &b)| Some(a? / b?)).collect();
    if r.len() < a.len() {
        return "-".into();
    }
    let lo = r.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = r.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    median(&mut r).map_or("-".into(), |m| format!("{m:.2} ({lo:.2}-{hi:.2})"))
}

fn main() {
    let child = std::env::var_os(CHILD).is_some();
    let mut c = Criterion::default().configure_from_args();
    if child {
        for (label, name, ns) in &table(&mut c, true) {
            println!("row\t{label}\t{name}\t{ns}");
        }
        return;
    }
    // Criterion's measurement of the default build, then the two tables
    // alternately.
    let first = table(&mut c, false);
    c.final_summary();
    let mut default = vec![first];
    let mut native = Vec::new();
    for alternation in 0..ALTERNATIONS {
        if alternation > 0 {
            default.push(table(&mut c, true));
        }
        match native_rows() {
            Ok(rows) => native.push(rows),
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        }
    }
    let column = |tables: &[Vec<Row>], label: &str, name: &str| -> Vec<Option<f64>> {
        tables.iter().map(|rows| lookup(rows, label, name)).collect()
    };
    let shown = |values: &[Option<f64>]| {
        let mut v: Vec<f64> = values.iter().flatten().copied().collect();
        median(&mut v).map_or("(missing)".into(), |m| format!("{m:.0}"))
    };
    println!(
        "\nmedian per call, ns, over 1000 poses x {ROUNDS} rounds, the default build and the copy (\"native\": RUSTFLAGS=\"{}\") measured alternately {ALTERNATIONS} times: each build's median of its {ALTERNATIONS} medians, and native / default taken per alternation (median, min-max)",
        copy_flags().0
    );
    println!("| robot, precision | call | default | native | native / default |");
    println!("| --- | --- | ---: | ---: | ---: |");
    for (label, name, _) in &default[0] {
        let (d, n) = (column(&default, label, name), column(&native, label, name));
        println!("| {label} | {name} | {} | {} | {} |", shown(&d), shown(&n), ratios(&n, &d));
    }
    println!("\nf32 / f64 per call, per alternation within one build (median, min-max)");
    println!("| robot | call | default | native |");
    println!("| --- | --- | ---: | ---: |");
    for (label, name, _) in default[0].iter().filter(|(l, _, _)| l.ends_with(" f32")) {
        let robot = label.trim_end_matches(" f32");
        let f64_label = format!("{robot} f64");
        let of =
            |tables: &[Vec<Row>]| ratios(&column(tables, label, name), &column(tables, &f64_label, name));
        println!("| {robot} | {name} | {} | {} |", of(&default), of(&native));
    }
}
