//! Every CSV file the tool writes is a conventions' table: one header line,
//! every record (the last one too) ended by a newline, even with no rows.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use tension_core::Method;

fn csv_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = vec![];
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(csv_files(&path));
        } else if path.extension().is_some_and(|e| e == "csv") {
            out.push(path);
        }
    }
    out
}

#[test]
fn every_csv_file_ends_with_a_newline() {
    let dir = scratch("csv-newline");
    let robot = robot("planar-point-4");
    let robot = robot.to_str().unwrap();
    let waypoints = robots().join("planar-point-4-waypoints.csv");
    let waypoints = waypoints.to_str().unwrap();
    std::fs::write(dir.join("empty.csv"), "time,x,y\n").unwrap();
    std::fs::write(dir.join("p.csv"), "x,y\n1.5,1.5\n0,0").unwrap();
    let solve = |poses: &str, out: &str| {
        cdpr_ok(&dir, &["solve", "--robot", robot, "--method", "barycenter", "--poses", poses, "--out", out]);
    };
    solve("empty.csv", "empty-out.csv");
    solve("p.csv", "p-out.csv");
    cdpr_ok(
        &dir,
        &["trajectory", "--robot", robot, "--waypoints", waypoints, "--rate", "50", "--out", "traj"],
    );
    cdpr_ok(&dir, &["compare", "--robot", robot, "--waypoints", waypoints, "--rate", "50", "--out", "c.csv"]);
    cdpr_ok(&dir, &["workspace", "--robot", robot, "--step", "0.5", "--mass-sweep", "0:10:3", "--out", "ws"]);
    let written: Vec<PathBuf> =
        csv_files(&dir).into_iter().filter(|p| !p.ends_with("empty.csv") && !p.ends_with("p.csv")).collect();
    // solve twice; trajectory: every method (planar-point-4 has r = 2), poses and
    // robustness; compare; the mass sweep.
    assert_eq!(written.len(), 2 + (Method::ALL.len() + 2) + 1 + 1, "{written:?}");
    for path in &written {
        let text = std::fs::read_to_string(path).unwrap();
        assert!(text.ends_with('\n') && !text.ends_with("\n\n"), "{}: {text:?}", path.display());
    }
    assert_eq!(std::fs::read_to_string(dir.join("empty-out.csv")).unwrap(), "time,t1,t2,t3,t4,status\n");
    let (_, rows) = read_csv(&dir.join("p-out.csv"));
    assert_eq!(rows.len(), 2, "the last input line has no newline and is still read");
}
