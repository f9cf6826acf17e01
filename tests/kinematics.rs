//! Kinematics against the conventions, checked independently: the wrench matrix
//! against finite differences of the cable lengths (virtual work), the Euler
//! convention against hand-worked rotations, the angular velocity against the
//! derivative of `R`, and the external wrench against hand-derived values.

use cdpr_integration_tests::shipped_robot;
use nalgebra::{Matrix3, Rotation3, SMatrix, SVector, Vector3};
use tension_core::{Motion, Platform, Robot, RobotKind, TensionLimits, Winch};

fn lengths(robot: &Robot<f64, 6, 8>, p: Vector3<f64>, r: Matrix3<f64>) -> SVector<f64, 8> {
    SVector::from_fn(|i, _| (robot.anchors()[i] - p - r * robot.attachments()[i]).norm())
}

/// Virtual work: for a small displacement `dp` and small rotation `dtheta`
/// (applied in the base frame), `dl_i = -(W^T [dp; dtheta])_i`.
#[test]
fn wrench_matrix_is_minus_the_length_jacobian_transposed() {
    for name in ["suspended-8", "ipanema1", "cogiro"] {
        let robot: Robot<f64, 6, 8> = shipped_robot(name);
        let pose = SVector::<f64, 6>::new(0.1, -0.2, 1.0, 0.1, -0.2, 0.3);
        let (p, r) = robot.frame(&pose).unwrap();
        let w = robot.wrench_matrix(&pose).unwrap();
        let h = 1e-6;
        for k in 0..6 {
            let mut twist = SVector::<f64, 6>::zeros();
            twist[k] = h;
            let dp = Vector3::new(twist[0], twist[1], twist[2]);
            let dr = Rotation3::from_scaled_axis(Vector3::new(twist[3], twist[4], twist[5])).into_inner();
            let plus = lengths(&robot, p + dp, dr * r);
            let dr_minus =
                Rotation3::from_scaled_axis(-Vector3::new(twist[3], twist[4], twist[5])).into_inner();
            let minus = lengths(&robot, p - dp, dr_minus * r);
            let dl = (plus - minus) / (2.0 * h);
            let predicted = -(w.transpose() * (twist / h));
            assert!((dl - predicted).amax() < 1e-7, "{name} direction {k}: {dl:?} vs {predicted:?}");
        }
    }
}

#[test]
fn euler_convention_is_xyz_intrinsic() {
    let robot: Robot<f64, 6, 8> = shipped_robot("ipanema1");
    let q = std::f64::consts::FRAC_PI_2;
    // Rx(pi/2): y -> z.
    let (_, r) = robot.frame(&SVector::<f64, 6>::new(0.0, 0.0, 0.0, q, 0.0, 0.0)).unwrap();
    assert!((r * Vector3::y() - Vector3::z()).amax() < 1e-15);
    // Rx(pi/2) Ry(pi/2): x -> (Rx)(-z) = y; the z-axis first goes to x then stays.
    let (_, r) = robot.frame(&SVector::<f64, 6>::new(0.0, 0.0, 0.0, q, q, 0.0)).unwrap();
    assert!((r * Vector3::x() - Vector3::y()).amax() < 1e-15, "{}", r * Vector3::x());
    assert!((r * Vector3::z() - Vector3::x()).amax() < 1e-15);
    // Rz alone: x -> y.
    let (p, r) = robot.frame(&SVector::<f64, 6>::new(1.0, 2.0, 3.0, 0.0, 0.0, q)).unwrap();
    assert!((r * Vector3::x() - Vector3::y()).amax() < 1e-15);
    assert_eq!(p, Vector3::new(1.0, 2.0, 3.0));
}

