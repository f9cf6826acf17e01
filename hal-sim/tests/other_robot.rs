//! `hal-sim --robot FILE`: every scenario on a robot file's derived site
//! ([`Site::derived`]): IPAnema 1 (0.1 kg, 1-10 N, 0.1 N m winches: the
//! light end of the shipped robots) and suspended-8's own file (its poses
//! derived rather than hand-picked). Their figures are not suspended-8's
//! README's; what is checked is what a user of any robot relies on:
//!
//! * the static holds and the tracking loop stay Enabled throughout, in
//!   both feedback schemes, within 2 mm and 0.5 degrees of the reference,
//!   the true tensions within the robot's limits (5 % of the range of
//!   slack for the cables' dynamics);
//! * each fault ends in Fault for its own reason (the same sequences as
//!   suspended-8's tests: `tests/closed_loop.rs`, `tests/can_bus.rs`), the
//!   brakes holding within 21 ms of it and the platform dropping at most
//!   15 mm after the event;
//! * a wrong homing either plays through or is caught by the estimator
//!   (the lengths fit no pose: on IPAnema 1's small frame 20 mm is).
//!
//! The derived poses have static barycenter tensions 2 % of the range
//! from the limits (checked here with tension-core, apart from the
//! derivation).

use cdpr_control::protocol::{Reason, State};
use cdpr_demo::derive::{Robot68, MARGIN};
use hal_sim::output::figures;
use hal_sim::scenario::Path;
use hal_sim::{run, Config, Outcome, Scenario, Site};
use nalgebra::SVector;
use tension_core::{Method, TensionSolver};

fn robot_file(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../robots/{name}.toml"))
}

/// The state sequence after the Enable.
fn after_enable(o: &Outcome) -> Vec<(State, Reason, Reason)> {
    o.transitions.iter().skip(1).map(|&(_, s, r, h)| (s, r, h)).collect()
}

/// The state sequence each fault scenario ends in (after the Enable).
fn expected(name: &str) -> Option<Vec<(State, Reason, Reason)>> {
    let base = name.strip_suffix("-joint").unwrap_or(name);
    let fault = |r| vec![(State::Fault, r, Reason::None)];
    Some(match base {
        "cable-break" | "encoder-stuck" => fault(Reason::Estimator),
        "winch-saturation" => fault(Reason::Output),
        "drive-unreadable" => fault(Reason::Encoder),
        "can-drive-fault" | "can-drive-drop" | "can-bus-off" => fault(Reason::Drive),
        "infeasible-setpoint" | "out-of-range-setpoint" => vec![
            (State::Holding, Reason::BadSetpoint, Reason::BadSetpoint),
            (State::Fault, Reason::HoldTimeout, Reason::BadSetpoint),
        ],
        "lost-stream" => vec![
            (State::Holding, Reason::Stale, Reason::Stale),
            (State::Fault, Reason::HoldTimeout, Reason::Stale),
        ],
        _ => return None,
    })
}

fn static_robustness(robot: &Robot68, pose: &[f64; 6]) -> Option<f64> {
    let (w, f) = robot.wrench_problem(&SVector::from(*pose), &SVector::zeros(), None).ok()?;
    TensionSolver::<f64, 8>::new(Method::Barycenter).solve(&w, &f, robot.limits()).ok().map(|s| s.robustness)
}

