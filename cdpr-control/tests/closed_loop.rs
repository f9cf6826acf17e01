//! The closed loop through the winch encoders: homing, counts to lengths,
//! the pose and speed estimate, both feedback schemes and the faults and
//! holds of the read side (unreadable drive, estimator failure).

use crate::common;

use cdpr_control::feedback::Scheme;
use cdpr_control::protocol::{HostMessage, Reason, Rejection, Setpoint, State};
use cdpr_control::setpoint::Pose6;
use cdpr_control::supervisor::SafetyLimits;
use cdpr_control::{ControlLoop, NoClock, StepReport, WinchDrives, WinchReading, CABLES};
use tension_core::Method;

const POSE: [f32; 6] = [0.1, -0.2, 1.9, 0.02, -0.01, 0.05];

/// A drive read failure naming the drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Unreadable(usize);

/// Encoders the test sets; a drive can be made unreadable.
struct Encoders {
    readings: [WinchReading; CABLES],
    unreadable: Option<usize>,
}

impl WinchDrives for Encoders {
    type Error = Unreadable;
    fn apply(&mut self, _: &[f32; CABLES]) -> Result<(), Unreadable> {
        Ok(())
    }
    fn set_brakes(&mut self, _: bool) -> Result<(), Unreadable> {
        Ok(())
    }
    fn read(&mut self, readings: &mut [WinchReading; CABLES]) -> Result<(), Unreadable> {
        match self.unreadable {
            Some(i) => Err(Unreadable(i)),
            None => {
                *readings = self.readings;
                Ok(())
            }
        }
    }
    fn failed_drive(&self, error: &Unreadable) -> Option<usize> {
        Some(error.0)
    }
}

fn control() -> ControlLoop {
    ControlLoop::new(
        common::suspended8(),
        Method::Barycenter,
        common::setpoint_range(),
        SafetyLimits::DEFAULT,
    )
    .unwrap()
}

fn at_rest(seq: u32, pose: [f32; 6]) -> HostMessage {
    HostMessage::Setpoint(Setpoint { seq, pose, velocity: [0.0; 6], acceleration: [0.0; 6] })
}

fn lengths_at(control: &ControlLoop, pose: [f32; 6]) -> [f32; CABLES] {
    control.controller().robot().cables(&Pose6::from(pose)).unwrap().lengths.into()
}

struct Rig {
    control: ControlLoop,
    drives: Encoders,
    seq: u32,
}

impl Rig {
    /// Homed at `POSE` (counts offset near the 32-bit wrap), disabled.
    fn homed() -> Self {
        let mut control = control();
        let mut readings = common::readings_at(&control, POSE);
        for r in &mut readings {
            r.counts = r.counts.wrapping_add(i32::MAX - 1000);
        }
        let mut drives = Encoders { readings, unreadable: None };
        common::home(&mut control, &mut drives, POSE);
        Self { control, drives, seq: 0 }
    }

    /// The plant's cables at `lengths` (counts with the homing's offset).
    fn set_lengths(&mut self, lengths: &[f32; CABLES]) {
        for (i, r) in self.drives.readings.iter_mut().enumerate() {
            r.counts = self.control.encoder().counts_of(i, lengths[i], i32::MAX - 1000).unwrap();
        }
    }

    fn step_at(&mut self, pose: [f32; 6]) -> StepReport {
        self.seq += 1;
        self.control.receive(at_rest(self.seq, pose));
        self.control.step(&NoClock, &mut self.drives, false)
    }

    fn enable(&mut self, scheme: Scheme) {
        self.control.receive(HostMessage::SelectFeedback(scheme.wire_id()));
        self.control.receive(HostMessage::Enable);
        assert_eq!(self.step_at(POSE).state, State::Enabled);
    }
}

#[test]
fn enable_is_refused_until_homed() {
    let mut control = control();
    let mut drives = Encoders { readings: common::readings_at(&control, POSE), unreadable: None };
    control.receive(at_rest(1, POSE));
    control.receive(HostMessage::Enable);
    let r = control.step(&NoClock, &mut drives, false);
    assert_eq!(r.state, State::Disabled);
    assert_eq!(control.counters().rejected_state, 1);
    assert_eq!(control.counters().last_rejection, Rejection::Homing);
    assert!(!control.homed());
    // A non-finite or out-of-range home pose is refused as range.
    control.receive(HostMessage::Home([f32::NAN, 0.0, 1.9, 0.0, 0.0, 0.0]));
    control.receive(HostMessage::Home([9.0, 0.0, 1.9, 0.0, 0.0, 0.0]));
    assert_eq!(control.counters().rejected_range, 2);
    // Homed: Enable is granted.
    common::home(&mut control, &mut drives, POSE);
    control.receive(at_rest(2, POSE));
    control.receive(HostMessage::Enable);
    let r = control.step(&NoClock, &mut drives, false);
    assert_eq!(r.state, State::Enabled);
    assert!(r.telemetry.is_none() || r.telemetry.is_some_and(|t| t.homed));
    // Home while enabled: refused as state.
    let before = control.counters().rejected_state;
    control.receive(HostMessage::Home(POSE));
    assert_eq!(control.counters().rejected_state, before + 1);
    assert_eq!(control.counters().last_rejection, Rejection::State);
}

