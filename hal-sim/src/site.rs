//! The robot a run simulates and the poses its scenarios use: a [`Site`].
//!
//! * [`Site::suspended_8`]: `robots/suspended-8.toml` with the hand-picked
//!   poses whose figures `hal-sim/README.md` states (what `hal-sim` runs
//!   without `--robot`, and what the tests check those figures on);
//! * [`Site::derived`]: any 6-DOF, 8-cable robot file, with its poses
//!   derived from its workspace as the firmware's demo trajectory is
//!   (`cdpr_demo::derive::derive_loop`: the centre of the static
//!   workspace, the loop around it that keeps every tension 2 % of the
//!   range from its limits): the holds at fractions of the loop's
//!   amplitudes from the centre, each checked to have static barycenter
//!   tensions with that margin (and drawn in towards the centre until it
//!   does), the tracking loop on the loop's path at half its amplitudes,
//!   the jumps' targets
//!   found on the robot's own workspace and setpoint range, and the push
//!   scaled by the platform's weight.

use std::path::{Path as FilePath, PathBuf};

use cdpr_control::link::SetpointRange;
use cdpr_demo::derive::{derive_loop, Robot68, MARGIN};
use nalgebra::SVector;
use tension_core::{Error, Method, Solution, TensionSolver};

use crate::scenario::{Path, LOOP_AMPLITUDES};

/// Suspended-8's winches' largest torque, N m (its `[winch] torque_max`),
/// which the simulated winch model is for.
pub const SUSPENDED_8_TORQUE_MAX: f64 = 2.5;

/// The static holds' push, N and N m, on suspended-8 (scaled by the
/// platform's weight on another robot).
pub const PUSH: [f64; 6] = [3.0, -2.0, 0.0, 0.0, 0.0, 0.2];

