//! Forward kinematics (`Robot::forward_kinematics`, issue 13 part 1) checked
//! against lengths computed here independently (nalgebra's `Rotation3`
//! from axis angles, not `tension-core`'s frames): round trips on every
//! shipped robot and on random robots, warm and cold, in f64 and f32;
//! encoder quantisation and noise within the bound `|J^+| |dL|` (J by finite
//! differences, its pseudo-inverse norm by nalgebra's SVD, host side only);
//! the cold start over a grid of the stated region, the mirror pose of
//! suspended-8; the Jacobian's sign; hostile inputs; a warm-started
//! trajectory; lengths that no pose has (one cable stretched or slack).

use cdpr_integration_tests::{persisted_config, shipped_robot};
use nalgebra::{DMatrix, Matrix3, Rotation3, SMatrix, SVector, Vector3};
use proptest::prelude::*;
use tension_core::{ForwardError, ForwardSettings, Platform, Real, Robot, RobotKind, TensionLimits};

/// `(p, R)` of a pose by the conventions, from axis-angle rotations.
fn frame<const N: usize>(kind: RobotKind, pose: &SVector<f64, N>) -> (Vector3<f64>, Matrix3<f64>) {
    let rot =
        |axis: Vector3<f64>, a: f64| Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), a);
    match kind {
        RobotKind::Spatial6 => (
            Vector3::new(pose[0], pose[1], pose[2]),
            (rot(Vector3::x(), pose[3]) * rot(Vector3::y(), pose[4]) * rot(Vector3::z(), pose[5]))
                .into_inner(),
        ),
        RobotKind::Planar3 => (Vector3::new(pose[0], pose[1], 0.0), rot(Vector3::z(), pose[2]).into_inner()),
        RobotKind::Planar2 => (Vector3::new(pose[0], pose[1], 0.0), Matrix3::zeros()),
    }
}

fn to64<T: Real>(v: &Vector3<T>) -> Vector3<f64> {
    v.map(|x| x.to_subset().expect("real"))
}

/// Cable lengths at a pose (f64), computed here.
fn lengths_of<T: Real, const N: usize, const M: usize>(
    robot: &Robot<T, N, M>,
    pose: &SVector<f64, N>,
) -> SVector<f64, M> {
    let (p, r) = frame(robot.kind(), pose);
    SVector::from_fn(|i, _| {
        let mut l = to64(&robot.anchors()[i]) - p - r * to64(&robot.attachments()[i]);
        if robot.kind() != RobotKind::Spatial6 {
            l.z = 0.0;
        }
        l.norm()
    })
}

fn cast<T: Real, const K: usize>(v: &SVector<f64, K>) -> SVector<T, K> {
    v.map(T::lit)
}

fn back<T: Real, const K: usize>(v: &SVector<T, K>) -> SVector<f64, K> {
    v.map(|x| x.to_subset().expect("real"))
}

/// The magnitude of the robot's coordinates, what rounding scales with
/// (largest anchor or attachment coordinate, or side of the anchors' box).
fn size<T: Real, const N: usize, const M: usize>(robot: &Robot<T, N, M>) -> f64 {
    let (mut lo, mut hi) = (to64(&robot.anchors()[0]), to64(&robot.anchors()[0]));
    let mut s: f64 = 0.0;
    for i in 0..M {
        let a = to64(&robot.anchors()[i]);
        s = s.max(a.amax()).max(to64(&robot.attachments()[i]).amax());
        lo = lo.inf(&a);
        hi = hi.sup(&a);
    }
    s.max((hi - lo).amax())
}

/// Pose error: positions in m, angles in rad, angles compared modulo 2 pi.
fn pose_error<const N: usize>(kind: RobotKind, a: &SVector<f64, N>, b: &SVector<f64, N>) -> f64 {
    let first_angle = match kind {
        RobotKind::Spatial6 => 3,
        RobotKind::Planar3 => 2,
        RobotKind::Planar2 => N,
    };
    (0..N)
        .map(|k| {
            let d = a[k] - b[k];
            if k >= first_angle {
                (d - std::f64::consts::TAU * (d / std::f64::consts::TAU).round()).abs()
            } else {
                d.abs()
            }
        })
        .fold(0.0, f64::max)
}

/// The anchors' box with a flat axis reaching to the floor, as documented.
fn region<T: Real, const N: usize, const M: usize>(robot: &Robot<T, N, M>) -> (Vector3<f64>, Vector3<f64>) {
    let (mut lo, mut hi) = (to64(&robot.anchors()[0]), to64(&robot.anchors()[0]));
    for a in robot.anchors() {
        lo = lo.inf(&to64(a));
        hi = hi.sup(&to64(a));
    }
    let widest = (hi - lo).amax();
    for k in 0..3 {
        if hi[k] - lo[k] <= 0.1 * widest && (hi[k] + lo[k]) / 2.0 > 0.1 * widest {
            lo[k] = 0.0;
        }
    }
    (lo, hi)
}

const SHIPPED_SPATIAL8: [&str; 3] = ["suspended-8", "ipanema1", "cogiro"];