#[test]
fn homing_offsets_are_the_inverse_kinematics_and_the_counts() {
    let rig = Rig::homed();
    let home = rig.control.homing().unwrap();
    let expected = lengths_at(&rig.control, POSE);
    assert_eq!(home.lengths, expected);
    assert_eq!(home.counts, rig.drives.readings.map(|r| r.counts));
    // One drum turn more on cable 2 (32768 counts, through the wrap): 2 pi r more.
    let mut readings = rig.drives.readings;
    readings[2].counts = readings[2].counts.wrapping_add(32768);
    let l = rig.control.encoder().lengths(home, &readings);
    let turn = 2.0 * core::f32::consts::PI * 0.04;
    assert!((l[2] - (expected[2] + turn)).abs() < 5e-6, "{} vs {}", l[2], expected[2] + turn);
    assert!((l[0] - expected[0]).abs() < 1e-6);
}

#[test]
fn the_estimate_finds_a_displaced_platform() {
    let mut rig = Rig::homed();
    let mut true_pose = POSE;
    true_pose[0] += 0.004;
    true_pose[2] -= 0.002;
    true_pose[5] += 0.003;
    let lengths = lengths_at(&rig.control, true_pose);
    rig.set_lengths(&lengths);
    let mut last = None;
    for _ in 0..3 {
        last = rig.step_at(POSE).estimate;
    }
    let e = last.unwrap().unwrap();
    for (k, truth) in true_pose.iter().enumerate() {
        // One count is 7.7 um; the linearisation about the setpoint adds
        // about |delta|^2 / L.
        assert!((e.pose[k] - truth).abs() < 3e-5, "{k}: {} vs {truth}", e.pose[k]);
    }
    assert!(e.residual < 2e-5, "residual {}", e.residual);
    // Minus the pose error.
    assert!((e.delta[0] - 0.004).abs() < 3e-5 && (e.delta[2] + 0.002).abs() < 3e-5, "{:?}", e.delta);
}

#[test]
fn the_speed_estimate_follows_a_constant_speed() {
    let mut rig = Rig::homed();
    // The platform moves at 0.2 m/s in y; the setpoint with it.
    let mut est = None;
    for k in 0..100 {
        let mut pose = POSE;
        pose[1] += 0.0002 * k as f32;
        let lengths = lengths_at(&rig.control, pose);
        rig.set_lengths(&lengths);
        est = rig.step_at(pose).estimate;
    }
    let v = est.unwrap().unwrap().velocity;
    // 100 ms is 31 filter time constants: the filter has settled.
    assert!((v[1] - 0.2).abs() < 0.004, "{v:?}");
    assert!(v[0].abs() < 0.004 && v[2].abs() < 0.004, "{v:?}");
}

#[test]
fn task_space_feedback_pushes_the_platform_back() {
    let mut rig = Rig::homed();
    // The platform 1 mm further along x than the setpoint, at rest (the
    // speed estimate settles while disabled).
    let mut true_pose = POSE;
    true_pose[0] += 0.001;
    let lengths = lengths_at(&rig.control, true_pose);
    rig.set_lengths(&lengths);
    for _ in 0..60 {
        rig.step_at(POSE);
    }
    rig.enable(Scheme::TaskSpace);
    let r = rig.step_at(POSE);
    assert_eq!(r.state, State::Enabled, "{:?} {:?} {:?}", r.reason, r.estimate, r.solved);
    let kp = rig.control.task_pid().gains().kp[0];
    let integral = rig.control.task_pid().integral()[0];
    // Proportional and (two cycles of) integral: -Kp e + Ki integral(e).
    let fx = r.feedback[0];
    assert!(fx < 0.0, "{fx}");
    assert!((fx - (-kp * 0.001 + integral)).abs() < 0.02 * kp * 0.001, "fx {fx}, kp e {}", kp * 0.001);
    assert!(
        r.feedback[1].abs() < 0.05 * fx.abs() && r.feedback[2].abs() < 0.05 * fx.abs(),
        "{:?}",
        r.feedback
    );
    // The tension distribution shares the feedback: W t = f + feedback.
    let c = r.solved.unwrap().result.unwrap();
    let setpoint = rig.control.newest_setpoint().unwrap();
    let k = rig.control.controller().kinematics(setpoint).unwrap();
    let wt = k.w * tension_core::nalgebra::SVector::<f32, CABLES>::from(c.tensions);
    let want = k.f + r.feedback;
    assert!((wt - want).amax() < 1e-2, "{wt:?} vs {want:?}");
}

