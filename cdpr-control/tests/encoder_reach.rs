//! The encoders' 32-bit counts must count every cable the setpoint range
//! allows: a cable that moves more than 2^31 counts from its homing wraps
//! and reads as a length it does not have. Found with `hal-sim --robot` on
//! suspended-8 with 2^31 counts a motor turn (3 cm of cable in 2^31
//! counts): the platform went 218 mm off its path, a cable slack, before a
//! tracking fault. The control loop now refuses such a scale
//! (`ControlLoop::set_encoder`), and the firmware's build refuses the file.

use crate::common;

use cdpr_control::encoder::{EncoderScale, ScaleError, COUNT_SPAN};
use cdpr_control::link::SetpointRange;
use proptest::prelude::*;
use tension_core::nalgebra::SVector;

/// suspended-8's file in `f64`, for the lengths the bound is checked against.
fn suspended8_f64() -> tension_core::Robot<f64, 6, 8> {
    robot_file::RobotFile::load(common::ROBOT_FILE)
        .and_then(|f| f.to_robot::<f64, 6, 8>())
        .expect("suspended-8")
}

/// The robot file's other robot of the firmware's shape.
fn ipanema1() -> (tension_core::Robot<f32, 6, 8>, tension_core::Robot<f64, 6, 8>) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../robots/ipanema1.toml");
    let file = robot_file::RobotFile::load(path).expect("ipanema1");
    (file.to_robot().expect("f32"), file.to_robot().expect("f64"))
}

/// The longest cable over poses within `range`: every corner of the
/// position box at the angle limits' corners and at zero, and `draws`
/// random poses (the largest length sampled).
fn longest_sampled(robot: &tension_core::Robot<f64, 6, 8>, range: &SetpointRange, draws: &[[f64; 6]]) -> f64 {
    let (lo, hi, a) = (range.position_min, range.position_max, f64::from(range.angle_max));
    let mut poses = Vec::new();
    for corner in 0..8 {
        let p = |k: usize| f64::from(if corner >> k & 1 == 1 { hi[k] } else { lo[k] });
        for turn in 0..28 {
            // Zero, and the 27 sign patterns of -a, 0, +a.
            let angle = |k: usize| {
                if turn == 0 {
                    0.0
                } else {
                    a * (((turn - 1) / 3usize.pow(k as u32)) % 3) as f64 - a
                }
            };
            poses.push([p(0), p(1), p(2), angle(0), angle(1), angle(2)]);
        }
    }
    poses.extend_from_slice(draws);
    let mut longest = 0.0f64;
    for pose in &poses {
        let cables = robot.cables(&SVector::from(*pose)).expect("a pose within the range has cables");
        longest = longest.max(cables.lengths.max());
    }
    longest
}

fn draw(range: &SetpointRange, u: [f64; 6]) -> [f64; 6] {
    let (lo, hi, a) = (range.position_min, range.position_max, f64::from(range.angle_max));
    core::array::from_fn(|k| {
        if k < 3 {
            f64::from(lo[k]) + u[k] * f64::from(hi[k] - lo[k])
        } else {
            a * (2.0 * u[k] - 1.0)
        }
    })
}

#[test]
fn the_longest_cable_bounds_every_pose_of_the_range_and_is_near_the_longest_sampled() {
    let mut rng = 0x9e37_79b9_7f4a_7c15u64;
    let mut uniform = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    let (ipa32, ipa64) = ipanema1();
    let mut compared = 0;
    for (robot32, robot64) in [(common::suspended8(), suspended8_f64()), (ipa32, ipa64)] {
        let range = SetpointRange::for_robot(&robot32);
        let draws: Vec<[f64; 6]> =
            (0..20_000).map(|_| draw(&range, core::array::from_fn(|_| uniform()))).collect();
        let sampled = longest_sampled(&robot64, &range, &draws);
        let bound = f64::from(range.longest_cable(&robot32));
        let largest_attachment = robot64.attachments().iter().map(|b| b.norm()).fold(0.0, f64::max);
        // A bound (to f32's rounding), and not looser than the attachment's
        // length (the rotation that would align it is beyond the angles).
        assert!(sampled <= bound * (1.0 + 1e-6), "sampled {sampled} > bound {bound}");
        assert!(bound - sampled <= largest_attachment, "bound {bound} sampled {sampled}");
        compared += 1;
    }
    assert_eq!(compared, 2);
}