/// A pose in the middle part of the region: the box shrunk by `margin` of
/// each side, `u` in `[0, 1]^3`, angles as given.
fn pose_in<T: Real, const N: usize, const M: usize>(
    robot: &Robot<T, N, M>,
    margin: f64,
    u: [f64; 3],
    angles: [f64; 3],
) -> SVector<f64, N> {
    let (lo, hi) = region(robot);
    let at = |k: usize| lo[k] + (hi[k] - lo[k]) * (margin + (1.0 - 2.0 * margin) * u[k]);
    let b_mean: Vector3<f64> = robot.attachments().iter().map(to64).sum::<Vector3<f64>>() / M as f64;
    let mut pose = SVector::<f64, N>::zeros();
    match robot.kind() {
        RobotKind::Spatial6 => {
            // The attachments' centroid at the grid point.
            let angles6 = SVector::<f64, 6>::new(0.0, 0.0, 0.0, angles[0], angles[1], angles[2]);
            let (_, r) = frame(RobotKind::Spatial6, &angles6);
            let p = Vector3::new(at(0), at(1), at(2)) - r * b_mean;
            for k in 0..3 {
                pose[k] = p[k];
                pose[k + 3] = angles[k];
            }
        }
        RobotKind::Planar3 => {
            pose[0] = at(0);
            pose[1] = at(1);
            pose[2] = angles[2];
        }
        RobotKind::Planar2 => {
            pose[0] = at(0);
            pose[1] = at(1);
        }
    }
    pose
}

// ---------------------------------------------------------------- (1)

/// The accuracy asserted: f64, 1e-9 (m, rad); f32, `2 |J^+|_2 (tolerance +
/// 16 eps s)` with `s` the robot's size: the stopping tolerance (`32 eps s`)
/// and the lengths' own rounding, mapped to the pose by the Jacobian's
/// pseudo-inverse (computed here by finite differences and SVD). For
/// suspended-8 (s = 4 m) that is 4.6e-5 times `|J^+|_2` (1.5 to 12 over the
/// region).
fn accuracy<T: Real, const N: usize, const M: usize>(robot: &Robot<T, N, M>, truth: &SVector<f64, N>) -> f64 {
    let eps = back(&SVector::<T, 1>::new(T::eps()))[0];
    if eps < 1e-10 {
        1e-9
    } else {
        2.0 * pinv_norm(&numeric_jacobian(robot, truth)) * 48.0 * eps * size(robot)
    }
}

fn round_trip<T: Real, const N: usize, const M: usize>(
    robot: &Robot<T, N, M>,
    truth: &SVector<f64, N>,
    guess: &SVector<f64, N>,
) -> Result<(f64, f64), TestCaseError> {
    let settings = ForwardSettings::for_robot(robot);
    let lengths = cast::<T, M>(&lengths_of(robot, truth));
    let bound = accuracy(robot, truth);
    let mut errors = (0.0, 0.0);
    for (warm, slot) in [(true, 0), (false, 1)] {
        let g = cast::<T, N>(guess);
        let sol = robot
            .forward_kinematics(&lengths, warm.then_some(&g), &settings)
            .map_err(|e| TestCaseError::fail(format!("{e} at {truth:?} (warm {warm})")))?;
        let err = pose_error(robot.kind(), &back(&sol.pose), truth);
        prop_assert!(
            err <= bound,
            "error {err} > {bound} at {truth:?} warm {warm}: {:?} worst {} cond {} it {}",
            sol.pose,
            sol.worst,
            sol.condition,
            sol.iterations
        );
        prop_assert!(sol.worst <= settings.consistency);
        if slot == 0 {
            prop_assert!(!sol.cold_started, "the warm start did not hold at {truth:?}");
            errors.0 = err;
        } else {
            prop_assert!(sol.cold_started);
            errors.1 = err;
        }
    }
    Ok(errors)
}

fn unit3() -> impl Strategy<Value = [f64; 3]> {
    [0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0]
}

fn tilt() -> impl Strategy<Value = [f64; 3]> {
    [-0.3f64..0.3, -0.3f64..0.3, -0.5f64..0.5]
}

fn perturbation() -> impl Strategy<Value = [f64; 6]> {
    [-0.005f64..0.005, -0.005f64..0.005, -0.005f64..0.005, -0.01f64..0.01, -0.01f64..0.01, -0.01f64..0.01]
}

fn perturbed<const N: usize>(pose: &SVector<f64, N>, d: &[f64; 6]) -> SVector<f64, N> {
    SVector::from_fn(|k, _| pose[k] + d[k])
}