#[test]
fn joint_space_feedback_pulls_a_long_cable_harder() {
    let mut rig = Rig::homed();
    rig.enable(Scheme::JointSpace);
    let ff = rig.step_at(POSE).solved.unwrap().result.unwrap().tensions;
    // Cable 4 is 1 mm longer than desired (a residual of 1 mm: within the
    // estimator's 5 mm), paying out at 10 mm/s.
    let mut lengths = lengths_at(&rig.control, POSE);
    lengths[4] += 0.001;
    rig.set_lengths(&lengths);
    let per_count = rig.control.encoder().per_count()[4];
    rig.drives.readings[4].counts_per_second = (0.01 / per_count) as i32;
    let r = rig.step_at(POSE);
    assert_eq!(r.state, State::Enabled, "{:?}", r.estimate);
    let g = *rig.control.joint_pid().unwrap().gains();
    let expected = g.kp * 0.001 + g.kd * 0.01 + g.ki * 0.001 * 0.001;
    assert!(r.offsets[4] > 0.0);
    assert!((r.offsets[4] - expected).abs() < 0.01 * expected, "{} vs {expected}", r.offsets[4]);
    for i in (0..CABLES).filter(|&i| i != 4) {
        assert!(r.offsets[i].abs() < 1e-3 * expected, "cable {i}: {}", r.offsets[i]);
    }
    let c = r.solved.unwrap().result.unwrap();
    assert!(
        (c.tensions[4] - (ff[4] + r.offsets[4])).abs() < 0.5,
        "{} vs {}",
        c.tensions[4],
        ff[4] + r.offsets[4]
    );
    assert!(!c.limited.any());
}

#[test]
fn joint_space_tensions_are_limited_and_reported() {
    let mut rig = Rig::homed();
    rig.control.set_tracking_limit(None);
    rig.enable(Scheme::JointSpace);
    rig.control.receive(HostMessage::TelemetryPeriod(1));
    // Cable 1 far too long (4 mm: 55 N more than a tension near the top
    // would allow? no: the speed term does it) paying out at 2 m/s.
    let per_count = rig.control.encoder().per_count()[1];
    rig.drives.readings[1].counts_per_second = (2.0 / per_count) as i32;
    let r = rig.step_at(POSE);
    let c = r.solved.unwrap().result.unwrap();
    let t_max = rig.control.controller().robot().limits().max()[1];
    assert!(c.limited.cable(1), "{:?} {:?}", c.tensions, r.offsets);
    assert_eq!(c.tensions[1], t_max);
    assert_eq!(r.telemetry.unwrap().tension_limited, 1 << 1);
}

#[test]
fn an_unreadable_drive_faults_and_forgets_the_homing() {
    let mut rig = Rig::homed();
    rig.enable(Scheme::TaskSpace);
    rig.control.receive(HostMessage::TelemetryPeriod(1));
    rig.drives.unreadable = Some(3);
    let r = rig.step_at(POSE);
    assert_eq!((r.state, r.reason, r.brakes), (State::Fault, Reason::Encoder, true));
    assert_eq!(r.unreadable_drive, Some(3));
    let t = r.telemetry.unwrap();
    assert_eq!((t.unreadable_drive, t.homed, t.reason), (Some(3), false, Reason::Encoder));
    assert!(t.residual.is_nan());
    assert_eq!(rig.control.counters().faults, 1);
    // Readable again and the fault cleared: Enable is refused until homed.
    rig.drives.unreadable = None;
    for _ in 0..=SafetyLimits::DEFAULT.ramp_cycles {
        rig.step_at(POSE);
    }
    rig.control.receive(HostMessage::ClearFault);
    assert_eq!(rig.step_at(POSE).state, State::Disabled);
    rig.control.receive(HostMessage::Enable);
    assert_eq!(rig.step_at(POSE).state, State::Disabled);
    assert_eq!(rig.control.counters().last_rejection, Rejection::Homing);
}