#[test]
fn a_scale_whose_counts_do_not_reach_the_longest_cable_is_refused_with_the_counts_that_would() {
    let robot = common::suspended8();
    let longest = SetpointRange::for_robot(&robot).longest_cable(&robot);
    // suspended-8: 0.04 m drum, gear 8. 4096 counts a turn: 7.67 um a
    // count, 16.5 km in 2^31.
    let file_scale = EncoderScale::new(0.04, 8.0, 4096, [1; 8]).unwrap();
    assert!((file_scale.reach() - 16_470.0).abs() < 10.0, "{}", file_scale.reach());
    assert_eq!(file_scale.check_reach(longest), Ok(()));
    // 2^31 counts a turn: 3.1 cm in 2^31.
    let fine = EncoderScale::new(0.04, 8.0, 1 << 31, [1; 8]).unwrap();
    let Err(ScaleError::Reach { reach, longest: said, counts_max }) = fine.check_reach(longest) else {
        panic!("accepted");
    };
    let per_count = 2.0 * std::f64::consts::PI * 0.04 / (8.0 * 2f64.powi(31));
    assert!((f64::from(reach) - per_count * f64::from(COUNT_SPAN)).abs() < 1e-6, "{reach}");
    assert_eq!(said, longest);
    // The advice: the most counts a turn that reach, by hand, and it passes.
    let by_hand = f64::from(COUNT_SPAN) * 2.0 * std::f64::consts::PI * 0.04 / (8.0 * f64::from(longest));
    assert!((f64::from(counts_max) - by_hand).abs() <= by_hand * 1e-5, "{counts_max} against {by_hand}");
    let advised = EncoderScale::new(0.04, 8.0, counts_max, [1; 8]).unwrap();
    assert_eq!(advised.check_reach(longest), Ok(()));
    let over = EncoderScale::new(0.04, 8.0, counts_max + counts_max / 1000, [1; 8]).unwrap();
    assert!(over.check_reach(longest).is_err());
    // The message says the numbers and what to do.
    let text = fine.check_reach(longest).unwrap_err().to_string();
    assert!(text.contains("0.031 m") && text.contains(&format!("at most {counts_max}")), "{text}");
    // A length that is not a number is not reached.
    assert!(file_scale.check_reach(f32::NAN).is_err());
}

#[test]
fn the_control_loop_refuses_such_a_scale_and_keeps_its_own() {
    let mut control = common::control_loop();
    let before = *control.encoder();
    let fine = EncoderScale::new(0.04, 8.0, 1 << 31, [1; 8]).unwrap();
    assert!(matches!(control.set_encoder(fine), Err(ScaleError::Reach { .. })));
    assert_eq!(*control.encoder(), before);
    let signed = EncoderScale::new(0.04, 8.0, 16384, [-1; 8]).unwrap();
    assert_eq!(control.set_encoder(signed), Ok(()));
    assert_eq!(*control.encoder(), signed);
}

proptest! {
    /// Any drum, gear and counts: the check passes exactly when 2^31 - 1
    /// counts, computed here in `f64`, cover the longest cable (away from
    /// the rounding at the border).
    #[test]
    fn the_check_is_the_count_span_against_the_longest_cable(
        radius in 0.005f32..0.5,
        gear in 1.0f32..200.0,
        counts in 1u32..=u32::MAX,
        longest in 0.1f32..100.0,
    ) {
        let scale = EncoderScale::new(radius, gear, counts, [1; 8]).unwrap();
        let reach = f64::from(COUNT_SPAN) * 2.0 * std::f64::consts::PI * f64::from(radius)
            / (f64::from(gear) * f64::from(counts));
        let margin = (reach - f64::from(longest)) / reach;
        prop_assume!(margin.abs() > 1e-5);
        prop_assert_eq!(scale.check_reach(longest).is_ok(), margin > 0.0, "reach {} longest {}", reach, longest);
    }
}