proptest! {
    #![proptest_config(persisted_config(64, file!()))]

    #[test]
    fn inverse_then_forward_on_the_shipped_robots(u in unit3(), angles in tilt(), d in perturbation()) {
        for name in SHIPPED_SPATIAL8 {
            let r64: Robot<f64, 6, 8> = shipped_robot(name);
            let r32: Robot<f32, 6, 8> = shipped_robot(name);
            let truth = pose_in(&r64, 0.1, u, angles);
            round_trip(&r64, &truth, &perturbed(&truth, &d))?;
            round_trip(&r32, &truth, &perturbed(&truth, &d))?;
        }
        let r64: Robot<f64, 6, 10> = shipped_robot("spatial6-10");
        let r32: Robot<f32, 6, 10> = shipped_robot("spatial6-10");
        let truth = pose_in(&r64, 0.1, u, angles);
        round_trip(&r64, &truth, &perturbed(&truth, &d))?;
        round_trip(&r32, &truth, &perturbed(&truth, &d))?;
        let angles3 = [0.0, 0.0, angles[2] * 2.0 * std::f64::consts::PI];
        let r64: Robot<f64, 3, 5> = shipped_robot("planar3-5");
        let r32: Robot<f32, 3, 5> = shipped_robot("planar3-5");
        let truth = pose_in(&r64, 0.1, u, angles3);
        round_trip(&r64, &truth, &perturbed(&truth, &d))?;
        round_trip(&r32, &truth, &perturbed(&truth, &d))?;
        let r64: Robot<f64, 2, 4> = shipped_robot("planar-point-4");
        let r32: Robot<f32, 2, 4> = shipped_robot("planar-point-4");
        let truth = pose_in(&r64, 0.1, u, angles);
        round_trip(&r64, &truth, &perturbed(&truth, &d))?;
        round_trip(&r32, &truth, &perturbed(&truth, &d))?;
    }

    /// Random robots: anchors near the corners of a 4 x 3 x 2.5 m box (each
    /// moved by up to 0.3 m), attachments on a 0.1 to 0.3 m platform.
    #[test]
    fn inverse_then_forward_on_random_robots(
        jitter in prop::collection::vec(-0.3f64..0.3, 48),
        radius in 0.1f64..0.3,
        u in unit3(),
        angles in tilt(),
        d in perturbation(),
    ) {
        let corners: [[f64; 3]; 8] = [
            [-2.0, -1.5, 0.0], [2.0, -1.5, 0.0], [2.0, 1.5, 0.0], [-2.0, 1.5, 0.0],
            [-2.0, -1.5, 2.5], [2.0, -1.5, 2.5], [2.0, 1.5, 2.5], [-2.0, 1.5, 2.5],
        ];
        let anchors: [Vector3<f64>; 8] = std::array::from_fn(|i| {
            Vector3::new(corners[i][0] + jitter[3 * i], corners[i][1] + jitter[3 * i + 1], corners[i][2] + jitter[3 * i + 2])
        });
        let attach: [Vector3<f64>; 8] = std::array::from_fn(|i| {
            let c = corners[i];
            Vector3::new(c[0].signum() * radius, c[1].signum() * radius, (c[2] - 1.25).signum() * radius * 0.5)
                + Vector3::new(jitter[24 + 3 * i], jitter[25 + 3 * i], jitter[26 + 3 * i]) * 0.1
        });
        let r64 = robot_from(RobotKind::Spatial6, anchors, attach);
        let r32: Robot<f32, 6, 8> = robot_from(
            RobotKind::Spatial6,
            anchors.map(|a| a.map(|x| x as f32)),
            attach.map(|a| a.map(|x| x as f32)),
        );
        let truth = pose_in(&r64, 0.2, u, angles);
        round_trip(&r64, &truth, &perturbed(&truth, &d))?;
        round_trip(&r32, &truth, &perturbed(&truth, &d))?;
    }
}

fn robot_from<T: Real, const N: usize, const M: usize>(
    kind: RobotKind,
    anchors: [Vector3<T>; M],
    attach: [Vector3<T>; M],
) -> Robot<T, N, M> {
    let platform = Platform {
        mass: T::one(),
        com: Vector3::zeros(),
        gravity: Vector3::new(T::zero(), T::zero(), T::lit(-9.81)),
        inertia: Matrix3::zeros(),
    };
    Robot::new(
        kind,
        anchors,
        attach,
        TensionLimits::uniform(T::one(), T::lit(100.0)).unwrap(),
        platform,
        None,
    )
    .unwrap()
}

// ---------------------------------------------------------------- (2)

/// `J = dl/dx` by central differences of [`lengths_of`] (independent of the
/// code under test).
fn numeric_jacobian<T: Real, const N: usize, const M: usize>(
    robot: &Robot<T, N, M>,
    pose: &SVector<f64, N>,
) -> SMatrix<f64, M, N> {
    let h = 1e-6;
    let mut j = SMatrix::<f64, M, N>::zeros();
    for k in 0..N {
        let mut plus = *pose;
        let mut minus = *pose;
        plus[k] += h;
        minus[k] -= h;
        j.set_column(k, &((lengths_of(robot, &plus) - lengths_of(robot, &minus)) / (2.0 * h)));
    }
    j
}

/// `|J^+|_2 = 1 / sigma_min(J)` by nalgebra's SVD (host test, finite input).
fn pinv_norm<const N: usize, const M: usize>(j: &SMatrix<f64, M, N>) -> f64 {
    let d = DMatrix::from_fn(M, N, |r, c| j[(r, c)]);
    let sv = d.svd(false, false).singular_values;
    1.0 / sv.iter().copied().fold(f64::INFINITY, f64::min)
}