#[test]
fn an_unreadable_drive_in_disabled_only_shows() {
    let mut rig = Rig::homed();
    rig.drives.unreadable = Some(6);
    let r = rig.step_at(POSE);
    assert_eq!((r.state, r.reason, r.unreadable_drive), (State::Disabled, Reason::None, Some(6)));
    assert_eq!(rig.control.counters().faults, 0);
    assert!(!rig.control.homed());
}

#[test]
fn lengths_that_fit_no_pose_fault_at_once() {
    let mut rig = Rig::homed();
    rig.control.set_tracking_limit(None);
    rig.enable(Scheme::JointSpace);
    rig.control.receive(HostMessage::TelemetryPeriod(1));
    // Cable 5 slips by 5 mm: no pose has these lengths. The two redundant
    // cables absorb most of one cable's slip (5 mm leaves a residual of
    // about 1.4 mm, beyond the estimator's 1 mm; 2 mm would leave 0.55 mm).
    let mut lengths = lengths_at(&rig.control, POSE);
    lengths[5] += 0.005;
    rig.set_lengths(&lengths);
    let r = rig.step_at(POSE);
    assert!(
        matches!(r.estimate, Some(Err(cdpr_control::estimator::EstimateError::Residual))),
        "{:?}",
        r.estimate
    );
    assert_eq!((r.state, r.reason, r.brakes), (State::Fault, Reason::Estimator, true));
    assert_eq!(rig.control.counters().faults, 1);
    assert!(r.telemetry.unwrap().residual.is_nan());
    // 2 mm is within the limit: Enabled, the residual in telemetry.
    let mut rig = Rig::homed();
    rig.control.set_tracking_limit(None);
    rig.enable(Scheme::JointSpace);
    rig.control.receive(HostMessage::TelemetryPeriod(1));
    let mut lengths = lengths_at(&rig.control, POSE);
    lengths[5] += 0.002;
    rig.set_lengths(&lengths);
    let r = rig.step_at(POSE);
    assert_eq!(r.state, State::Enabled, "{:?}", r.estimate);
    let residual = r.telemetry.unwrap().residual;
    assert!(residual > 0.3e-3 && residual < 1e-3, "{residual}");
}

/// The lengths of `POSE` moved by 60 mm along x: a pose, but beyond the
/// estimator's 50 mm correction about the setpoint.
fn lengths_60_mm_off(control: &ControlLoop) -> [f32; CABLES] {
    let mut far = POSE;
    far[0] += 0.06;
    lengths_at(control, far)
}

#[test]
fn an_estimator_failure_holds_then_faults() {
    let mut rig = Rig::homed();
    rig.control.set_tracking_limit(None);
    rig.enable(Scheme::JointSpace);
    let held = rig.step_at(POSE).torques;
    rig.set_lengths(&lengths_60_mm_off(&rig.control));
    let r = rig.step_at(POSE);
    assert_eq!((r.state, r.reason), (State::Holding, Reason::Estimator), "{:?}", r.estimate);
    assert!(matches!(r.estimate, Some(Err(cdpr_control::estimator::EstimateError::Correction))));
    assert_eq!(r.torques, held);
    let mut r = r;
    for _ in 0..SafetyLimits::DEFAULT.hold_cycles {
        r = rig.step_at(POSE);
        if r.state == State::Fault {
            break;
        }
        assert_eq!(r.torques, held);
    }
    assert_eq!(r.state, State::Fault);
    assert_eq!((r.reason, rig.control.supervisor().hold_reason()), (Reason::HoldTimeout, Reason::Estimator));
}

#[test]
fn an_estimator_failure_clears_when_the_lengths_agree_again() {
    let mut rig = Rig::homed();
    rig.control.set_tracking_limit(None);
    rig.enable(Scheme::TaskSpace);
    let good = lengths_at(&rig.control, POSE);
    let bad = lengths_60_mm_off(&rig.control);
    rig.set_lengths(&bad);
    assert_eq!(rig.step_at(POSE).state, State::Holding);
    rig.set_lengths(&good);
    assert_eq!(rig.step_at(POSE).state, State::Enabled);
    // In Disabled the same failure refuses Enable.
    rig.control.receive(HostMessage::Disable);
    rig.set_lengths(&bad);
    for _ in 0..=SafetyLimits::DEFAULT.ramp_cycles {
        rig.step_at(POSE);
    }
    rig.control.receive(HostMessage::Enable);
    assert_eq!(rig.step_at(POSE).state, State::Disabled);
    assert_eq!(rig.control.counters().last_rejection, Rejection::State);
}

