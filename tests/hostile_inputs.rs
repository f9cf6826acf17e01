//! Hostile inputs: NaN, infinities, arbitrary bit patterns, zero-length
//! cables, coincident anchors, huge coordinates, bad limits. Every call
//! returns a typed error or a valid answer; nothing panics or hangs.

use cdpr_integration_tests::shipped_robot;
use nalgebra::{Matrix3, SMatrix, SVector, Vector2, Vector3};
use proptest::prelude::*;
use tension_core::{
    analytic_centre, barycenter, polygon::FeasiblePolygon, Error, Method, Platform, Real, Robot, RobotKind,
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

/// Every method on a robot built from the given numbers: a typed error or a
/// tension vector that balances the wrench within the limits.
fn exercise<T: Real + std::fmt::Debug, const N: usize, const M: usize>(kind: RobotKind, numbers: &[T]) {
    let v = |k: usize| Vector3::new(numbers[k], numbers[k + 1], numbers[k + 2]);
    let anchors: [Vector3<T>; M] = core::array::from_fn(|i| v(3 * i));
    let attach: [Vector3<T>; M] = core::array::from_fn(|i| v(3 * M + 3 * i));
    let base = 6 * M;
    let pose = SVector::<T, N>::from_fn(|i, _| numbers[base + i]);
    let extra = SVector::<T, N>::from_fn(|i, _| numbers[base + N + i]);
    let (lo, hi) = (numbers[base + 2 * N], numbers[base + 2 * N + 1]);
    let Ok(limits) = TensionLimits::uniform(lo, hi) else {
        return;
    };
    let platform = Platform {
        mass: numbers[base + 2 * N + 2],
        com: v(base + 2 * N + 3),
        gravity: Vector3::new(T::zero(), T::zero(), T::lit(-9.81)),
        inertia: Matrix3::identity() * T::lit(0.01),
    };
    let Ok(robot) = Robot::<T, N, M>::new(kind, anchors, attach, limits, platform, None) else {
        return;
    };
    let Ok(w) = robot.wrench_matrix(&pose) else {
        return;
    };
    let Ok(f) = robot.required_wrench(&pose, &extra, None) else {
        return;
    };
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
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    #[test]
    fn arbitrary_bits_spatial_f64(numbers in prop::collection::vec(hostile_f64(), 6 * 8 + 12 + 6)) {
        exercise::<f64, 6, 8>(RobotKind::Spatial6, &numbers);
    }

    #[test]
    fn arbitrary_bits_spatial_f32(numbers in prop::collection::vec(hostile_f32(), 6 * 8 + 12 + 6)) {
        exercise::<f32, 6, 8>(RobotKind::Spatial6, &numbers);
    }

    #[test]
    fn arbitrary_bits_planar3_f64(numbers in prop::collection::vec(hostile_f64(), 6 * 5 + 6 + 6)) {
        exercise::<f64, 3, 5>(RobotKind::Planar3, &numbers);
    }

    #[test]
    fn arbitrary_bits_planar2_f32(numbers in prop::collection::vec(hostile_f32(), 6 * 4 + 4 + 6)) {
        exercise::<f32, 2, 4>(RobotKind::Planar2, &numbers);
    }

    #[test]
    fn arbitrary_wrench_matrices(entries in prop::collection::vec(hostile_f64(), 6 * 8 + 6 + 8)) {
        let w = SMatrix::<f64, 6, 8>::from_fn(|i, j| entries[i * 8 + j]);
        let f = SVector::<f64, 6>::from_fn(|i, _| entries[48 + i]);
        let start = SVector::<f64, 8>::from_fn(|i, _| entries[54 + i]);
        let limits = TensionLimits::uniform(1.0, 100.0).unwrap();
        for method in Method::ALL {
            let _ = TensionSolver::<f64, 8>::new(method).solve(&w, &f, &limits);
        }
        let _ = analytic_centre(&w, &f, &limits, Some(&start));
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
    assert_eq!(barycenter(&w_bad, &f.map(|_| 1.0), robot.limits(), None).unwrap_err(), Error::NonFinite);
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
    assert_eq!(barycenter(&w, &f, &limits, None).unwrap_err(), Error::UnsupportedShape);
    assert!(!Method::Barycenter.supports(6, 9));
    assert!(Method::AnalyticCentre.supports(6, 9));
    let wide = SMatrix::<f64, 3, 2>::zeros();
    assert_eq!(
        analytic_centre(&wide, &SVector::<f64, 3>::zeros(), &TensionLimits::uniform(1.0, 2.0).unwrap(), None)
            .unwrap_err(),
        Error::UnsupportedShape
    );
}
