//! The barycenter walk (Lamaury & Gouttefarde 2013) against the brute force
//! (Mikelsons et al. 2008) and against an independent polygon-clipping
//! reference, on random wrench matrices of every shape with `M = N + 2`.

use cdpr_integration_tests::{clip_polygon, clip_polygon_auto, random_problem, reference_barycenter};
use nalgebra::{SMatrix, SVector, Vector2};
use std::sync::atomic::{AtomicUsize, Ordering};

use proptest::{prelude::*, test_runner::TestRunner};
use tension_core::{
    polygon::FeasiblePolygon, solve, ActivePair, Error, Method, PreviousCycle, Real, TensionLimits, WarmStart,
};

/// Relative agreement of two tension vectors against the tension scale.
fn close<const M: usize>(a: &SVector<f64, M>, b: &SVector<f64, M>, scale: f64, rel: f64) -> bool {
    (a - b).amax() <= rel * scale
}

fn check_solution<const N: usize, const M: usize>(
    w: &SMatrix<f64, N, M>,
    f: &SVector<f64, N>,
    limits: &TensionLimits<f64, M>,
    t: &SVector<f64, M>,
) {
    let scale = limits.scale();
    assert!((w * t - f).amax() <= 1e-9 * (1.0 + f.amax() + scale), "W t != f: {}", (w * t - f).amax());
    for i in 0..M {
        assert!(t[i] >= limits.min()[i] - 1e-9 * scale && t[i] <= limits.max()[i] + 1e-9 * scale);
    }
}

/// Compares walk (cold and warm), brute force and the clipping reference;
/// `true` when the pose was feasible.
fn compare<const N: usize, const M: usize>(
    w: SMatrix<f64, N, M>,
    f: SVector<f64, N>,
    limits: TensionLimits<f64, M>,
) -> bool {
    let walk = solve(Method::Barycenter, &w, &f, &limits, &PreviousCycle::NONE);
    let brute = solve(Method::BarycenterBrute, &w, &f, &limits, &PreviousCycle::NONE);
    let reference = reference_barycenter(&w, &f, &limits);
    let scale = limits.scale();
    match (&walk, &brute) {
        (Ok(a), Ok(b)) => {
            check_solution(&w, &f, &limits, &a.tensions);
            assert!(
                close(&a.tensions, &b.tensions, scale, 1e-9),
                "walk {:?}\nbrute {:?}",
                a.tensions,
                b.tensions
            );
            if let Some((r, rel_area)) = reference {
                if rel_area > 1e-6 {
                    assert!(close(&a.tensions, &r, scale, 1e-7), "walk {:?}\nreference {r:?}", a.tensions);
                }
            }
            // Warm start from the returned pair gives the same answer.
            let pair = a.diagnostics.active_pair.expect("pair");
            let warm =
                solve(Method::Barycenter, &w, &f, &limits, &PreviousCycle::pair(Some(pair))).expect("warm");
            assert_eq!(warm.diagnostics.warm_start, WarmStart::Held);
            assert!(close(&a.tensions, &warm.tensions, scale, 1e-9));
            true
        }
        (Err(Error::Infeasible), Err(Error::Infeasible)) => {
            if let Some((_, rel_area)) = reference {
                assert!(rel_area < 1e-9, "reference finds a polygon of relative area {rel_area}");
            }
            false
        }
        other => panic!("walk and brute disagree: {other:?}"),
    }
}

/// Runs `cases` random problems through [`compare`] and checks that both the
/// feasible and the infeasible branch were exercised.
fn random_cases<const N: usize, const M: usize>(cases: u32) {
    let feasible = AtomicUsize::new(0);
    let infeasible = AtomicUsize::new(0);
    let mut runner = TestRunner::new(cdpr_integration_tests::persisted_config(cases, file!()));
    runner
        .run(&random_problem::<N, M>(30.0), |(w, f, limits)| {
            match compare(w, f, limits) {
                true => feasible.fetch_add(1, Ordering::Relaxed),
                false => infeasible.fetch_add(1, Ordering::Relaxed),
            };
            Ok(())
        })
        .unwrap();
    let (ok, no) = (feasible.into_inner(), infeasible.into_inner());
    assert!(ok >= cases as usize / 5 && no >= cases as usize / 20, "{ok} feasible, {no} infeasible");
}

#[test]
fn walk_matches_brute_and_reference_6x8() {
    random_cases::<6, 8>(600);
}

#[test]
fn walk_matches_brute_and_reference_3x5() {
    random_cases::<3, 5>(600);
}

