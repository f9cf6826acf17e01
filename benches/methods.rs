//! Cost of every tension distribution method on the host, in one run, and how
//! it grows with the number of cables (`cargo bench --bench methods`).
//!
//! * 1000 feasible poses along a smooth 1 kHz path (1 s) of suspended-8 and of
//!   IPAnema 1, in `f64` and `f32`: every method of `Method::ALL` through
//!   `TensionSolver`, warm (the solver's carried state) and, for the methods
//!   that warm-start, cold; and a bounded QP (minimum 2-norm within the
//!   limits) solved by `clarabel`, what a user would otherwise reach for.
//! * Scaling: `analytic-centre` and `improved-closed-form` for 6 DOF with 7 to
//!   12 cables.
//!
//! Criterion measures each method over the 1000 poses; then a table of the
//! median and worst time per solve (each solve timed on its own, 20 rounds)
//! and each method's ratio to `barycenter` warm is printed, all from the same
//! run (ratios, not absolute times, are what carry over between machines).

use std::{hint::black_box, time::Instant};

use cdpr_integration_tests::{shipped_robot, smooth_path};
use clarabel::{algebra::CscMatrix, solver::*};
use criterion::Criterion;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use tension_core::{
    solve, Method, Platform, PreviousCycle, Real, Robot, RobotKind, TensionLimits, TensionSolver,
};

/// One pose: `W` and `f`.
type Case<T, const M: usize> = (SMatrix<T, 6, M>, SVector<T, 6>);

/// `count` poses along a smooth closed path around `centre` at 1 kHz
/// ([`smooth_path`]): their `W` and `f`.
fn path<T: Real, const M: usize>(
    robot: &Robot<T, 6, M>,
    centre: [f64; 3],
    amp: [f64; 3],
    tilt: [f64; 3],
    count: usize,
) -> Vec<Case<T, M>> {
    smooth_path::<T>(centre, amp, tilt, count)
        .iter()
        .map(|pose| {
            let w = robot.wrench_matrix(pose).expect("pose");
            let f = robot.required_wrench(pose, &SVector::zeros(), None).expect("wrench");
            (w, f)
        })
        .collect()
}

/// What is timed: a method through `TensionSolver` (warm: the solver's
/// carried state; cold: reset before every pose), or the reference QP.
#[derive(Clone, Copy, PartialEq)]
enum Variant {
    Method { method: Method, warm: bool },
    QpClarabel,
}

impl Variant {
    /// Every method of `Method::ALL` (warm and cold where it warm-starts),
    /// then the QP.
    fn all() -> Vec<Variant> {
        let mut all = Vec::new();
        for method in Method::ALL {
            all.push(Variant::Method { method, warm: true });
            if method.warm_starts() {
                all.push(Variant::Method { method, warm: false });
            }
        }
        all.push(Variant::QpClarabel);
        all
    }

    fn name(self) -> String {
        match self {
            Variant::Method { method, warm } if method.warm_starts() => {
                format!("{} ({})", method.name(), if warm { "warm" } else { "cold" })
            }
            Variant::Method { method, .. } => method.name().to_string(),
            Variant::QpClarabel => "QP min |t|_2 (clarabel)".to_string(),
        }
    }
}

/// Carries the warm-start state from one pose to the next.
struct Runner<T: Real, const M: usize> {
    solver: Option<TensionSolver<T, M>>,
}

impl<T: Real, const M: usize> Runner<T, M> {
    fn new(variant: Variant) -> Self {
        match variant {
            Variant::Method { method, .. } => Self { solver: Some(TensionSolver::new(method)) },
            Variant::QpClarabel => Self { solver: None },
        }
    }

    /// Solves one pose; `false` if the method failed there.
    fn solve(&mut self, variant: Variant, case: &Case<T, M>, limits: &TensionLimits<T, M>) -> bool {
        let (w, f) = case;
        let Some(solver) = self.solver.as_mut() else { return qp(w, f, limits) };
        if variant == (Variant::Method { method: solver.method(), warm: false }) {
            solver.reset();
        }
        match solver.solve(w, f, limits) {
            Ok(sol) => {
                black_box(sol);
                true
            }
            Err(_) => false,
        }
    }
}

