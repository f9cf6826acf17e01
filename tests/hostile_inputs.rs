//! Hostile inputs: NaN, infinities, arbitrary bit patterns, zero-length
//! cables, coincident anchors, huge coordinates, bad limits. Every call
//! returns a typed error or a valid answer; nothing panics or hangs.

use cdpr_integration_tests::shipped_robot;
use nalgebra::{Matrix3, SMatrix, SVector, Vector2, Vector3};
use proptest::prelude::*;
use tension_core::{
    polygon::FeasiblePolygon, solve, Error, Method, Platform, PreviousCycle, Real, Robot, RobotKind,
    TensionLimits, TensionSolver,
};

/// Any bit pattern, special values, or a plausible number.
fn hostile_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        any::<u64>().prop_map(f64::from_bits),
        prop::sample::select(vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.0,
            -0.0,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            5e-324,
            1e200,
            -1e200,
            1e-200,
        ]),
        -5.0f64..5.0,
        -5.0f64..5.0,
    ]
}

fn hostile_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        any::<u32>().prop_map(f32::from_bits),
        prop::sample::select(vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, f32::MAX, 1e30, 1e-38]),
        -5.0f32..5.0,
        -5.0f32..5.0,
    ]
}

/// How far the cases of a campaign got: robots built, wrenches computed,
/// and method answers checked against `W t = f` and the limits (the asserts).
#[derive(Debug, Default, Clone, Copy)]
struct Reach {
    cases: usize,
    robots: usize,
    wrenches: usize,
    checked: usize,
    cases_checked: usize,
}

/// Every method on a robot built from `base + numbers` (`base` a plausible
/// layout, or zeros for raw numbers): a typed error or a tension vector that
/// balances the wrench within the limits. Counts what reached the checks.
fn exercise<T: Real + std::fmt::Debug, const N: usize, const M: usize>(
    kind: RobotKind,
    numbers: &[T],
    base: &[T],
    reach: &mut Reach,
) {
    reach.cases += 1;
    let x = |k: usize| base[k] + numbers[k];
    let v = |k: usize| Vector3::new(x(k), x(k + 1), x(k + 2));
    let anchors: [Vector3<T>; M] = core::array::from_fn(|i| v(3 * i));
    let attach: [Vector3<T>; M] = core::array::from_fn(|i| v(3 * M + 3 * i));
    let b = 6 * M;
    let pose = SVector::<T, N>::from_fn(|i, _| x(b + i));
    let extra = SVector::<T, N>::from_fn(|i, _| x(b + N + i));
    let (lo, hi) = (x(b + 2 * N), x(b + 2 * N + 1));
    let Ok(limits) = TensionLimits::uniform(lo, hi) else {
        return;
    };
    let platform = Platform {
        mass: x(b + 2 * N + 2),
        com: v(b + 2 * N + 3),
        gravity: Vector3::new(T::zero(), T::zero(), T::lit(-9.81)),
        inertia: Matrix3::identity() * T::lit(0.01),
    };
    let Ok(robot) = Robot::<T, N, M>::new(kind, anchors, attach, limits, platform, None) else {
        return;
    };
    reach.robots += 1;
    let Ok(w) = robot.wrench_matrix(&pose) else {
        return;
    };
    let Ok(f) = robot.required_wrench(&pose, &extra, None) else {
        return;
    };
    reach.wrenches += 1;
    let checked_before = reach.checked;
    for method in Method::ALL {
        if !method.supports(N, M) {
            continue;
        }
        let mut solver = TensionSolver::<T, M>::new(method);
        for _ in 0..2 {
            if let Ok(sol) = solver.solve(&w, &f, &limits) {
                let t = sol.tensions;
                let scale = limits.scale();
                let slack = T::lit(1e-3) * scale;
                for i in 0..M {
                    assert!(t[i].is_finite());
                    assert!(t[i] >= lo - slack && t[i] <= hi + slack, "{method:?}: {t:?}");
                }
                let r = (w * t - f).amax();
                assert!(r <= T::lit(1e-2) * (T::one() + f.amax() + scale), "{method:?}: residual {r:?}");
                reach.checked += 1;
            }
        }
    }
    reach.cases_checked += usize::from(reach.checked > checked_before);
}