#[test]
fn select_feedback_only_in_disabled_and_known() {
    let mut rig = Rig::homed();
    rig.control.receive(HostMessage::SelectFeedback(7));
    assert_eq!(rig.control.counters().last_rejection, Rejection::Range);
    rig.enable(Scheme::TaskSpace);
    rig.control.receive(HostMessage::SelectFeedback(2));
    assert_eq!(rig.control.counters().last_rejection, Rejection::State);
    assert_eq!(rig.control.scheme(), Scheme::TaskSpace);
}

/// A robot file without `[platform] inertia` gives the task-space PID zero
/// rotation gains: selecting it is refused (`Range`, as the joint-space
/// PID without gains), the loop stays feed-forward; with the inertia the
/// same selection is taken. Accepted, the host would believe the
/// orientation held by feedback when only the feed-forward holds it.
#[test]
fn task_space_feedback_without_the_platforms_inertia_is_refused() {
    let mut robot = common::suspended8();
    let platform =
        tension_core::Platform { inertia: tension_core::nalgebra::Matrix3::zeros(), ..*robot.platform() };
    robot.set_platform(platform).unwrap();
    let mut bare =
        ControlLoop::new(robot, Method::Barycenter, common::setpoint_range(), SafetyLimits::DEFAULT).unwrap();
    let g = *bare.task_pid().gains();
    assert!(g.kp[..3].iter().all(|&k| k > 0.0) && g.kp[3..].iter().all(|&k| k == 0.0), "{g:?}");
    assert!(!bare.task_pid().acts_on_every_axis());
    bare.receive(HostMessage::SelectFeedback(1));
    assert_eq!((bare.counters().rejected_range, bare.counters().last_rejection), (1, Rejection::Range));
    assert_eq!(bare.scheme(), Scheme::FeedForward);
    // The other schemes are still offered.
    bare.receive(HostMessage::SelectFeedback(2));
    assert_eq!((bare.scheme(), bare.counters().rejected_range), (Scheme::JointSpace, 1));
    let mut control = control();
    assert!(control.task_pid().acts_on_every_axis());
    control.receive(HostMessage::SelectFeedback(1));
    assert_eq!((control.scheme(), control.counters().rejected_range), (Scheme::TaskSpace, 0));
}

#[test]
fn default_joint_gains_are_the_stated_ones() {
    // `feedback::JointGains`' doc: at the setpoint range's centre
    // (0, 0, 1.75) the softest translation is y, s_y = 2.04.
    let control = control();
    let g = *control.joint_pid().unwrap().gains();
    let near = |x: f32, stated: f32| (x - stated).abs() < 0.01 * stated;
    assert!(near(g.kp, 9195.0) && near(g.kd, 292.7) && near(g.ki, 96_300.0), "{g:?}");
    let robot = common::suspended8();
    let w = robot.wrench_matrix(&Pose6::from([0.0, 0.0, 1.75, 0.0, 0.0, 0.0])).unwrap();
    let s: Vec<f32> = (0..3).map(|k| (0..CABLES).map(|i| w[(k, i)] * w[(k, i)]).sum()).collect();
    assert!(near(s[0], 3.60) && near(s[1], 2.04) && near(s[2], 2.35), "{s:?}");
}

#[test]
fn the_fused_kinematics_are_tension_cores() {
    let control = control();
    let robot = control.controller().robot();
    for (pose, v, a) in [
        (POSE, [0.3, -0.2, 0.1, 0.05, -0.04, 0.2], [-1.2, 0.8, 2.0, -0.3, 0.1, 0.5]),
        ([0.8, 0.4, 2.0, 0.05, -0.05, 0.1], [0.0; 6], [0.0; 6]),
        (
            [-0.9, -0.4, 2.4, 0.3, 0.5, -0.7],
            [1.0, 0.5, -0.5, 1.0, -2.0, 3.0],
            [5.0, -3.0, 2.0, 10.0, 4.0, -8.0],
        ),
    ] {
        let s = cdpr_control::Setpoint {
            seq: 1,
            pose: Pose6::from(pose),
            velocity: Pose6::from(v),
            acceleration: Pose6::from(a),
        };
        let k = control.controller().kinematics(&s).unwrap();
        let cables = robot.cables(&s.pose).unwrap();
        let (w, f) =
            robot.wrench_problem(&s.pose, &Pose6::zeros(), Some((&s.velocity, &s.acceleration))).unwrap();
        assert!((k.lengths - cables.lengths).amax() < 1e-6);
        assert!((k.w - w).amax() < 1e-6, "{} {}", k.w, w);
        assert!((k.f - f).amax() < 1e-4 * f.amax(), "{} {}", k.f, f);
        let (_, r) = robot.frame(&s.pose).unwrap();
        assert!((k.trig.rotation() - r).amax() < 1e-6);
    }
    let nan = cdpr_control::Setpoint {
        seq: 1,
        pose: Pose6::from([f32::NAN, 0.0, 1.9, 0.0, 0.0, 0.0]),
        velocity: Pose6::zeros(),
        acceleration: Pose6::zeros(),
    };
    assert_eq!(control.controller().kinematics(&nan).unwrap_err(), tension_core::Error::NonFinite);
    // Every one of the setpoint's 18 numbers NaN or infinite, the others a
    // pose the kinematics accepts: refused as non-finite.
    let good = cdpr_control::Setpoint { pose: Pose6::from([0.0, 0.0, 1.9, 0.0, 0.0, 0.0]), ..nan };
    assert!(control.controller().kinematics(&good).is_ok());
    let mut refused = 0;
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        for part in 0..3 {
            for i in 0..6 {
                let mut s = good;
                [&mut s.pose, &mut s.velocity, &mut s.acceleration][part][i] = bad;
                assert_eq!(
                    control.controller().kinematics(&s).unwrap_err(),
                    tension_core::Error::NonFinite,
                    "{bad} in part {part}, entry {i}"
                );
                refused += 1;
            }
        }
    }
    assert_eq!(refused, 54);
}

