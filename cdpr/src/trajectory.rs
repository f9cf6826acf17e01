//! Smooth point-to-point trajectories through timed waypoints: at rest at
//! every waypoint, each segment follows the 7th-degree time law
//! `s(u) = 35u^4 - 84u^5 + 70u^6 - 20u^7` (Di Paola et al. 2024, Eq. 17),
//! whose velocity, acceleration and jerk vanish at both ends.

use std::path::Path;

use robot_file::Readable;
use tension_core::RobotKind;

use crate::table::{read_poses, TimeColumn};
use crate::CliError;

pub use tension_core::trajectory::time_law;

/// Most samples a trajectory is sampled into (memory and time stay bounded).
pub const MAX_SAMPLES: usize = 2_000_000;

/// Timed waypoints: pose (and optional extra wrench) at each time. Built
/// by [`Waypoints::new`] or [`Waypoints::read`], which check what sampling
/// relies on (so no sample indexes past the end or divides by a zero
/// duration).
#[derive(Debug, Clone, PartialEq)]
pub struct Waypoints {
    /// Strictly increasing finite times, s (at least two).
    times: Vec<f64>,
    /// Poses, one per time, all of one length, finite.
    poses: Vec<Vec<f64>>,
    /// Extra external wrenches, one per time, all of one length, finite
    /// (interpolated with the same time law).
    extras: Option<Vec<Vec<f64>>>,
}

/// One trajectory sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// Time, s.
    pub time: f64,
    /// Pose.
    pub pose: Vec<f64>,
    /// Pose velocity.
    pub velocity: Vec<f64>,
    /// Pose acceleration.
    pub acceleration: Vec<f64>,
    /// Extra external wrench, if any.
    pub extra: Option<Vec<f64>>,
}

impl Waypoints {
    /// Reads a waypoint table: `time`, then the pose columns (and optionally
    /// the extra wrench columns); at least two rows.
    pub fn read(path: &Path, kind: RobotKind) -> Result<Self, CliError> {
        let table = read_poses(path, kind, TimeColumn::Required)?;
        let times = table.rows.iter().map(|r| r.time.as_ref().map_or(f64::NAN, |t| t.1)).collect();
        let poses = table.rows.iter().map(|r| r.pose.clone()).collect();
        let extras =
            table.has_extra.then(|| table.rows.iter().map(|r| r.extra.clone().unwrap_or_default()).collect());
        Self::new(times, poses, extras).map_err(|e| CliError::at(path, None, None, &e.message))
    }

    /// Waypoints from their parts: at least two, the times finite and
    /// strictly increasing, one pose (and, if given, one extra wrench) per
    /// time, the poses all of one length and the extras too, every number
    /// finite. Anything else is bad input ([`CliError::input`]).
    pub fn new(
        times: Vec<f64>,
        poses: Vec<Vec<f64>>,
        extras: Option<Vec<Vec<f64>>>,
    ) -> Result<Self, CliError> {
        if times.len() < 2 {
            return Err(CliError::input(format!(
                "{} waypoint(s); a trajectory needs at least two",
                times.len()
            )));
        }
        if let Some(k) = times.iter().position(|t| !t.is_finite()) {
            return Err(CliError::input(format!(
                "waypoint {}: time {} is not a finite number",
                k + 1,
                times[k]
            )));
        }
        if let Some(k) = times.windows(2).position(|w| w[1] <= w[0]) {
            return Err(CliError::input(format!(
                "waypoint {}: time {} s does not follow {} s (times must increase strictly)",
                k + 2,
                Readable(times[k + 1]),
                Readable(times[k])
            )));
        }
        check_rows("pose", &poses, times.len())?;
        if let Some(extras) = &extras {
            check_rows("extra wrench", extras, times.len())?;
        }
        Ok(Self { times, poses, extras })
    }

    /// The times, s.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// The poses, one per time.
    pub fn poses(&self) -> &[Vec<f64>] {
        &self.poses
    }

    /// The extra wrenches, one per time, if any.
    pub fn extras(&self) -> Option<&[Vec<f64>]> {
        self.extras.as_deref()
    }

    /// Start time.
    pub fn start(&self) -> f64 {
        self.times[0]
    }

    /// End time.
    pub fn end(&self) -> f64 {
        self.times[self.times.len() - 1]
    }

    /// The sample times at `rate` Hz, from the first waypoint's time to the
    /// last's, both included. Errors (bad input): a rate that is not a
    /// positive number, or more than [`MAX_SAMPLES`] samples (memory and
    /// time stay bounded; a long span at a high rate would otherwise ask for
    /// more memory than there is).
    pub fn sample_times(&self, rate: f64) -> Result<Vec<f64>, CliError> {
        if !(rate.is_finite() && rate > 0.0) {
            return Err(CliError::input(format!(
                "--rate {}: the sample rate must be a positive number of hertz",
                Readable(rate)
            )));
        }
        let (t0, t1) = (self.start(), self.end());
        let count = ((t1 - t0) * rate).round().max(1.0);
        // (The times are finite and increasing: the span is positive, at
        // worst infinite, never NaN.)
        if count > MAX_SAMPLES as f64 {
            return Err(CliError::input(format!(
                "{} s at {} Hz is more than {MAX_SAMPLES} samples; lower --rate",
                Readable(t1 - t0),
                Readable(rate)
            )));
        }
        let count = count as usize;
        Ok((0..=count).map(|k| if k == count { t1 } else { t0 + k as f64 / rate }).collect())
    }

    /// Index of the segment holding `t` (the last segment for the end time).
    pub fn segment(&self, t: f64) -> usize {
        let k = self.times.partition_point(|&s| s <= t);
        k.clamp(1, self.times.len() - 1) - 1
    }

    /// Pose, velocity and acceleration at time `t`.
    pub fn sample(&self, t: f64) -> Sample {
        let k = self.segment(t);
        let (ta, tb) = (self.times[k], self.times[k + 1]);
        let duration = tb - ta;
        let (s, ds, dds) = time_law((t - ta) / duration);
        let (a, b) = (&self.poses[k], &self.poses[k + 1]);
        let pose = a.iter().zip(b).map(|(a, b)| a + (b - a) * s).collect();
        let velocity = a.iter().zip(b).map(|(a, b)| (b - a) * ds / duration).collect();
        let acceleration = a.iter().zip(b).map(|(a, b)| (b - a) * dds / (duration * duration)).collect();
        let extra =
            self.extras.as_ref().map(|e| e[k].iter().zip(&e[k + 1]).map(|(a, b)| a + (b - a) * s).collect());
        Sample { time: t, pose, velocity, acceleration, extra }
    }
}

/// `rows` holds one row per waypoint, all of one length, every number finite.
fn check_rows(what: &str, rows: &[Vec<f64>], count: usize) -> Result<(), CliError> {
    if rows.len() != count {
        return Err(CliError::input(format!("{} {what}(s) for {count} waypoint times", rows.len())));
    }
    let width = rows[0].len();
    for (k, row) in rows.iter().enumerate() {
        if row.len() != width {
            return Err(CliError::input(format!(
                "waypoint {}: {} {what} value(s), waypoint 1 has {width}",
                k + 1,
                row.len()
            )));
        }
        if let Some(v) = row.iter().find(|v| !v.is_finite()) {
            return Err(CliError::input(format!(
                "waypoint {}: {what} value {v} is not a finite number",
                k + 1
            )));
        }
    }
    Ok(())
}
