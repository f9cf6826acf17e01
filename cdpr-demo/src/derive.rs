//! The demo trajectory's [`Params`] derived from a robot (host side, `f64`,
//! `tension-core`): the one place both the firmware's `build.rs` (which
//! emits them as `firmware::robot::DEMO`) and `cargo xtask` (which streams
//! and checks the same trajectory) compute them. Behind the `std` feature.
//!
//! 1. **Centre**: the centroid (rounded to the millimetre, no rotation)
//!    of the positions on a 19 x 19 x 19 grid over the box the setpoint
//!    range is built on (`SetpointRange::for_robot`) where the static pose
//!    has barycenter tensions; it must have them itself.
//! 2. **Loop**: amplitudes start at fractions of the box's half-extents
//!    ([`START_FRACTION`], rotations [`START_ANGLES`]) and shrink by
//!    [`SHRINK`] until every sampled setpoint of the loop (every 5 ms, with
//!    its velocity and acceleration: the d'Alembert wrench) is solved by
//!    the firmware's `barycenter` with at least [`MARGIN`] of
//!    `t_max - t_min` from every limit, and by `puncture` (the end-to-end
//!    test selects it).
//! 3. **Excursion**: along one of `+-x`, `+-y`, `+-z` (the one that leaves
//!    the workspace with the smallest offset), the smallest offset (in
//!    5 mm steps) at which every setpoint of the
//!    plateau is `infeasible`, then 50 % further out ([`EXCURSION_FACTORS`]:
//!    less when the range does not allow); the whole excursion, cycle by cycle,
//!    must give only solutions or `infeasible`, be infeasible in one run of at least
//!    [`INFEASIBLE_CYCLES`] cycles in a row (longer than the supervisor's
//!    hold), and stay within the setpoint range (positions half a margin
//!    inside, speeds and accelerations within 80 % of the limits).

use std::format;
use std::string::String;
use std::vec::Vec;

use cdpr_control::link::SetpointRange;
use cdpr_control::setpoint::Setpoint;
use cdpr_control::supervisor::SafetyLimits;
use tension_core::nalgebra::{SVector, Vector3};
use tension_core::{Error, Method, Platform, Robot, Solution, TensionLimits, TensionSolver, Winch};

use crate::trajectory::{Params, DURATION_S, EXCURSION_WINDOW, PERIOD_S};

/// The firmware's robot shape.
pub type Robot68 = Robot<f64, 6, 8>;

/// Smallest distance of the loop's barycenter tensions to a limit, as a
/// fraction of `t_max - t_min`.
pub const MARGIN: f64 = 0.02;
/// The loop's starting amplitudes of `x, y, z` as fractions of the box's
/// half-extents.
pub const START_FRACTION: [f64; 3] = [0.45, 0.27, 0.25];
/// The loop's starting amplitudes of `rx, ry, rz`, rad.
pub const START_ANGLES: [f64; 3] = [0.1, 0.08, 0.2];
/// Factor the amplitudes shrink by per attempt.
pub const SHRINK: f64 = 0.85;
/// Longest the excursion must stay infeasible in a row, cycles: the
/// supervisor's hold and half as much again.
pub const INFEASIBLE_CYCLES: u32 = SafetyLimits::DEFAULT.hold_cycles * 3 / 2;
/// How much further out than the first offset with an infeasible plateau
/// the excursion goes, tried in turn until one fits the range: far enough
/// that it crosses the workspace's border briskly (the solver's costliest
/// cycles are the infeasible ones just beyond it, a cold search that
/// cannot rule lines out).
pub const EXCURSION_FACTORS: [f32; 5] = [1.5, 1.35, 1.2, 1.1, 1.0];
/// The excursion's start, rise time and plateau, s.
const EXCURSION_TIMES: (f32, f32, f32) = (1.75, 0.95, 0.2);

/// The parameters and what the derivation found.
#[derive(Debug, Clone, Copy)]
pub struct Derivation {
    /// The trajectory.
    pub params: Params,
    /// The static barycenter robustness at the centre, N.
    pub centre_robustness: f64,
    /// The loop's smallest barycenter robustness (with motion), N.
    pub loop_robustness: f64,
    /// The amplitudes' scale against the starting ones.
    pub scale: f64,
    /// Cycles of the excursion with infeasible setpoints (longest run).
    pub infeasible_run: u32,
}