/// Number of values `exercise` reads for `N x M`.
const fn input_len(n: usize, m: usize) -> usize {
    6 * m + 2 * n + 6
}

/// A plausible robot to perturb: anchors on a frame around the platform
/// (alternately high and low), small attachments, a pose near the middle,
/// limits 1..1000 N, 1 kg (`kind`'s first coordinates only where planar).
fn plausible_layout(n: usize, m: usize) -> Vec<f64> {
    let mut base = vec![0.0; input_len(n, m)];
    for i in 0..m {
        let a = 2.0 * std::f64::consts::PI * (i as f64 + 0.5) / m as f64;
        let high = if n == 6 && i % 2 == 1 { 0.0 } else { 3.0 };
        base[3 * i..3 * i + 3].copy_from_slice(&[
            3.0 * a.cos(),
            2.5 * a.sin(),
            if n == 6 { high } else { 0.0 },
        ]);
        let b = 3 * m + 3 * i;
        let z = if n == 6 {
            if i % 2 == 0 {
                0.1
            } else {
                -0.1
            }
        } else {
            0.0
        };
        // Attachments turned against the anchors, alternately either way, so that
        // the cables resist a twist both ways.
        let c = if i % 2 == 0 { a + 0.6 } else { a - 0.6 };
        base[b..b + 3].copy_from_slice(&[0.15 * c.cos(), 0.15 * c.sin(), z]);
    }
    let b = 6 * m;
    if n == 6 {
        base[b + 2] = 1.5;
    }
    base[b + 2 * n] = 1.0;
    base[b + 2 * n + 1] = 1000.0;
    base[b + 2 * n + 2] = 1.0;
    base
}

/// Perturbations of +-20 % (relative), one value in 200 hostile (about one case in three
/// of the plausible half then holds a hostile value somewhere).
fn perturbation(hostile: impl Strategy<Value = f64> + Clone + 'static) -> BoxedStrategy<f64> {
    prop_oneof![199 => -0.2f64..0.2, 1 => hostile].boxed()
}