#[test]
fn walk_matches_brute_and_reference_2x4() {
    random_cases::<2, 4>(600);
}

#[test]
fn walk_matches_brute_and_reference_1x3() {
    random_cases::<1, 3>(600);
}

// ---- Constructed polygons, directly in null-space coordinates ----

/// Runs walk, brute and clipping on half-planes `lo_k <= n_k . x <= hi_k`.
fn polygon_case<const M: usize>(rows: [[f64; 2]; M], lo: [f64; M], hi: [f64; M]) -> (usize, Vector2<f64>) {
    let poly = FeasiblePolygon::new(rows.map(|r| Vector2::new(r[0], r[1])), lo, hi).unwrap();
    let walk = poly.walk(None).expect("walk");
    let brute = poly.brute_force().expect("brute");
    assert!((walk.centroid - brute.centroid).amax() < 1e-9, "{:?} vs {:?}", walk.centroid, brute.centroid);
    assert_eq!(walk.vertices.len(), brute.vertices.len());
    // Each list says which filled it.
    assert!(!walk.vertices.by_brute_force() && brute.vertices.by_brute_force());
    let clipped = clip_polygon(&rows, &lo, &hi, 1e3);
    if clipped.area > 1e-9 {
        assert!((walk.area - clipped.area).abs() < 1e-9 * clipped.area.max(1.0));
        assert!((walk.centroid.x - clipped.centroid[0]).abs() < 1e-9);
        assert!((walk.centroid.y - clipped.centroid[1]).abs() < 1e-9);
    }
    // From every vertex as a warm start, the same centroid.
    for v in walk.vertices.iter() {
        let pair = ActivePair {
            first: (
                (v.lines.0 / 2),
                if v.lines.0 % 2 == 1 { tension_core::Bound::Max } else { tension_core::Bound::Min },
            ),
            second: (
                (v.lines.1 / 2),
                if v.lines.1 % 2 == 1 { tension_core::Bound::Max } else { tension_core::Bound::Min },
            ),
        };
        let warm = poly.walk(Some(pair)).expect("warm walk");
        assert!(warm.warm_start_held && !warm.vertices.by_brute_force());
        assert!((warm.centroid - walk.centroid).amax() < 1e-9);
    }
    (walk.vertices.len(), walk.centroid)
}

#[test]
fn unit_square() {
    let (q, c) = polygon_case([[1.0, 0.0], [0.0, 1.0]], [0.0, 0.0], [1.0, 1.0]);
    assert_eq!(q, 4);
    assert!((c - Vector2::new(0.5, 0.5)).amax() < 1e-12);
}

#[test]
fn triangle_from_three_cables() {
    // x >= 0, y >= 0, x + y <= 1: centroid (1/3, 1/3); the other bounds far away.
    let (q, c) = polygon_case([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]], [0.0, 0.0, -10.0], [10.0, 10.0, 1.0]);
    assert_eq!(q, 3);
    assert!((c - Vector2::new(1.0 / 3.0, 1.0 / 3.0)).amax() < 1e-12);
}

#[test]
fn three_concurrent_lines_at_a_vertex() {
    // The square [0,1]^2 and the line x + y <= 2 through the corner (1,1):
    // it supports the polygon at that vertex only (Sect. 2.3, Fig. 2).
    let (q, c) = polygon_case([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]], [0.0, 0.0, -10.0], [1.0, 1.0, 2.0]);
    assert_eq!(q, 4);
    assert!((c - Vector2::new(0.5, 0.5)).amax() < 1e-12);
}

#[test]
fn four_concurrent_lines_at_a_vertex() {
    // Two extra lines through the corner (1,1), both supporting at the vertex only.
    let (q, c) = polygon_case(
        [[1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 2.0]],
        [0.0, 0.0, -10.0, -10.0],
        [1.0, 1.0, 2.0, 3.0],
    );
    assert_eq!(q, 4);
    assert!((c - Vector2::new(0.5, 0.5)).amax() < 1e-12);
}

