//! `cdpr solve` against values worked out independently of the code under
//! test: by hand (symmetry and the equilibrium equations), by an
//! independent polygon computation, and by an independent equilibrium check.

mod common;

use common::*;
use tension_core::Method;

/// planar-point-4 at the centre (1.5, 1.5) of its 3 m x 3 m square. The
/// cables point to the corners, u = (+-1, +-1)/sqrt(2); W 1 = 0 and
/// W (1,-1,1,-1) = 0 span the null space. Mirror symmetry x -> 3 - x swaps
/// cables 1<->2 and 3<->4, so t = (a, a, b, b); the vertical equation
/// sqrt(2) (b - a) = m g gives b - a = c = m g / sqrt(2). In the null-space
/// coordinates u = l1 + l2, v = l1 - l2 the feasible set is the square
/// [t_min, t_max - c]^2 (t1 = u, t2 = v, t3 = c + u, t4 = c + v), whose
/// centroid is u = v = (t_min + t_max - c) / 2. The analytic centre is the
/// same point (the barrier is symmetric about it), and so is the closed
/// form (W t_m = 0 and the minimum-norm part is (-c/2, -c/2, c/2, c/2)),
/// and the optimally safe point (the smallest distance to a limit,
/// min(u - t_min, t_max - c - u, ...), is largest there and only there).
/// The smallest 1- and 2-norms are at the square's lower corner
/// u = v = t_min, and so is the puncture: the segment from W^+ f
/// (u = v = -c/2) to the closed form enters the limits at u = t_min.
#[test]
fn point_mass_at_the_centre_every_method_by_hand() {
    let dir = scratch("centre");
    std::fs::write(dir.join("p.csv"), "x,y\n1.5,1.5\n").unwrap();
    let c = POINT4_MASS * G / 2f64.sqrt();
    let (lo, hi) = POINT4_LIMITS;
    let a = (lo + hi - c) / 2.0;
    let b = a + c;
    assert!((a - 155.632_824_765_599_7).abs() < 1e-9);
    for method in Method::ALL {
        let want = match method {
            Method::Barycenter
            | Method::BarycenterBrute
            | Method::AnalyticCentre
            | Method::ClosedForm
            | Method::ImprovedClosedForm
            | Method::OptimallySafe => [a, a, b, b],
            Method::Puncture | Method::ImprovedPuncture | Method::Min2Norm | Method::Min1Norm => {
                [lo, lo, lo + c, lo + c]
            }
        };
        let method = method.name();
        let out = format!("{method}.csv");
        let run = cdpr_ok(
            &dir,
            &[
                "solve",
                "--robot",
                robot("planar-point-4").to_str().unwrap(),
                "--method",
                method,
                "--poses",
                "p.csv",
                "--out",
                &out,
            ],
        );
        assert!(run.stdout.contains("1 of 1 poses solved"), "{}", run.stdout);
        let (header, rows) = read_csv(&dir.join(&out));
        assert_eq!(header, ["t1", "t2", "t3", "t4", "status"]);
        assert_eq!(rows.len(), 1);
        let t = tensions(&rows[0], 4).expect("feasible");
        assert_close(&t, &want, 1e-7, method);
    }
}

/// The tensions of the three-cable point mass below, by hand, at the two
/// rows of its table (no extra force, then fx = 10): `None` where the
/// method does not apply (the barycenters need m = n + 2 = 4 cables).
/// t3 = 19.62 always (slack 18.62 to t_min) and t2 = t1 + fx.
/// * closed-form, improved-closed-form, analytic-centre:
///   t_m + W^T (W W^T)^-1 (f - W t_m) = (50.5, 50.5, 19.62), and
///   (45.5, 55.5, 19.62) with fx = 10 (the analytic centre's barrier in the
///   one free coordinate is symmetric about the same point).
/// * min-2-norm and min-1-norm: the smallest t1 with t1, t2 >= 1: (1, 1) and
///   (1, 11).
/// * puncture, improved-puncture: from W^+ f = (-fx/2, fx/2, 19.62) towards
///   the closed form (50.5 - fx/2, 50.5 + fx/2, 19.62), cable 1 enters its
///   range first: t1 = 1, the same points.
/// * optimally-safe: cable 3's slack 18.62 is the largest possible smallest
///   slack; every t1 with t1 - 1 >= 18.62 and 100 - t2 >= 18.62 reaches it,
///   and the smallest 2-norm among them has t1 = 19.62: (19.62, 19.62) and
///   (19.62, 29.62).
fn three_cables_by_hand(method: Method) -> Option<[[f64; 3]; 2]> {
    Some(match method {
        Method::Barycenter | Method::BarycenterBrute => return None,
        Method::ClosedForm | Method::ImprovedClosedForm | Method::AnalyticCentre => {
            [[50.5, 50.5, 19.62], [45.5, 55.5, 19.62]]
        }
        Method::Min2Norm | Method::Min1Norm | Method::Puncture | Method::ImprovedPuncture => {
            [[1.0, 1.0, 19.62], [1.0, 11.0, 19.62]]
        }
        Method::OptimallySafe => [[19.62, 19.62, 19.62], [19.62, 29.62, 19.62]],
    })
}