/// `robot`'s demo trajectory (see the module's description); an error
/// says which step found nothing.
pub fn derive(robot: &Robot68) -> Result<Derivation, String> {
    derive_around(robot, centre(robot)?)
}

/// [`derive`] from its step 1's result, `centre` ([`centre`]), for a
/// caller that has it already (the firmware's build, which needs the
/// centre with or without a demo).
pub fn derive_around(robot: &Robot68, centre: Centre) -> Result<Derivation, String> {
    let d = loop_around(robot, centre)?;
    let range = SetpointRange::for_robot(&to_f32(robot)?);
    let (params, infeasible_run) = excursion(robot, d.params, &range)?;
    Ok(Derivation {
        params,
        centre_robustness: d.centre_robustness,
        loop_robustness: d.loop_robustness,
        scale: d.scale,
        infeasible_run,
    })
}

/// Step 1 of [`derive`]: the static workspace's centre (see the module's
/// description). The product firmware's QEMU build rests its encoders'
/// stand-in there when the robot has no demo loop, and the stress set
/// centres on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Centre {
    /// The position, base frame, m (no rotation).
    pub position: [f32; 3],
    /// The static barycenter robustness there, N.
    pub robustness: f64,
}

/// Step 1 of [`derive`]: the centroid, rounded to the millimetre, of the
/// positions on a 19 x 19 x 19 grid over the setpoint range's box where
/// the static pose has barycenter tensions; an error says what the grid's
/// poses gave, or that the centroid itself has none.
pub fn centre(robot: &Robot68) -> Result<Centre, String> {
    let (lo, hi) = grid_box(robot)?;
    let half: [f64; 3] = core::array::from_fn(|k| 0.5 * (hi[k] - lo[k]));
    let steps = 19;
    let (mut sum, mut count) = ([0.0f64; 3], 0usize);
    // How many grid poses failed with each status, for the error.
    let mut failed: Vec<(&'static str, usize)> = Vec::new();
    for i in 0..steps {
        for j in 0..steps {
            for k in 0..steps {
                let at =
                    |n: usize, axis: usize| lo[axis] + (n as f64 + 0.5) / steps as f64 * 2.0 * half[axis];
                let p = [at(i, 0), at(j, 1), at(k, 2)];
                match solve(robot, Method::Barycenter, &at_rest(p)) {
                    Ok(_) => {
                        (0..3).for_each(|a| sum[a] += p[a]);
                        count += 1;
                    }
                    Err(e) => match failed.iter_mut().find(|(status, _)| *status == e.status()) {
                        Some((_, n)) => *n += 1,
                        None => failed.push((e.status(), 1)),
                    },
                }
            }
        }
    }
    if count == 0 {
        let statuses: Vec<String> = failed.iter().map(|(status, n)| format!("{status} {n}")).collect();
        let hint = if failed.iter().any(|&(status, _)| status == "infeasible") {
            "; a suspended robot needs its base origin on the floor under it or in its anchors' plane, \
             and a platform heavier than its cables' t_min pull up"
        } else {
            ""
        };
        return Err(format!(
            "no pose on a grid over the setpoint range's box (x {:.3}..{:.3}, y {:.3}..{:.3}, z {:.3}..{:.3} m: \
             the platform's region: `Robot::platform_region`) has feasible static tensions \
             ({} poses: {}){hint}",
            lo[0],
            hi[0],
            lo[1],
            hi[1],
            lo[2],
            hi[2],
            steps * steps * steps,
            statuses.join(", "),
        ));
    }
    // Rounded to the millimetre, so that the constants read well.
    let centre = sum.map(|c| ((c / count as f64) * 1e3).round() / 1e3 + 0.0);
    let robustness = solve(robot, Method::Barycenter, &at_rest(centre))
        .map_err(|e| {
            format!("the centre of the static workspace {centre:?} is not feasible ({})", e.status())
        })?
        .robustness;
    Ok(Centre { position: centre.map(|c| c as f32), robustness })
}

/// The box the centre's grid and the loop's amplitudes are taken from: the
/// setpoint range's positions, [`SetpointRange::MARGIN`] inside.
fn grid_box(robot: &Robot68) -> Result<([f64; 3], [f64; 3]), String> {
    let range = SetpointRange::for_robot(&to_f32(robot)?);
    let margin = f64::from(SetpointRange::MARGIN);
    let lo: [f64; 3] = core::array::from_fn(|k| f64::from(range.position_min[k]) + margin);
    let hi: [f64; 3] = core::array::from_fn(|k| f64::from(range.position_max[k]) - margin);
    Ok((lo, hi))
}

/// Steps 1 and 2 of [`derive`]: the centre and the loop (no excursion:
/// `excursion` is zero, `infeasible_run` 0). `hal-sim` builds its
/// scenarios for a robot file on them.
pub fn derive_loop(robot: &Robot68) -> Result<Derivation, String> {
    loop_around(robot, centre(robot)?)
}

/// Step 2 of [`derive`], around step 1's `centre`.
fn loop_around(robot: &Robot68, centre: Centre) -> Result<Derivation, String> {
    let (lo, hi) = grid_box(robot)?;
    let half: [f64; 3] = core::array::from_fn(|k| 0.5 * (hi[k] - lo[k]));
    let span = robot
        .limits()
        .max()
        .iter()
        .zip(robot.limits().min().iter())
        .map(|(h, l)| h - l)
        .fold(f64::INFINITY, f64::min);

    let Centre { position: centre, robustness: centre_robustness } = centre;

    // 2. The loop.
    let (start, ramp, hold) = EXCURSION_TIMES;
    let mut scale = 1.0f64;
    let mut params = None;
    let mut loop_robustness = 0.0;
    for _ in 0..40 {
        let amplitude: [f32; 6] = core::array::from_fn(|k| {
            let a = if k < 3 { START_FRACTION[k] * half[k] } else { START_ANGLES[k - 3] };
            (a * scale) as f32
        });
        let p = Params {
            centre,
            amplitude,
            excursion: [0.0; 3],
            excursion_start: start,
            excursion_ramp: ramp,
            excursion_hold: hold,
        };
        if let Some(worst) = loop_margin(robot, &p) {
            if worst >= MARGIN * span {
                params = Some(p);
                loop_robustness = worst;
                break;
            }
        }
        scale *= SHRINK;
    }
    let params = params.ok_or_else(|| {
        format!(
            "no loop around the centre {centre:?} keeps the tensions {MARGIN} of the range from the limits"
        )
    })?;
    Ok(Derivation { params, centre_robustness, loop_robustness, scale, infeasible_run: 0 })
}

/// Step 3 of [`derive`]: the excursion added to the loop's `params`, and
/// the longest run of its infeasible cycles.
fn excursion(robot: &Robot68, params: Params, range: &SetpointRange) -> Result<(Params, u32), String> {
    let (start, ramp, hold) = EXCURSION_TIMES;
    let inside = |p: &[f32; 3]| {
        (0..3).all(|k| {
            let (a, b) = (
                range.position_min[k] + 0.5 * SetpointRange::MARGIN,
                range.position_max[k] - 0.5 * SetpointRange::MARGIN,
            );
            p[k] >= a && p[k] <= b
        })
    };
    let plateau: Vec<f32> = (0..=30).map(|i| start + ramp + hold * i as f32 / 30.0).collect();
    let mut found: Option<(f32, Params, u32)> = None;
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            let mut threshold = None;
            for n in 1..2000 {
                let e = 0.005 * n as f32;
                let mut p = params;
                p.excursion[axis] = sign * e;
                let poses: Vec<Setpoint> = plateau.iter().map(|&t| p.setpoint_at(t)).collect();
                if !poses.iter().all(|s| inside(&[s.pose[0], s.pose[1], s.pose[2]])) {
                    break;
                }
                if poses.iter().all(|s| matches!(solve(robot, Method::Barycenter, s), Err(Error::Infeasible)))
                {
                    threshold = Some(e);
                    break;
                }
            }
            let Some(e) = threshold else { continue };
            if found.is_some_and(|(best, _, _)| best <= e) {
                continue;
            }
            // Further out, within the range.
            let mut p = params;
            for factor in EXCURSION_FACTORS {
                p.excursion = [0.0; 3];
                p.excursion[axis] = sign * e * factor;
                if let Some(run) = excursion_run(robot, &p, range, &inside) {
                    if run >= INFEASIBLE_CYCLES {
                        found = Some((e, p, run));
                        break;
                    }
                }
            }
        }
    }
    let (_, excursion, infeasible_run) = found.ok_or(
        "no excursion along +-x, +-y, +-z leaves the workspace for long enough within the setpoint range",
    )?;
    Ok((excursion, infeasible_run))
}

