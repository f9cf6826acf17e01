//! The setpoint range derived from suspended-8's anchors
//! (`robots/suspended-8.toml`) is the range the firmware has always used,
//! and its check is the comparisons it stands for.

use crate::common;

use cdpr_control::link::SetpointRange;
use cdpr_protocol::Setpoint;
use proptest::prelude::*;

#[test]
fn setpoint_range_of_suspended8() {
    let expected = SetpointRange {
        position_min: [-2.5, -2.0, -0.5],
        position_max: [2.5, 2.0, 4.0],
        angle_max: 1.0,
        speed_max: 5.0,
        angular_speed_max: 10.0,
        acceleration_max: 50.0,
        angular_acceleration_max: 100.0,
    };
    assert_eq!(common::setpoint_range(), expected);
}

/// suspended-8 with its anchors moved by `shift` and gravity `gravity`.
fn moved(shift: [f32; 3], gravity: [f32; 3]) -> cdpr_control::ControlRobot {
    use tension_core::nalgebra::Vector3;
    let base = common::suspended8();
    let anchors = base.anchors().map(|a| a + Vector3::from(shift));
    let mut platform = *base.platform();
    platform.gravity = Vector3::from(gravity);
    tension_core::Robot::new(
        base.kind(),
        anchors,
        *base.attachments(),
        *base.limits(),
        platform,
        base.winch().copied(),
    )
    .unwrap()
}

/// The range is the box the forward kinematics takes the platform to be
/// in, 0.5 m wider: the anchors' box wherever the base origin lies beside
/// it (a frame 50 m and 30 m beside the robot gave a range 52 m wide), from
/// a flat anchor plane to the origin (the floor), or for anchors in the
/// origin's plane (a frame on the ceiling) 4 m, the box's width, along
/// gravity. IPAnema 1's and suspended-8's ranges are the same as before
/// (above); COGIRO's anchors lie within 3 cm of one height, and its range
/// reaches the floor.
#[test]
fn the_range_is_the_platforms_region_wherever_the_frame_lies() {
    let g = [0.0, 0.0, -9.81];
    let r = SetpointRange::for_robot(&moved([50.0, 30.0, 0.0], g));
    assert_eq!((r.position_min, r.position_max), ([47.5, 28.0, -0.5], [52.5, 32.0, 4.0]));
    let r = SetpointRange::for_robot(&moved([0.0, 0.0, -3.5], g));
    assert_eq!((r.position_min, r.position_max), ([-2.5, -2.0, -4.5], [2.5, 2.0, 0.5]));
    let r = SetpointRange::for_robot(&moved([0.0, 0.0, -3.5], [0.0, 0.0, 9.81]));
    assert_eq!((r.position_min, r.position_max), ([-2.5, -2.0, -0.5], [2.5, 2.0, 4.5]));
    // The frame above the anchors: the origin's side, as the conventions'
    // mirror rule takes it (no pose of that range hangs; the firmware's
    // build says why).
    let r = SetpointRange::for_robot(&moved([0.0, 0.0, -20.0], g));
    assert_eq!((r.position_min, r.position_max), ([-2.5, -2.0, -17.0], [2.5, 2.0, 0.5]));
    // Gravity along -y (a robot on a wall): the origin counts along y only;
    // without gravity, the anchors' box alone.
    let r = SetpointRange::for_robot(&moved([50.0, 30.0, 0.0], [0.0, -9.81, 0.0]));
    assert_eq!((r.position_min, r.position_max), ([47.5, -0.5, 3.0], [52.5, 32.0, 4.0]));
    let r = SetpointRange::for_robot(&moved([50.0, 30.0, 0.0], [0.0; 3]));
    assert_eq!((r.position_min, r.position_max), ([47.5, 28.0, 3.0], [52.5, 32.0, 4.0]));
    // A frame tilted by 10 degrees about x (anchors and gravity turned):
    // the anchors span 0.52 m in z, more than the flat test's 0.4 m, and
    // the range still reaches the floor, where the platform hangs (a range
    // of the anchors' box alone derived a demo 0.3 m under them, whose
    // every hold in hal-sim faulted).
    let (s, c) = 10f32.to_radians().sin_cos();
    let base = common::suspended8();
    let mut platform = *base.platform();
    platform.gravity = tension_core::nalgebra::Vector3::new(0.0, 9.81 * s, -9.81 * c);
    let turned = base
        .anchors()
        .map(|a| tension_core::nalgebra::Vector3::new(a.x, c * a.y - s * a.z, s * a.y + c * a.z));
    let tilted: cdpr_control::ControlRobot = tension_core::Robot::new(
        base.kind(),
        turned,
        *base.attachments(),
        *base.limits(),
        platform,
        base.winch().copied(),
    )
    .unwrap();
    let r = SetpointRange::for_robot(&tilted);
    assert_eq!(r.position_min[2], -0.5, "{r:?}");
    assert!((r.position_max[2] - (3.5 * c + 1.5 * s + 0.5)).abs() < 1e-5, "{r:?}");
    for (name, min, max) in [
        ("ipanema1", [-2.5, -2.0, -0.5], [2.5, 2.0, 2.5]),
        ("cogiro", [-7.9594, -6.0342, -0.5], [8.0208, 5.9753, 5.92]),
    ] {
        let path = format!("{}/../robots/{name}.toml", env!("CARGO_MANIFEST_DIR"));
        let robot = robot_file::RobotFile::load(&path).unwrap().to_robot::<f32, 6, 8>().unwrap();
        let r = SetpointRange::for_robot(&robot);
        for k in 0..3 {
            assert!((r.position_min[k] - min[k]).abs() < 1e-5, "{name}: {r:?}");
            assert!((r.position_max[k] - max[k]).abs() < 1e-5, "{name}: {r:?}");
        }
    }
}

