//! The walk's hinted steps (`FeasiblePolygon::walk_into` tries, at each
//! edge, the line that followed it in the polygon its list's last walk
//! found, and takes it only when that is provably what the full step of
//! Lamaury & Gouttefarde 2013, Eqs. 16-21, would choose) change nothing:
//! the same vertices, lines, error bounds, centroid and warm-start pair, bit
//! for bit, as the walk with an empty list (no hint: every step a full
//! one), whose centroid (summed as the walk goes) is the list's by the
//! shoelace formulas taken afterwards, along the shipped robots' paths,
//! across jumps, at polygons shifted towards the feasibility border, and
//! with hints from an unrelated polygon. Each check counts the steps that
//! took a hint, so that the comparison is known to have reached them.

use cdpr_integration_tests::{
    eight_cable_polygon, frame_poses, persisted_config, shifted_polygon, shipped_robot, smooth_path,
    EightCablePolygon, IPANEMA1_PATH, SUSPENDED8_PATH,
};
use nalgebra::{SVector, Vector2};
use proptest::prelude::*;
use tension_core::{
    linalg::WrenchFactorization,
    polygon::{ActivePair, FeasiblePolygon, PolygonSummary, VertexList},
    tension_polygon::TensionPolygon,
    Error, Real, Robot,
};

const M: usize = 8;

/// Steps compared: all of them, and those that took a hint.
#[derive(Debug, Default, Clone, Copy)]
struct Counts {
    walks: usize,
    steps: usize,
    hinted: usize,
}

/// Walks `polygon` from `warm` with the hints `kept` holds (its last
/// polygon; it keeps this one) and with none, and requires the same
/// outcome bit for bit. Returns the hinted walk's outcome.
fn compare<T: Real + std::fmt::Debug, const K: usize>(
    polygon: &FeasiblePolygon<T, K>,
    warm: Option<ActivePair>,
    kept: &mut VertexList<T, K>,
    counts: &mut Counts,
    context: &dyn Fn() -> String,
) -> Result<PolygonSummary<T>, Error> {
    let mut fresh = VertexList::new();
    let plain = polygon.walk_into(warm, &mut fresh);
    let hinted = polygon.walk_into(warm, kept);
    match (&plain, &hinted) {
        (Ok(a), Ok(b)) => {
            assert_eq!(a.hinted_steps, 0, "no hint in an empty list: {}", context());
            let same = PolygonSummary { hinted_steps: 0, ..*b };
            assert_eq!(*a, same, "{}", context());
            assert_eq!(fresh.len(), kept.len(), "{}", context());
            for (x, y) in fresh.iter().zip(kept.iter()) {
                // Bit for bit: `Debug` prints the shortest representation
                // that reads back to the same bits, and the sign of a zero.
                assert_eq!(x.lines, y.lines, "{}", context());
                for (p, q) in [(x.point.x, y.point.x), (x.point.y, y.point.y), (x.error, y.error)] {
                    assert_eq!(format!("{p:?}"), format!("{q:?}"), "{}", context());
                }
            }
            // The centroid the walk summed as it went is the list's, bit
            // for bit.
            let (c, area) = polygon.centroid_of(&fresh);
            for (p, q) in [(c.x, a.centroid.x), (c.y, a.centroid.y), (area, a.area)] {
                assert_eq!(format!("{p:?}"), format!("{q:?}"), "{}", context());
            }
            counts.walks += 1;
            // A walk's steps: one per vertex after the first, and the
            // closing one (none for a single point).
            counts.steps += b.vertices.max(1);
            counts.hinted += b.hinted_steps;
            assert!(b.hinted_steps <= b.vertices.max(1), "{}", context());
        }
        (Err(a), Err(b)) => assert_eq!(a, b, "{}", context()),
        _ => panic!("{plain:?} against {hinted:?}: {}", context()),
    }
    hinted
}

