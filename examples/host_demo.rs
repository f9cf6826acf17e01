//! Host demo: the suspended-8 robot of `../shared/robots` follows a smooth
//! trajectory that leaves the workspace and comes back; every millisecond the
//! barycenter tensions (warm-started) are computed, as the firmware does, and
//! every 100 ms a line shows what was computed. The other methods run on the
//! same samples for comparison.

use std::time::Instant;

use cdpr_integration_tests::shared_robot;
use nalgebra::SVector;
use tension_core::{Method, Motion, Robot, TensionSolver};

fn time_law(u: f64) -> (f64, f64, f64) {
    let s = u.powi(4) * (35.0 - 84.0 * u + 70.0 * u * u - 20.0 * u.powi(3));
    let ds = u.powi(3) * (140.0 - 420.0 * u + 420.0 * u * u - 140.0 * u.powi(3));
    let dds = u * u * (420.0 - 1680.0 * u + 2100.0 * u * u - 840.0 * u.powi(3));
    (s, ds, dds)
}

fn main() {
    let robot: Robot<f64, 6, 8> = shared_robot("suspended-8");
    let waypoints = [
        SVector::<f64, 6>::from([0.0, 0.0, 1.5, 0.0, 0.0, 0.0]),
        SVector::<f64, 6>::from([1.6, 0.3, 1.2, 0.05, 0.0, 0.1]),
        SVector::<f64, 6>::from([-0.5, -0.4, 2.0, -0.1, 0.1, -0.2]),
        SVector::<f64, 6>::from([0.0, 0.0, 1.5, 0.0, 0.0, 0.0]),
    ];
    let seconds = 2.0;
    let winch = robot.winch().copied();
    println!("suspended-8, barycenter at 1 kHz (f64, host); limits 5..350 N");
    println!(
        "{:>6} {:>28} {:>58} {:>6} {:>4} {:>5}",
        "t [s]", "pose x y z [m] rz [rad]", "tensions t1..t8 [N]", "robust", "vert", "warm"
    );
    let mut solvers: Vec<TensionSolver<f64, 8>> =
        Method::ALL.iter().map(|&m| TensionSolver::new(m)).collect();
    let mut stats = vec![(0usize, 0usize, 0.0f64, 0.0f64, None::<SVector<f64, 8>>); Method::ALL.len()];
    let mut k = 0usize;
    for pair in waypoints.windows(2) {
        let delta = pair[1] - pair[0];
        for step in 0..(seconds * 1000.0) as usize {
            let (s, ds, dds) = time_law(step as f64 / (seconds * 1000.0));
            let pose = pair[0] + delta * s;
            let motion = Motion::from_pose_derivatives(
                robot.kind(),
                &pose,
                &(delta * (ds / seconds)),
                &(delta * (dds / seconds / seconds)),
            )
            .unwrap();
            let w = robot.wrench_matrix(&pose).unwrap();
            let f = robot.required_wrench(&pose, &SVector::zeros(), Some(&motion)).unwrap();
            for (i, solver) in solvers.iter_mut().enumerate() {
                let start = Instant::now();
                let result = solver.solve(&w, &f, robot.limits());
                stats[i].3 += start.elapsed().as_secs_f64();
                match result {
                    Ok(sol) => {
                        stats[i].0 += 1;
                        if let Some(prev) = stats[i].4 {
                            stats[i].2 = stats[i].2.max((sol.tensions - prev).amax());
                        }
                        stats[i].4 = Some(sol.tensions);
                        if i == 0 && k.is_multiple_of(100) {
                            let t: Vec<String> = sol.tensions.iter().map(|x| format!("{x:6.1}")).collect();
                            println!(
                                "{:6.2} {:6.3} {:6.3} {:6.3} {:6.3} {} {:6.2} {:>4} {:>5}",
                                k as f64 / 1000.0,
                                pose[0],
                                pose[1],
                                pose[2],
                                pose[5],
                                t.join(" "),
                                sol.robustness,
                                sol.diagnostics.vertices,
                                format!("{:?}", sol.diagnostics.warm_start)
                            );
                        }
                    }
                    Err(e) => {
                        stats[i].1 += 1;
                        stats[i].4 = None;
                        if i == 0 && k.is_multiple_of(100) {
                            println!(
                                "{:6.2} {:6.3} {:6.3} {:6.3} {:6.3} {:>58}",
                                k as f64 / 1000.0,
                                pose[0],
                                pose[1],
                                pose[2],
                                pose[5],
                                e.status()
                            );
                        }
                    }
                }
            }
            k += 1;
        }
    }
    if let Some(w) = winch {
        let t = robot.limits().max()[0];
        println!(
            "motor torque at t_max ({t} N): {:.3} N m (limit {})",
            w.motor_torque(t).unwrap().torque,
            w.torque_max
        );
    }
    println!(
        "\n{:<22} {:>7} {:>10} {:>16} {:>12}",
        "method", "solved", "failed", "largest step [N]", "mean [us]"
    );
    for (m, s) in Method::ALL.iter().zip(&stats) {
        println!("{:<22} {:>7} {:>10} {:>16.3} {:>12.2}", m.name(), s.0, s.1, s.2, s.3 / k as f64 * 1e6);
    }
}
