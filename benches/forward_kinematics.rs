//! Cost of the forward kinematics on the host (`cargo bench --bench
//! forward_kinematics`): suspended-8 along a smooth 1 kHz path (the pose
//! moves up to about 4 mm and 2 mrad a cycle), warm-started from the
//! previous cycle's answer, in f32 and f64; and the cold start (no guess)
//! on the same poses. After criterion, a table of the mean time per call and
//! the mean and largest iteration counts (cable evaluations after the
//! first), from the same run.

use std::{hint::black_box, time::Instant};

use cdpr_integration_tests::shipped_robot;
use criterion::Criterion;
use nalgebra::SVector;
use tension_core::{ForwardSettings, Real, Robot};

const COUNT: usize = 1000;

/// Poses along the path, and their lengths (in `T`).
fn path<T: Real>(robot: &Robot<T, 6, 8>) -> Vec<(SVector<T, 6>, SVector<T, 8>)> {
    (0..COUNT)
        .map(|k| {
            let w = 2.0 * std::f64::consts::PI * k as f64 / COUNT as f64;
            let pose = SVector::<T, 6>::from_fn(|i, _| {
                T::lit(match i {
                    0 => 0.6 * w.sin(),
                    1 => 0.4 * (2.0 * w).sin(),
                    2 => 1.8 + 0.4 * w.cos(),
                    3 => 0.1 * w.sin(),
                    4 => -0.1 * w.cos(),
                    _ => 0.2 * w.sin(),
                })
            });
            let lengths = robot.cables(&pose).expect("pose").lengths;
            (pose, lengths)
        })
        .collect()
}

/// Runs the path once; returns (iterations total, largest).
fn sweep<T: Real>(
    robot: &Robot<T, 6, 8>,
    cases: &[(SVector<T, 6>, SVector<T, 8>)],
    warm: bool,
) -> (u64, u32) {
    let settings = ForwardSettings::for_robot(robot);
    let mut prev = cases[cases.len() - 1].0;
    let (mut total, mut most) = (0u64, 0u32);
    for (_, lengths) in cases {
        let sol = robot
            .forward_kinematics(black_box(lengths), warm.then_some(&prev), &settings)
            .expect("forward kinematics");
        total += u64::from(sol.iterations);
        most = most.max(sol.iterations);
        prev = sol.pose;
    }
    (total, most)
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let r64: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let r32: Robot<f32, 6, 8> = shipped_robot("suspended-8");
    let (p64, p32) = (path(&r64), path(&r32));
    let mut group = c.benchmark_group("forward_kinematics (1000 poses)");
    group.bench_function("warm f32", |b| b.iter(|| sweep(&r32, &p32, true)));
    group.bench_function("warm f64", |b| b.iter(|| sweep(&r64, &p64, true)));
    group.bench_function("cold f32", |b| b.iter(|| sweep(&r32, &p32, false)));
    group.bench_function("cold f64", |b| b.iter(|| sweep(&r64, &p64, false)));
    group.finish();
    println!("\n| case | mean per call | mean iterations | largest |\n| --- | --- | --- | --- |");
    for (name, warm, f32_case) in [
        ("warm f32", true, true),
        ("warm f64", true, false),
        ("cold f32", false, true),
        ("cold f64", false, false),
    ] {
        let rounds = 20;
        let start = Instant::now();
        let mut it = (0, 0);
        for _ in 0..rounds {
            it = if f32_case { sweep(&r32, &p32, warm) } else { sweep(&r64, &p64, warm) };
        }
        let per_call = start.elapsed().as_secs_f64() / (rounds * COUNT) as f64;
        println!("| {name} | {:.2} us | {:.2} | {} |", per_call * 1e6, it.0 as f64 / COUNT as f64, it.1);
    }
    c.final_summary();
}