/// Along `poses` (each warm-started from the last outcome, as a control
/// loop does), the hinted walk against the plain one.
fn along<T: Real + std::fmt::Debug>(robot: &Robot<T, 6, M>, poses: &[SVector<T, 6>]) -> Counts {
    let mut counts = Counts::default();
    let mut kept = VertexList::new();
    let mut warm = None;
    let mut fact = WrenchFactorization::<T, 6, M>::zeroed();
    let mut polygon = TensionPolygon::<T, 6, M>::zeroed();
    for (i, pose) in poses.iter().enumerate() {
        let (Ok(w), Ok(f)) =
            (robot.wrench_matrix(pose), robot.required_wrench(pose, &SVector::zeros(), None))
        else {
            continue;
        };
        if fact.factor(&w, &[true; M], 2).is_err() || polygon.set(&fact, &f, robot.limits()).is_err() {
            continue;
        }
        let context = || format!("pose {i}: {pose:?}");
        if let Ok(found) = compare(&polygon.polygon, warm, &mut kept, &mut counts, &context) {
            warm = Some(found.robust_pair);
        }
    }
    counts
}

fn shipped<T: Real + std::fmt::Debug>(
    name: &str,
    path: [[f64; 3]; 3],
    frame: ([f64; 3], [f64; 4]),
) -> [Counts; 2] {
    let robot: Robot<T, 6, M> = shipped_robot(name);
    let smooth = along(&robot, &smooth_path::<T>(path[0], path[1], path[2], 2_000));
    let jumps: Vec<SVector<T, 6>> =
        frame_poses(frame.0, frame.1, 2_000, 7).iter().map(|p| p.map(|x| T::lit(x))).collect();
    let jumps = along(&robot, &jumps);
    [smooth, jumps]
}

/// Along the benchmarks' smooth paths most steps take the hint (the
/// polygon's lines change only where a vertex appears or goes); across
/// random poses of the frame (a different polygon each time, most of them
/// empty) a few still do. Every outcome is the plain walk's.
#[test]
fn hinted_walk_is_the_plain_walk_on_the_shipped_robots() {
    let suspended = ([0.0, 0.0, 1.6], [1.5, 1.2, 1.0, 0.3]);
    let ipanema = ([0.0, 0.0, 1.0], [0.5, 0.4, 0.3, 0.1]);
    let runs = [
        ("suspended-8 f64", shipped::<f64>("suspended-8", SUSPENDED8_PATH, suspended)),
        ("suspended-8 f32", shipped::<f32>("suspended-8", SUSPENDED8_PATH, suspended)),
        ("ipanema1 f64", shipped::<f64>("ipanema1", IPANEMA1_PATH, ipanema)),
        ("ipanema1 f32", shipped::<f32>("ipanema1", IPANEMA1_PATH, ipanema)),
    ];
    for (name, [smooth, jumps]) in runs {
        println!("{name}: smooth {smooth:?}, jumps {jumps:?}");
        assert!(smooth.walks >= 1_900, "{name}: only {} walks compared on the path", smooth.walks);
        assert!(
            smooth.hinted * 10 >= smooth.steps * 9,
            "{name}: {} of {} steps hinted on the smooth path",
            smooth.hinted,
            smooth.steps
        );
        assert!(jumps.walks >= 100 && jumps.hinted > 0, "{name}: jumps {jumps:?}");
    }
}

type Case = EightCablePolygon;

fn case() -> impl Strategy<Value = Case> {
    eight_cable_polygon()
}

fn polygon<T: Real>(c: &Case, tau: f64) -> Option<FeasiblePolygon<T, M>> {
    shifted_polygon(c, tau)
}

/// The case's polygon shifted in small steps until it is empty (vertices
/// appear and go, lines become concurrent), each walk hinted by the last.
fn shifted<T: Real + std::fmt::Debug>(c: &Case, counts: &mut Counts) {
    let mut kept = VertexList::new();
    let mut warm = None;
    for step in 0..400 {
        let tau = 0.1 * step as f64;
        let Some(p) = polygon::<T>(c, tau) else { continue };
        let context = || format!("shift {tau} of {c:?}");
        match compare(&p, warm, &mut kept, counts, &context) {
            Ok(found) => warm = Some(found.robust_pair),
            Err(_) => break,
        }
    }
}