/// Suspended-8's winch: drum radius 0.04 m, gear 8, an encoder of 4096 x 4
/// counts per motor turn: one count is `2 pi r / (cpr G)` = 1.9e-6 m of
/// cable. Lengths quantised to counts and with noise of about two counts
/// (the sum of four uniforms, standard deviation 2 counts, at most 6.9):
/// the pose error within `|J^+|_2 |dL|_2` (first order, plus 5 % and the
/// rounding) in f64, and in f32 plus its own 2e-5 s.
#[test]
fn encoder_quantisation_and_noise_stay_within_the_jacobian_bound() {
    let r64: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let r32: Robot<f32, 6, 8> = shipped_robot("suspended-8");
    let count = 2.0 * std::f64::consts::PI * 0.04 / (4096.0 * 4.0 * 8.0);
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut checked, mut worst_ratio) = (0, 0.0f64);
    for ix in 0..4 {
        for iz in 0..4 {
            let u = [0.15 + 0.7 * ix as f64 / 3.0, 0.5, 0.15 + 0.7 * iz as f64 / 3.0];
            let truth = pose_in(&r64, 0.1, u, [0.1, -0.15, 0.2]);
            let exact = lengths_of(&r64, &truth);
            let j = numeric_jacobian(&r64, &truth);
            let pinv = pinv_norm(&j);
            for _ in 0..10 {
                let measured = exact.map(|l| {
                    let noise: f64 = (0..4).map(|_| uniform() - 0.5).sum::<f64>() * 2.0 * 3.0f64.sqrt();
                    ((l / count).round() + (noise * 2.0).round()) * count
                });
                let dl = (measured - exact).norm();
                let bound = pinv * dl * 1.05 + 1e-12;
                let s64 = r64.forward_kinematics(&measured, Some(&truth), &ForwardSettings::for_robot(&r64));
                let s64 = s64.expect("noisy lengths are consistent");
                let e64 = (s64.pose - truth).norm();
                assert!(e64 <= bound, "f64 error {e64} > bound {bound}");
                let s32 = r32
                    .forward_kinematics(
                        &cast(&measured),
                        Some(&cast(&truth)),
                        &ForwardSettings::for_robot(&r32),
                    )
                    .expect("noisy lengths are consistent in f32");
                let e32 = (back(&s32.pose) - truth).norm();
                assert!(e32 <= bound + 2e-5 * 4.0, "f32 error {e32} > bound {bound}");
                worst_ratio = worst_ratio.max(e64 / (pinv * dl));
                checked += 1;
            }
        }
    }
    println!("noise: {checked} cases, worst f64 error / (|J+| |dL|) = {worst_ratio:.3}");
    assert_eq!(checked, 160);
}

// ---------------------------------------------------------------- (3)

/// Every pose of the grid found by the cold start within [`accuracy`]. Counts
/// printed and asserted.
fn cold_grid<T: Real, const N: usize, const M: usize>(
    robot: &Robot<T, N, M>,
    cells: usize,
    angles: &[[f64; 3]],
) -> (usize, u32) {
    let settings = ForwardSettings::for_robot(robot);
    let (mut found, mut worst_iterations) = (0, 0);
    let zs = if robot.kind() == RobotKind::Spatial6 { cells } else { 1 };
    for ix in 0..cells {
        for iy in 0..cells {
            for iz in 0..zs {
                let f = |i: usize| if cells == 1 { 0.5 } else { i as f64 / (cells - 1) as f64 };
                for a in angles {
                    let truth = pose_in(robot, 0.1, [f(ix), f(iy), f(iz)], *a);
                    let lengths = cast::<T, M>(&lengths_of(robot, &truth));
                    let sol = robot
                        .forward_kinematics(&lengths, None, &settings)
                        .unwrap_or_else(|e| panic!("{e} at {truth:?}"));
                    let err = pose_error(robot.kind(), &back(&sol.pose), &truth);
                    assert!(err <= accuracy(robot, &truth), "cold start found {:?} for {truth:?}", sol.pose);
                    worst_iterations = worst_iterations.max(sol.iterations);
                    found += 1;
                }
            }
        }
    }
    (found, worst_iterations)
}

fn spatial_angles() -> Vec<[f64; 3]> {
    let mut v = Vec::new();
    for rx in [-0.3, 0.0, 0.3] {
        for ry in [-0.3, 0.0, 0.3] {
            for rz in [-0.5, 0.0, 0.5] {
                v.push([rx, ry, rz]);
            }
        }
    }
    v
}

#[test]
fn cold_start_finds_every_pose_of_the_stated_region() {
    let angles = spatial_angles();
    let mut total = 0;
    for name in SHIPPED_SPATIAL8 {
        let robot: Robot<f64, 6, 8> = shipped_robot(name);
        let (n, it) = cold_grid(&robot, 5, &angles);
        println!("cold start {name}: {n} of {n} grid poses found, at most {it} iterations");
        assert_eq!(n, 3375);
        total += n;
    }
    let robot: Robot<f64, 6, 10> = shipped_robot("spatial6-10");
    let (n, it) = cold_grid(&robot, 5, &angles);
    println!("cold start spatial6-10: {n} of {n} grid poses found, at most {it} iterations");
    assert_eq!(n, 3375);
    total += n;
    let thetas: Vec<[f64; 3]> =
        (0..9).map(|k| [0.0, 0.0, -std::f64::consts::PI + k as f64 * std::f64::consts::TAU / 9.0]).collect();
    let robot: Robot<f64, 3, 5> = shipped_robot("planar3-5");
    let (n, it) = cold_grid(&robot, 9, &thetas);
    println!("cold start planar3-5: {n} of {n} grid poses found, at most {it} iterations");
    assert_eq!(n, 729);
    total += n;
    let robot: Robot<f64, 2, 4> = shipped_robot("planar-point-4");
    let (n, it) = cold_grid(&robot, 9, &[[0.0; 3]]);
    println!("cold start planar-point-4: {n} of {n} grid poses found, at most {it} iterations");
    assert_eq!(n, 81);
    total += n;
    // f32 on suspended-8 and planar3-5.
    let robot: Robot<f32, 6, 8> = shipped_robot("suspended-8");
    let (n, _) = cold_grid(&robot, 5, &angles);
    assert_eq!(n, 3375);
    total += n;
    let robot: Robot<f32, 3, 5> = shipped_robot("planar3-5");
    let (n, _) = cold_grid(&robot, 9, &thetas);
    assert_eq!(n, 729);
    total += n;
    println!("cold start: {total} grid poses in all");
    assert_eq!(total, 4 * 3375 + 729 + 81 + 3375 + 729);
}

