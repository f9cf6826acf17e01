//! A robot's winches must pull its cables' upper tension limits: the
//! control loop keeps tensions within `t_min..t_max`, and a motor that
//! cannot give `t_max r / (G eta)` has its torque cut below them. Found
//! with `hal-sim --robot` on suspended-8 with `torque_max = 0.12` N m (its
//! winches pull 21.6 N against `t_max` 350 N): the board ran it, the
//! solver commanded up to 37 N, and on the loop the platform went 197 mm
//! off before a tracking fault. The control loop now refuses such a robot
//! (`ControlLoop::new`, `cdpr_control::controller::check_winch_reach`), and
//! the firmware's build and `hal-sim` refuse the file and say why.

use crate::common;

use cdpr_control::controller::{check_winch_reach, WinchReachError};
use cdpr_control::{ControlLoop, ControlRobot};
use tension_core::nalgebra::SVector;
use tension_core::{Error, Method, Robot, TensionLimits, Winch};

/// suspended-8 with `winch` and the upper limits `t_max` (lower limits
/// kept at the file's 5 N).
fn with(winch: Winch<f32>, t_max: [f32; 8]) -> ControlRobot {
    let base = common::suspended8();
    let limits = TensionLimits::new(*base.limits().min(), SVector::from(t_max)).expect("limits");
    Robot::new(base.kind(), *base.anchors(), *base.attachments(), limits, *base.platform(), Some(winch))
        .expect("robot")
}

/// Whether the control loop takes `robot`.
fn loop_of(robot: ControlRobot) -> Result<(), Error> {
    let range = cdpr_control::link::SetpointRange::for_robot(&robot);
    ControlLoop::new(robot, Method::Barycenter, range, cdpr_control::supervisor::SafetyLimits::DEFAULT)
        .map(|_| ())
}

#[test]
fn the_shipped_robots_winches_pull_their_limits() {
    // suspended-8: 2.5 N m x 8 x 0.9 / 0.04 m = 450 N >= 350 N; IPAnema 1:
    // 22.5 N >= 10 N (by hand from the files).
    for name in ["suspended-8", "ipanema1"] {
        let path = format!("{}/../robots/{name}.toml", env!("CARGO_MANIFEST_DIR"));
        let robot = robot_file::RobotFile::load(&path).and_then(|f| f.to_robot::<f32, 6, 8>()).unwrap();
        assert_eq!(check_winch_reach(&robot), Ok(()), "{name}");
        assert_eq!(loop_of(robot), Ok(()), "{name}");
    }
}

#[test]
fn a_winch_too_weak_for_t_max_is_refused_with_what_it_pulls() {
    let path = common::ROBOT_FILE;
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.contains("torque_max = 2.5\n"));
    let file =
        robot_file::RobotFile::parse(&text.replace("torque_max = 2.5\n", "torque_max = 0.12\n")).unwrap();
    let robot = file.to_robot::<f32, 6, 8>().unwrap();
    let e = check_winch_reach(&robot).unwrap_err();
    // 350 N x 0.04 m / (8 x 0.9) = 1.9444 N m; 0.12 x 8 x 0.9 / 0.04 = 21.6 N.
    assert_eq!((e.cable, e.t_max, e.torque_max), (0, 350.0, 0.12));
    assert!((e.torque - 1.944_444).abs() < 1e-5, "{e:?}");
    assert!(e.tension_max <= 21.6 && e.tension_max > 21.6 * (1.0 - 1e-5), "{e:?}");
    let said = e.to_string();
    for part in ["cable 1", "t_max = 350 N", "1.9444 N m", "torque_max = 0.12 N m", "at most 21.600 N"] {
        assert!(said.contains(part), "{part}: {said}");
    }
    assert_eq!(loop_of(robot).err(), Some(Error::InvalidLimits));
}

#[test]
fn the_first_cable_out_of_reach_is_named_and_the_advice_passes() {
    let winch = *common::suspended8().winch().unwrap();
    let mut t_max = [350.0; 8];
    // Cable 6 over the 450 N the winch pulls, cable 8 under it.
    t_max[5] = 460.0;
    t_max[7] = 449.0;
    let e = check_winch_reach(&with(winch, t_max)).unwrap_err();
    assert_eq!((e.cable, e.t_max), (5, 460.0), "{e:?}");
    assert!(e.to_string().starts_with("cable 6: "), "{e}");
    t_max[5] = e.tension_max;
    assert_eq!(check_winch_reach(&with(winch, t_max)), Ok(()));
    assert!(loop_of(with(winch, t_max)).is_ok());
}

