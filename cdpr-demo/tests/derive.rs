//! The derived demo trajectories of the 6 x 8 robots with a winch in
//! `robots/`: the loop feasible with its margin, the excursion infeasible
//! for longer than a hold, the same numbers every time.
#![cfg(feature = "std")]

use cdpr_demo::derive::{derive, solve, Derivation, INFEASIBLE_CYCLES, MARGIN};
use cdpr_demo::trajectory::{CYCLES, SCRIPT_CYCLES};
use tension_core::{Error, Method};

fn derived(file: &str) -> (cdpr_demo::derive::Robot68, Derivation) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(file);
    let robot = robot_file::RobotFile::load(&path).unwrap().to_robot::<f64, 6, 8>().unwrap();
    let d = derive(&robot).unwrap_or_else(|e| panic!("{file}: {e}"));
    (robot, d)
}

#[test]
fn suspended_8_and_ipanema1() {
    for file in ["robots/suspended-8.toml", "robots/ipanema1.toml"] {
        let (robot, d) = derived(file);
        println!("{file}: {d:?}");
        let span = robot.limits().max()[0] - robot.limits().min()[0];
        assert!(d.loop_robustness >= MARGIN * span);
        assert!(d.infeasible_run >= INFEASIBLE_CYCLES);
        let p = d.params;
        let (mut ok, mut infeasible) = (0, 0);
        for k in 0..SCRIPT_CYCLES as u32 {
            match solve(&robot, Method::Barycenter, &p.script(k)) {
                Ok(_) => ok += 1,
                Err(Error::Infeasible) => infeasible += 1,
                Err(e) => panic!("{file}: cycle {k}: {}", e.status()),
            }
        }
        println!("{file}: {ok} ok, {infeasible} infeasible of {SCRIPT_CYCLES}");
        assert!(infeasible as u32 >= INFEASIBLE_CYCLES && infeasible < CYCLES / 2);
        assert_eq!(derived(file).1.params, p);
    }
}

/// Limits that `f64` holds but the board's `f32` does not (t_max = 1e20 N,
/// beyond 6.5e18): refused with the bound, not a bare `invalid-limits`.
#[test]
fn limits_too_large_for_the_boards_f32_name_the_bound() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/suspended-8.toml");
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.contains("t_max = 350.0\n"));
    let file = robot_file::RobotFile::parse(&text.replacen("t_max = 350.0\n", "t_max = 1e20\n", 1)).unwrap();
    let robot = file.to_robot::<f64, 6, 8>().unwrap();
    let e = derive(&robot).unwrap_err();
    assert!(e.contains("limits in f32") && e.contains("t_max at most 6.5e18 N"), "{e}");
}
