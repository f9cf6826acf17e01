//! Instruction profile of one method on suspended-8 in f32 (for callgrind):
//! `cargo build --release --example profile_solver && valgrind --tool=callgrind target/release/examples/profile_solver barycenter`.
use cdpr_integration_tests::shipped_robot;
use nalgebra::SVector;
use tension_core::{Method, Robot, TensionSolver};

fn main() {
    let method = std::env::args().nth(1).and_then(|m| Method::from_name(&m)).unwrap_or(Method::Barycenter);
    let robot: Robot<f32, 6, 8> = shipped_robot("suspended-8");
    let mut solver = TensionSolver::<f32, 8>::new(method);
    let mut ok = 0;
    for k in 0..4000 {
        let s = 2.0 * std::f32::consts::PI * k as f32 / 4000.0;
        let pose = SVector::<f32, 6>::from([
            0.6 * s.sin(),
            0.4 * (2.0 * s).sin(),
            1.5 + 0.3 * s.cos(),
            0.05 * s.sin(),
            -0.05 * s.cos(),
            0.15 * s.sin(),
        ]);
        let (w, f) = robot.wrench_problem(&pose, &SVector::zeros(), None).unwrap();
        ok += solver.solve(&w, &f, robot.limits()).is_ok() as usize;
    }
    println!("{ok} solved");
}