/// min 1/2 |t|^2 subject to W t = f, t_min <= t <= t_max, by clarabel
/// (built per call, as a controller would for a new pose).
fn qp<T: Real, const M: usize>(
    w: &SMatrix<T, 6, M>,
    f: &SVector<T, 6>,
    limits: &TensionLimits<T, M>,
) -> bool {
    let to = |x: T| -> f64 { nalgebra::try_convert(x).unwrap_or(f64::NAN) };
    let p = CscMatrix::identity(M);
    let q = vec![0.0; M];
    let rows = 6 + 2 * M;
    let mut dense = vec![vec![0.0; M]; rows];
    let mut b = vec![0.0; rows];
    for r in 0..6 {
        for c in 0..M {
            dense[r][c] = to(w[(r, c)]);
        }
        b[r] = to(f[r]);
    }
    for i in 0..M {
        dense[6 + i][i] = 1.0;
        b[6 + i] = to(limits.max()[i]);
        dense[6 + M + i][i] = -1.0;
        b[6 + M + i] = -to(limits.min()[i]);
    }
    let a = CscMatrix::from(&dense);
    let cones = [ZeroConeT(6), NonnegativeConeT(2 * M)];
    let settings = DefaultSettingsBuilder::default().verbose(false).build().unwrap();
    let Ok(mut solver) = DefaultSolver::new(&p, &q, &a, &b, &cones, settings) else { return false };
    solver.solve();
    black_box(&solver.solution.x);
    solver.solution.status == SolverStatus::Solved
}

struct Row {
    name: String,
    median: f64,
    worst: f64,
    failures: usize,
}

fn table<T: Real, const M: usize>(
    label: &str,
    cases: &[Case<T, M>],
    limits: &TensionLimits<T, M>,
    variants: &[Variant],
) -> Vec<Row> {
    let rounds = 20;
    variants
        .iter()
        .map(|&variant| {
            let mut times = Vec::with_capacity(rounds * cases.len());
            let mut failures = 0;
            for _ in 0..rounds {
                let mut runner = Runner::new(variant);
                for case in cases {
                    let start = Instant::now();
                    let ok = runner.solve(variant, case, limits);
                    times.push(start.elapsed().as_secs_f64());
                    failures += !ok as usize;
                }
            }
            times.sort_by(|a, b| a.partial_cmp(b).unwrap());
            let _ = label;
            Row {
                name: variant.name(),
                median: times[times.len() / 2],
                worst: times[times.len() - 1],
                failures: failures / rounds,
            }
        })
        .collect()
}

fn print_table(label: &str, rows: &[Row]) {
    let base = rows[0].median;
    println!("\n{label}: per solve over 1000 poses x 20 rounds (ratio = median / median of barycenter warm)");
    println!("| method | median [us] | worst [us] | ratio | failed poses |");
    println!("| --- | ---: | ---: | ---: | ---: |");
    for r in rows {
        println!(
            "| {} | {:.2} | {:.1} | {:.2} | {} |",
            r.name,
            r.median * 1e6,
            r.worst * 1e6,
            r.median / base,
            r.failures
        );
    }
}

/// A shipped robot along `path` (centre, amplitudes, tilt amplitudes).
fn bench_robot<T: Real>(c: &mut Criterion, name: &str, label: &str, shape: [[f64; 3]; 3]) -> Vec<Row> {
    let robot: Robot<T, 6, 8> = shipped_robot(name);
    let cases = path(&robot, shape[0], shape[1], shape[2], 1000);
    let limits = *robot.limits();
    let variants = Variant::all();
    // Every pose is feasible for the barycenter.
    assert!(
        cases.iter().all(|(w, f)| solve(Method::Barycenter, w, f, &limits, &PreviousCycle::NONE).is_ok()),
        "{label}: path leaves the workspace"
    );
    let mut group = c.benchmark_group(label);
    group.sample_size(20);
    for &variant in &variants {
        group.bench_function(variant.name(), |b| {
            let mut runner = Runner::new(variant);
            b.iter(|| {
                for case in &cases {
                    runner.solve(variant, case, &limits);
                }
            })
        });
    }
    group.finish();
    table(label, &cases, &limits, &variants)
}