/// The smallest barycenter robustness over the loop (every 5 ms, no
/// excursion), `None` if a setpoint has no barycenter or puncture tensions.
fn loop_margin(robot: &Robot68, p: &Params) -> Option<f64> {
    let mut worst = f64::INFINITY;
    let samples = (DURATION_S / PERIOD_S) as u32 / 5;
    for i in 0..samples {
        let s = p.loop_at(i as f32 * 5.0 * PERIOD_S);
        let sol = solve(robot, Method::Barycenter, &s).ok()?;
        solve(robot, Method::Puncture, &s).ok()?;
        worst = worst.min(sol.robustness);
    }
    Some(worst)
}

/// The run of infeasible cycles of `p`'s excursion, `None` if there is
/// more than one, or a cycle fails otherwise or leaves the range.
fn excursion_run(
    robot: &Robot68,
    p: &Params,
    range: &SetpointRange,
    inside: &impl Fn(&[f32; 3]) -> bool,
) -> Option<u32> {
    let (from, to) = (p.excursion_start, p.excursion_end());
    if from < EXCURSION_WINDOW.0 || to > EXCURSION_WINDOW.1 {
        return None;
    }
    let (mut run, mut longest, mut runs) = (0u32, 0u32, 0u32);
    let first = (from / PERIOD_S) as u32;
    let last = (to / PERIOD_S) as u32 + 1;
    for k in first..=last {
        let s = p.setpoint(k);
        let slow = (0..3).all(|i| {
            s.velocity[i].abs() <= 0.8 * range.speed_max
                && s.acceleration[i].abs() <= 0.8 * range.acceleration_max
        });
        if !slow || !inside(&[s.pose[0], s.pose[1], s.pose[2]]) || !range.contains(&s.to_wire()) {
            return None;
        }
        match solve(robot, Method::Barycenter, &s) {
            Ok(_) => run = 0,
            Err(Error::Infeasible) => {
                if run == 0 {
                    runs += 1;
                }
                run += 1;
                longest = longest.max(run);
            }
            Err(_) => return None,
        }
    }
    // One run: the demo's states go Enabled, Holding, Fault once.
    (runs == 1).then_some(longest)
}