/// Suspended-8's anchors are all at z = 3.5 and its attachments all at
/// z = 0.15: the reflection through the anchors' plane gives a pose above
/// them with the same lengths (`R' = D R D`, `D = diag(1, 1, -1)`,
/// `p' = D p + 7 e_z - 0.3 R' e_z`). The cold start, and a warm start from
/// the mirror itself, return the pose below.
#[test]
fn mirror_pose_of_suspended_8_is_never_returned() {
    let robot: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let settings = ForwardSettings::for_robot(&robot);
    let d = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
    let mut checked = 0;
    for (u, angles) in [
        ([0.5, 0.5, 0.5], [0.0, 0.0, 0.0]),
        ([0.2, 0.7, 0.8], [0.2, -0.1, 0.4]),
        ([0.9, 0.1, 0.3], [-0.3, 0.3, -0.5]),
    ] {
        let truth = pose_in(&robot, 0.1, u, angles);
        let (p, r) = frame(RobotKind::Spatial6, &truth);
        let r_m = d * r * d;
        let p_m = d * p + Vector3::new(0.0, 0.0, 7.0) - r_m * Vector3::new(0.0, 0.0, 0.3);
        let rot = Rotation3::from_matrix(&r_m);
        let (a, b, c) = euler_xyz(rot.matrix());
        let mirror = SVector::<f64, 6>::new(p_m.x, p_m.y, p_m.z, a, b, c);
        let (lt, lm) = (lengths_of(&robot, &truth), lengths_of(&robot, &mirror));
        assert!((lt - lm).amax() < 1e-12, "not a mirror: {lt:?} vs {lm:?}");
        assert!(mirror[2] > 3.5);
        for warm in [None, Some(&mirror)] {
            let sol = robot.forward_kinematics(&lt, warm, &settings).unwrap();
            assert!(pose_error(RobotKind::Spatial6, &sol.pose, &truth) < 1e-9, "{:?}", sol.pose);
            assert!(sol.cold_started);
            checked += 1;
        }
    }
    assert_eq!(checked, 6);
}

/// XYZ Euler angles of `R = Rx(a) Ry(b) Rz(c)`, `|b| < pi/2`.
fn euler_xyz(r: &Matrix3<f64>) -> (f64, f64, f64) {
    let b = r[(0, 2)].clamp(-1.0, 1.0).asin();
    let a = (-r[(1, 2)]).atan2(r[(2, 2)]);
    let c = (-r[(0, 1)]).atan2(r[(0, 0)]);
    (a, b, c)
}

// ---------------------------------------------------------------- (4)

/// `J = dl/dx` against central differences of the lengths, and against
/// `-W^T diag(I, E)` with `E = [e_x, Rx e_y, Rx Ry e_z]` written here.
#[test]
fn jacobian_sign_matches_finite_differences() {
    let mut checked = 0;
    for name in SHIPPED_SPATIAL8 {
        let robot: Robot<f64, 6, 8> = shipped_robot(name);
        for pose in [
            pose_in(&robot, 0.1, [0.3, 0.6, 0.4], [0.2, -0.25, 0.4]),
            pose_in(&robot, 0.1, [0.7, 0.2, 0.8], [-0.3, 0.1, -0.5]),
        ] {
            let j = robot.length_jacobian(&pose).unwrap();
            let fd = numeric_jacobian(&robot, &pose);
            assert!((j - fd).amax() < 1e-7, "{name}: {j} vs {fd}");
            // lengthening along +z moves... the sign: d l / d z = -u_z.
            let w = robot.wrench_matrix(&pose).unwrap();
            let (a, b) = (pose[3], pose[4]);
            let e = Matrix3::from_columns(&[
                Vector3::x(),
                Vector3::new(0.0, a.cos(), a.sin()),
                Vector3::new(b.sin(), -a.sin() * b.cos(), a.cos() * b.cos()),
            ]);
            let mut map = SMatrix::<f64, 6, 6>::identity();
            map.fixed_view_mut::<3, 3>(3, 3).copy_from(&e);
            assert!((j + w.transpose() * map).amax() < 1e-12);
            checked += 1;
        }
    }
    let planar: Robot<f64, 3, 5> = shipped_robot("planar3-5");
    let pose = SVector::<f64, 3>::new(1.5, 1.2, 0.4);
    let j = planar.length_jacobian(&pose).unwrap();
    assert!((j - numeric_jacobian(&planar, &pose)).amax() < 1e-7);
    assert!((j + planar.wrench_matrix(&pose).unwrap().transpose()).amax() < 1e-12);
    let point: Robot<f64, 2, 4> = shipped_robot("planar-point-4");
    let pose = SVector::<f64, 2>::new(1.0, 2.0);
    let j = point.length_jacobian(&pose).unwrap();
    assert!((j - numeric_jacobian(&point, &pose)).amax() < 1e-7);
    checked += 2;
    // The sign by hand: suspended-8 moved straight down lengthens every cable.
    let robot: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let j = robot.length_jacobian(&SVector::<f64, 6>::new(0.0, 0.0, 1.5, 0.0, 0.0, 0.0)).unwrap();
    assert!(j.column(2).iter().all(|&v| v < 0.0), "d l / d z must be negative below the anchors");
    checked += 1;
    assert_eq!(checked, 9);
}

// ---------------------------------------------------------------- (5)