#[test]
fn angular_velocity_and_acceleration_match_the_derivative_of_r() {
    let robot: Robot<f64, 6, 8> = shipped_robot("ipanema1");
    // Angles along a smooth curve q(s) = q0 + v s + a s^2 / 2.
    let q0 = SVector::<f64, 6>::new(0.0, 0.0, 1.0, 0.3, -0.4, 0.5);
    let v = SVector::<f64, 6>::new(0.1, 0.2, 0.3, 0.7, -0.5, 0.9);
    let a = SVector::<f64, 6>::new(0.0, 0.0, 0.0, -1.1, 0.6, 0.4);
    let q = |s: f64| q0 + v * s + a * (s * s / 2.0);
    let motion = Motion::from_pose_derivatives(RobotKind::Spatial6, &q0, &v, &a).unwrap();
    let omega_at = |s: f64| {
        let h = 1e-6;
        let (_, r1) = robot.frame(&q(s + h)).unwrap();
        let (_, r0) = robot.frame(&q(s - h)).unwrap();
        let (_, r) = robot.frame(&q(s)).unwrap();
        let skew = (r1 - r0) / (2.0 * h) * r.transpose();
        Vector3::new(skew[(2, 1)], skew[(0, 2)], skew[(1, 0)])
    };
    assert!((omega_at(0.0) - motion.angular_velocity).amax() < 1e-8);
    let h = 1e-4;
    let alpha = (omega_at(h) - omega_at(-h)) / (2.0 * h);
    assert!(
        (alpha - motion.angular_acceleration).amax() < 1e-6,
        "{alpha} vs {}",
        motion.angular_acceleration
    );
    assert_eq!(motion.linear_acceleration, Vector3::new(0.0, 0.0, 0.0));
}

#[test]
fn gravity_wrench_at_an_offset_centre_of_mass() {
    let robot: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    // m = 6.34, c = (0, 0, -0.1); with rx = pi/2 the centre of mass is at R c = (0, 0.1, 0).
    let pose = SVector::<f64, 6>::new(0.0, 0.0, 1.0, std::f64::consts::FRAC_PI_2, 0.0, 0.0);
    let f = robot.required_wrench(&pose, &SVector::zeros(), None).unwrap();
    let mg = 6.34 * 9.81;
    // w_e = (0, 0, -mg, (R c) x (0, 0, -mg)) = (0, 0, -mg, -0.1 mg, 0, 0); f = -w_e.
    let expected = SVector::<f64, 6>::new(0.0, 0.0, mg, 0.1 * mg, 0.0, 0.0);
    assert!((f - expected).amax() < 1e-12, "{f}");
    // An extra wrench adds to w_e.
    let extra = SVector::<f64, 6>::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0);
    let f2 = robot.required_wrench(&pose, &extra, None).unwrap();
    assert!((f2 - (expected - extra)).amax() < 1e-12);
}

#[test]
fn dalembert_wrench() {
    let robot: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let pose = SVector::<f64, 6>::new(0.0, 0.0, 1.0, 0.0, 0.0, 0.0);
    let motion = Motion {
        linear_acceleration: Vector3::new(1.0, 0.0, 2.0),
        angular_velocity: Vector3::new(0.0, 0.0, 3.0),
        angular_acceleration: Vector3::new(0.5, 0.0, 0.0),
    };
    let f = robot.required_wrench(&pose, &SVector::zeros(), Some(&motion)).unwrap();
    let m = 6.34;
    // R = I, R c = (0, 0, -0.1). a_c = a + alpha x Rc + omega x (omega x Rc):
    // alpha x Rc = (0.5,0,0) x (0,0,-0.1) = (0, 0.05, 0); omega x Rc = (0,0,3) x (0,0,-0.1) = 0.
    let a_c = Vector3::new(1.0, 0.05, 2.0);
    let force = Vector3::new(0.0, 0.0, -9.81) * m - a_c * m;
    let rc = Vector3::new(0.0, 0.0, -0.1);
    // I alpha = (0.025, 0, 0); omega x I omega = (0,0,3) x (0,0,0.24) = 0.
    let moment = rc.cross(&force) - Vector3::new(0.05 * 0.5, 0.0, 0.0);
    let expected = -SVector::<f64, 6>::new(force.x, force.y, force.z, moment.x, moment.y, moment.z);
    assert!((f - expected).amax() < 1e-12, "{f} vs {expected}");
}