/// A campaign of `cases` inputs for `N x M`: half raw hostile numbers, half
/// hostile perturbations of [`plausible_layout`]. Returns how far they got.
fn campaign<T: Real + std::fmt::Debug, const N: usize, const M: usize>(
    kind: RobotKind,
    cases: u32,
    convert: fn(f64) -> T,
    raw: BoxedStrategy<f64>,
) -> Reach {
    let len = input_len(N, M);
    let layout_f64 = plausible_layout(N, M);
    let layout: Vec<T> = layout_f64.iter().copied().map(convert).collect();
    let zeros = vec![T::zero(); len];
    let strategy = (
        any::<bool>(),
        prop::collection::vec(raw.clone(), len),
        prop::collection::vec(perturbation(raw), len),
    );
    let reach = std::cell::Cell::new(Reach::default());
    let mut runner = proptest::test_runner::TestRunner::new(cdpr_integration_tests::persisted_config(
        cdpr_integration_tests::campaign_cases(cases),
        file!(),
    ));
    runner
        .run(&strategy, |(plausible, raw_numbers, perturbed)| {
            let mut r = reach.get();
            if plausible {
                // Perturbations relative to each value's size (at least 0.1).
                let numbers: Vec<T> =
                    perturbed.iter().zip(&layout_f64).map(|(d, x)| convert(d * x.abs().max(0.1))).collect();
                exercise::<T, N, M>(kind, &numbers, &layout, &mut r);
            } else {
                let numbers: Vec<T> = raw_numbers.into_iter().map(convert).collect();
                exercise::<T, N, M>(kind, &numbers, &zeros, &mut r);
            }
            reach.set(r);
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{kind:?} {N}x{M}: {e}"));
    let r = reach.get();
    println!("{kind:?} {N}x{M}: {r:?}");
    r
}

/// At least a quarter of the cases must reach the checks with some method's
/// answer, or the campaign tests nothing.
fn assert_reached(r: Reach) {
    assert!(r.cases_checked >= r.cases / 4, "too few cases checked: {r:?}");
}

#[test]
fn arbitrary_bits_spatial_f64() {
    assert_reached(campaign::<f64, 6, 8>(RobotKind::Spatial6, 3000, |x| x, hostile_f64().boxed()));
}

#[test]
fn arbitrary_bits_spatial_f32() {
    let raw = hostile_f32().prop_map(f64::from).boxed();
    assert_reached(campaign::<f32, 6, 8>(RobotKind::Spatial6, 3000, |x| x as f32, raw));
}

#[test]
fn arbitrary_bits_planar3_f64() {
    assert_reached(campaign::<f64, 3, 5>(RobotKind::Planar3, 3000, |x| x, hostile_f64().boxed()));
}

#[test]
fn arbitrary_bits_planar2_f32() {
    let raw = hostile_f32().prop_map(f64::from).boxed();
    assert_reached(campaign::<f32, 2, 4>(RobotKind::Planar2, 3000, |x| x as f32, raw));
}

/// The other shapes the tools serve: no redundancy, one, and up to six.
#[test]
fn arbitrary_bits_other_shapes() {
    let raw64 = || hostile_f64().boxed();
    let raw32 = || hostile_f32().prop_map(f64::from).boxed();
    let at_least = |r: Reach, fraction: usize| {
        assert!(r.cases_checked * fraction >= r.cases, "too few cases checked: {r:?}");
    };
    at_least(campaign::<f64, 6, 7>(RobotKind::Spatial6, 1000, |x| x, raw64()), 10);
    at_least(campaign::<f64, 6, 10>(RobotKind::Spatial6, 1000, |x| x, raw64()), 4);
    at_least(campaign::<f32, 6, 12>(RobotKind::Spatial6, 1000, |x| x as f32, raw32()), 4);
    at_least(campaign::<f32, 3, 4>(RobotKind::Planar3, 1000, |x| x as f32, raw32()), 10);
    at_least(campaign::<f64, 3, 8>(RobotKind::Planar3, 1000, |x| x, raw64()), 4);
    at_least(campaign::<f64, 2, 3>(RobotKind::Planar2, 1000, |x| x, raw64()), 10);
    at_least(campaign::<f32, 2, 6>(RobotKind::Planar2, 1000, |x| x as f32, raw32()), 4);
    // No redundancy: the robot must be exactly at its tensions; checked,
    // not required to be often feasible.
    campaign::<f64, 6, 6>(RobotKind::Spatial6, 500, |x| x, raw64());
}

proptest! {
    #![proptest_config(cdpr_integration_tests::persisted_config(cdpr_integration_tests::campaign_cases(3000), file!()))]

    #[test]
    fn arbitrary_wrench_matrices(entries in prop::collection::vec(hostile_f64(), 6 * 8 + 6 + 8)) {
        let w = SMatrix::<f64, 6, 8>::from_fn(|i, j| entries[i * 8 + j]);
        let f = SVector::<f64, 6>::from_fn(|i, _| entries[48 + i]);
        let start = SVector::<f64, 8>::from_fn(|i, _| entries[54 + i]);
        let limits = TensionLimits::uniform(1.0, 100.0).unwrap();
        for method in Method::ALL {
            let _ = TensionSolver::<f64, 8>::new(method).solve(&w, &f, &limits);
        }
        let _ = solve(Method::AnalyticCentre, &w, &f, &limits, &PreviousCycle::tensions(Some(start)));
    }

    #[test]
    fn arbitrary_polygons(entries in prop::collection::vec(hostile_f64(), 4 * 5)) {
        let rows = core::array::from_fn(|k| Vector2::new(entries[2 * k], entries[2 * k + 1]));
        let lower: [f64; 5] = core::array::from_fn(|k| entries[10 + k]);
        let upper: [f64; 5] = core::array::from_fn(|k| entries[15 + k]);
        if let Ok(poly) = FeasiblePolygon::new(rows, lower, upper) {
            if let Ok(found) = poly.walk(None) {
                prop_assert!(found.centroid.x.is_finite() && found.centroid.y.is_finite());
            }
            let _ = poly.brute_force();
        }
    }
}

fn suspended() -> (Robot<f64, 6, 8>, SVector<f64, 6>) {
    (shipped_robot("suspended-8"), SVector::<f64, 6>::new(0.0, 0.0, 1.5, 0.0, 0.0, 0.0))
}

#[test]
fn nan_and_infinite_poses_are_nonfinite() {
    let (robot, pose) = suspended();
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        for k in 0..6 {
            let mut p = pose;
            p[k] = bad;
            assert_eq!(robot.wrench_matrix(&p).unwrap_err(), Error::NonFinite);
            assert_eq!(robot.required_wrench(&p, &SVector::zeros(), None).unwrap_err(), Error::NonFinite);
        }
        let mut extra = SVector::<f64, 6>::zeros();
        extra[2] = bad;
        assert_eq!(robot.required_wrench(&pose, &extra, None).unwrap_err(), Error::NonFinite);
    }
    let w = robot.wrench_matrix(&pose).unwrap();
    let mut f = robot.required_wrench(&pose, &SVector::zeros(), None).unwrap();
    f[0] = f64::NAN;
    for method in Method::ALL {
        assert_eq!(
            TensionSolver::<f64, 8>::new(method).solve(&w, &f, robot.limits()).unwrap_err(),
            Error::NonFinite,
            "{method:?}"
        );
    }
    let mut w_bad = w;
    w_bad[(3, 4)] = f64::INFINITY;
    assert_eq!(
        solve(Method::Barycenter, &w_bad, &f.map(|_| 1.0), robot.limits(), &PreviousCycle::NONE).unwrap_err(),
        Error::NonFinite
    );
}

#[test]
fn zero_length_cable_is_degenerate() {
    let (robot, _) = suspended();
    // Put attachment 0 exactly on anchor 0: a = p + R b with R = I.
    let a = robot.anchors()[0];
    let b = robot.attachments()[0];
    let pose = SVector::<f64, 6>::new(a.x - b.x, a.y - b.y, a.z - b.z, 0.0, 0.0, 0.0);
    assert_eq!(robot.wrench_matrix(&pose).unwrap_err(), Error::DegenerateCable);
}

#[test]
fn coincident_anchors_are_singular() {
    let limits = TensionLimits::uniform(1.0, 100.0).unwrap();
    let platform = Platform {
        mass: 1.0,
        com: Vector3::zeros(),
        gravity: Vector3::new(0.0, 0.0, -9.81),
        inertia: Matrix3::identity(),
    };
    let robot = Robot::<f64, 6, 8>::new(
        RobotKind::Spatial6,
        [Vector3::new(0.0, 0.0, 3.0); 8],
        [Vector3::zeros(); 8],
        limits,
        platform,
        None,
    )
    .unwrap();
    let pose = SVector::<f64, 6>::new(0.0, 0.0, 1.0, 0.0, 0.0, 0.0);
    let w = robot.wrench_matrix(&pose).unwrap();
    let f = robot.required_wrench(&pose, &SVector::zeros(), None).unwrap();
    for method in Method::ALL {
        assert_eq!(
            TensionSolver::<f64, 8>::new(method).solve(&w, &f, &limits).unwrap_err(),
            Error::Singular,
            "{method:?}"
        );
    }
}

#[test]
fn huge_coordinates_give_errors_or_valid_answers() {
    let (robot, _) = suspended();
    for z in [1e150, 1e200, 1e300, f64::MAX] {
        let pose = SVector::<f64, 6>::new(0.0, 0.0, z, 0.0, 0.0, 0.0);
        match robot.wrench_matrix(&pose) {
            Ok(w) => {
                let f = robot.required_wrench(&pose, &SVector::zeros(), None).unwrap();
                for method in Method::ALL {
                    assert!(TensionSolver::<f64, 8>::new(method).solve(&w, &f, robot.limits()).is_err());
                }
            }
            Err(e) => assert!(matches!(e, Error::NonFinite | Error::DegenerateCable), "{e:?}"),
        }
    }
    let r32: Robot<f32, 6, 8> = shipped_robot("suspended-8");
    let pose = SVector::<f32, 6>::new(0.0, 0.0, 1e30, 0.0, 0.0, 0.0);
    assert_eq!(r32.wrench_matrix(&pose).unwrap_err(), Error::NonFinite);
}

#[test]
fn invalid_limits_are_rejected() {
    assert_eq!(TensionLimits::<f64, 8>::uniform(10.0, 10.0).unwrap_err(), Error::InvalidLimits);
    assert_eq!(TensionLimits::<f64, 8>::uniform(10.0, 5.0).unwrap_err(), Error::InvalidLimits);
    assert_eq!(TensionLimits::<f64, 8>::uniform(-1.0, 5.0).unwrap_err(), Error::InvalidLimits);
    assert_eq!(TensionLimits::<f64, 8>::uniform(f64::NAN, 5.0).unwrap_err(), Error::NonFinite);
    assert_eq!(TensionLimits::<f32, 8>::uniform(1.0, f32::INFINITY).unwrap_err(), Error::NonFinite);
}

#[test]
fn wrong_shapes_are_unsupported() {
    let w = SMatrix::<f64, 6, 9>::from_fn(|i, j| (((i * 9 + j) * (i * 9 + j)) as f64).sin());
    let f = SVector::<f64, 6>::repeat(1.0);
    let limits = TensionLimits::uniform(1.0, 10.0).unwrap();
    assert_eq!(
        solve(Method::Barycenter, &w, &f, &limits, &PreviousCycle::NONE).unwrap_err(),
        Error::UnsupportedShape
    );
    assert!(!Method::Barycenter.supports(6, 9));
    assert!(Method::AnalyticCentre.supports(6, 9));
    let wide = SMatrix::<f64, 3, 2>::zeros();
    assert_eq!(
        solve(
            Method::AnalyticCentre,
            &wide,
            &SVector::<f64, 3>::zeros(),
            &TensionLimits::uniform(1.0, 2.0).unwrap(),
            &PreviousCycle::NONE
        )
        .unwrap_err(),
        Error::UnsupportedShape
    );
}

#[test]
fn limits_whose_squares_overflow_are_refused_once() {
    // 1e308 N would make every pose `nonfinite`; it is refused where the
    // limits are made.
    assert_eq!(TensionLimits::<f64, 8>::uniform(1.0, 1e308).unwrap_err(), Error::InvalidLimits);
    assert_eq!(TensionLimits::<f64, 8>::uniform(1.0, 1e154).unwrap_err(), Error::InvalidLimits);
    assert!(TensionLimits::<f64, 8>::uniform(1.0, 1e150).is_ok());
    assert_eq!(TensionLimits::<f32, 8>::uniform(1.0, 1e19).unwrap_err(), Error::InvalidLimits);
    assert!(TensionLimits::<f32, 8>::uniform(1.0, 1e18).is_ok());
}

#[test]
fn inertia_must_be_symmetric_positive_semidefinite() {
    let build = |inertia: Matrix3<f64>| {
        let platform =
            Platform { mass: 1.0, com: Vector3::zeros(), gravity: Vector3::new(0.0, 0.0, -9.81), inertia };
        let (robot, _) = suspended();
        Robot::<f64, 6, 8>::new(
            RobotKind::Spatial6,
            *robot.anchors(),
            *robot.attachments(),
            *robot.limits(),
            platform,
            None,
        )
    };
    assert!(build(Matrix3::identity() * 0.01).is_ok());
    assert!(build(Matrix3::zeros()).is_ok(), "a point mass");
    for bad in [
        Matrix3::identity() * -0.01,
        Matrix3::from_diagonal(&Vector3::new(0.01, 0.01, -0.001)),
        // Symmetric with positive diagonal but indefinite.
        Matrix3::new(0.01, 0.02, 0.0, 0.02, 0.01, 0.0, 0.0, 0.0, 0.01),
        // Not symmetric.
        Matrix3::new(0.01, 0.005, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.01),
    ] {
        assert_eq!(build(bad).unwrap_err(), Error::InvalidLimits, "{bad}");
    }
}
