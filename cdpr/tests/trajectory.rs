//! `cdpr trajectory` and `cdpr compare` on the shipped robots: the files,
//! the pictures, and the dynamic wrench against an independent computation.

mod common;

use common::*;

/// s''(u) of 35u^4 - 84u^5 + 70u^6 - 20u^7, differentiated by hand.
fn law_acc(u: f64) -> f64 {
    420.0 * u * u - 1680.0 * u.powi(3) + 2100.0 * u.powi(4) - 840.0 * u.powi(5)
}

fn law(u: f64) -> f64 {
    35.0 * u.powi(4) - 84.0 * u.powi(5) + 70.0 * u.powi(6) - 20.0 * u.powi(7)
}

fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert!(bytes.len() > 1000, "PNG too small");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
    assert_eq!(&bytes[12..16], b"IHDR");
    let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
    (w, h)
}

fn check_svg(text: &str) {
    assert!(text.starts_with("<svg"), "SVG header");
    assert!(text.trim_end().ends_with("</svg>"), "SVG end");
    assert!(text.contains("<polyline") || text.contains("<path"), "SVG lines");
}

#[test]
fn planar_point_trajectory_files_plots_and_dynamics() {
    let dir = scratch("traj-point");
    let run = cdpr_ok(
        &dir,
        &[
            "trajectory",
            "--robot",
            robot("planar-point-4").to_str().unwrap(),
            "--waypoints",
            robots().join("planar-point-4-waypoints.csv").to_str().unwrap(),
            "--method",
            "barycenter,analytic-centre",
            "--method",
            "closed-form",
            "--rate",
            "200",
            "--out",
            "out",
        ],
    );
    let out = dir.join("out");
    for f in [
        "poses.csv",
        "robustness.csv",
        "robustness.png",
        "robustness.svg",
        "summary.txt",
        "tensions-barycenter.csv",
        "tensions-barycenter.png",
        "tensions-barycenter.svg",
        "tensions-analytic-centre.csv",
        "tensions-closed-form.csv",
    ] {
        assert!(out.join(f).is_file(), "{f} missing: {:?}", listing(&out));
    }
    assert!(!out.join("tensions-barycenter-brute.csv").exists());
    assert!(listing(&out).iter().all(|f| !f.starts_with('.')), "temp files left");
    assert_eq!(png_size(&std::fs::read(out.join("tensions-barycenter.png")).unwrap()), (1100, 600));
    png_size(&std::fs::read(out.join("robustness.png")).unwrap());
    check_svg(&std::fs::read_to_string(out.join("tensions-barycenter.svg")).unwrap());
    check_svg(&std::fs::read_to_string(out.join("robustness.svg")).unwrap());
    let summary = std::fs::read_to_string(out.join("summary.txt")).unwrap();
    assert!(summary.contains("largest step"));
    assert!(summary.contains("smallest robustness"));
    assert!(summary.contains("samples without tension"));
    assert!(run.stdout.contains("barycenter"));

    // 3.5 s at 200 Hz: 701 samples, both ends included.
    let (header, rows) = read_csv(&out.join("tensions-barycenter.csv"));
    assert_eq!(header, ["time", "t1", "t2", "t3", "t4", "status"]);
    assert_eq!(rows.len(), 701);
    assert_eq!(rows[0][0], "0");
    assert_eq!(rows[700][0], "3.5");
    let (lo, hi) = POINT4_LIMITS;
    // At rest at the first waypoint (1.5, 1.5): the static centre values.
    let c = POINT4_MASS * G / 2f64.sqrt();
    let a = (lo + hi - c) / 2.0;
    assert_close(&tensions(&rows[0], 4).unwrap(), &[a, a, a + c, a + c], 1e-7, "rest");
    // Moving: at t = 0.25 s (u = 0.25 of the first 1 s segment from
    // (1.5, 1.5) to (2.2, 1.0)) the point accelerates with
    // a = (b - a) s''(u) / T^2; the cables carry f = m (a - g).
    for (k, time) in [(50usize, 0.25), (130, 0.65), (300, 1.5)] {
        let (p0, p1, t0, t1) =
            if time < 1.0 { ([1.5, 1.5], [2.2, 1.0], 0.0, 1.0) } else { ([2.2, 1.0], [0.8, 2.2], 1.0, 2.5) };
        let dur: f64 = t1 - t0;
        let u = (time - t0) / dur;
        let pos = [0, 1].map(|i| p0[i] + (p1[i] - p0[i]) * law(u));
        let acc = [0, 1].map(|i| (p1[i] - p0[i]) * law_acc(u) / (dur * dur));
        let f = [POINT4_MASS * acc[0], POINT4_MASS * (acc[1] + G)];
        let want = polygon_barycenter_2x4(&POINT4_ANCHORS, pos, f, lo, hi).unwrap();
        let got_time: f64 = rows[k][0].parse().unwrap();
        assert!((got_time - time).abs() < 1e-12);
        assert_close(&tensions(&rows[k], 4).unwrap(), &want, 1e-6, "moving");
        // The static answer differs: the inertial force is there.
        let stat = polygon_barycenter_2x4(&POINT4_ANCHORS, pos, [0.0, POINT4_MASS * G], lo, hi).unwrap();
        if acc[0].abs() + acc[1].abs() > 0.1 {
            assert!(want.iter().zip(&stat).any(|(a, b)| (a - b).abs() > 0.1));
        }
    }
    // The pose table is a valid pose table (conventions) that `solve` reads back.
    let (pose_header, pose_rows) = read_csv(&out.join("poses.csv"));
    assert_eq!(pose_header, ["time", "x", "y"]);
    assert_eq!(pose_rows.len(), 701);
    // Robustness CSV: one column per method, in the order asked.
    let (rob_header, rob_rows) = read_csv(&out.join("robustness.csv"));
    assert_eq!(rob_header, ["time", "barycenter", "analytic-centre", "closed-form"]);
    assert_eq!(rob_rows.len(), 701);
    let r0: f64 = rob_rows[0][1].parse().unwrap();
    assert!((r0 - (a - lo)).abs() < 1e-7, "robustness at rest {r0}");
}