proptest! {
    #![proptest_config(persisted_config(64, file!()))]

    /// Polygons moved towards the border in `f64` and `f32`, and hints from
    /// another polygon (after a warm start that holds, the only case in
    /// which hints are tried): the plain walk's outcome every time.
    #[test]
    fn hinted_walk_is_the_plain_walk_towards_the_border(c in case(), other in case()) {
        let mut counts = Counts::default();
        let mut strangers = 0;
        shifted::<f64>(&c, &mut counts);
        shifted::<f32>(&c, &mut counts);
        // A stranger's polygon as the hints: the hints are only tried.
        for tau in [0.0, 1.0, 3.0] {
            if let (Some(p), Some(q)) = (polygon::<f64>(&c, tau), polygon::<f64>(&other, tau)) {
                // Hints are tried only after a warm start that holds: `p`'s own.
                let warm = p.walk(None).ok().map(|found| found.robust_pair);
                let mut kept = VertexList::new();
                let _ = q.walk_into(None, &mut kept);
                let context = || format!("{c:?} hinted by {other:?} at {tau}");
                let _ = compare(&p, warm, &mut kept, &mut counts, &context);
                strangers += 1;
            }
        }
        prop_assert!(counts.walks > 0 && strangers > 0, "{counts:?}, {strangers} strangers");
        // The origin is inside every unshifted polygon: the first shifts
        // are walked, hinted by the one before.
        prop_assert!(counts.hinted > 0, "{counts:?}");
    }
}

/// A line that passes within its tolerance outside a vertex, at an angle
/// where the full step's rule for concurrent lines (Sect. 2.3) follows it:
/// the square `0 <= x, y <= 1` and a third cable `-x/2 + y sqrt(3)/2 <=
/// c`, its line through `(1, 1)` moved out by `tol / 4`. From `(1, 0)` up
/// the edge `x = 1`, `y = 1` is reached first and the third line within
/// its tolerance there; the rule takes the third line. Hinted by the same
/// polygon with that line well inside (there `y = 1` followed `x = 1`), the
/// hint must be refused: the third line is only `tol / 4` from the
/// crossing, below the hinted step's gap.
#[test]
fn a_line_within_tolerance_of_the_hinted_vertex_refuses_the_hint() {
    let rows = [Vector2::new(1.0, 0.0), Vector2::new(0.0, 1.0), Vector2::new(-0.5, 3f64.sqrt() / 2.0)];
    let through = rows[2].dot(&Vector2::new(1.0, 1.0));
    let square =
        |shift: f64| FeasiblePolygon::<f64, 3>::new(rows, [0.0, 0.0, -10.0], [1.0, 1.0, through + shift]);
    let tol = square(0.0).unwrap().tolerance();
    let (near, inside) = (square(tol / 4.0).unwrap(), square(0.2).unwrap());
    let mut kept = VertexList::new();
    let found = inside.walk_into(None, &mut kept).unwrap();
    // The hint is there: `y = 1` (line 3) after `x = 1` (line 1).
    assert!(kept.iter().any(|v| v.lines == (1, 3)), "{:?}", kept.iter().collect::<Vec<_>>());
    let mut counts = Counts::default();
    let mut plain = VertexList::new();
    let reference = near.walk_into(Some(found.robust_pair), &mut plain).unwrap();
    assert!(reference.warm_start_held);
    // The full walk leaves `x = 1` for the third cable's line (line 5).
    assert!(plain.iter().any(|v| v.lines == (1, 5)), "{:?}", plain.iter().collect::<Vec<_>>());
    let hinted = compare(&near, Some(found.robust_pair), &mut kept, &mut counts, &|| "near".into()).unwrap();
    assert!(hinted.hinted_steps < hinted.vertices, "{hinted:?}");
    assert_eq!(counts.walks, 1);
}