#[test]
fn planar_wrench_matrices() {
    let limits = TensionLimits::uniform(1.0, 10.0).unwrap();
    let platform = Platform {
        mass: 1.0,
        com: Vector3::zeros(),
        gravity: Vector3::new(0.0, -9.81, 0.0),
        inertia: Matrix3::zeros(),
    };
    let anchors = [
        Vector3::new(0.0, 0.0, 5.0),
        Vector3::new(4.0, 0.0, -2.0),
        Vector3::new(4.0, 3.0, 0.0),
        Vector3::new(0.0, 3.0, 0.0),
        Vector3::new(2.0, 4.0, 0.0),
    ];
    let attach = [
        Vector3::new(-0.1, -0.1, 0.0),
        Vector3::new(0.1, -0.1, 0.0),
        Vector3::new(0.1, 0.1, 0.0),
        Vector3::new(-0.1, 0.1, 0.0),
        Vector3::new(0.0, 0.1, 0.0),
    ];
    let planar3 =
        Robot::<f64, 3, 5>::new(RobotKind::Planar3, anchors, attach, limits, platform, None).unwrap();
    let theta = 0.3;
    let w = planar3.wrench_matrix(&SVector::<f64, 3>::new(2.0, 1.5, theta)).unwrap();
    for i in 0..5 {
        let (s, c) = theta.sin_cos();
        let rb = [c * attach[i].x - s * attach[i].y, s * attach[i].x + c * attach[i].y];
        let l = [anchors[i].x - 2.0 - rb[0], anchors[i].y - 1.5 - rb[1]]; // z ignored
        let n = (l[0] * l[0] + l[1] * l[1]).sqrt();
        let u = [l[0] / n, l[1] / n];
        assert!((w[(0, i)] - u[0]).abs() < 1e-15 && (w[(1, i)] - u[1]).abs() < 1e-15);
        assert!((w[(2, i)] - (rb[0] * u[1] - rb[1] * u[0])).abs() < 1e-15);
    }
    let point: Robot<f64, 2, 4> = shipped_robot("planar-point-4");
    let w = point.wrench_matrix(&SVector::<f64, 2>::new(1.0, 1.0)).unwrap();
    let h = 1.0 / 2f64.sqrt();
    let expected = SMatrix::<f64, 2, 4>::new(
        -h,
        2.0 / 5f64.sqrt(),
        2.0 / 8f64.sqrt(),
        -1.0 / 5f64.sqrt(),
        -h,
        -1.0 / 5f64.sqrt(),
        2.0 / 8f64.sqrt(),
        2.0 / 5f64.sqrt(),
    );
    assert!((w - expected).amax() < 1e-15, "{w}");
    // Kind and size must agree.
    assert!(Robot::<f64, 2, 5>::new(RobotKind::Planar3, anchors, attach, limits, platform, None).is_err());
}

#[test]
fn motor_torque_follows_the_spec_and_reports_saturation() {
    let winch = Winch::<f64>::new(0.04, 8.0, 0.9, 2.5).unwrap();
    let tau = winch.motor_torque(100.0).unwrap();
    assert!((tau.torque - 100.0 * 0.04 / (8.0 * 0.9)).abs() < 1e-15);
    assert!(!tau.saturated);
    let tau = winch.motor_torque(1000.0).unwrap();
    assert_eq!(tau.torque, 2.5);
    assert!(tau.saturated);
    assert!(winch.motor_torque(f64::NAN).is_err());
    assert!(Winch::<f64>::new(0.04, 8.0, 1.5, 2.5).is_err());
    assert!(Winch::<f64>::new(0.0, 8.0, 0.9, 2.5).is_err());
}

#[test]
fn one_pass_wrench_problem_equals_the_separate_calls() {
    let robot: Robot<f32, 6, 8> = shipped_robot("suspended-8");
    let pose = SVector::<f32, 6>::new(0.3, -0.2, 1.4, 0.1, -0.05, 0.3);
    let vel = SVector::<f32, 6>::new(0.1, 0.2, -0.1, 0.3, 0.2, -0.4);
    let acc = SVector::<f32, 6>::new(1.0, -0.5, 0.2, 0.7, -0.3, 0.5);
    let extra = SVector::<f32, 6>::new(1.0, 0.0, 0.0, 0.0, 0.5, 0.0);
    let (w, f) = robot.wrench_problem(&pose, &extra, Some((&vel, &acc))).unwrap();
    let motion = Motion::from_pose_derivatives(RobotKind::Spatial6, &pose, &vel, &acc).unwrap();
    assert_eq!(w, robot.wrench_matrix(&pose).unwrap());
    assert_eq!(f, robot.required_wrench(&pose, &extra, Some(&motion)).unwrap());
    let (_, f_static) = robot.wrench_problem(&pose, &extra, None).unwrap();
    assert_eq!(f_static, robot.required_wrench(&pose, &extra, None).unwrap());
    // f32 kinematics (single-precision sine and cosine) against f64.
    let r64: Robot<f64, 6, 8> = shipped_robot("suspended-8");
    let (w64, f64_) = r64
        .wrench_problem(
            &pose.map(|x| x as f64),
            &extra.map(|x| x as f64),
            Some((&vel.map(|x| x as f64), &acc.map(|x| x as f64))),
        )
        .unwrap();
    assert!((w.map(|x| x as f64) - w64).amax() < 1e-6);
    assert!((f.map(|x| x as f64) - f64_).amax() < 1e-4);
}