#[test]
fn concurrent_lines_cutting_a_corner() {
    // Square [0,2]^2 cut by x + y <= 3 and 2x + y <= 4.5... both through (1.5, 1.5)
    // with x + 2y <= 4.5 too: three lines concurrent at a point that is a vertex.
    let (q, _) = polygon_case(
        [[1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [2.0, 1.0], [1.0, 2.0]],
        [0.0, 0.0, -10.0, -10.0, -10.0],
        [2.0, 2.0, 3.0, 4.5, 4.5],
    );
    // Vertices: (0,0) (2,0) (2,0.5) (1.5,1.5) (0.5,2) (0,2).
    assert_eq!(q, 6);
}

#[test]
fn parallel_and_duplicate_lines() {
    // Cables 0 and 2 have parallel rows (a scaled copy) and cable 3 duplicates cable 1.
    let (q, c) = polygon_case(
        [[1.0, 0.0], [0.0, 1.0], [2.0, 0.0], [0.0, 1.0]],
        [0.0, 0.0, -1.0, 0.0],
        [3.0, 1.0, 4.0, 1.0],
    );
    assert_eq!(q, 4);
    assert!((c - Vector2::new(1.0, 0.5)).amax() < 1e-12);
}

#[test]
fn polygon_with_2m_vertices() {
    // Eight cables whose 16 lines are the edges of a regular 16-gon.
    const M: usize = 8;
    let rows: [[f64; 2]; M] = core::array::from_fn(|k| {
        let a = core::f64::consts::PI * k as f64 / M as f64;
        [a.cos(), a.sin()]
    });
    let (q, c) = polygon_case(rows, [-1.0; M], [1.0; M]);
    assert_eq!(q, 2 * M);
    assert!(c.amax() < 1e-12);
}

#[test]
fn near_empty_polygon() {
    // A sliver: 0 <= x <= 1, 0 <= y <= 1e-7.
    let (q, c) = polygon_case([[1.0, 0.0], [0.0, 1.0]], [0.0, 0.0], [1.0, 1e-7]);
    assert_eq!(q, 4);
    assert!((c - Vector2::new(0.5, 0.5e-7)).amax() < 1e-12);
}

#[test]
fn single_point_and_segment_polygons() {
    // A point: x = 1 exactly and y = 2 exactly.
    let poly = FeasiblePolygon::new([Vector2::new(1.0, 0.0), Vector2::new(0.0, 1.0)], [1.0, 2.0], [1.0, 2.0])
        .unwrap();
    let walk = poly.walk(None).unwrap();
    assert!((walk.centroid - Vector2::new(1.0, 2.0)).amax() < 1e-12);
    assert_eq!(walk.area, 0.0);
    // A segment: x in [0, 4], y = 1: centroid at its midpoint.
    let poly = FeasiblePolygon::new([Vector2::new(1.0, 0.0), Vector2::new(0.0, 1.0)], [0.0, 1.0], [4.0, 1.0])
        .unwrap();
    let walk = poly.walk(None).unwrap();
    let brute = poly.brute_force().unwrap();
    assert!((walk.centroid - Vector2::new(2.0, 1.0)).amax() < 1e-12, "{:?}", walk.centroid);
    assert!((brute.centroid - Vector2::new(2.0, 1.0)).amax() < 1e-12);
}

#[test]
fn empty_polygon_is_infeasible() {
    // x >= 2 and x <= 1 through two different cables.
    let poly = FeasiblePolygon::new(
        [Vector2::new(1.0, 0.0), Vector2::new(1.0, 0.0), Vector2::new(0.0, 1.0)],
        [2.0, -5.0, 0.0],
        [5.0, 1.0, 1.0],
    )
    .unwrap();
    assert_eq!(poly.walk(None).unwrap_err(), Error::Infeasible);
    assert_eq!(poly.brute_force().unwrap_err(), Error::Infeasible);
}

#[test]
fn lost_warm_start_falls_back_to_cold_search() {
    let poly = FeasiblePolygon::new(
        [Vector2::new(1.0, 0.0), Vector2::new(0.0, 1.0), Vector2::new(1.0, 1.0)],
        [0.0, 0.0, -10.0],
        [1.0, 1.0, 1.5],
    )
    .unwrap();
    // Cable 2 at its minimum and cable 0 at its max do not meet on the polygon.
    let pair = ActivePair { first: (2, tension_core::Bound::Min), second: (0, tension_core::Bound::Max) };
    let warm = poly.walk(Some(pair)).unwrap();
    assert!(!warm.warm_start_held);
    let cold = poly.walk(None).unwrap();
    assert!((warm.centroid - cold.centroid).amax() < 1e-12);
}

/// The warm pair's crossing is the first vertex when every cable's
/// half-planes hold there within the slack tolerance widened by the
/// crossing's error bound (`tol + |n_k| error`, `error = tol (|n_1| +
/// |n_2|) / |det|`): a third cable that cuts the crossing off by 0.9 of that
/// keeps the warm start, by 1.1 of it loses it (the cold search then
/// starts), in both precisions and at three scales.
#[test]
fn warm_start_holds_exactly_within_the_widened_tolerance() {
    fn case<T: Real>(scale: f64, fraction: f64) -> bool {
        // x <= 1 (cable 0's maximum) and y <= 1 (cable 1's) cross at (1, 1)
        // with |det| = 1; cable 2's row (1, 1) has n . p = 2 there.
        let rows = [[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]].map(|[x, y]| Vector2::new(T::lit(x), T::lit(y)));
        let at = |x: f64| T::lit(x * scale);
        let lower = [-10.0, -10.0, -10.0].map(at);
        // The tolerance scales with the largest bound (10 scale, a lower one).
        let tol = FeasiblePolygon::<T, 3>::new(rows, lower, [1.0, 1.0, 2.0].map(at)).unwrap().tolerance();
        let widened = tol + T::lit(2f64.sqrt()) * (T::lit(2.0) * tol);
        let upper = [at(1.0), at(1.0), at(2.0) - T::lit(fraction) * widened];
        let poly = FeasiblePolygon::<T, 3>::new(rows, lower, upper).unwrap();
        let pair = ActivePair { first: (0, tension_core::Bound::Max), second: (1, tension_core::Bound::Max) };
        let warm = poly.walk(Some(pair)).unwrap();
        let cold = poly.walk(None).unwrap();
        assert_eq!(warm.vertices.len(), cold.vertices.len());
        warm.warm_start_held
    }
    let mut cases = 0;
    for scale in [1.0, 1e-3, 1e4] {
        assert!(case::<f64>(scale, 0.9) && !case::<f64>(scale, 1.1), "f64, scale {scale}");
        assert!(case::<f32>(scale, 0.9) && !case::<f32>(scale, 1.1), "f32, scale {scale}");
        cases += 4;
    }
    assert_eq!(cases, 12);
}

#[test]
#[allow(clippy::excessive_precision)]
fn nearly_parallel_lines_meeting_at_the_first_vertex() {
    // IPAnema 1 on a dynamic trajectory: the null-space rows come in nearly
    // parallel pairs, so the first vertex found (cables 0 and 2 at t_max)
    // is the crossing of two lines 0.03 degrees apart, and its computed slacks
    // exceed the tolerance. The walk once stopped there with a single vertex.
    let rows = [
        [-4.70410371483061945e-2, 4.98217832885124057e-1],
        [4.97337704476146558e-1, 4.70895894606125354e-2],
        [-4.67610291356474611e-2, 4.97870436930976878e-1],
        [4.97546606677496894e-1, 4.62408470394958387e-2],
        [4.98148651711220747e-1, 4.72330421089394159e-2],
        [-4.67001045788985741e-2, 4.97677621501716017e-1],
        [4.98072638265039336e-1, 4.78306038684866153e-2],
        [-4.78935998919287759e-2, 4.97339553804054091e-1],
    ];
    let lo = [
        6.82404379276539186e-1,
        6.74798504493149931e-1,
        6.78097827752953464e-1,
        6.85703820672343145e-1,
        1.32211360798852451e0,
        1.31346955371184215e0,
        1.31701152867836391e0,
        1.32565329240724861e0,
    ];
    let hi = lo.map(|x| x + 9.0);
    let (q, _) = polygon_case(rows, lo, hi);
    assert_eq!(q, 5);
}

/// Polygons whose lines come in nearly parallel bundles (symmetric robots):
/// the walk, the brute force and the clipping reference agree.
#[test]
fn nearly_parallel_bundles() {
    let mut runner = TestRunner::new(cdpr_integration_tests::persisted_config(2000, file!()));
    let strategy = (
        prop::collection::vec(0.0f64..std::f64::consts::PI, 2),
        prop::collection::vec(-1e-3f64..1e-3, 16),
        prop::collection::vec(-0.5f64..0.5, 8),
        0.5f64..10.0,
    );
    runner
        .run(&strategy, |(angles, jitter, shift, width)| {
            let rows: [[f64; 2]; 8] = core::array::from_fn(|k| {
                let a = angles[k % 2] + jitter[2 * k];
                [0.5 * a.cos() + jitter[2 * k + 1], 0.5 * a.sin()]
            });
            let lo: [f64; 8] = core::array::from_fn(|k| shift[k]);
            let hi: [f64; 8] = core::array::from_fn(|k| shift[k] + width);
            let poly = FeasiblePolygon::new(rows.map(|r| Vector2::new(r[0], r[1])), lo, hi).unwrap();
            match (poly.walk(None), poly.brute_force()) {
                (Ok(a), Ok(b)) => {
                    prop_assert!(
                        (a.centroid - b.centroid).amax() < 1e-9 * (1.0 + b.centroid.amax()),
                        "{:?} vs {:?}",
                        a.centroid,
                        b.centroid
                    );
                    let clipped = clip_polygon_auto(&rows, &lo, &hi);
                    if clipped.area > 1e-6 {
                        prop_assert!(
                            (a.centroid.x - clipped.centroid[0]).abs()
                                < 1e-6 * (1.0 + clipped.centroid[0].abs())
                        );
                        prop_assert!(
                            (a.centroid.y - clipped.centroid[1]).abs()
                                < 1e-6 * (1.0 + clipped.centroid[1].abs())
                        );
                    }
                }
                (Err(Error::Infeasible), Err(Error::Infeasible)) => {}
                other => prop_assert!(false, "{other:?}"),
            }
            Ok(())
        })
        .unwrap();
}

/// The same pose twice, as a robot at rest: the second solve's warm start
/// holds (a lost one falls back to the cold search or to the brute force,
/// twice the cost on the board). At the symmetric centre of suspended-8 two
/// cables' limit lines coincide, which used to make the walk from the warm
/// vertex miss its own start and fall back every cycle.
fn repeated_pose_holds<T: tension_core::Real + std::fmt::Debug>(
    robot_name: &str,
    poses: &[[f64; 6]],
) -> usize {
    let robot: tension_core::Robot<T, 6, 8> = cdpr_integration_tests::shipped_robot(robot_name);
    let mut held = 0;
    for p in poses {
        let pose = SVector::<T, 6>::from_fn(|i, _| T::lit(p[i]));
        let (Ok(w), Ok(f)) =
            (robot.wrench_matrix(&pose), robot.required_wrench(&pose, &SVector::zeros(), None))
        else {
            continue;
        };
        let mut solver = tension_core::TensionSolver::<T, 8>::new(tension_core::Method::Barycenter);
        if solver.solve(&w, &f, robot.limits()).is_err() {
            continue;
        }
        for _ in 0..2 {
            let again = solver.solve(&w, &f, robot.limits()).unwrap();
            assert_eq!(again.diagnostics.warm_start, WarmStart::Held, "{robot_name} at {p:?}");
        }
        held += 1;
    }
    held
}

#[test]
fn warm_start_holds_at_rest_including_symmetric_poses() {
    let mut poses = Vec::new();
    // Symmetric: the centre of the frame at several heights, level.
    for z in [0.6, 1.0, 1.5, 1.8, 2.2, 2.6] {
        poses.push([0.0, 0.0, z, 0.0, 0.0, 0.0]);
    }
    // And a grid of other static poses.
    for i in 0..5 {
        for j in 0..5 {
            for k in 0..4 {
                let (x, y, z) = (-0.8 + 0.4 * i as f64, -0.6 + 0.3 * j as f64, 0.8 + 0.5 * k as f64);
                poses.push([x, y, z, 0.05 * (i as f64 - 2.0), 0.0, 0.1 * (j as f64 - 2.0)]);
            }
        }
    }
    for robot in ["suspended-8", "ipanema1", "cogiro"] {
        let a = repeated_pose_holds::<f64>(robot, &poses);
        let b = repeated_pose_holds::<f32>(robot, &poses);
        assert!(a >= 10 && b >= 10, "{robot}: only {a} / {b} feasible static poses");
    }
    // The pose of the report: suspended-8 at rest at its centre.
    assert_eq!(repeated_pose_holds::<f32>("suspended-8", &[[0.0, 0.0, 1.8, 0.0, 0.0, 0.0]]), 1);
}

/// Suspended-8's cables come in twins (0-4, 1-5, 2-6, 3-7: the frame and
/// the platform are symmetric under a half turn about z), whose limit lines
/// in the null space are nearly parallel over much of the workspace. The
/// crossing of a pair of twins' lines has a large error bound, so a warm
/// pair of twins holds although another cable's line cuts its crossing
/// off by more than the slack tolerance (here by 2.5 to 74 tolerances, within
/// the acceptance widened by that bound); the walk from it comes back
/// round along one of the two lines instead of its first edge, and meets
/// an edge twice. It used to fall back to the brute force there: on the
/// board the solver cost 18 461-21 018 instructions on these cycles
/// (7 876-8 436 now), a step over the budget's 20 000. These pairs of consecutive setpoints
/// (`f32`, the board's precision) were found along random streams of
/// suspended-8 poses: the first four in steps of at most 2 mm and 4 mrad a
/// cycle (93 such cycles in 4 000 000; 55 in steps of 2 mm and 2 mrad), the
/// last two in steps up to the link's jump limits (50 mm, 0.1 rad).
const TWIN_CUT_WARM_STARTS: [([f32; 6], [f32; 6]); 6] = [
    (
        [0.20413625, -0.06659435, 2.3494966, -0.042239513, -0.004367064, -0.06797246],
        [0.20483029, -0.06828195, 2.3483648, -0.044143967, -0.007735276, -0.067864716],
    ),
    (
        [-0.11248301, -0.16712599, 1.7736804, -0.011050826, 0.023418836, 0.19622262],
        [-0.111310855, -0.16702369, 1.7744193, -0.013662797, 0.020148141, 0.19594578],
    ),
    (
        [0.083017096, 0.16572012, 1.6416093, -0.03340717, 0.0409876, 0.11851115],
        [0.08383775, 0.16501379, 1.6431315, -0.033641655, 0.044620857, 0.12115115],
    ),
    (
        [-0.13305412, 0.04114589, 1.5309463, -0.028781053, 0.021746969, -0.004958992],
        [-0.13304763, 0.042643324, 1.5296601, -0.024898844, 0.018788503, -0.00627586],
    ),
    (
        [-0.557095, 0.033761546, 1.9471284, 0.17919263, -0.022465592, -0.36429366],
        [-0.53171134, 0.059559353, 1.9407737, 0.2592593, -0.09073013, -0.4397566],
    ),
    (
        [-0.23361173, 0.07213412, 2.615432, -0.09311058, 0.09035111, -0.2818546],
        [-0.21906763, 0.115202464, 2.586897, -0.17911781, 0.0011511067, -0.35757253],
    ),
];

/// IPAnema 1 (`f32`): a pose whose warm start from the last pose is lost,
/// and whose cold search (either way) starts at the crossing of cable 0's
/// and cable 7's upper lines (nearly parallel, and cable 5's nearly
/// concurrent with them there): the first step goes nowhere (a zero step
/// to cable 5's line, whose crossing with cable 0's lies 1.2 beyond), and
/// the walk comes back round along cable 5's line from the other side. It
/// fell back to the brute force (the board's solver 29 946 instructions;
/// 11 049 now). Found along the same streams (one cycle in 4 000 000).
const NEARLY_CONCURRENT_START: ([f32; 6], [f32; 6]) = (
    [-0.11898832, 0.034393195, 1.0911285, 0.0303877, 0.019621626, -0.027917959],
    [-0.11941954, 0.033974875, 1.0895642, 0.027469987, 0.022603638, -0.024649275],
);

/// What one walk in `f32` (the board's precision) did.
struct BoardWalk {
    /// The warm start held.
    held: bool,
    /// The vertices are the brute force's.
    brute_force: bool,
    /// The warm pair's crossing (in `f64`, from the `f32` lines) lies
    /// beyond another cable's line by more than the slack tolerance.
    cut_off: bool,
    /// The tensions at the centroid.
    tensions: SVector<f64, 8>,
    /// The next cycle's warm start.
    robust_pair: ActivePair,
}

/// Walks the polygon of `pose` in `f32` from `warm`, as the board's solver
/// does; `None` when the pose has no polygon.
fn board_walk(
    robot: &tension_core::Robot<f32, 6, 8>,
    pose: &[f32; 6],
    warm: Option<ActivePair>,
) -> Option<BoardWalk> {
    board_walk_with(robot, pose, warm, &mut tension_core::polygon::VertexList::new())
}

/// [`board_walk`] with the caller's vertex list, which keeps the last
/// walk's successors (a control loop's).
fn board_walk_with(
    robot: &tension_core::Robot<f32, 6, 8>,
    pose: &[f32; 6],
    warm: Option<ActivePair>,
    vertices: &mut tension_core::polygon::VertexList<f32, 8>,
) -> Option<BoardWalk> {
    use tension_core::{linalg::WrenchFactorization, tension_polygon::TensionPolygon};
    let (w, f) = robot.wrench_problem(&SVector::from(*pose), &SVector::zeros(), None).ok()?;
    let mut fact = WrenchFactorization::<f32, 6, 8>::zeroed();
    fact.factor(&w, &[true; 8], 2).ok()?;
    let polygon = TensionPolygon::new(&fact, &f, robot.limits()).ok()?;
    let found = polygon.polygon.walk_into(warm, vertices).ok()?;
    let cut_off = warm.is_some_and(|pair| {
        // Each line in f64: n_k . lambda = bound (t_min or t_max - t_p).
        let line = |(k, side): (u8, tension_core::Bound)| {
            let k = k as usize;
            let limit = match side {
                tension_core::Bound::Min => robot.limits().min()[k],
                tension_core::Bound::Max => robot.limits().max()[k],
            };
            let n = polygon.rows[k];
            (k, [n.x as f64, n.y as f64], (limit - polygon.particular[k]) as f64)
        };
        let ((k1, a, b1), (k2, c, b2)) = (line(pair.first), line(pair.second));
        let det = a[0] * c[1] - a[1] * c[0];
        let p = [(b1 * c[1] - a[1] * b2) / det, (a[0] * b2 - b1 * c[0]) / det];
        (0..8).filter(|&k| k != k1 && k != k2).any(|k| {
            let n = polygon.rows[k];
            let np = n.x as f64 * p[0] + n.y as f64 * p[1];
            let lower = (robot.limits().min()[k] - polygon.particular[k]) as f64;
            let upper = (robot.limits().max()[k] - polygon.particular[k]) as f64;
            (lower - np).max(np - upper) > polygon.polygon.tolerance() as f64
        })
    });
    Some(BoardWalk {
        held: found.warm_start_held,
        brute_force: vertices.by_brute_force(),
        cut_off,
        tensions: polygon.tensions(&found.centroid).map(|t| t as f64),
        robust_pair: found.robust_pair,
    })
}

/// The barycenter of `pose` in `f64` by the brute force (Mikelsons et al.
/// 2008): the reference for the `f32` walk (`None`: infeasible in `f64`,
/// at the workspace's border).
fn f64_reference(robot: &tension_core::Robot<f64, 6, 8>, pose: &[f32; 6]) -> Option<SVector<f64, 8>> {
    let pose = SVector::<f64, 6>::from_fn(|i, _| pose[i] as f64);
    let (w, f) = robot.wrench_problem(&pose, &SVector::zeros(), None).ok()?;
    solve(Method::BarycenterBrute, &w, &f, robot.limits(), &PreviousCycle::default()).ok().map(|s| s.tensions)
}

/// `walk`'s tensions against the `f64` reference, as a fraction of the
/// tension range.
fn from_reference(
    walk: &BoardWalk,
    reference: &SVector<f64, 8>,
    robot: &tension_core::Robot<f64, 6, 8>,
) -> f64 {
    let range = robot.limits().max()[0] - robot.limits().min()[0];
    (walk.tensions - reference).amax() / range
}

/// The cases of [`TWIN_CUT_WARM_STARTS`] and [`NEARLY_CONCURRENT_START`]:
/// the walk closes the polygon where it comes back round, with no brute
/// force; the tensions are the `f64` reference's within 3e-3 of the tension
/// range (1 N of suspended-8's 345; along 4 000 000 cycles of streams up to
/// the link's jump limits, the `f32` brute force was up to 5.8e-3 from it
/// where the walk came back round, the closed walk 1.4e-3).
#[test]
fn walks_that_come_back_round_close_without_the_brute_force() {
    let mut checked = 0;
    let robot: tension_core::Robot<f32, 6, 8> = cdpr_integration_tests::shipped_robot("suspended-8");
    let reference: tension_core::Robot<f64, 6, 8> = cdpr_integration_tests::shipped_robot("suspended-8");
    for (before, pose) in TWIN_CUT_WARM_STARTS {
        // As a control loop walks them: one list for both cycles, the
        // first's successors kept for the second.
        let mut kept = tension_core::polygon::VertexList::new();
        let first = board_walk_with(&robot, &before, None, &mut kept).unwrap();
        let walk = board_walk_with(&robot, &pose, Some(first.robust_pair), &mut kept).unwrap();
        // With a fresh list, the same answer bit for bit.
        let fresh = board_walk(&robot, &pose, Some(first.robust_pair)).unwrap();
        assert_eq!(walk.tensions, fresh.tensions, "{pose:?}");
        assert!(!walk.brute_force, "{pose:?}: the walk fell back to the brute force");
        assert!(walk.held && walk.cut_off, "{pose:?}: the case is no longer a cut-off warm start");
        let error = from_reference(&walk, &f64_reference(&reference, &pose).unwrap(), &reference);
        assert!(error <= 3e-3, "{pose:?}: {error:e} of the range from the f64 reference");
        checked += 1;
    }
    let robot: tension_core::Robot<f32, 6, 8> = cdpr_integration_tests::shipped_robot("ipanema1");
    let reference: tension_core::Robot<f64, 6, 8> = cdpr_integration_tests::shipped_robot("ipanema1");
    let (before, pose) = NEARLY_CONCURRENT_START;
    let first = board_walk(&robot, &before, None).unwrap();
    for warm in [Some(first.robust_pair), None] {
        let walk = board_walk(&robot, &pose, warm).unwrap();
        assert!(!walk.brute_force, "IPAnema 1 from {warm:?}: the walk fell back to the brute force");
        let error = from_reference(&walk, &f64_reference(&reference, &pose).unwrap(), &reference);
        assert!(error <= 3e-3, "IPAnema 1 from {warm:?}: {error:e} of the range from the f64 reference");
        checked += 1;
    }
    assert_eq!(checked, TWIN_CUT_WARM_STARTS.len() + 2);
}

/// Random streams of setpoints of suspended-8 and IPAnema 1 in `f32`, each
/// pose warm-started from the last: half in steps of at most 2 mm and
/// 2 mrad a cycle (a fast robot), half up to the link's jump limits (50 mm,
/// 0.1 rad). No walk falls back to the brute force, and wherever a held
/// warm pair's crossing is cut off by another cable's line (the case
/// above, and its neighbours) the tensions are the `f64` reference's
/// within 3e-3 of the range.
#[test]
fn streams_never_fall_back_to_the_brute_force() {
    // (robot, the box's centre and half sizes, the largest Euler angles)
    let robots = [
        ("suspended-8", [0.0, 0.0, 1.8], [0.8, 0.6, 0.6], [0.3, 0.3, 0.5]),
        ("ipanema1", [0.0, 0.0, 1.0], [0.4, 0.3, 0.25], [0.1; 3]),
    ];
    for (name, centre, half, angles) in robots {
        let robot: tension_core::Robot<f32, 6, 8> = cdpr_integration_tests::shipped_robot(name);
        let reference: tension_core::Robot<f64, 6, 8> = cdpr_integration_tests::shipped_robot(name);
        // xorshift64 (Marsaglia 2003): uniform in [-1, 1).
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut symmetric = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            2.0 * ((state >> 11) as f64 / (1u64 << 53) as f64) - 1.0
        };
        let (mut walks, mut held, mut cut_off, mut compared) = (0, 0, 0, 0);
        for stream in 0..2_000 {
            let (step, turn) = if stream % 2 == 0 { (0.002, 0.002) } else { (0.05, 0.1) };
            let mut pose: [f64; 6] =
                core::array::from_fn(|i| if i < 3 { centre[i] + half[i] * symmetric() } else { 0.0 });
            let mut warm = None;
            // One list for the stream, as the board keeps it.
            let mut kept = tension_core::polygon::VertexList::new();
            for _ in 0..200 {
                for (i, x) in pose.iter_mut().enumerate() {
                    let (size, limit, mid) =
                        if i < 3 { (step, half[i], centre[i]) } else { (turn, angles[i - 3], 0.0) };
                    *x = (*x + size * symmetric()).clamp(mid - limit, mid + limit);
                }
                let pose32 = pose.map(|x| x as f32);
                let Some(walk) = board_walk_with(&robot, &pose32, warm, &mut kept) else { continue };
                walks += 1;
                assert!(
                    !walk.brute_force,
                    "{name} {pose32:?} from {warm:?}: the walk fell back to the brute force"
                );
                if walk.held {
                    held += 1;
                    if walk.cut_off {
                        cut_off += 1;
                        // The kept successors change nothing, bit for bit.
                        let fresh = board_walk(&robot, &pose32, warm).unwrap();
                        assert_eq!(walk.tensions, fresh.tensions, "{name} {pose32:?}");
                        // (At the border the f64 polygon may be empty.)
                        if let Some(t) = f64_reference(&reference, &pose32) {
                            let error = from_reference(&walk, &t, &reference);
                            assert!(
                                error <= 3e-3,
                                "{name} {pose32:?}: {error:e} of the range from the f64 reference"
                            );
                            compared += 1;
                        }
                    }
                }
                warm = Some(walk.robust_pair);
            }
        }
        println!(
            "{name}: {walks} walks, {held} warm starts held, {cut_off} of them cut off by another cable's line \
             ({compared} compared with the f64 reference)"
        );
        assert!(
            walks >= 300_000 && held >= 200_000 && compared >= 20,
            "{name}: {walks} / {held} / {cut_off} / {compared}"
        );
    }
}
