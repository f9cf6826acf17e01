//! Bad input: every case exits with code 2, prints one line naming the
//! file, the line and the column (as far as they are known), and leaves no
//! output file (not even a partial or temporary one) behind.

mod common;

use common::*;

const POINT4: &str = "name = \"p\"\nkind = \"planar2\"\n[limits]\nt_min = 50.0\nt_max = 400.0\n[platform]\nmass = 20.0\ngravity = [0.0, -9.81, 0.0]\n";

fn cable(x: f64, y: f64) -> String {
    format!("[[cable]]\nanchor = [{x:?}, {y:?}, 0.0]\nattach = [0.0, 0.0, 0.0]\n")
}

fn point4_robot() -> String {
    let mut s = POINT4.to_string();
    for (x, y) in [(0.0, 0.0), (3.0, 0.0), (3.0, 3.0), (0.0, 3.0)] {
        s.push_str(&cable(x, y));
    }
    s
}

struct Case {
    name: &'static str,
    files: Vec<(&'static str, String)>,
    args: Vec<String>,
    expect: Vec<&'static str>,
    outputs: Vec<&'static str>,
}

fn solve_case(
    name: &'static str,
    robot: String,
    poses: &str,
    method: &str,
    expect: Vec<&'static str>,
) -> Case {
    Case {
        name,
        files: vec![("r.toml", robot), ("p.csv", poses.to_string())],
        args: ["solve", "--robot", "r.toml", "--method", method, "--poses", "p.csv", "--out", "o.csv"]
            .map(String::from)
            .to_vec(),
        expect,
        outputs: vec!["o.csv"],
    }
}

fn trajectory_case(name: &'static str, waypoints: &str, extra: &[&str], expect: Vec<&'static str>) -> Case {
    let mut args: Vec<String> = ["trajectory", "--robot", "r.toml", "--waypoints", "w.csv", "--out", "out"]
        .map(String::from)
        .to_vec();
    args.extend(extra.iter().map(|s| s.to_string()));
    Case {
        name,
        files: vec![("r.toml", point4_robot()), ("w.csv", waypoints.to_string())],
        args,
        expect,
        outputs: vec!["out"],
    }
}

fn workspace_case(name: &'static str, extra: &[&str], expect: Vec<&'static str>) -> Case {
    let mut args: Vec<String> = ["workspace", "--robot", "r.toml", "--out", "ws"].map(String::from).to_vec();
    args.extend(extra.iter().map(|s| s.to_string()));
    Case { name, files: vec![("r.toml", point4_robot())], args, expect, outputs: vec!["ws"] }
}

fn cases() -> Vec<Case> {
    let good = point4_robot();
    let mut seven = POINT4.to_string();
    for k in 0..7 {
        seven.push_str(&cable(k as f64, 3.0));
    }
    let mut spatial4 = POINT4.replace("planar2", "spatial6");
    for k in 0..4 {
        spatial4.push_str(&cable(k as f64, 3.0));
    }
    let poses = "x,y\n1.5,1.5\n";
    vec![
        // Pose tables.
        solve_case(
            "missing column",
            good.clone(),
            "x\n1.5\n",
            "barycenter",
            vec!["p.csv, line 1: missing column `y`"],
        ),
        solve_case(
            "missing extra column",
            good.clone(),
            "x,y,fx\n1,1,0\n",
            "barycenter",
            vec!["p.csv, line 1: missing column `fy`"],
        ),
        solve_case(
            "not a number",
            good.clone(),
            "x,y\n1.5,1.5\n\n1.0,abc\n",
            "barycenter",
            vec!["p.csv, line 4, column 2 (y): `abc` is not a number"],
        ),
        solve_case(
            "empty field",
            good.clone(),
            "x,y\n,1.5\n",
            "barycenter",
            vec!["p.csv, line 2, column 1 (x): `empty field` is not a number"],
        ),
        solve_case(
            "too many fields",
            good.clone(),
            "x,y\n1.5,1.5,7\n",
            "barycenter",
            vec!["p.csv, line 2: 3 fields, the header has 2"],
        ),
        solve_case(
            "columns of another kind",
            good.clone(),
            "x,y,z,rx,ry,rz\n0,0,1,0,0,0\n",
            "barycenter",
            vec!["p.csv, line 1, column 3: unknown column `z` for a planar2 robot"],
        ),
        solve_case("empty pose file", good.clone(), "", "barycenter", vec!["p.csv: empty file"]),
        // Methods.
        solve_case(
            "unknown method",
            good.clone(),
            poses,
            "barycentre",
            vec!["--method: unknown method `barycentre`", "analytic-centre"],
        ),
        solve_case(
            "method for another shape",
            seven
                .replace("[[cable]]\nanchor = [6.0", "#\nX = [6.0")
                .replace("X = [6.0, 3.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n", ""),
            poses,
            "barycenter",
            vec!["method barycenter needs m = n + 2 cables; r.toml has 2 DOF and 6 cables"],
        ),
        // Robot files that are not the conventions'.
        solve_case(
            "unknown robot field",
            good.replace("mass = 20.0", "mass = 20.0\ncolour = 3"),
            poses,
            "barycenter",
            vec!["r.toml, line 8, column 1: unknown field `colour`"],
        ),
        solve_case(
            "robot number as text",
            good.replace("t_max = 400.0", "t_max = \"400\""),
            poses,
            "barycenter",
            vec!["r.toml, line 5, column 9: invalid type: string \"400\", expected f64"],
        ),
        solve_case(
            "unknown kind",
            good.replace("planar2", "hexapod"),
            poses,
            "barycenter",
            vec!["r.toml, line 2, column 8 (kind): unknown kind `hexapod`"],
        ),
        solve_case(
            "missing platform",
            good.replace("[platform]\nmass = 20.0\ngravity = [0.0, -9.81, 0.0]\n", ""),
            poses,
            "barycenter",
            vec!["r.toml, line 1, column 1: missing field `platform`"],
        ),
        solve_case(
            "anchor with two numbers",
            good.replace("anchor = [3.0, 3.0, 0.0]", "anchor = [3.0, 3.0]"),
            poses,
            "barycenter",
            vec!["r.toml, line 16, column 10: invalid length 2, expected an array of length 3"],
        ),
        solve_case(
            "limits upside down",
            good.replace("t_min = 50.0", "t_min = 500.0"),
            poses,
            "barycenter",
            vec!["r.toml, line 3: [limits]: limits t_min = 500, t_max = 400"],
        ),
        solve_case(
            "cable limit override upside down",
            good.replacen("attach = [0.0, 0.0, 0.0]\n", "attach = [0.0, 0.0, 0.0]\nt_max = 10.0\n", 2),
            poses,
            "barycenter",
            vec!["r.toml, line 12: cable 1: limits t_min = 50, t_max = 10"],
        ),
        solve_case(
            "negative mass",
            good.replace("mass = 20.0", "mass = -1.0"),
            poses,
            "barycenter",
            vec!["r.toml, line 7: [platform] mass = -1 must be finite and >= 0"],
        ),
        solve_case(
            "negative inertia",
            good.replace(
                "mass = 20.0",
                "mass = 20.0\ninertia = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]",
            ),
            poses,
            "barycenter",
            vec!["[platform] inertia must be symmetric positive semi-definite (invalid-limits)"],
        ),
        solve_case(
            "limits whose squares overflow",
            good.replace("t_max = 400.0", "t_max = 1e308"),
            poses,
            "barycenter",
            vec!["[limits]: limits t_min = 50, t_max = 1e308: t_max is too large", "(invalid-limits)"],
        ),
        solve_case(
            "unsupported cable count",
            seven,
            poses,
            "analytic-centre",
            vec!["r.toml, line 2: a planar2 robot with 7 cables is not supported"],
        ),
        solve_case(
            "too few cables",
            spatial4,
            "x,y,z,rx,ry,rz\n0,0,1,0,0,0\n",
            "analytic-centre",
            vec!["r.toml: a spatial6 robot needs at least 6 cables, the file has 4"],
        ),
        solve_case(
            "not toml",
            "time,x,y\n0,1,2\n".to_string(),
            poses,
            "barycenter",
            vec!["r.toml, line 1, column 5:"],
        ),
        Case {
            name: "missing robot file",
            files: vec![("p.csv", poses.to_string())],
            args: [
                "solve",
                "--robot",
                "none.toml",
                "--method",
                "barycenter",
                "--poses",
                "p.csv",
                "--out",
                "o.csv",
            ]
            .map(String::from)
            .to_vec(),
            expect: vec!["none.toml: "],
            outputs: vec!["o.csv"],
        },
        // Waypoints.
        trajectory_case(
            "waypoints without time",
            "x,y\n1,1\n2,2\n",
            &[],
            vec!["w.csv, line 1: missing column `time`"],
        ),
        trajectory_case(
            "time going back",
            "time,x,y\n0,1.5,1.5\n2,1,1\n1,2,2\n",
            &[],
            vec!["w.csv, line 4, column 1 (time): time 1 does not come after"],
        ),
        trajectory_case(
            "one waypoint",
            "time,x,y\n0,1.5,1.5\n",
            &[],
            vec!["w.csv: 1 waypoint(s); a trajectory needs at least two"],
        ),
        trajectory_case(
            "waypoint not finite",
            "time,x,y\n0,1.5,1.5\n1,inf,1\n",
            &[],
            vec!["w.csv, line 3, column 2 (x): `inf` is not a finite number"],
        ),
        trajectory_case(
            "waypoint not a number",
            "time,x,y\n0,1.5,1.5\n1,1,1O\n",
            &[],
            vec!["w.csv, line 3, column 3 (y): `1O` is not a number"],
        ),
        trajectory_case("zero rate", "time,x,y\n0,1.5,1.5\n1,1,1\n", &["--rate", "0"], vec!["--rate 0"]),
        trajectory_case(
            "unknown method in a list",
            "time,x,y\n0,1.5,1.5\n1,1,1\n",
            &["--method", "barycenter,newton"],
            vec!["unknown method `newton`"],
        ),
        Case {
            name: "compare with bad waypoints",
            files: vec![("r.toml", point4_robot()), ("w.csv", "time,x,y\n0,1.5\n".to_string())],
            args: ["compare", "--robot", "r.toml", "--waypoints", "w.csv"].map(String::from).to_vec(),
            expect: vec!["w.csv, line 2: 2 fields, the header has 3"],
            outputs: vec!["compare.csv"],
        },
        // Workspace options.
        workspace_case(
            "orientation for a point",
            &["--orientation", "0.1"],
            vec!["--orientation: 1 value(s) given, a planar2 robot takes nothing"],
        ),
        workspace_case(
            "mass sweep malformed",
            &["--mass-sweep", "0:10"],
            vec!["--mass-sweep `0:10`: expected a:b:n"],
        ),
        workspace_case("negative step", &["--step", "-1"], vec!["--step -1"]),
        workspace_case(
            "threads beyond the maximum",
            &["--threads", "100000"],
            vec!["--threads 100000: expected 1 to 256 worker threads"],
        ),
        workspace_case("no threads", &["--threads", "0"], vec!["--threads 0: expected 1 to 256"]),
        workspace_case(
            "payload below zero mass",
            &["--mass-sweep", "-30:0:2"],
            vec!["--mass-sweep: payload -30 kg makes the mass -10 kg negative"],
        ),
    ]
}

#[test]
fn every_bad_input_is_one_line_exit_2_and_no_output() {
    let mut failures = vec![];
    for (k, case) in cases().into_iter().enumerate() {
        let dir = scratch(&format!("bad-{k}"));
        for (name, text) in &case.files {
            std::fs::write(dir.join(name), text).unwrap();
        }
        let args: Vec<&str> = case.args.iter().map(String::as_str).collect();
        let run = cdpr(&dir, &args);
        let lines: Vec<&str> = run.stderr.lines().collect();
        let mut problems = vec![];
        if run.code != 2 {
            problems.push(format!("exit code {}", run.code));
        }
        if lines.len() != 1 || !lines[0].starts_with("cdpr: error: ") {
            problems.push("stderr is not one `cdpr: error:` line".to_string());
        }
        for e in &case.expect {
            if !run.stderr.contains(e) {
                problems.push(format!("message lacks `{e}`"));
            }
        }
        for o in &case.outputs {
            if dir.join(o).exists() {
                problems.push(format!("{o} was written"));
            }
        }
        let stray: Vec<String> =
            listing(&dir).into_iter().filter(|f| !case.files.iter().any(|(n, _)| n == f)).collect();
        if !stray.is_empty() {
            problems.push(format!("files left behind: {stray:?}"));
        }
        if !problems.is_empty() {
            failures.push(format!(
                "{}: {} (stderr: {})",
                case.name,
                problems.join("; "),
                run.stderr.trim_end()
            ));
        }
    }
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
}

/// An output that cannot be written is not bad input: exit code 1, and
/// the previous file is kept whole when writing fails.
#[test]
fn unwritable_output_is_exit_1() {
    let dir = scratch("unwritable");
    std::fs::write(dir.join("r.toml"), point4_robot()).unwrap();
    std::fs::write(dir.join("p.csv"), "x,y\n1.5,1.5\n").unwrap();
    let run = cdpr(
        &dir,
        &[
            "solve",
            "--robot",
            "r.toml",
            "--method",
            "barycenter",
            "--poses",
            "p.csv",
            "--out",
            "missing-dir/o.csv",
        ],
    );
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert!(run.stderr.contains("missing-dir/o.csv"));
    assert_eq!(run.stderr.lines().count(), 1);
}

/// Rows that cannot be solved are not bad input: they carry their status,
/// including `nonfinite` for a NaN in the table, and the run exits 0.
#[test]
fn unsolvable_rows_keep_their_status() {
    let dir = scratch("statuses");
    std::fs::write(dir.join("r.toml"), point4_robot()).unwrap();
    std::fs::write(dir.join("p.csv"), "time,x,y\n0,1.5,1.5\n1,NaN,1.5\n2,0.1,2.95\n3,0,0\n4,1.5,1.5\n")
        .unwrap();
    let run = cdpr_ok(
        &dir,
        &["solve", "--robot", "r.toml", "--method", "barycenter", "--poses", "p.csv", "--out", "o.csv"],
    );
    let (_, rows) = read_csv(&dir.join("o.csv"));
    let status: Vec<&str> = rows.iter().map(|r| r.last().unwrap().as_str()).collect();
    assert_eq!(status, ["ok", "nonfinite", "infeasible", "degenerate-cable", "ok"]);
    assert_eq!(rows[1], ["1", "", "", "", "", "nonfinite"]);
    assert!(run.stdout.contains("2 of 5 poses solved"), "{}", run.stdout);
}