#[test]
fn suspended_trajectory_reports_infeasible_samples() {
    let dir = scratch("traj-susp");
    cdpr_ok(
        &dir,
        &[
            "trajectory",
            "--robot",
            robot("suspended-8").to_str().unwrap(),
            "--waypoints",
            robots().join("suspended-8-waypoints.csv").to_str().unwrap(),
            "--method",
            "barycenter",
            "--rate",
            "100",
            "--out",
            "out",
        ],
    );
    let (_, rows) = read_csv(&dir.join("out").join("tensions-barycenter.csv"));
    assert_eq!(rows.len(), 601);
    let bad = rows.iter().filter(|r| r.last().unwrap() == "infeasible").count();
    assert!(bad > 0 && bad < 200, "{bad} infeasible samples");
    let summary = std::fs::read_to_string(dir.join("out").join("summary.txt")).unwrap();
    assert!(summary.contains(&format!("samples without tension: {bad} ({bad} infeasible)")));
}

#[test]
fn compare_table_and_csv() {
    let dir = scratch("compare");
    let run = cdpr_ok(
        &dir,
        &[
            "compare",
            "--robot",
            robot("planar3-5").to_str().unwrap(),
            "--waypoints",
            robots().join("planar3-5-waypoints.csv").to_str().unwrap(),
            "--rate",
            "100",
        ],
    );
    for m in [
        "barycenter",
        "barycenter-brute",
        "analytic-centre",
        "closed-form",
        "improved-closed-form",
        "puncture",
        "improved-puncture",
        "min-2-norm",
        "min-1-norm",
        "optimally-safe",
    ] {
        assert!(run.stdout.contains(m), "{}", run.stdout);
    }
    let (header, rows) = read_csv(&dir.join("compare.csv"));
    assert_eq!(
        header,
        [
            "method",
            "samples",
            "solved",
            "failed",
            "robustness_min",
            "robustness_mean",
            "largest_step",
            "median_solve_us",
            "max_solve_us"
        ]
    );
    assert_eq!(rows.len(), 10);
    for r in &rows {
        assert_eq!(r[1], "401");
        let solved: usize = r[2].parse().unwrap();
        let failed: usize = r[3].parse().unwrap();
        assert_eq!(solved + failed, 401);
        // Solve times in whole nanoseconds: at most three decimals of a
        // microsecond (`s * 1e6` wrote 1.9829999999999999).
        for t in &r[7..9] {
            let decimals = t.split_once('.').map_or(0, |(_, d)| d.len());
            assert!(decimals <= 3 && t.parse::<f64>().unwrap() >= 0.0, "{t}");
        }
    }
    // The walk and the brute force find the same barycenter.
    assert_eq!(rows[0][2], rows[1][2]);
    let (a, b): (f64, f64) = (rows[0][4].parse().unwrap(), rows[1][4].parse().unwrap());
    assert!((a - b).abs() < 1e-6);

    // A 10-cable robot: the barycenter methods do not apply and say so.
    let run = cdpr_ok(
        &dir,
        &[
            "compare",
            "--robot",
            robot("spatial6-10").to_str().unwrap(),
            "--waypoints",
            robots().join("spatial6-10-waypoints.csv").to_str().unwrap(),
            "--rate",
            "50",
            "--out",
            "c10.csv",
        ],
    );
    assert!(run.stdout.contains("barycenter             not applicable"));
    let (_, rows) = read_csv(&dir.join("c10.csv"));
    // Every method but the two barycenters applies to any redundancy.
    assert_eq!(rows.len(), 8);
}