/// The robot file and the poses of its scenarios.
#[derive(Debug, Clone, PartialEq)]
pub struct Site {
    /// The robot file (the plant's robot, and the controller's in `f32`).
    pub file: PathBuf,
    /// The four static holds, by name.
    pub holds: [(&'static str, [f64; 6]); 4],
    /// The pose the fault scenarios (but the lost stream in motion) start
    /// from and hold.
    pub fault_pose: [f64; 6],
    /// The loop the tracking scenarios follow.
    pub track: Path,
    /// A pose inside the setpoint range without static tensions: the
    /// `infeasible-setpoint` jump's target, and what its description says
    /// of it.
    pub infeasible: ([f64; 6], String),
    /// A pose beyond the setpoint range: the `out-of-range-setpoint`
    /// jump's target, and what its description says of it.
    pub out_of_range: ([f64; 6], String),
    /// The platform's weight against the one the feedback's defaults were
    /// set for (`cdpr_control::control_loop::weight_scale`, the firmware's
    /// rule): what the holds' push ([`PUSH`]) and the feedback's bounds
    /// scale by.
    pub weight_scale: f64,
    /// The winches' `torque_max` against suspended-8's
    /// ([`SUSPENDED_8_TORQUE_MAX`]): what the simulated winches' inertia
    /// and friction scale by (`WinchModel::scaled`).
    pub motor_scale: f64,
    /// What the descriptions of `lost-stream-moving` and `encoder-stuck`
    /// say of the platform's motion at their events.
    pub motion: (String, String),
}

/// Static-hold poses of suspended-8 (conventions: pose order).
pub const HOLD_POSES: [(&str, [f64; 6]); 4] = [
    ("hold-centre", [0.0, 0.0, 1.8, 0.0, 0.0, 0.0]),
    ("hold-corner", [0.8, 0.4, 2.0, 0.05, -0.05, 0.1]),
    ("hold-high", [-0.9, -0.4, 2.4, 0.0, 0.08, -0.2]),
    ("hold-low", [0.5, -0.6, 1.5, 0.1, 0.0, 0.0]),
];

/// The pose suspended-8's fault scenarios (but the lost stream) start from
/// and hold.
pub const FAULT_POSE: [f64; 6] = [0.4, 0.2, 1.9, 0.03, -0.02, 0.05];

/// The loop suspended-8's tracking scenarios follow.
pub const TRACK: Path =
    Path::Loop { base: [0.0, 0.0, 1.8, 0.0, 0.0, 0.0], start: 0.2, period: 8.0, amplitudes: LOOP_AMPLITUDES };

/// The shipped suspended-8's robot file.
pub fn suspended_8_file() -> PathBuf {
    FilePath::new(env!("CARGO_MANIFEST_DIR")).join("../robots/suspended-8.toml")
}

/// Fractions of the loop's amplitudes (`x, y, z` m, `rx, ry, rz` rad) at
/// which a derived site's holds and fault pose lie from the centre.
const HOLD_FRACTIONS: [(&str, [f64; 6]); 4] = [
    ("hold-centre", [0.0; 6]),
    ("hold-corner", [0.7, 0.7, 0.5, 0.5, -0.5, 0.5]),
    ("hold-high", [-0.7, -0.7, 0.9, 0.0, 0.8, -0.8]),
    ("hold-low", [0.5, -0.8, -0.9, 0.8, 0.0, 0.0]),
];
const FAULT_FRACTIONS: [f64; 6] = [0.5, 0.5, 0.3, 0.3, -0.3, 0.3];
/// A derived site's tracking loop against the demo's amplitudes.
const TRACK_FRACTION: f64 = 0.5;

impl Site {
    /// `robots/suspended-8.toml` with the poses `hal-sim/README.md`'s
    /// figures are for.
    pub fn suspended_8() -> Self {
        Self {
            file: suspended_8_file(),
            holds: HOLD_POSES,
            fault_pose: FAULT_POSE,
            track: TRACK,
            infeasible: (
                [0.0, 0.0, 3.4, 0.0, 0.0, 0.0],
                "a pose outside the wrench-feasible workspace (z = 3.4 m)".into(),
            ),
            out_of_range: ([3.0, 0.0, 1.9, 0.0, 0.0, 0.0], "outside the setpoint range (x = 3 m)".into()),
            weight_scale: 1.0,
            motor_scale: 1.0,
            motion: ("mid-loop at 0.9 m/s".into(), "mid-loop (the platform at 0.57 m/s)".into()),
        }
    }

    /// `file` (6 DOF, 8 cables) with poses derived from its workspace (the
    /// module's description); an error says what was not found.
    pub fn derived(file: &FilePath) -> Result<Self, String> {
        let shown = file.display();
        let parsed = robot_file::RobotFile::load(file).map_err(|e| format!("{shown}: {e}"))?;
        let robot: Robot68 =
            parsed.to_robot().map_err(|e| format!("{shown}: {e} (hal-sim simulates 6 DOF x 8 cables)"))?;
        // What the board refuses of the robot in its f32 (the control
        // loop's checks, made here so that no scenario starts).
        let robot32 =
            parsed.to_robot::<f32, 6, 8>().map_err(|e| format!("{shown}: {e} (in the board's f32)"))?;
        let (scale, _, _) = crate::scenario::encoders_of(&parsed, file)?;
        cdpr_control::control_loop::check_board_robot(&robot32, &scale)
            .map_err(|e| format!("{shown}: {e}"))?;
        let range = SetpointRange::for_robot(&robot32);
        let derivation = derive_loop(&robot).map_err(|e| format!("{shown}: {e}"))?;
        let p = derivation.params;
        let centre = [f64::from(p.centre[0]), f64::from(p.centre[1]), f64::from(p.centre[2]), 0.0, 0.0, 0.0];
        let amplitude = p.amplitude.map(f64::from);
        let span =
            (0..8).map(|i| robot.limits().max()[i] - robot.limits().min()[i]).fold(f64::INFINITY, f64::min);
        let held = |fractions: [f64; 6]| -> Result<[f64; 6], String> {
            // Drawn in towards the centre until the static tensions keep
            // the margin (the centre has them: the derivation checked).
            let mut scale = 1.0;
            for _ in 0..20 {
                let pose: [f64; 6] =
                    core::array::from_fn(|k| centre[k] + scale * fractions[k] * amplitude[k]);
                if static_solution(&robot, &pose).is_ok_and(|s| s.robustness >= MARGIN * span) {
                    return Ok(pose);
                }
                scale *= 0.8;
            }
            Err(format!("{shown}: no hold pose towards {fractions:?} of the loop has static tensions"))
        };
        let mut holds = HOLD_POSES;
        for (slot, (name, fractions)) in holds.iter_mut().zip(HOLD_FRACTIONS) {
            *slot = (name, held(fractions)?);
        }
        let fault_pose = held(FAULT_FRACTIONS)?;
        // The loop at half the demo's amplitudes, on its path (hal-sim's
        // loop runs from its base through `base + A (1 - cos)` in z: the
        // base below the centre by the z amplitude traces the demo's
        // `C - A cos`). At the full amplitudes IPAnema 1's loop takes the
        // estimator's residual past its 1 mm limit a third of the way
        // round (0.93 mm before it: the 2 mm anchor errors of every
        // scenario, which its small frame feels more), a fault: measured,
        // at periods of 8 s and 16 s alike.
        let loop_amplitudes = amplitude.map(|a| TRACK_FRACTION * a);
        let mut base = centre;
        base[2] -= loop_amplitudes[2];
        let track = Path::Loop { base, start: 0.2, period: 8.0, amplitudes: loop_amplitudes };
        let infeasible = infeasible_target(&robot, &range, &fault_pose)
            .ok_or_else(|| format!("{shown}: no pose along x, y or z from the fault pose, inside the setpoint range, lacks static tensions"))?;
        let mut out = fault_pose;
        out[0] = f64::from(range.position_max[0])
            + 0.25 * f64::from(range.position_max[0] - range.position_min[0]);
        let platform = robot.platform();
        let weight = f64::from(cdpr_control::control_loop::weight_scale(
            platform.mass as f32,
            platform.gravity.map(|g| g as f32).into(),
        ));
        Ok(Self {
            file: file.to_path_buf(),
            holds,
            fault_pose,
            track,
            infeasible,
            out_of_range: (out, format!("outside the setpoint range (x = {:.2} m)", out[0])),
            weight_scale: weight,
            motor_scale: robot.winch().map_or(1.0, |w| w.torque_max / SUSPENDED_8_TORQUE_MAX),
            motion: ("mid-loop".into(), "mid-loop".into()),
        })
    }
}

/// The barycenter's tensions at `pose` at rest, cold.
fn static_solution(robot: &Robot68, pose: &[f64; 6]) -> Result<Solution<f64, 8>, Error> {
    let (w, f) = robot.wrench_problem(&SVector::from(*pose), &SVector::zeros(), None)?;
    TensionSolver::<f64, 8>::new(Method::Barycenter).solve(&w, &f, robot.limits())
}

/// From `from`, the nearest pose along `+-x`, `+-y`, `+-z` (5 mm steps)
/// that has no static tensions (`infeasible`), taken 20 % further out when
/// the range allows, inside the setpoint range (a margin in): the target
/// and its description.
fn infeasible_target(robot: &Robot68, range: &SetpointRange, from: &[f64; 6]) -> Option<([f64; 6], String)> {
    let margin = f64::from(SetpointRange::MARGIN);
    let inside = |k: usize, v: f64| {
        v >= f64::from(range.position_min[k]) + margin && v <= f64::from(range.position_max[k]) - margin
    };
    let infeasible = |pose: &[f64; 6]| matches!(static_solution(robot, pose), Err(Error::Infeasible));
    // The nearest offset, and its axis.
    let mut best: Option<(f64, usize)> = None;
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            for n in 1..2000 {
                let d = sign * 0.005 * f64::from(n);
                if !inside(axis, from[axis] + d) {
                    break;
                }
                let mut pose = *from;
                pose[axis] += d;
                if infeasible(&pose) {
                    if best.is_none_or(|(b, _)| d.abs() < b.abs()) {
                        best = Some((d, axis));
                    }
                    break;
                }
            }
        }
    }
    let (d, axis) = best?;
    let at = |d: f64| {
        let mut pose = *from;
        pose[axis] += d;
        pose
    };
    let further = at(1.2 * d);
    let pose = if inside(axis, further[axis]) && infeasible(&further) { further } else { at(d) };
    let name = ["x", "y", "z"][axis];
    Some((pose, format!("a pose outside the wrench-feasible workspace ({name} = {:.2} m)", pose[axis])))
}