/// Hostile inputs: typed errors, never a panic, never `ok` with a residual
/// above the consistency threshold. Counts the cases that reached their
/// asserts.
#[test]
fn hostile_inputs_give_typed_errors() {
    let robot: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let r32: Robot<f32, 6, 8> = shipped_robot("suspended-8");
    let settings = ForwardSettings::for_robot(&robot);
    let truth = pose_in(&robot, 0.1, [0.4, 0.6, 0.5], [0.1, 0.05, -0.2]);
    let good = lengths_of(&robot, &truth);
    let mut reached = 0;
    let mut expect = |result: Result<_, ForwardError>, allowed: &[ForwardError], what: &str| {
        match result {
            Ok(sol) => {
                let sol: tension_core::ForwardSolution<f64, 6, 8> = sol;
                panic!("{what}: ok with worst residual {}", sol.worst);
            }
            Err(e) => assert!(allowed.contains(&e), "{what}: {e}"),
        }
        reached += 1;
    };
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -0.1] {
        let mut l = good;
        l[3] = bad;
        expect(robot.forward_kinematics(&l, None, &settings), &[ForwardError::NonFinite], "bad length");
        expect(
            robot.forward_kinematics(&l, Some(&truth), &settings),
            &[ForwardError::NonFinite],
            "bad length",
        );
        let mut guess = truth;
        guess[4] = bad;
        if bad.is_finite() {
            continue;
        }
        expect(
            robot.forward_kinematics(&good, Some(&guess), &settings),
            &[ForwardError::NonFinite],
            "bad guess",
        );
    }
    // One cable 5 cm longer than the pose's: no pose has these lengths.
    for cable in 0..8 {
        let mut l = good;
        l[cable] += 0.05;
        let inconsistent = [ForwardError::InconsistentLengths, ForwardError::NoConvergence];
        expect(robot.forward_kinematics(&l, Some(&truth), &settings), &inconsistent, "5 cm longer, warm");
        expect(robot.forward_kinematics(&l, None, &settings), &inconsistent, "5 cm longer, cold");
        let attempt = robot.forward_kinematics_attempt(&l, Some(&truth), &settings).unwrap_err();
        assert_eq!(attempt.error, ForwardError::InconsistentLengths, "cable {cable}");
        assert!(attempt.closest.unwrap().worst > settings.consistency);
    }
    let any_failure =
        [ForwardError::InconsistentLengths, ForwardError::NoConvergence, ForwardError::IllConditioned];
    expect(robot.forward_kinematics(&SVector::zeros(), None, &settings), &any_failure, "all-zero lengths");
    expect(robot.forward_kinematics(&SVector::repeat(1e30), None, &settings), &any_failure, "huge lengths");
    expect(robot.forward_kinematics(&SVector::repeat(1e300), Some(&truth), &settings), &any_failure, "huge");
    expect(robot.forward_kinematics(&SVector::repeat(f64::MAX), None, &settings), &any_failure, "f64::MAX");
    // f32 overflow.
    let r = r32.forward_kinematics(&SVector::repeat(1e30f32), None, &ForwardSettings::for_robot(&r32));
    assert!(r.is_err());
    reached += 1;
    // A degenerate robot: every anchor at one point (rotation and position
    // along the cables unobservable).
    let degenerate: Robot<f64, 6, 8> =
        robot_from(RobotKind::Spatial6, [Vector3::new(0.0, 0.0, 3.0); 8], *robot.attachments());
    let l = lengths_of(&degenerate, &truth);
    let r = degenerate.forward_kinematics(&l, None, &ForwardSettings::for_robot(&degenerate));
    assert!(matches!(r, Err(ForwardError::IllConditioned | ForwardError::NoConvergence)), "{r:?}");
    reached += 1;
    // A pose at the gimbal lock of the Euler angles (ry = pi/2).
    let lock = SVector::<f64, 6>::new(0.0, 0.0, 1.5, 0.2, std::f64::consts::FRAC_PI_2, 0.1);
    let r = robot.forward_kinematics(&lengths_of(&robot, &lock), Some(&lock), &settings);
    assert!(matches!(r, Err(ForwardError::IllConditioned) | Ok(_)), "{r:?}");
    if let Ok(sol) = r {
        assert!(sol.condition <= settings.condition_max && sol.worst <= settings.consistency);
    }
    reached += 1;
    println!("hostile: {reached} cases reached their asserts");
    assert_eq!(reached, 4 * 2 + 3 + 16 + 4 + 3);
}

proptest! {
    #![proptest_config(persisted_config(256, file!()))]

    /// Any finite lengths and guess: an error, or a pose whose lengths
    /// (computed here) match within the consistency threshold.
    #[test]
    fn random_lengths_are_never_ok_with_a_large_residual(
        lengths in prop::collection::vec(prop_oneof![0.0f64..6.0, 0.0f64..1e6, Just(0.0)], 8),
        guess in prop::collection::vec(-5.0f64..5.0, 6),
        warm in any::<bool>(),
    ) {
        let robot: Robot<f64, 6, 8> = shipped_robot("suspended-8");
        let settings = ForwardSettings::for_robot(&robot);
        let l = SVector::<f64, 8>::from_column_slice(&lengths);
        let g = SVector::<f64, 6>::from_column_slice(&guess);
        if let Ok(sol) = robot.forward_kinematics(&l, warm.then_some(&g), &settings) {
            let worst = (lengths_of(&robot, &sol.pose) - l).amax();
            prop_assert!(worst <= settings.consistency * 1.001, "ok with residual {worst}");
        }
    }
}

