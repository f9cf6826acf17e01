//! Smooth point-to-point trajectories through timed waypoints: at rest at
//! every waypoint, each segment follows the 7th-degree time law
//! `s(u) = 35u^4 - 84u^5 + 70u^6 - 20u^7` (Di Paola et al. 2024, Eq. 17),
//! whose velocity, acceleration and jerk vanish at both ends.

use std::path::Path;

use tension_core::RobotKind;

use crate::table::{read_poses, TimeColumn};
use crate::CliError;

pub use tension_core::trajectory::time_law;

/// Timed waypoints: pose (and optional extra wrench) at each time.
#[derive(Debug, Clone, PartialEq)]
pub struct Waypoints {
    /// Strictly increasing times, s.
    pub times: Vec<f64>,
    /// Poses.
    pub poses: Vec<Vec<f64>>,
    /// Extra external wrenches (interpolated with the same time law).
    pub extras: Option<Vec<Vec<f64>>>,
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
        if table.rows.len() < 2 {
            return Err(CliError::at(
                path,
                None,
                None,
                &format!("{} waypoint(s); a trajectory needs at least two", table.rows.len()),
            ));
        }
        let times = table.rows.iter().map(|r| r.time.as_ref().expect("time is required").1).collect();
        let poses = table.rows.iter().map(|r| r.pose.clone()).collect();
        let extras = table.has_extra.then(|| table.rows.iter().filter_map(|r| r.extra.clone()).collect());
        Ok(Self { times, poses, extras })
    }

    /// Start time.
    pub fn start(&self) -> f64 {
        self.times[0]
    }

    /// End time.
    pub fn end(&self) -> f64 {
        *self.times.last().expect("at least two waypoints")
    }

    /// The sample times at `rate` Hz, from the first waypoint's time to the
    /// last's, both included.
    pub fn sample_times(&self, rate: f64) -> Vec<f64> {
        let (t0, t1) = (self.start(), self.end());
        let count = ((t1 - t0) * rate).round().max(1.0) as usize;
        (0..=count).map(|k| if k == count { t1 } else { t0 + k as f64 / rate }).collect()
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_rest_at_waypoints() {
        let w = Waypoints {
            times: vec![0.0, 1.0, 3.0],
            poses: vec![vec![0.0, 0.0], vec![1.0, 2.0], vec![1.0, 0.0]],
            extras: None,
        };
        let times = w.sample_times(10.0);
        assert_eq!(times.len(), 31);
        assert_eq!(*times.last().unwrap(), 3.0);
        for (t, p) in [(0.0, [0.0, 0.0]), (1.0, [1.0, 2.0]), (3.0, [1.0, 0.0])] {
            let s = w.sample(t);
            assert_eq!(s.pose, p.to_vec());
            assert!(s.velocity.iter().all(|v| v.abs() < 1e-12));
        }
        let mid = w.sample(2.0);
        assert!((mid.pose[1] - 1.0).abs() < 1e-12);
        // Peak speed of the law is 35/16 times the mean speed.
        assert!((mid.velocity[1] + 2.0 / 2.0 * 35.0 / 16.0).abs() < 1e-12);
    }
}