#[test]
fn the_limit_itself_is_in_reach_and_the_next_tension_is_not() {
    // Exact in binary: 2.5 N m x 8 x 1 / 0.0625 m = 320 N.
    let winch = Winch::new(0.0625, 8.0, 1.0, 2.5).unwrap();
    assert_eq!(check_winch_reach(&with(winch, [320.0; 8])), Ok(()));
    let next = f32::from_bits(320.0f32.to_bits() + 1);
    let mut t_max = [320.0; 8];
    t_max[2] = next;
    let e = check_winch_reach(&with(winch, t_max)).unwrap_err();
    assert_eq!((e.cable, e.t_max), (2, next));
    assert_eq!(check_winch_reach(&with(winch, [319.9; 8])), Ok(()));
}

/// The check against `t_max r / (G eta) <= torque_max` in `f64` (cases
/// within `f32` rounding of the boundary left out), and its advice passes
/// it: 2 000 random winches and limits from a fixed seed, counted.
#[test]
fn the_check_is_the_torque_that_t_max_needs_against_torque_max() {
    use proptest::strategy::{Strategy, ValueTree};
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let draw = (
        0.005f32..0.2,
        1.0f32..100.0,
        0.05f32..=1.0,
        0.01f32..50.0,
        proptest::collection::vec(10.0f32..5000.0, 8),
    );
    let (mut refused, mut taken, mut advice_checked, cases) = (0, 0, 0, 2000);
    for _ in 0..cases {
        let (r, g, eta, torque_max, t_max) = draw.new_tree(&mut runner).unwrap().current();
        let winch = Winch::new(r, g, eta, torque_max).unwrap();
        let t_max: [f32; 8] = t_max.try_into().unwrap();
        let needs = |t: f32| f64::from(t) * f64::from(r) / (f64::from(g) * f64::from(eta));
        let margin = |t: f32| needs(t) / f64::from(torque_max) - 1.0;
        if t_max.iter().any(|&t| margin(t).abs() <= 1e-5) {
            continue;
        }
        let first_out = t_max.iter().position(|&t| margin(t) > 0.0);
        match (first_out, check_winch_reach(&with(winch, t_max))) {
            (None, Ok(())) => taken += 1,
            (Some(i), Err(WinchReachError { cable, tension_max, .. })) => {
                refused += 1;
                assert_eq!(cable, i);
                assert!(margin(tension_max) <= 0.0 && margin(tension_max) > -1e-5, "{tension_max}");
                if tension_max > 5.0 {
                    let fixed = t_max.map(|t| t.min(tension_max));
                    assert_eq!(check_winch_reach(&with(winch, fixed)), Ok(()));
                    advice_checked += 1;
                }
            }
            (want, got) => {
                panic!("winch {winch:?}, t_max {t_max:?}: expected first out {want:?}, got {got:?}")
            }
        }
    }
    // Both verdicts, and the advice, reached in numbers.
    assert!(refused > cases / 4 && taken > cases / 20, "{refused} refused, {taken} taken of {cases}");
    assert!(advice_checked > refused / 2, "{advice_checked} of {refused}");
    println!("{refused} refused ({advice_checked} advices checked), {taken} taken of {cases}");
}

/// `check_board_robot`, the board's checks as its build and `hal-sim` make
/// them: suspended-8 with its file's encoders passes; its winches at
/// 0.12 N m are refused for the winches, its encoders at 2^31 counts a turn
/// (3.1 cm of cable in 2^31 counts) for the encoders, each with the
/// underlying check's own error and `[winch]: ` in front.
#[test]
fn the_board_refuses_its_robot_for_its_winches_or_its_encoders() {
    use cdpr_control::control_loop::{check_board_robot, RobotRefusal};
    use cdpr_control::encoder::EncoderScale;
    let robot = common::suspended8();
    let scale = EncoderScale::new(0.04, 8.0, 4096, [1; 8]).unwrap();
    assert_eq!(check_board_robot(&robot, &scale), Ok(()));
    let weak = with(Winch::new(0.04, 8.0, 0.9, 0.12).unwrap(), [350.0; 8]);
    let e = check_board_robot(&weak, &scale).unwrap_err();
    assert_eq!(e, RobotRefusal::Winch(check_winch_reach(&weak).unwrap_err()));
    assert_eq!(e.to_string(), format!("[winch]: {}", check_winch_reach(&weak).unwrap_err()));
    let fine = EncoderScale::new(0.04, 8.0, 1 << 31, [1; 8]).unwrap();
    let longest = cdpr_control::link::SetpointRange::for_robot(&robot).longest_cable(&robot);
    let e = check_board_robot(&robot, &fine).unwrap_err();
    assert_eq!(e, RobotRefusal::Encoders(fine.check_reach(longest).unwrap_err()));
    assert!(e.to_string().starts_with("[winch]: ") && e.to_string().contains("0.031 m"), "{e}");
    // Both wrong: the encoders are named first, as the build says them.
    assert!(matches!(check_board_robot(&weak, &fine), Err(RobotRefusal::Encoders(_))));
}