#[test]
fn the_estimate_agrees_with_tension_cores_forward_kinematics() {
    use tension_core::forward_kinematics::ForwardSettings;
    let mut rig = Rig::homed();
    let robot = rig.control.controller().robot().clone();
    let settings = ForwardSettings::for_robot(&robot);
    for offset in
        [[0.005, -0.003, 0.002, 0.003, -0.002, 0.004], [-0.01, 0.008, -0.006, -0.004, 0.005, -0.006]]
    {
        let mut true_pose = POSE;
        for (p, o) in true_pose.iter_mut().zip(offset) {
            *p += o;
        }
        let lengths = lengths_at(&rig.control, true_pose);
        rig.set_lengths(&lengths);
        let e = rig.step_at(POSE).estimate.unwrap().unwrap();
        // The same encoder lengths (quantised to a count) through the full solver.
        let measured = rig.control.encoder().lengths(rig.control.homing().unwrap(), rig.control.readings());
        let fk = robot
            .forward_kinematics(
                &tension_core::nalgebra::SVector::<f32, CABLES>::from(measured),
                Some(&Pose6::from(POSE)),
                &settings,
            )
            .unwrap();
        // One step about the setpoint: the linearisation leaves about
        // |delta|^2 / L (13 um at 12 mm, 2 m cables).
        let tol = if offset[0].abs() > 0.008 { 1e-4 } else { 3e-5 };
        for k in 0..6 {
            assert!(
                (e.pose[k] - fk.pose[k]).abs() < tol,
                "{k}: {} vs {} ({:?})",
                e.pose[k],
                fk.pose[k],
                offset
            );
        }
    }
}

/// A task-space PID whose wrench is bounded only far beyond what the
/// cables can give (1 kN, 100 N m).
fn unbounded_task_pid(control: &ControlLoop) -> cdpr_control::feedback::TaskPid {
    cdpr_control::feedback::TaskPid::new(
        *control.task_pid().gains(),
        cdpr_control::feedback::FeedbackLimits {
            force_max: 1000.0,
            moment_max: 100.0,
            integral_max: [0.0; 6],
        },
    )
    .expect("bounds of zero or more")
}

#[test]
fn an_infeasible_feedback_wrench_backs_off_and_recovers() {
    let mut rig = Rig::homed();
    rig.control.set_tracking_limit(None);
    let pid = unbounded_task_pid(&rig.control);
    rig.control.set_task_pid(pid);
    rig.control.receive(HostMessage::TelemetryPeriod(1));
    rig.enable(Scheme::TaskSpace);
    let held = rig.step_at(POSE).torques;
    // The platform 15 mm along x: the PID asks for about -280 N sideways,
    // which no tensions within the limits give.
    let mut off = POSE;
    off[0] += 0.015;
    rig.set_lengths(&lengths_at(&rig.control, off));
    let mut scales = Vec::new();
    let mut first_solved = None;
    for k in 0..200 {
        let r = rig.step_at(POSE);
        assert_eq!(r.state, State::Enabled, "cycle {k}: {:?}", r.reason);
        let t = r.telemetry.unwrap();
        scales.push(t.feedback_scale);
        match r.solved.unwrap().result {
            Err(tension_core::Error::Infeasible) => {
                assert_eq!(t.feedback_scale, 0);
                // Held: the last feasible torques, not a ramp or zero.
                if first_solved.is_none() {
                    assert_eq!(r.torques, held, "cycle {k}");
                }
            }
            Ok(c) => {
                first_solved.get_or_insert(k);
                // None at all once the halving went below 1/16.
                if t.feedback_scale == 0 {
                    assert!(r.feedback.iter().all(|f| *f == 0.0), "{:?}", r.feedback);
                } else {
                    assert!(r.feedback[0] < 0.0, "{:?}", r.feedback);
                }
                assert_eq!(r.torques, c.torques);
            }
            Err(e) => panic!("cycle {k}: {e:?}"),
        }
    }
    // Halved each cycle: 100 (failed), 50, 25, 12.5, 6.25, then none;
    // the first cycle that solves is within five.
    let first = first_solved.expect("the feedback backs off until a cycle solves");
    assert!(first <= 5, "{scales:?}");
    assert_eq!(scales[0], 0, "{scales:?}");
    // After a solve the fraction grows 2 % a cycle until it fails again.
    assert!(scales.windows(2).any(|w| w[0] > 0 && w[1] == w[0] + 2), "{scales:?}");
    // And never climbs back to full: 280 N is out of reach.
    assert!(scales.iter().all(|&s| s < 100), "{scales:?}");
}

