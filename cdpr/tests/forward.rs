//! `cdpr forward`: lengths written here from a pose table (the cable
//! lengths `|a_i - p - R b_i|` computed in this file, from the robot file's
//! numbers and hand-written rotations), read back to the poses; the status
//! and residual columns; bad input is one line, exit 2, nothing written.

mod common;

use common::*;

/// `R = Rx(a) Ry(b) Rz(c)` multiplied out by hand.
fn rotation(a: f64, b: f64, c: f64) -> [[f64; 3]; 3] {
    let (sa, ca, sb, cb, sc, cc) = (a.sin(), a.cos(), b.sin(), b.cos(), c.sin(), c.cos());
    [
        [cb * cc, -cb * sc, sb],
        [sa * sb * cc + ca * sc, ca * cc - sa * sb * sc, -sa * cb],
        [sa * sc - ca * sb * cc, ca * sb * sc + sa * cc, ca * cb],
    ]
}

/// Anchors and attachments of a shipped robot file, read as text.
fn geometry(name: &str) -> Vec<([f64; 3], [f64; 3])> {
    let text = std::fs::read_to_string(robot(name)).unwrap();
    let value: toml::Table = text.parse().unwrap();
    let v3 = |v: &toml::Value| -> [f64; 3] {
        let a = v.as_array().unwrap();
        [0, 1, 2].map(|k| a[k].as_float().or(a[k].as_integer().map(|i| i as f64)).unwrap())
    };
    value["cable"].as_array().unwrap().iter().map(|c| (v3(&c["anchor"]), v3(&c["attach"]))).collect()
}

fn lengths(cables: &[([f64; 3], [f64; 3])], pose: &[f64]) -> Vec<f64> {
    let (p, r) = match pose.len() {
        6 => ([pose[0], pose[1], pose[2]], rotation(pose[3], pose[4], pose[5])),
        3 => ([pose[0], pose[1], 0.0], rotation(0.0, 0.0, pose[2])),
        _ => ([pose[0], pose[1], 0.0], [[0.0; 3]; 3]),
    };
    cables
        .iter()
        .map(|(a, b)| {
            let mut s = 0.0;
            for k in 0..3 {
                let rb: f64 = (0..3).map(|j| r[k][j] * b[j]).sum();
                let d = if pose.len() == 6 || k < 2 { a[k] - p[k] - rb } else { 0.0 };
                s += d * d;
            }
            s.sqrt()
        })
        .collect()
}

fn write_lengths(path: &std::path::Path, times: bool, rows: &[Vec<f64>]) {
    let m = rows[0].len();
    let mut text = String::new();
    if times {
        text.push_str("time,");
    }
    text.push_str(&(1..=m).map(|i| format!("l{i}")).collect::<Vec<_>>().join(","));
    text.push('\n');
    for (k, row) in rows.iter().enumerate() {
        if times {
            text.push_str(&format!("{},", k as f64 * 0.001));
        }
        text.push_str(&row.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(","));
        text.push('\n');
    }
    std::fs::write(path, text).unwrap();
}

/// suspended-8's pose table: lengths out (here), poses back (the tool), within 1e-9.
#[test]
fn round_trip_of_the_shipped_pose_table() {
    let dir = scratch("forward-round-trip");
    let cables = geometry("suspended-8");
    let poses_text = std::fs::read_to_string(robots().join("suspended-8-poses.csv")).unwrap();
    let poses: Vec<Vec<f64>> = poses_text
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split(',').skip(1).map(|f| f.trim().parse().unwrap()).collect())
        .collect();
    assert!(poses.len() >= 4);
    write_lengths(&dir.join("l.csv"), true, &poses.iter().map(|p| lengths(&cables, p)).collect::<Vec<_>>());
    let r = robot("suspended-8");
    let run =
        cdpr_ok(&dir, &["forward", "--robot", r.to_str().unwrap(), "--lengths", "l.csv", "--out", "p.csv"]);
    assert!(run.stdout.contains(&format!("{0} of {0} rows have a pose", poses.len())), "{}", run.stdout);
    let (header, rows) = read_csv(&dir.join("p.csv"));
    assert_eq!(header, ["time", "x", "y", "z", "rx", "ry", "rz", "status", "residual"]);
    assert_eq!(rows.len(), poses.len());
    for (k, (row, pose)) in rows.iter().zip(&poses).enumerate() {
        assert_eq!(row[0], format!("{}", k as f64 * 0.001));
        assert_eq!(row[7], "ok");
        let got: Vec<f64> = row[1..7].iter().map(|f| f.parse().unwrap()).collect();
        assert_close(&got, pose, 1e-9, &format!("row {k}"));
        let residual: f64 = row[8].parse().unwrap();
        assert!(residual.abs() < 1e-9);
        // Every number in at most the 24 characters of an `f64`'s shortest
        // exponent form (a residual of 4.4e-16 used to take 33, a pose's
        // 2.5e-32 off zero 48).
        assert!(row[1..7].iter().chain([&row[8]]).all(|f| f.len() <= 24), "row {k}: {row:?}");
    }
}