#[test]
fn every_scenario_on_a_derived_site_holds_tracks_and_fails_safe() {
    let mut checked = 0;
    for name in ["ipanema1", "suspended-8"] {
        let file = robot_file(name);
        let site = Site::derived(&file).unwrap();
        let robot: Robot68 = robot_file::RobotFile::load(&file).unwrap().to_robot().unwrap();
        let (lo, hi) = (robot.limits().min()[0], robot.limits().max()[0]);
        let span = hi - lo;
        for pose in site.holds.iter().map(|(_, p)| p).chain([&site.fault_pose]) {
            let r = static_robustness(&robot, pose).expect("static tensions");
            assert!(r >= MARGIN * span * (1.0 - 1e-9), "{name}: {pose:?}: {r}");
        }
        assert!(static_robustness(&robot, &site.infeasible.0).is_none(), "{name}: {:?}", site.infeasible);
        let config = Config::for_site(&site).unwrap();
        let scenarios = Scenario::all_at(&site);
        assert_eq!(scenarios.len(), Scenario::all().len());
        for s in &scenarios {
            let c = if s.can_fault.is_some() { config.on_can_buses() } else { config };
            let o = run(s, &c).unwrap_or_else(|e| panic!("{name} {}: {e}", s.name));
            let f = figures(&o, 0.0);
            let states = after_enable(&o);
            let shown = format!("{name} {}: {states:?} {f:?}", s.name);
            println!(
                "{name} {}: {:?}, |e_p| {:.3} mm, rotation {:.2} deg, tensions {:.2}..{:.2} N, drop {:.1} mm",
                s.name,
                states,
                f.position_error * 1e3,
                f.rotation_error.to_degrees(),
                f.tension_min,
                f.tension_max,
                f.drop * 1e3
            );
            let base = s.name.strip_suffix("-joint").unwrap_or(&s.name);
            if base.starts_with("hold-") || base == "track" {
                assert!(states.is_empty(), "{shown}");
                assert!(f.position_error < 2e-3, "{shown}");
                assert!(f.rotation_error < 0.5f64.to_radians(), "{shown}");
                assert!(f.tension_min >= lo - 0.05 * span && f.tension_max <= hi + 0.05 * span, "{shown}");
                assert!(matches!(s.path, Path::Hold(_) | Path::Loop { .. }));
            } else if base.starts_with("wrong-homing") {
                let caught = matches!(
                    states.last(),
                    Some(
                        (State::Fault, Reason::Estimator, _)
                            | (State::Fault, Reason::HoldTimeout, Reason::Estimator)
                    )
                );
                assert!(states.is_empty() || caught, "{shown}");
            } else {
                if let Some(sequence) = expected(&s.name) {
                    assert_eq!(states, sequence, "{shown}");
                } else {
                    // The lost stream in motion: stale, then the length
                    // check or the hold's end.
                    assert_eq!(base, "lost-stream-moving", "{shown}");
                    assert_eq!(states.last().map(|s| s.0), Some(State::Fault), "{shown}");
                }
                let (fault, locked) = (f.fault_at.unwrap(), f.locked_at.unwrap());
                assert!(locked - fault <= 0.021 + 1e-9, "{shown}");
                assert!(f.drop < 15e-3, "{shown}");
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 2 * Scenario::all().len());
}

/// A robot file the simulator cannot take says why, and nothing runs.
#[test]
fn a_site_needs_a_six_dof_eight_cable_robot_with_a_workspace() {
    let e = Site::derived(&robot_file("planar3-5")).unwrap_err();
    assert!(e.contains("planar3-5.toml") && e.contains("6 DOF x 8 cables"), "{e}");
    let e = Site::derived(std::path::Path::new("no/such/robot.toml")).unwrap_err();
    assert!(e.contains("no/such/robot.toml"), "{e}");
}

/// A robot file without `[platform] inertia`: the board would refuse the
/// task-space PID (zero rotation gains), so a task-space scenario stops
/// with that error; the joint-space one runs.
#[test]
fn a_platform_without_inertia_has_no_task_space_scenario() {
    let text = std::fs::read_to_string(robot_file("ipanema1")).unwrap();
    let start = text.find("\ninertia").expect("ipanema1 states an inertia");
    let end = start + 1 + text[start + 1..].find('\n').unwrap();
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("no-inertia");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("ipanema1-no-inertia.toml");
    std::fs::write(&file, format!("{}{}", &text[..start], &text[end..])).unwrap();
    let site = Site::derived(&file).unwrap();
    let config = Config::for_site(&site).unwrap();
    let e = run(&Scenario::named_at(&site, "hold-centre").unwrap(), &config).unwrap_err();
    assert!(e.contains("no task-space PID") && e.contains("without [platform] inertia"), "{e}");
    let o = run(&Scenario::named_at(&site, "hold-centre-joint").unwrap(), &config).unwrap();
    assert!(after_enable(&o).is_empty() && figures(&o, 0.0).position_error < 2e-3);
}

/// A heavy robot on heavy winches needs a lower feedback bandwidth, and
/// the robot file sets it (`[control] bandwidth`). COGIRO (91 kg, its
/// published geometry) given 30 N m winches (0.1 m drums, 20:1; their
/// simulated rotors scale with the torque, 6.7 kg at each cable) on the
/// CAN buses, joint-space PID, holding before its drive fault at 2 s: at
/// the default 5 Hz the loop rings up and the estimator faults it 0.1 s
/// after the Enable, the platform ending 0.4 m off its pose; at 2 Hz it
/// holds within 5 mm until the drive fault, which then faults it for its
/// own reason.
#[test]
fn a_heavy_robot_holds_at_the_bandwidth_its_file_sets() {
    let text = std::fs::read_to_string(robot_file("cogiro")).unwrap();
    assert!(!text.contains("[winch]") && text.matches("[[cable]]").count() == 8);
    let winch = "[winch]\ndrum_radius = 0.1\ngear_ratio = 20.0\nefficiency = 0.9\ntorque_max = 30.0\nrated_torque = 10.0\n";
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("bandwidth");
    std::fs::create_dir_all(&dir).unwrap();
    let mut outcomes = Vec::new();
    for (name, control) in [("default", ""), ("2-hz", "[control]\nbandwidth = 2.0\n")] {
        let file = dir.join(format!("cogiro-{name}.toml"));
        std::fs::write(&file, text.replacen("[[cable]]", &format!("{winch}{control}[[cable]]"), 1)).unwrap();
        let site = Site::derived(&file).unwrap();
        let config = Config::for_site(&site).unwrap().on_can_buses();
        let scenario = Scenario::named_at(&site, "can-drive-fault-joint").unwrap();
        let o = run(&scenario, &config).unwrap_or_else(|e| panic!("{name}: {e}"));
        let f = figures(&o, 0.0);
        println!(
            "{name}: {:?}, |e_p| {:.1} mm, fault at {:?} s",
            after_enable(&o),
            f.position_error * 1e3,
            f.fault_at
        );
        outcomes.push((config.bandwidth_hz, after_enable(&o), f));
    }
    let (hz, states, f) = &outcomes[0];
    assert_eq!(*hz, 5.0);
    assert_eq!(states, &vec![(State::Fault, Reason::Estimator, Reason::None)]);
    assert!(f.fault_at.unwrap() < 0.3 && f.position_error > 0.1, "{f:?}");
    let (hz, states, f) = &outcomes[1];
    assert_eq!(*hz, 2.0);
    assert_eq!(states, &expected("can-drive-fault-joint").unwrap());
    assert!(f.fault_at.unwrap() >= 2.0 && f.position_error < 5e-3, "{f:?}");
}