// ---------------------------------------------------------------- (6)

/// A smooth 2 s trajectory at 1 kHz on suspended-8, each row warm-started
/// from the previous answer: every row ok, the warm start held, the pose
/// within 1e-9 (f64) / 2e-5 s (f32), and at most 3 iterations a row.
#[test]
fn warm_started_trajectory_is_continuous() {
    let r64: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let r32: Robot<f32, 6, 8> = shipped_robot("suspended-8");
    let (s64, s32) = (ForwardSettings::for_robot(&r64), ForwardSettings::for_robot(&r32));
    let pose_at = |t: f64| {
        let w = std::f64::consts::PI * t;
        SVector::<f64, 6>::new(
            1.2 * w.sin(),
            0.8 * (2.0 * w).sin(),
            1.8 + 0.6 * w.cos(),
            0.2 * w.sin(),
            -0.15 * w.cos(),
            0.4 * w.sin(),
        )
    };
    let mut prev64 = pose_at(0.0);
    let mut prev32 = cast::<f32, 6>(&prev64);
    let (mut rows, mut most) = (0, (0, 0));
    for k in 1..=2000 {
        let truth = pose_at(k as f64 / 1000.0);
        let l = lengths_of(&r64, &truth);
        let a = r64.forward_kinematics(&l, Some(&prev64), &s64).unwrap();
        assert!(!a.cold_started && (a.pose - truth).amax() < 1e-9, "row {k}");
        let b = r32.forward_kinematics(&cast(&l), Some(&prev32), &s32).unwrap();
        assert!(!b.cold_started && (back(&b.pose) - truth).amax() < 8e-5, "row {k} f32");
        // Continuity: consecutive answers differ as the truth does.
        assert!((a.pose - prev64).amax() < 0.01);
        most = (most.0.max(a.iterations), most.1.max(b.iterations));
        prev64 = a.pose;
        prev32 = b.pose;
        rows += 1;
    }
    println!("trajectory: {rows} rows, at most {} iterations (f64), {} (f32)", most.0, most.1);
    assert_eq!(rows, 2000);
    assert!(most.1 <= 2, "f32 warm path took {} iterations", most.1);
    assert!(most.0 <= 4, "f64 warm path took {} iterations", most.0);
}

// ---------------------------------------------------------------- (7)

/// The least-squares minimum of `sum r_i^2` near `from`, computed here
/// independently of the library: Gauss-Newton on a central-difference
/// Jacobian of [`lengths_of`], through an SVD, halving a step until the
/// sum falls, 400 iterations. Returns the RMS residual there.
fn least_squares_rms<T: Real>(
    robot: &Robot<T, 6, 8>,
    lengths: &SVector<f64, 8>,
    from: &SVector<f64, 6>,
) -> f64 {
    let residual = |x: &SVector<f64, 6>| lengths_of(robot, x) - lengths;
    let mut x = *from;
    let mut r = residual(&x);
    for _ in 0..400 {
        let h = 1e-7;
        let j = DMatrix::from_fn(8, 6, |i, k| {
            let mut a = x;
            let mut b = x;
            a[k] += h;
            b[k] -= h;
            (residual(&a)[i] - residual(&b)[i]) / (2.0 * h)
        });
        let rv = nalgebra::DVector::from_column_slice(r.as_slice());
        let Ok(dx) = j.svd(true, true).solve(&(-rv), 1e-12) else { break };
        let mut step = 1.0;
        let mut moved = false;
        while step > 1e-6 {
            let trial = x + SVector::<f64, 6>::from_fn(|k, _| step * dx[k]);
            let rt = residual(&trial);
            if rt.norm_squared() < r.norm_squared() {
                (x, r, moved) = (trial, rt, true);
                break;
            }
            step *= 0.5;
        }
        if !moved {
            break;
        }
    }
    (r.norm_squared() / 8.0).sqrt()
}