/// planar3-5 without a time column; a row with one cable 5 cm longer is
/// `inconsistent-lengths` with its residual and empty pose cells, a
/// negative length `nonfinite`, and the rows after them still `ok`.
#[test]
fn planar_rows_with_failures_keep_their_status() {
    let dir = scratch("forward-planar");
    let cables = geometry("planar3-5");
    let poses = [
        vec![2.0, 1.5, 0.0],
        vec![2.1, 1.4, 0.1],
        vec![2.1, 1.4, 0.1],
        vec![2.2, 1.3, 0.2],
        vec![2.3, 1.2, -0.3],
    ];
    let mut table: Vec<Vec<f64>> = poses.iter().map(|p| lengths(&cables, p)).collect();
    table[1][2] += 0.05;
    table[2][0] = -1.0;
    write_lengths(&dir.join("l.csv"), false, &table);
    let r = robot("planar3-5");
    let run =
        cdpr_ok(&dir, &["forward", "--robot", r.to_str().unwrap(), "--lengths", "l.csv", "--out", "p.csv"]);
    assert!(
        run.stdout.contains("3 of 5 rows have a pose (1 inconsistent-lengths, 1 nonfinite)"),
        "{}",
        run.stdout
    );
    let (header, rows) = read_csv(&dir.join("p.csv"));
    assert_eq!(header, ["x", "y", "theta", "status", "residual"]);
    for (k, row) in rows.iter().enumerate() {
        match k {
            1 => {
                assert_eq!(row[3], "inconsistent-lengths");
                assert!(row[..3].iter().all(String::is_empty));
                assert!(row[4].parse::<f64>().unwrap() > 1e-3);
            }
            2 => {
                assert_eq!(row[3], "nonfinite");
                assert!(row[..3].iter().all(String::is_empty) && row[4].is_empty());
            }
            _ => {
                assert_eq!(row[3], "ok", "row {k}");
                let got: Vec<f64> = row[..3].iter().map(|f| f.parse().unwrap()).collect();
                assert_close(&got, &poses[k], 1e-9, &format!("row {k}"));
            }
        }
    }
}

#[test]
fn bad_length_tables_are_one_line_exit_2_and_no_output() {
    let cases: [(&str, &str, &str); 8] = [
        ("missing file", "", "nofile.csv"),
        ("wrong column count", "l1,l2,l3,l4\n1,2,3,4\n", "missing column `l5`"),
        ("unknown column", "l1,l2,l3,l4,l5,x\n", "unknown column `x`"),
        ("short row", "l1,l2,l3,l4,l5\n1,2,3,4\n", "line 2: 4 fields, the header has 5"),
        ("non-numeric", "l1,l2,l3,l4,l5\n1,2,abc,4,5\n", "line 2, column 3 (l3): `abc` is not a number"),
        ("repeated", "l1,l1,l2,l3,l4,l5\n", "column `l1` appears twice"),
        (
            "time backwards",
            "time,l1,l2,l3,l4,l5\n1,1,2,3,4,5\n0.5,1,2,3,4,5\n",
            "line 3, column 1 (time): time 0.5 comes before the previous row's 1",
        ),
        ("time not finite", "time,l1,l2,l3,l4,l5\ninf,1,2,3,4,5\n", "not a finite number"),
    ];
    let r = robot("planar3-5");
    let mut reached = 0;
    for (k, (name, text, expect)) in cases.iter().enumerate() {
        let dir = scratch(&format!("forward-bad-{k}"));
        let input = if *name == "missing file" { "nofile.csv" } else { "l.csv" };
        if *name != "missing file" {
            std::fs::write(dir.join("l.csv"), text).unwrap();
        }
        let run =
            cdpr(&dir, &["forward", "--robot", r.to_str().unwrap(), "--lengths", input, "--out", "p.csv"]);
        assert_eq!(run.code, 2, "{name}: {}", run.stderr);
        let lines: Vec<&str> = run.stderr.lines().collect();
        assert_eq!(lines.len(), 1, "{name}: {}", run.stderr);
        assert!(lines[0].starts_with("cdpr: error: ") && lines[0].contains(expect), "{name}: {}", lines[0]);
        assert!(!dir.join("p.csv").exists(), "{name}: output written");
        assert_eq!(listing(&dir).len(), usize::from(*name != "missing file"), "{name}: files left behind");
        reached += 1;
    }
    assert_eq!(reached, 8);
}