/// A hand-made planar point mass on three cables: anchors (1,0), (-1,0),
/// (0,1), the point at the origin, so u = (1,0), (-1,0), (0,1) and
/// W = [[1,-1,0],[0,0,1]]. Gravity (0,-9.81) on 2 kg: f = (0, 19.62), so
/// t3 = 19.62 and t1 - t2 = -fx_extra; limits [1, 100]; an extra external
/// force fx = 10 on the second row. Every method against
/// [`three_cables_by_hand`]; the time column is carried through as
/// written; a method that does not apply is a clean error and no file.
#[test]
fn point_mass_on_three_cables_every_method_by_hand() {
    let dir = scratch("three");
    std::fs::write(
        dir.join("r.toml"),
        "name = \"three\"\nkind = \"planar2\"\n[limits]\nt_min = 1.0\nt_max = 100.0\n[platform]\nmass = 2.0\ngravity = [0.0, -9.81, 0.0]\n\
         [[cable]]\nanchor = [1.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n\
         [[cable]]\nanchor = [-1.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n\
         [[cable]]\nanchor = [0.0, 1.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n",
    )
    .unwrap();
    std::fs::write(dir.join("p.csv"), "time,x,y,fx,fy\n0.250,0,0,0,0\n1e-3,0,0,10,0\n").unwrap();
    for method in Method::ALL {
        let out = format!("{}.csv", method.name());
        let args =
            ["solve", "--robot", "r.toml", "--method", method.name(), "--poses", "p.csv", "--out", &out];
        let Some([first, second]) = three_cables_by_hand(method) else {
            let run = cdpr(&dir, &args);
            assert_eq!(run.code, 2, "{}", method.name());
            assert!(run.stderr.contains("r.toml"), "{}", run.stderr);
            assert!(!dir.join(&out).exists());
            continue;
        };
        cdpr_ok(&dir, &args);
        let (header, rows) = read_csv(&dir.join(&out));
        assert_eq!(header, ["time", "t1", "t2", "t3", "status"]);
        assert_eq!(rows[0][0], "0.250");
        assert_eq!(rows[1][0], "1e-3");
        assert_close(&tensions(&rows[0], 3).unwrap(), &first, 1e-9, method.name());
        assert_close(&tensions(&rows[1], 3).unwrap(), &second, 1e-9, method.name());
    }
}

/// The barycenter (walk and brute force) of planar-point-4 at poses away
/// from the centre, with and without an extra force, against the centroid
/// of the feasible polygon computed in `common` (clipping, not the vertex
/// walk nor the pairwise intersections). Infeasible rows carry their status
/// and the run goes on.
#[test]
fn barycenter_2x4_against_an_independent_polygon() {
    let dir = scratch("polygon");
    let poses = [
        (1.0, 2.0, 0.0, 0.0),
        (2.5, 0.5, 0.0, 0.0),
        (0.7, 1.2, 0.0, 0.0),
        (1.5, 1.5, 30.0, 0.0),
        (2.2, 2.4, -15.0, 40.0),
        (0.2, 2.9, 0.0, 0.0),
        (1.8, 0.9, 0.0, 0.0),
    ];
    let mut text = String::from("x,y,fx,fy\n");
    for p in &poses {
        text.push_str(&format!("{},{},{},{}\n", p.0, p.1, p.2, p.3));
    }
    std::fs::write(dir.join("p.csv"), text).unwrap();
    let (lo, hi) = POINT4_LIMITS;
    for method in ["barycenter", "barycenter-brute"] {
        let run = cdpr_ok(
            &dir,
            &[
                "solve",
                "--robot",
                robot("planar-point-4").to_str().unwrap(),
                "--method",
                method,
                "--poses",
                "p.csv",
                "--out",
                "o.csv",
            ],
        );
        let (_, rows) = read_csv(&dir.join("o.csv"));
        assert_eq!(rows.len(), poses.len());
        let mut infeasible = 0;
        for (row, p) in rows.iter().zip(&poses) {
            // f = -w_e = -(m g + extra) with g = (0, -9.81).
            let f = [-p.2, POINT4_MASS * G - p.3];
            let want = polygon_barycenter_2x4(&POINT4_ANCHORS, [p.0, p.1], f, lo, hi);
            match (tensions(row, 4), want) {
                (Some(t), Some(w)) => assert_close(&t, &w, 1e-6, method),
                (None, None) => {
                    assert_eq!(row.last().unwrap(), "infeasible");
                    infeasible += 1;
                }
                (got, want) => panic!("{method} at {p:?}: got {got:?}, expected {want:?}"),
            }
        }
        assert_eq!(infeasible, 1, "the pose by the top-left anchor");
        assert!(run.stdout.contains("(1 infeasible)"), "{}", run.stdout);
    }
}