/// One cable stretched, slack or short by 5 cm to 50 cm at poses across the
/// workspace: no pose has those lengths, and the answer is
/// `inconsistent-lengths`, warm from the true pose and cold, in f64 and
/// f32: never `ok`, never `no-convergence`, never another error. At such
/// residuals Gauss-Newton converges only linearly and a run can meet the
/// iteration cap first: it then ends inconsistent when its last step found
/// the linear model's best residual beyond twice the consistency threshold
/// with the step within an eighth of it (`gauss_newton`). Before that
/// rule IPAnema 1 ran to the cap in 180 of 240 cases (f64) and 120 (f32),
/// suspended-8 in 16 and 4: `no-convergence`. The closest pose it reports
/// (f64, warm) is near the least-squares minimum, found here independently
/// from it: within 2 % in RMS residual.
/// Suspended-8 at its centre with cable 1 0.5 m long was `no-convergence`
/// with the absolute stopping test alone (`cdpr forward`).
#[test]
fn a_stretched_or_slack_cable_is_never_a_pose() {
    fn verdicts<T: Real>(name: &str) -> (usize, f64) {
        let robot: Robot<T, 6, 8> = shipped_robot(name);
        let settings = ForwardSettings::for_robot(&robot);
        let mut inconsistent = 0;
        let mut worst_excess = 0.0f64;
        for u in [[0.5, 0.5, 0.5], [0.2, 0.7, 0.4], [0.8, 0.3, 0.6]] {
            let truth = pose_in(&robot, 0.15, u, [0.05, -0.05, 0.1]);
            let good = lengths_of(&robot, &truth);
            for cable in 0..8 {
                for delta in [0.05, 0.2, 0.5, -0.05, -0.2] {
                    let mut l = good;
                    l[cable] += delta;
                    for warm in [Some(cast::<T, 6>(&truth)), None] {
                        match robot.forward_kinematics_attempt(&cast::<T, 8>(&l), warm.as_ref(), &settings) {
                            Err(f) if f.error == ForwardError::InconsistentLengths => {
                                inconsistent += 1;
                                let closest = f.closest.expect("the closest pose");
                                if warm.is_some() && T::eps() < T::lit(1e-10) {
                                    let reported: f64 = closest.rms.to_subset().expect("real");
                                    let minimum = least_squares_rms(&robot, &l, &back(&closest.pose));
                                    assert!(minimum <= reported * (1.0 + 1e-9));
                                    worst_excess = worst_excess.max(reported / minimum - 1.0);
                                }
                            }
                            Ok(sol) => panic!("{name}: cable {cable} {delta:+} m: ok, worst {:?}", sol.worst),
                            Err(f) => panic!("{name}: cable {cable} {delta:+} m: {}", f.error),
                        }
                    }
                }
            }
        }
        (inconsistent, worst_excess)
    }
    for name in ["suspended-8", "ipanema1"] {
        let ((c64, excess), (c32, _)) = (verdicts::<f64>(name), verdicts::<f32>(name));
        println!(
            "{name}: inconsistent-lengths f64 {c64} of 240, f32 {c32} of 240; the reported RMS at most {:.3} % above the least-squares minimum's (f64, warm)",
            100.0 * excess
        );
        assert_eq!((c64, c32), (240, 240));
        assert!(excess <= 0.02, "{name}: {excess}");
    }
    let robot: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let mut l = lengths_of(&robot, &SVector::<f64, 6>::new(0.0, 0.0, 1.5, 0.0, 0.0, 0.0));
    l[0] += 0.5;
    let failure =
        robot.forward_kinematics_attempt(&l, None, &ForwardSettings::for_robot(&robot)).unwrap_err();
    assert_eq!(failure.error, ForwardError::InconsistentLengths);
    let closest = failure.closest.unwrap();
    assert!(closest.worst > 0.1 && closest.worst < 0.5, "{:?}", closest.worst);
}

/// Where the base frame lies changes no verdict: suspended-8 and IPAnema 1
/// with their anchors moved 50 m and 30 m across gravity, one cable
/// slipped by 0.5 to 20 mm, warm and cold, give the same verdict (`f64`)
/// and, where consistent, the same pose moved. The consistency threshold
/// was 2.5e-4 of the largest coordinate, so 13 mm there against 1 mm: a
/// 5 mm slip was a pose beside the robot and a slip at home.
#[test]
fn the_base_frames_place_changes_no_verdict() {
    let shift = Vector3::new(50.0, 30.0, 0.0);
    let (mut compared, mut inconsistent) = (0, 0);
    for name in ["suspended-8", "ipanema1"] {
        let robot: Robot<f64, 6, 8> = shipped_robot(name);
        let moved = Robot::<f64, 6, 8>::new(
            robot.kind(),
            robot.anchors().map(|a| a + shift),
            *robot.attachments(),
            *robot.limits(),
            *robot.platform(),
            robot.winch().copied(),
        )
        .unwrap();
        let (s, m) = (ForwardSettings::for_robot(&robot), ForwardSettings::for_robot(&moved));
        assert_eq!(s.consistency, m.consistency, "{name}");
        assert_eq!(s.consistency, 1e-3, "{name}: 2.5e-4 of its 4 m");
        for u in [[0.5, 0.5, 0.5], [0.2, 0.7, 0.4]] {
            let truth = pose_in(&robot, 0.15, u, [0.05, -0.05, 0.1]);
            let mut truth_moved = truth;
            for k in 0..3 {
                truth_moved[k] += shift[k];
            }
            for cable in 0..8 {
                for delta in [5e-4, 2e-3, 5e-3, 2e-2, -5e-3] {
                    let mut l = lengths_of(&robot, &truth);
                    l[cable] += delta;
                    let mut lm = lengths_of(&moved, &truth_moved);
                    lm[cable] += delta;
                    for warm in [true, false] {
                        let a = robot.forward_kinematics(&l, warm.then_some(&truth), &s);
                        let b = moved.forward_kinematics(&lm, warm.then_some(&truth_moved), &m);
                        match (a, b) {
                            (Ok(a), Ok(b)) => {
                                let mut back = b.pose;
                                for k in 0..3 {
                                    back[k] -= shift[k];
                                }
                                assert!(pose_error(RobotKind::Spatial6, &a.pose, &back) < 1e-9, "{name}");
                            }
                            (Err(a), Err(b)) => {
                                assert_eq!(a, b, "{name}: cable {cable} {delta:+}");
                                inconsistent += usize::from(a == ForwardError::InconsistentLengths);
                            }
                            (a, b) => {
                                panic!("{name}: cable {cable} {delta:+} m, warm {warm}: {a:?} against {b:?}")
                            }
                        }
                        compared += 1;
                    }
                }
            }
        }
    }
    // Both verdicts reached: the small slips are poses, the large ones not.
    assert_eq!(compared, 320);
    assert!(inconsistent > 64 && inconsistent < 256, "{inconsistent} of {compared}");
    println!("{inconsistent} of {compared} inconsistent in both frames");
}