/// The moment of the first cycle that solves after the platform is put
/// 4 mm along x and 0.01 rad about z off the setpoint, backing off `how`.
fn moment_after_back_off(how: cdpr_control::BackOff) -> (u8, f32) {
    let mut rig = Rig::homed();
    rig.control.set_tracking_limit(None);
    rig.control.set_back_off(how);
    let pid = unbounded_task_pid(&rig.control);
    rig.control.set_task_pid(pid);
    rig.control.receive(HostMessage::TelemetryPeriod(1));
    rig.enable(Scheme::TaskSpace);
    rig.step_at(POSE);
    let mut off = POSE;
    off[0] += 0.004;
    off[5] -= 0.01;
    rig.set_lengths(&lengths_at(&rig.control, off));
    for _ in 0..10 {
        let r = rig.step_at(POSE);
        if r.solved.unwrap().result.is_ok() {
            return (r.telemetry.unwrap().feedback_scale, r.feedback[5]);
        }
    }
    panic!("no cycle solved");
}

#[test]
fn the_back_off_keeps_the_moment_feedback() {
    // The same force fraction either way; the moment whole only when the
    // force backs off first (rc x F is small beside it).
    let (whole_scale, whole) = moment_after_back_off(cdpr_control::BackOff::Whole);
    let (first_scale, kept) = moment_after_back_off(cdpr_control::BackOff::ForceFirst);
    assert_eq!(whole_scale, first_scale);
    assert!(whole_scale > 0 && whole_scale < 100, "{whole_scale}");
    assert!(kept > 0.0 && whole > 0.0, "{kept} {whole}");
    let ratio = kept / whole;
    let expected = 100.0 / f32::from(whole_scale);
    println!("force at {whole_scale} %: moment {kept} N m kept, {whole} N m scaled with the force");
    assert!((ratio - expected).abs() < 0.25 * expected, "{kept} / {whole}: {ratio} vs {expected}");
}

#[test]
fn a_setpoint_infeasible_by_itself_holds_despite_the_backing_off() {
    let mut rig = Rig::homed();
    rig.control.set_tracking_limit(None);
    rig.control.set_jump_limits(None);
    let pid = unbounded_task_pid(&rig.control);
    rig.control.set_task_pid(pid);
    rig.enable(Scheme::TaskSpace);
    let held = rig.step_at(POSE).torques;
    // In range, but beyond the wrench-feasible workspace (the platform's
    // lengths there, so that the estimate and the feedback run).
    let high = [0.0, 0.0, 3.4, 0.0, 0.0, 0.0];
    let mut near = high;
    near[0] += 0.001;
    rig.set_lengths(&lengths_at(&rig.control, near));
    let mut held_for = 0;
    loop {
        let r = rig.step_at(high);
        assert!(matches!(r.estimate, Some(Ok(_))), "{:?}", r.estimate);
        assert_eq!(r.torques, held);
        if r.state == State::Holding {
            assert_eq!(r.reason, Reason::Infeasible);
            break;
        }
        assert_eq!(r.state, State::Enabled);
        held_for += 1;
        assert!(held_for <= 5, "still Enabled after {held_for} cycles");
    }
    assert!(held_for >= 1, "the feedback was on: the first failure is the feedback's");
    assert_eq!(rig.control.counters().infeasible, 1);
}

