//! The `hal-sim` command line (clap): the listing, and usage errors with
//! exit code 2 that say what is wrong, before any scenario runs.

use std::process::Command;

use hal_sim::Scenario;

fn run(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_hal-sim")).args(args).output().expect("hal-sim runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn list_names_every_scenario() {
    let (code, stdout, _) = run(&["--list"]);
    assert_eq!(code, 0);
    let all = Scenario::all();
    assert_eq!(stdout.lines().count(), all.len());
    for (line, s) in stdout.lines().zip(&all) {
        assert!(line.starts_with(&s.name) && line.ends_with(&s.description), "{line}");
    }
}

#[test]
fn usage_errors_exit_2_and_say_what_is_wrong() {
    let cases: [(&[&str], &str); 7] = [
        (&[], "--scenario"),
        (&["--scenario", "all"], "--out"),
        (&["--out", "x"], "--scenario"),
        (&["--scenario"], "a value is required"),
        (&["--list", "--out", "x"], "cannot be used with"),
        (&["--bogus"], "unexpected argument '--bogus'"),
        (&["--scenario", "no-such", "--out", "x"], "unknown scenario `no-such`"),
    ];
    for (args, expected) in cases {
        let (code, stdout, stderr) = run(args);
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert!(stdout.is_empty(), "{args:?}: {stdout}");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
    }
    // Nothing was written for the unknown scenario.
    assert!(!std::path::Path::new("x").exists());
}

/// `--robot FILE`: the listing of that robot's derived site (its own
/// numbers in the descriptions); a file the simulator cannot take, or
/// none, exits 2 and says why.
#[test]
fn robot_lists_its_own_scenarios_or_says_why_not() {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/../robots/ipanema1.toml");
    let (code, stdout, stderr) = run(&["--list", "--robot", file]);
    assert_eq!(code, 0, "{stderr}");
    let site = hal_sim::Site::derived(std::path::Path::new(file)).unwrap();
    let all = Scenario::all_at(&site);
    assert_eq!(stdout.lines().count(), all.len());
    for (line, s) in stdout.lines().zip(&all) {
        assert!(line.starts_with(&s.name) && line.ends_with(&s.description), "{line}");
    }
    // Not suspended-8's: the push scaled by the weight, its own jumps.
    assert_ne!(stdout, run(&["--list"]).1);
    assert!(stdout.contains(&site.out_of_range.1), "{stdout}");
    // suspended-8 with 2^31 counts a motor turn: 3 cm of cable in 2^31
    // counts (it ran, and the platform went 218 mm off its loop, a cable
    // slack, before a tracking fault).
    let fine = std::env::temp_dir().join(format!("hal-sim-cli-{}-fine-encoder.toml", std::process::id()));
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../robots/suspended-8.toml")).unwrap();
    std::fs::write(
        &fine,
        text.replace("torque_max = 2.5", "torque_max = 2.5\ncounts_per_revolution = 2147483648"),
    )
    .unwrap();
    // suspended-8 with winches that pull 21.6 N against t_max = 350 N (it
    // ran, the solver asked up to 37 N, and the platform went 197 mm off
    // its loop before a tracking fault).
    let weak = std::env::temp_dir().join(format!("hal-sim-cli-{}-weak-winch.toml", std::process::id()));
    std::fs::write(&weak, text.replace("torque_max = 2.5", "torque_max = 0.12")).unwrap();
    for (robot, expected) in [
        (concat!(env!("CARGO_MANIFEST_DIR"), "/../robots/planar3-5.toml"), "6 DOF x 8 cables"),
        ("no/such/robot.toml", "no/such/robot.toml"),
        (fine.to_str().unwrap(), "counts_per_revolution must be at most 9362"),
        (weak.to_str().unwrap(), "cable 1: t_max = 350 N needs 1.9444 N m at the motor"),
    ] {
        let (code, stdout, stderr) = run(&["--list", "--robot", robot]);
        assert_eq!(code, 2, "{robot}: {stderr}");
        assert!(stdout.is_empty() && stderr.contains(expected), "{robot}: {stderr}");
    }
    let _ = std::fs::remove_file(&fine);
    let _ = std::fs::remove_file(&weak);
}

/// A robot file with all eight drives on CAN1 (it was taken, and the CAN
/// scenarios ended "the CAN drives were not ready after 500 cycles"): the
/// scenarios on the buses stop with the reason before they run, as the
/// firmware's build refuses the file; the others, which do not use the
/// buses, are still listed and run.
#[test]
fn drives_crowded_on_one_bus_are_refused_with_the_reason() {
    let crowded = std::env::temp_dir().join(format!("hal-sim-cli-{}-one-bus.toml", std::process::id()));
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../robots/suspended-8.toml")).unwrap();
    let text = text
        .replace("node_id = [1, 2, 3, 4, 1, 2, 3, 4]", "node_id = [1, 2, 3, 4, 5, 6, 7, 8]")
        .replace("can_bus = [1, 1, 1, 1, 2, 2, 2, 2]", "can_bus = [1, 1, 1, 1, 1, 1, 1, 1]");
    assert!(text.contains("can_bus = [1, 1, 1, 1, 1, 1, 1, 1]"), "suspended-8's drives changed");
    std::fs::write(&crowded, text).unwrap();
    let file = crowded.to_str().unwrap();
    let (code, stdout, _) = run(&["--list", "--robot", file]);
    assert!(code == 0 && stdout.contains("can-drive-fault"), "{stdout}");
    let out = std::env::temp_dir().join(format!("hal-sim-cli-{}-one-bus-out", std::process::id()));
    let (code, _, stderr) =
        run(&["--scenario", "can-bus-off", "--out", out.to_str().unwrap(), "--robot", file]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("CAN1 has 8 drives; a bus serves at most 4"), "{stderr}");
    let _ = std::fs::remove_file(&crowded);
    let _ = std::fs::remove_dir_all(&out);
}