fn rot(rx: f64, ry: f64, rz: f64) -> [[f64; 3]; 3] {
    let (sa, ca, sb, cb, sc, cc) = (rx.sin(), rx.cos(), ry.sin(), ry.cos(), rz.sin(), rz.cos());
    let x = [[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]];
    let y = [[cb, 0.0, sb], [0.0, 1.0, 0.0], [-sb, 0.0, cb]];
    let z = [[cc, -sc, 0.0], [sc, cc, 0.0], [0.0, 0.0, 1.0]];
    let mul = |a: [[f64; 3]; 3], b: [[f64; 3]; 3]| {
        let mut c = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                c[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
            }
        }
        c
    };
    mul(mul(x, y), z)
}

fn apply(r: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| (0..3).map(|k| r[i][k] * v[k]).sum())
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// Spatial robots: every `ok` row of `solve` balances the conventions' wrench
/// (gravity at the centre of mass, XYZ Euler angles) within the limits,
/// checked with a wrench matrix built here, for every shipped spatial robot
/// and every method that applies.
#[test]
fn spatial_rows_balance_the_gravity_wrench() {
    let dir = scratch("spatial");
    let poses = "time,x,y,z,rx,ry,rz\n0,0,0,1.5,0,0,0\n1,0.5,0.2,1.2,0.05,-0.04,0.1\n2,-0.3,0.25,1.0,-0.08,0.06,-0.15\n3,0.2,-0.1,2.2,0.1,0.1,0.2\n";
    std::fs::write(dir.join("p.csv"), poses).unwrap();
    let pose_rows: Vec<[f64; 6]> = poses
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').skip(1).map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3], v[4], v[5]]
        })
        .collect();
    for name in ["suspended-8", "ipanema1", "spatial6-10", "cogiro"] {
        let file = robot_file::RobotFile::load(robot(name)).unwrap();
        let m = file.cables.len();
        let mut solved = 0;
        for method in Method::ALL {
            let applies = method.supports(file.dof(), m);
            let method = method.name();
            let run = cdpr(
                &dir,
                &[
                    "solve",
                    "--robot",
                    robot(name).to_str().unwrap(),
                    "--method",
                    method,
                    "--poses",
                    "p.csv",
                    "--out",
                    "o.csv",
                ],
            );
            if !applies {
                assert_eq!(run.code, 2, "{name} {method}");
                continue;
            }
            assert_eq!(run.code, 0, "{name} {method}: {}", run.stderr);
            let (_, rows) = read_csv(&dir.join("o.csv"));
            for (row, p) in rows.iter().zip(&pose_rows) {
                let Some(t) = tensions(row, m) else { continue };
                solved += 1;
                let r = rot(p[3], p[4], p[5]);
                let mut wrench = [0.0; 6];
                for (i, c) in file.cables.iter().enumerate() {
                    let rb = apply(&r, c.attach);
                    let l = [0, 1, 2].map(|k| c.anchor[k] - p[k] - rb[k]);
                    let n = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
                    let u = l.map(|x| x / n);
                    let mo = cross(rb, u);
                    for k in 0..3 {
                        wrench[k] += t[i] * u[k];
                        wrench[k + 3] += t[i] * mo[k];
                    }
                    assert!(t[i] >= c.t_min - 1e-9 && t[i] <= c.t_max + 1e-9);
                }
                let force = file.gravity.map(|g| g * file.mass);
                let moment = cross(apply(&r, file.com), force);
                for k in 0..3 {
                    wrench[k] += force[k];
                    wrench[k + 3] += moment[k];
                }
                let scale = file.mass * G;
                for (k, w) in wrench.iter().enumerate() {
                    assert!(
                        w.abs() < 1e-8 * scale.max(1.0),
                        "{name} {method} pose {p:?}: residual {k} = {w}"
                    );
                }
            }
        }
        assert!(solved > 0, "{name}: no pose solved");
    }
}