/// The estimator's step through the solver's factorisation (`R`, shared
/// with the tension solver since the controller factors `W` once a cycle)
/// is its step through the formed `W W^T`: the same pose to `f32`
/// rounding, and the same refusals, over references across the workspace
/// and displacements from a few millimetres to beyond the correction
/// limit.
#[test]
fn the_estimate_through_the_solvers_factorisation_is_the_gram_ones() {
    use cdpr_control::estimator::{EstimateError, Estimator, EstimatorSettings, Reference};
    use tension_core::linalg::WrenchFactorization;
    let control = control();
    let mut state = 5u64;
    let mut uniform = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    };
    let (mut agreed, mut refused) = (0, 0);
    for i in 0..400 {
        let pose = [
            0.4 * uniform(),
            0.4 * uniform(),
            1.9 + 0.3 * uniform(),
            0.1 * uniform(),
            0.1 * uniform(),
            0.1 * uniform(),
        ];
        // Every fifth displacement is 0.2 m or 0.2 rad: beyond the limit.
        let size = if i % 5 == 0 { 0.2 } else { 0.015 };
        let truth: [f32; 6] = core::array::from_fn(|k| pose[k] + size * uniform());
        let setpoint = cdpr_control::Setpoint {
            seq: 1,
            pose: Pose6::from(pose),
            velocity: Pose6::zeros(),
            acceleration: Pose6::zeros(),
        };
        let k = control.controller().kinematics(&setpoint).unwrap();
        let fact = WrenchFactorization::new(&k.w).unwrap();
        let lengths = lengths_at(&control, truth);
        let settings = EstimatorSettings::default();
        let shared =
            Estimator::new(settings).about(Reference::of_setpoint(&setpoint.pose, &k, Some(&fact)), &lengths);
        let gram = Estimator::new(settings).about(Reference::of_setpoint(&setpoint.pose, &k, None), &lengths);
        match (shared, gram) {
            (Ok(a), Ok(b)) => {
                for j in 0..6 {
                    assert!((a.pose[j] - b.pose[j]).abs() < 2e-6, "{i}: {j}: {} vs {}", a.pose[j], b.pose[j]);
                }
                assert!((a.residual - b.residual).abs() < 2e-6, "{i}: {} vs {}", a.residual, b.residual);
                agreed += 1;
            }
            (Err(a), Err(b)) => {
                assert_eq!(a, b, "{i}");
                assert!(matches!(a, EstimateError::Correction | EstimateError::Residual), "{i}: {a:?}");
                refused += 1;
            }
            (a, b) => panic!("{i}: {a:?} vs {b:?}"),
        }
    }
    assert!(agreed >= 250 && refused >= 40, "{agreed} agreed, {refused} refused");
}

/// A factorisation made by `prepare` and overwritten before `finish` (by
/// another `prepare` or a `solve`) is not solved with: `finish` factors
/// its own kinematics anew, and `factorization` no longer offers it. The
/// closed form (no warm start) gives the same command as a fresh
/// controller; solved with the other pose's factorisation it would not.
#[test]
fn a_prepared_factorisation_overwritten_before_finish_is_made_anew() {
    use cdpr_control::controller::{Controller, PhaseTicks, Wrench};
    let at = |pose: [f32; 6]| cdpr_control::Setpoint {
        seq: 1,
        pose: Pose6::from(pose),
        velocity: Pose6::zeros(),
        acceleration: Pose6::zeros(),
    };
    let (s1, s2) = (at(POSE), at([-0.3, 0.25, 2.1, -0.05, 0.04, -0.1]));
    let mut fresh = Controller::new(common::suspended8().clone(), Method::ClosedForm).unwrap();
    let k1 = fresh.kinematics(&s1).unwrap();
    let k2 = fresh.kinematics(&s2).unwrap();
    let p = fresh.prepare(&k1, &NoClock);
    let expected =
        fresh.finish(&s1, p, &Wrench::zeros(), None, &NoClock, &mut PhaseTicks::default()).unwrap();
    let mut checked = 0;
    for overwrite_by_solve in [true, false] {
        let mut c = Controller::new(common::suspended8().clone(), Method::ClosedForm).unwrap();
        let p = c.prepare(&k1, &NoClock);
        assert!(c.factorization(&p).is_some());
        if overwrite_by_solve {
            c.solve(&k2.w, &k2.f).unwrap();
        } else {
            let _other = c.prepare(&k2, &NoClock);
        }
        assert!(c.factorization(&p).is_none());
        let got = c.finish(&s1, p, &Wrench::zeros(), None, &NoClock, &mut PhaseTicks::default()).unwrap();
        assert_eq!(got, expected);
        checked += 1;
    }
    assert_eq!(checked, 2);
    // The poses differ enough that the other factorisation would matter.
    assert!((k1.w - k2.w).amax() > 0.05);
}
