//! Helpers for the integration tests: run the built `cdpr` binary, scratch
//! directories, CSV reading, and reference computations written here,
//! independently of `tension-core` and of the tool.

#![allow(dead_code)]

use cdpr_integration_tests::clip_polygon_auto;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The shipped robot files and examples.
pub fn robots() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join("robots")
}

/// A robot file of `robots/`.
pub fn robot(name: &str) -> PathBuf {
    robots().join(format!("{name}.toml"))
}

/// A fresh, empty scratch directory for one test, removed when dropped.
pub struct Scratch(PathBuf);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// See [`Scratch`].
pub fn scratch(test: &str) -> Scratch {
    let dir = std::env::temp_dir().join(format!("cdpr-tests-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    Scratch(dir)
}

/// Exit code, stdout, stderr of one run.
pub struct Run {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

/// Runs `cdpr` with `args` in `dir`.
pub fn cdpr(dir: &Path, args: &[&str]) -> Run {
    let out =
        Command::new(env!("CARGO_BIN_EXE_cdpr")).args(args).current_dir(dir).output().expect("cdpr runs");
    Run {
        code: out.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// Runs and expects success.
pub fn cdpr_ok(dir: &Path, args: &[&str]) -> Run {
    let run = cdpr(dir, args);
    assert_eq!(run.code, 0, "cdpr {args:?} failed: {}", run.stderr);
    run
}

/// Reads a CSV file (the `csv` crate): header and rows of fields. Every
/// file the tool writes ends with a newline; this checks that too.
pub fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(text.ends_with('\n'), "{} does not end with a newline", path.display());
    let mut reader = csv::ReaderBuilder::new().has_headers(false).from_reader(text.as_bytes());
    let mut records = reader.records().map(|r| r.unwrap().iter().map(String::from).collect::<Vec<_>>());
    let header = records.next().expect("header");
    (header, records.collect())
}

/// The tensions of a row of a tension table (`status` last), `None` if not `ok`.
pub fn tensions(row: &[String], m: usize) -> Option<Vec<f64>> {
    let status = row.last().unwrap();
    if status != "ok" {
        assert!(row[row.len() - 1 - m..row.len() - 1].iter().all(|f| f.is_empty()));
        return None;
    }
    Some(row[row.len() - 1 - m..row.len() - 1].iter().map(|f| f.parse().unwrap()).collect())
}

/// Asserts two vectors agree within `tol` (absolute).
pub fn assert_close(got: &[f64], want: &[f64], tol: f64, what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: lengths");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!((g - w).abs() <= tol, "{what}: t{} = {g}, expected {w} (tolerance {tol})", i + 1);
    }
}

/// The files in a directory (names), sorted.
pub fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Barycenter of the feasible tension polygon of a planar point mass with
/// four cables, computed independently: null space from the 2x2 block
/// `W = [A | B]` (`n = [-A^-1 B z; z]`), the polygon by clipping a large
/// square with the eight half-planes (Sutherland-Hodgman, the workspace's
/// `clip_polygon_auto`), its centroid, mapped back to tensions. `None` when empty.
pub fn polygon_barycenter_2x4(
    anchors: &[[f64; 2]; 4],
    point: [f64; 2],
    f: [f64; 2],
    t_min: f64,
    t_max: f64,
) -> Option<[f64; 4]> {
    let mut u = [[0.0; 2]; 4];
    for i in 0..4 {
        let d = [anchors[i][0] - point[0], anchors[i][1] - point[1]];
        let l = (d[0] * d[0] + d[1] * d[1]).sqrt();
        u[i] = [d[0] / l, d[1] / l];
    }
    // A = [u0 u1] (columns); A^-1 by the 2x2 formula.
    let det = u[0][0] * u[1][1] - u[1][0] * u[0][1];
    assert!(det.abs() > 1e-9, "test pose must keep u0, u1 independent");
    let inv = |v: [f64; 2]| -> [f64; 2] {
        [(u[1][1] * v[0] - u[1][0] * v[1]) / det, (-u[0][1] * v[0] + u[0][0] * v[1]) / det]
    };
    let p01 = inv(f);
    let particular = [p01[0], p01[1], 0.0, 0.0];
    // Null vectors for z = e1 (cable 3) and z = e2 (cable 4).
    let a2 = inv(u[2]);
    let a3 = inv(u[3]);
    let n1 = [-a2[0], -a2[1], 1.0, 0.0];
    let n2 = [-a3[0], -a3[1], 0.0, 1.0];
    // The polygon in (z1, z2) and its centroid: the workspace's
    // Sutherland-Hodgman reference (`tests/support`).
    let rows: Vec<[f64; 2]> = (0..4).map(|k| [n1[k], n2[k]]).collect();
    let lo: Vec<f64> = (0..4).map(|k| t_min - particular[k]).collect();
    let hi: Vec<f64> = (0..4).map(|k| t_max - particular[k]).collect();
    let clipped = clip_polygon_auto(&rows, &lo, &hi);
    if clipped.vertices.is_empty() || clipped.area.is_nan() || clipped.area < 1e-12 {
        return None;
    }
    let lam = clipped.centroid;
    let mut t = [0.0; 4];
    for k in 0..4 {
        t[k] = particular[k] + n1[k] * lam[0] + n2[k] * lam[1];
    }
    Some(t)
}

/// The anchors of `robots/planar-point-4.toml`.
pub const POINT4_ANCHORS: [[f64; 2]; 4] = [[0.0, 0.0], [3.0, 0.0], [3.0, 3.0], [0.0, 3.0]];
/// Its mass (kg), gravity (m/s^2) and limits (N).
pub const POINT4_MASS: f64 = 20.0;
pub const G: f64 = 9.81;
pub const POINT4_LIMITS: (f64, f64) = (50.0, 400.0);