/// At rest at position `p`, no rotation.
fn at_rest(p: [f64; 3]) -> Setpoint {
    Setpoint {
        seq: 0,
        pose: SVector::from([p[0] as f32, p[1] as f32, p[2] as f32, 0.0, 0.0, 0.0]),
        velocity: SVector::zeros(),
        acceleration: SVector::zeros(),
    }
}

/// `method`'s tensions for the setpoint `s` (with its motion), cold, in `f64`.
pub fn solve(robot: &Robot68, method: Method, s: &Setpoint) -> Result<Solution<f64, 8>, Error> {
    let v = |a: &SVector<f32, 6>| SVector::<f64, 6>::from_fn(|i, _| f64::from(a[i]));
    let (w, f) =
        robot.wrench_problem(&v(&s.pose), &SVector::zeros(), Some((&v(&s.velocity), &v(&s.acceleration))))?;
    TensionSolver::<f64, 8>::new(method).solve(&w, &f, robot.limits())
}

/// The robot in `f32` (for the setpoint range the firmware builds).
fn to_f32(robot: &Robot68) -> Result<Robot<f32, 6, 8>, String> {
    let v = |a: &Vector3<f64>| a.cast::<f32>();
    let p = robot.platform();
    let platform = Platform {
        mass: p.mass as f32,
        com: v(&p.com),
        gravity: v(&p.gravity),
        inertia: p.inertia.cast::<f32>(),
    };
    let limits = TensionLimits::new(robot.limits().min().cast::<f32>(), robot.limits().max().cast::<f32>())
        .map_err(|e| {
        // The file's limits passed in f64; in the board's f32 only the
        // size can fail them.
        let most = (f32::MAX / 8.0).sqrt();
        format!(
            "limits in f32, the board's precision: {} (t_max at most {most:.1e} N: the methods' sums of \
                 squares of 8 tensions must stay finite)",
            e.status()
        )
    })?;
    let winch = match robot.winch() {
        Some(w) => Some(
            Winch::new(w.drum_radius as f32, w.gear_ratio as f32, w.efficiency as f32, w.torque_max as f32)
                .map_err(|e| format!("winch in f32: {}", e.status()))?,
        ),
        None => None,
    };
    Robot::new(
        robot.kind(),
        robot.anchors().each_ref().map(v),
        robot.attachments().each_ref().map(v),
        limits,
        platform,
        winch,
    )
    .map_err(|e| format!("the robot in f32: {}", e.status()))
}
