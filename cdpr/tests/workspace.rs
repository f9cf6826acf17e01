//! `cdpr workspace` against hand estimates on simple planar robots, and on
//! the shipped suspended robot.

mod common;

use std::path::Path;

use common::*;

fn summary_value(summary: &str, key: &str) -> f64 {
    let line =
        summary.lines().find(|l| l.starts_with(key)).unwrap_or_else(|| panic!("no `{key}` in {summary}"));
    line[key.len()..].split_whitespace().next().unwrap().parse().unwrap()
}

fn write_robot(dir: &Path, name: &str, body: &str) {
    std::fs::write(dir.join(name), body).unwrap();
}

/// Without gravity a point pulled by four cables to the corners of a 3 m
/// square is in equilibrium with tensions in [1 N, 1e6 N] everywhere
/// inside the square (the directions positively span the plane), so the
/// area is the whole square, 9 m^2, 100 % of the frame.
#[test]
fn weightless_point_fills_its_square() {
    let dir = scratch("ws-square");
    write_robot(
        &dir,
        "r.toml",
        "name = \"square\"\nkind = \"planar2\"\n[limits]\nt_min = 1.0\nt_max = 1e6\n[platform]\nmass = 0.0\ngravity = [0.0, 0.0, 0.0]\n\
         [[cable]]\nanchor = [0.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n\
         [[cable]]\nanchor = [3.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n\
         [[cable]]\nanchor = [3.0, 3.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n\
         [[cable]]\nanchor = [0.0, 3.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n",
    );
    let run = cdpr_ok(&dir, &["workspace", "--robot", "r.toml", "--step", "0.05", "--out", "ws"]);
    assert!(run.stderr.is_empty(), "no progress bar off a terminal: {}", run.stderr);
    let summary = std::fs::read_to_string(dir.join("ws").join("summary.txt")).unwrap();
    assert!((summary_value(&summary, "area:") - 9.0).abs() < 1e-9, "{summary}");
    assert!(summary.contains("= 100.00 % of the frame's 9.000000 m^2"), "{summary}");
    assert!(summary.contains("cells: 3600; feasible 3600"), "{summary}");
    let png = std::fs::read(dir.join("ws").join("workspace.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
}

/// A point mass m hanging from two anchors (0, 2) and (2, 2): with
/// d = 2 - y, l1, l2 the cable lengths, the equilibrium gives by hand
/// t1 = m g (2 - x) l1 / (2 d), t2 = m g x l2 / (2 d). The workspace is
/// where both lie in [t_min, t_max]; its area is integrated here on a
/// 2000 x 2000 grid of that formula and compared with the tool's (whose
/// frame is [0, 2] x [0, 2]: the anchors' box reaches down to the floor).
#[test]
fn two_cable_pendulum_area_matches_the_hand_formula() {
    let dir = scratch("ws-pendulum");
    let (m, t_min, t_max) = (1.0, 2.0, 12.0);
    write_robot(
        &dir,
        "r.toml",
        &format!(
            "name = \"pendulum\"\nkind = \"planar2\"\n[limits]\nt_min = {t_min:?}\nt_max = {t_max:?}\n[platform]\nmass = {m:?}\ngravity = [0.0, -9.81, 0.0]\n\
             [[cable]]\nanchor = [0.0, 2.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n\
             [[cable]]\nanchor = [2.0, 2.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n"
        ),
    );
    let n = 2000;
    let h = 2.0 / n as f64;
    let mut inside = 0usize;
    for i in 0..n {
        for j in 0..n {
            let (x, y) = ((i as f64 + 0.5) * h, (j as f64 + 0.5) * h);
            let d = 2.0 - y;
            let l1 = (x * x + d * d).sqrt();
            let l2 = ((2.0 - x) * (2.0 - x) + d * d).sqrt();
            let t1 = m * G * (2.0 - x) * l1 / (2.0 * d);
            let t2 = m * G * x * l2 / (2.0 * d);
            if (t_min..=t_max).contains(&t1) && (t_min..=t_max).contains(&t2) {
                inside += 1;
            }
        }
    }
    let hand = inside as f64 * h * h;
    assert!(hand > 0.5 && hand < 3.5, "a non-trivial region: {hand}");
    for method in ["closed-form", "improved-closed-form", "analytic-centre"] {
        cdpr_ok(
            &dir,
            &["workspace", "--robot", "r.toml", "--step", "0.01", "--method", method, "--out", "ws"],
        );
        let summary = std::fs::read_to_string(dir.join("ws").join("summary.txt")).unwrap();
        let area = summary_value(&summary, "area:");
        assert!((area - hand).abs() < 0.01 * hand, "{method}: area {area} m^2, by hand {hand} m^2");
    }
}

/// The same pendulum framed on its ceiling (anchors at y = 0): the frame
/// reaches the anchors' widest extent (2 m) down along gravity, where the
/// forward kinematics takes the platform to hang, and the area is the one
/// framed from the floor, cell for cell. The tool refused it ("every
/// anchor has y = 0 ... give --bounds"); without gravity it still does.
#[test]
fn a_pendulum_framed_on_its_ceiling_has_the_same_area() {
    let dir = scratch("ws-ceiling");
    let robot = |anchor_y: f64, gravity_y: f64| {
        format!(
            "name = \"pendulum\"\nkind = \"planar2\"\n[limits]\nt_min = 2.0\nt_max = 12.0\n[platform]\nmass = 1.0\ngravity = [0.0, {gravity_y:?}, 0.0]\n\
             [[cable]]\nanchor = [0.0, {anchor_y:?}, 0.0]\nattach = [0.0, 0.0, 0.0]\n\
             [[cable]]\nanchor = [2.0, {anchor_y:?}, 0.0]\nattach = [0.0, 0.0, 0.0]\n"
        )
    };
    let mut summaries = Vec::new();
    for (name, anchor_y) in [("floor.toml", 2.0), ("ceiling.toml", 0.0)] {
        write_robot(&dir, name, &robot(anchor_y, -9.81));
        cdpr_ok(&dir, &["workspace", "--robot", name, "--step", "0.02", "--out", "ws"]);
        summaries.push(std::fs::read_to_string(dir.join("ws").join("summary.txt")).unwrap());
    }
    let cells = |s: &str| s.lines().find(|l| l.starts_with("cells:")).map(str::to_owned);
    assert!(cells(&summaries[1]).is_some() && cells(&summaries[0]) == cells(&summaries[1]), "{summaries:?}");
    let (floor, ceiling) = (summary_value(&summaries[0], "area:"), summary_value(&summaries[1], "area:"));
    assert!(floor > 0.5 && (floor - ceiling).abs() < 1e-9, "{floor} against {ceiling}");
    assert!(summaries[1].contains("y: -2 m to 0 m"), "{}", summaries[1]);
    // Without gravity there is no side to hang on: refused, as before.
    write_robot(&dir, "weightless.toml", &robot(0.0, 0.0));
    let run = cdpr(&dir, &["workspace", "--robot", "weightless.toml", "--step", "0.02", "--out", "ws"]);
    assert!(
        run.code != 0
            && run.stderr.contains("every anchor has y = 0")
            && run.stderr.contains("give --bounds"),
        "{}",
        run.stderr
    );
}

/// COGIRO's anchors lie within 3 cm of one height (5.387 to 5.42 m): the
/// default frame was that 3 cm slab, and the volume 0 m^3 ("0.00 % of the
/// frame"). The frame now reaches the floor as the forward kinematics'
/// region does, and most of it holds the platform.
#[test]
fn cogiros_nearly_level_anchors_frame_reaches_the_floor() {
    let dir = scratch("ws-cogiro");
    cdpr_ok(
        &dir,
        &["workspace", "--robot", robot("cogiro").to_str().unwrap(), "--step", "0.5", "--out", "ws"],
    );
    let summary = std::fs::read_to_string(dir.join("ws").join("summary.txt")).unwrap();
    assert!(summary.contains("z: 0 m to 5.42 m"), "{summary}");
    let volume = summary_value(&summary, "volume:");
    // The frame is 15 m x 11 m x 5.4 m, 894 m^3.
    assert!(volume > 300.0 && volume < 894.0, "{summary}");
}

/// The suspended robot: the volume does not depend on the thread count,
/// lies inside the frame, the sweep starts at the nominal robot, and the
/// pictures exist. (A suspended robot's volume may grow with payload: the
/// weight is what keeps its cables above t_min.)
#[test]
fn suspended_volume_sweep_and_pictures() {
    let dir = scratch("ws-susp");
    let mut volumes = vec![];
    for threads in ["1", "2"] {
        let run = cdpr_ok(
            &dir,
            &[
                "workspace",
                "--robot",
                robot("suspended-8").to_str().unwrap(),
                "--orientation",
                "0,0,0.1",
                "--step",
                "0.2",
                "--threads",
                threads,
                "--mass-sweep",
                "0:20:3",
                "--out",
                "ws",
            ],
        );
        let summary = std::fs::read_to_string(dir.join("ws").join("summary.txt")).unwrap();
        assert!(summary.contains("z: 0 m to 3.5 m"), "{summary}");
        let v = summary_value(&summary, "volume:");
        assert!(v > 1.0 && v < 42.0, "{v}");
        volumes.push(v);
        assert!(run.stdout.contains("volume:"));
    }
    assert_eq!(volumes[0], volumes[1]);
    let ws = dir.join("ws");
    for f in
        ["slices-xy.png", "slice-xz.png", "mass-sweep.csv", "mass-sweep.png", "mass-sweep.svg", "summary.txt"]
    {
        let bytes = std::fs::read(ws.join(f)).unwrap_or_else(|_| panic!("{f} missing"));
        assert!(bytes.len() > 100, "{f} is empty");
        if f.ends_with(".png") {
            assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{f}");
        }
        if f.ends_with(".svg") {
            assert!(bytes.starts_with(b"<svg"), "{f}");
        }
    }
    let (header, rows) = read_csv(&ws.join("mass-sweep.csv"));
    assert_eq!(header, ["payload_kg", "mass_kg", "volume_m3", "share"]);
    assert_eq!(rows.len(), 3);
    let vol: Vec<f64> = rows.iter().map(|r| r[2].parse().unwrap()).collect();
    assert!((vol[0] - volumes[0]).abs() < 1e-5, "payload 0 is the nominal robot");
    assert!(vol.iter().all(|v| *v > 0.0 && *v < 42.0), "{vol:?}");
    let mass: f64 = rows[2][1].parse().unwrap();
    assert!((mass - 26.34).abs() < 1e-9);
}

/// planar-point-4 with a payload sweep: at payload 0 the nominal area; at
/// 1000 kg the weight (10006 N) exceeds what four cables of at most 400 N
/// can hold (1600 N), so nothing is feasible.
#[test]
fn point_mass_sweep_ends_at_zero_area() {
    let dir = scratch("ws-sweep");
    cdpr_ok(
        &dir,
        &[
            "workspace",
            "--robot",
            robot("planar-point-4").to_str().unwrap(),
            "--step",
            "0.05",
            "--mass-sweep",
            "0:1000:3",
            "--out",
            "ws",
        ],
    );
    let summary = std::fs::read_to_string(dir.join("ws").join("summary.txt")).unwrap();
    let area = summary_value(&summary, "area:");
    let (header, rows) = read_csv(&dir.join("ws").join("mass-sweep.csv"));
    assert_eq!(header, ["payload_kg", "mass_kg", "area_m2", "share"]);
    let areas: Vec<f64> = rows.iter().map(|r| r[2].parse().unwrap()).collect();
    assert_eq!(rows[1][1], "520");
    assert!((areas[0] - area).abs() < 1e-5);
    assert!(areas[0] > 1.0 && areas[0] < 9.0);
    assert_eq!(areas[2], 0.0);
    assert_eq!(rows[2][3], "0");
}