/// A fully constrained 6-DOF robot with `M` cables on a ring, alternately
/// high and low, for the scaling study (illustrative geometry).
fn ring_robot<const M: usize>() -> Robot<f64, 6, M> {
    let anchors = core::array::from_fn(|i| {
        let a = 2.0 * std::f64::consts::PI * i as f64 / M as f64;
        Vector3::new(2.0 * a.cos(), 1.5 * a.sin(), if i % 2 == 0 { 2.0 } else { 0.0 })
    });
    let attach = core::array::from_fn(|i| {
        let a = 2.0 * std::f64::consts::PI * (i as f64 + 0.3) / M as f64;
        Vector3::new(0.1 * a.cos(), 0.1 * a.sin(), if i % 2 == 0 { 0.05 } else { -0.05 })
    });
    let platform = Platform {
        mass: 0.5,
        com: Vector3::zeros(),
        gravity: Vector3::new(0.0, 0.0, -9.81),
        inertia: Matrix3::identity() * 0.01,
    };
    Robot::new(
        RobotKind::Spatial6,
        anchors,
        attach,
        TensionLimits::uniform(1.0, 50.0).unwrap(),
        platform,
        None,
    )
    .unwrap()
}

fn scaling<const M: usize>(c: &mut Criterion, rows: &mut Vec<(usize, f64, f64)>) {
    let robot = ring_robot::<M>();
    let cases = path(&robot, [0.0, 0.0, 1.0], [0.3, 0.2, 0.2], [0.05, 0.05, 0.15], 1000);
    let limits = *robot.limits();
    let mut group = c.benchmark_group(format!("scaling/6x{M}"));
    group.sample_size(10);
    let mut medians = [0.0; 2];
    let variants = [
        Variant::Method { method: Method::AnalyticCentre, warm: true },
        Variant::Method { method: Method::ImprovedClosedForm, warm: true },
    ];
    for (k, variant) in variants.into_iter().enumerate() {
        group.bench_function(variant.name(), |b| {
            let mut runner = Runner::new(variant);
            b.iter(|| {
                for case in &cases {
                    runner.solve(variant, case, &limits);
                }
            })
        });
        medians[k] = table("", &cases, &limits, &[variant])[0].median;
    }
    group.finish();
    rows.push((M, medians[0], medians[1]));
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let suspended = [[0.0, 0.0, 1.5], [0.6, 0.4, 0.3], [0.05, 0.05, 0.15]];
    let ipanema = [[0.0, 0.0, 1.0], [0.4, 0.25, 0.1], [0.02, 0.02, 0.05]];
    let tables = [
        ("suspended-8, f64", bench_robot::<f64>(&mut c, "suspended-8", "suspended-8/f64", suspended)),
        ("suspended-8, f32", bench_robot::<f32>(&mut c, "suspended-8", "suspended-8/f32", suspended)),
        ("IPAnema 1, f64", bench_robot::<f64>(&mut c, "ipanema1", "ipanema1/f64", ipanema)),
        ("IPAnema 1, f32", bench_robot::<f32>(&mut c, "ipanema1", "ipanema1/f32", ipanema)),
    ];
    let mut scale = Vec::new();
    scaling::<7>(&mut c, &mut scale);
    scaling::<8>(&mut c, &mut scale);
    scaling::<9>(&mut c, &mut scale);
    scaling::<10>(&mut c, &mut scale);
    scaling::<11>(&mut c, &mut scale);
    scaling::<12>(&mut c, &mut scale);
    c.final_summary();
    for (label, rows) in &tables {
        print_table(label, rows);
    }
    println!("\nscaling (f64, 6 DOF, 1000 poses x 20 rounds): median per solve");
    println!("| cables | redundancy | analytic-centre (warm) [us] | improved-closed-form [us] |");
    println!("| ---: | ---: | ---: | ---: |");
    for (m, ac, icf) in scale {
        println!("| {m} | {} | {:.2} | {:.2} |", m - 6, ac * 1e6, icf * 1e6);
    }
}