/// The check as written in comparisons: finite and `lo <= v <= hi`.
fn reference(r: &SetpointRange, s: &Setpoint) -> bool {
    let within = |v: f32, lo: f32, hi: f32| v.is_finite() && v >= lo && v <= hi;
    let bounded = |v: f32, max: f32| within(v, -max, max);
    (0..3).all(|i| {
        within(s.pose[i], r.position_min[i], r.position_max[i])
            && bounded(s.pose[i + 3], r.angle_max)
            && bounded(s.velocity[i], r.speed_max)
            && bounded(s.velocity[i + 3], r.angular_speed_max)
            && bounded(s.acceleration[i], r.acceleration_max)
            && bounded(s.acceleration[i + 3], r.angular_acceleration_max)
    })
}

/// The pose's part of [`reference`] (a `Home`'s check).
fn reference_pose(r: &SetpointRange, pose: &[f32; 6]) -> bool {
    let within = |v: f32, lo: f32, hi: f32| v.is_finite() && v >= lo && v <= hi;
    (0..3).all(|i| {
        within(pose[i], r.position_min[i], r.position_max[i])
            && within(pose[i + 3], -r.angle_max, r.angle_max)
    })
}

/// Mostly values near the limits (either side, at them, +-0), some NaN,
/// infinities, subnormals and extremes.
fn value(limit: f32) -> impl Strategy<Value = f32> {
    prop_oneof![
        8 => (-1.2f32..1.2).prop_map(move |x| x * limit),
        2 => Just(limit),
        2 => Just(-limit),
        1 => Just(f32::from_bits(limit.to_bits() + 1)),
        1 => Just(-f32::from_bits(limit.to_bits() + 1)),
        1 => Just(0.0),
        1 => Just(-0.0),
        1 => Just(f32::NAN),
        1 => Just(-f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(f32::MIN_POSITIVE / 4.0),
        1 => Just(f32::MAX),
    ]
}

/// A limit: the firmware's, or one a range built by hand may hold.
fn limit(usual: f32) -> impl Strategy<Value = f32> {
    prop_oneof![
        12 => Just(usual),
        1 => Just(0.0),
        1 => Just(-0.0),
        1 => Just(-usual),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::MAX),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 20_000, failure_persistence: None, ..ProptestConfig::default() })]
    #[test]
    fn the_check_is_the_comparisons_it_stands_for(
        maxima in (limit(1.0), limit(5.0), limit(10.0), limit(50.0), limit(100.0)),
        (pose, velocity, acceleration) in (
            (value(3.0), value(3.0), value(3.0), value(1.0), value(1.0), value(1.0)),
            (value(5.0), value(5.0), value(5.0), value(10.0), value(10.0), value(10.0)),
            (value(50.0), value(50.0), value(50.0), value(100.0), value(100.0), value(100.0)),
        ),
        lo in limit(-2.0),
        one in 0usize..6,
    ) {
        let mut r = common::setpoint_range();
        (r.angle_max, r.speed_max, r.angular_speed_max, r.acceleration_max, r.angular_acceleration_max) = maxima;
        r.position_min[0] = lo;
        let a = |t: (f32, f32, f32, f32, f32, f32)| [t.0, t.1, t.2, t.3, t.4, t.5];
        let mut s = Setpoint { seq: 1, pose: a(pose), velocity: a(velocity), acceleration: a(acceleration) };
        prop_assert_eq!(r.contains(&s), reference(&r, &s), "{:?} {:?}", r, s);
        prop_assert_eq!(r.contains_pose(&s.pose), reference_pose(&r, &s.pose), "{:?} {:?}", r, s.pose);
        // One value at a time (the others inside): each test on its own.
        let inside = Setpoint { seq: 1, pose: [0.1, 0.1, 0.5, 0.0, 0.0, 0.0], velocity: [0.0; 6], acceleration: [0.0; 6] };
        for field in 0..3 {
            let mut t = inside;
            let v = [s.pose[one], s.velocity[one], s.acceleration[one]][field];
            [&mut t.pose, &mut t.velocity, &mut t.acceleration][field][one] = v;
            prop_assert_eq!(r.contains(&t), reference(&r, &t), "{:?} {:?}", r, t);
        }
        s.seq = 2;
        prop_assert_eq!(r.contains(&s), reference(&r, &s));
    }
}
