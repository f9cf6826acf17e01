//! What `cdpr stream` sends: the trajectory points of a timed pose table or
//! of waypoints along the project's time law, checked against the board's
//! rules before anything is sent (setpoint range, the buffer's longest
//! segment, the jump check between consecutive points).

use std::path::Path;

use cdpr_control::link::{JumpLimits, SetpointRange};
use cdpr_control::point_buffer::MAX_SEGMENT_MS;
use cdpr_control::protocol::{encode, HostMessage, Setpoint, TrajectoryPoint, MAX_FRAME};
use tension_core::RobotKind;

use crate::table::{read_poses, TimeColumn};
use crate::trajectory::Waypoints;
use crate::CliError;
use robot_file::Readable;

/// The share of the serial line the points may take over any second of
/// play: the rest is for the commands, and for a USB bridge's bursts (the
/// FTDI latency timer defaults to 16 ms).
pub const LINK_SHARE: f64 = 0.75;

/// The points to stream, with where each came from (for messages).
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The points, times from 0 ms.
    pub points: Vec<TrajectoryPoint>,
    /// The file line of each point (pose tables) or `None` (sampled).
    pub lines: Vec<Option<usize>>,
}

impl Plan {
    /// The pose of the first point (where the host homes the board).
    pub fn start(&self) -> [f32; 6] {
        self.points[0].pose
    }

    /// The last point's time, ms.
    pub fn end_ms(&self) -> u32 {
        self.points.last().map_or(0, |p| p.time_ms)
    }

    /// Points along waypoints (`time` and the pose columns), sampled at
    /// `rate` Hz along the time law (at rest at every waypoint).
    pub fn from_waypoints(path: &Path, rate: f64) -> Result<Self, CliError> {
        if !(rate.is_finite() && (4.0..=1000.0).contains(&rate)) {
            return Err(CliError::input(format!(
                "--rate {}: the board takes points at 4 to 1000 Hz",
                Readable(rate)
            )));
        }
        let w = Waypoints::read(path, RobotKind::Spatial6)?;
        let t0 = w.start();
        // The points' times are u32 ms from the first (as a pose table's).
        if (w.end() - t0) * 1000.0 > f64::from(u32::MAX) {
            return Err(CliError::at(path, None, None, "last waypoint beyond 49 days after the first"));
        }
        let times = w.sample_times(rate).map_err(|e| CliError::at(path, None, None, &e.message))?;
        let mut points = Vec::with_capacity(times.len());
        for t in times {
            // The board's times are whole milliseconds: each point is the
            // trajectory at its own millisecond. (Sampled at `t` and
            // labelled with `t` rounded, a rate whose period is not a whole
            // number of ms, 400 Hz, put each pose up to 0.5 ms off its
            // time: the board's cubic through poses and velocities that
            // disagree by that much swings its acceleration by hundreds of
            // m/s^2, and the setpoints' d'Alembert wrench made them
            // infeasible.)
            let time_ms = ((t - t0) * 1000.0).round();
            // (Within the waypoints: a last waypoint off the ms grid rounds
            // up past it, where the trajectory is at rest anyway.)
            let s = w.sample((t0 + time_ms / 1000.0).min(w.end()));
            points.push(TrajectoryPoint {
                time_ms: time_ms as u32,
                pose: to_f32(&s.pose),
                velocity: to_f32(&s.velocity),
            });
        }
        points.dedup_by_key(|p| p.time_ms);
        let lines = vec![None; points.len()];
        Ok(Self { points, lines })
    }

    /// A timed pose table (`time`, then the pose columns) as points, one
    /// per row: times in whole ms from the first row's (within 1 us; a
    /// row between two ms is refused), the
    /// velocity the central difference of the neighbours (zero at the first
    /// and last rows: the motion starts and ends at rest).
    pub fn from_pose_table(path: &Path) -> Result<Self, CliError> {
        let table = read_poses(path, RobotKind::Spatial6, TimeColumn::Required)?;
        if table.rows.len() < 2 {
            return Err(CliError::at(path, None, None, "a stream needs at least two timed poses"));
        }
        let t0 = table.rows[0].time.as_ref().map_or(0.0, |t| t.1);
        let times: Vec<f64> = table.rows.iter().map(|r| r.time.as_ref().map_or(0.0, |t| t.1) - t0).collect();
        let mut points = Vec::with_capacity(table.rows.len());
        let mut lines = Vec::with_capacity(table.rows.len());
        for (i, row) in table.rows.iter().enumerate() {
            let velocity = if i == 0 || i + 1 == table.rows.len() {
                [0.0; 6]
            } else {
                let dt = times[i + 1] - times[i - 1];
                let a = &table.rows[i - 1].pose;
                let b = &table.rows[i + 1].pose;
                core::array::from_fn(|k| ((b[k] - a[k]) / dt) as f32)
            };
            let time_ms = (times[i] * 1000.0).round();
            // The board's points are at whole milliseconds. A row between
            // them cannot be sent as it is: rounded, its pose would lie off
            // its time by up to 0.5 ms, and the board's cubic through poses
            // and velocities that disagree so swings its acceleration by
            // hundreds of m/s^2 (a 2.5 ms table at 1 m/s: about 500 m/s^2).
            if (times[i] * 1000.0 - time_ms).abs() > 1e-3 {
                return Err(CliError::at(
                    path,
                    Some(row.line),
                    None,
                    &format!(
                        "time {} s after the first row is not a whole millisecond (the board's points are): \
                         resample the table at whole ms, or give waypoints (--waypoints, --rate)",
                        Readable(times[i])
                    ),
                ));
            }
            if time_ms > f64::from(u32::MAX) {
                return Err(CliError::at(
                    path,
                    Some(row.line),
                    None,
                    "time beyond 49 days after the first row",
                ));
            }
            points.push(TrajectoryPoint { time_ms: time_ms as u32, pose: to_f32(&row.pose), velocity });
            lines.push(Some(row.line));
        }
        Ok(Self { points, lines })
    }

    /// Checks every point as the board will (range, then the buffer's
    /// order, gap and jump rules), naming the first that fails.
    pub fn check(&self, path: &Path, range: &SetpointRange) -> Result<(), CliError> {
        let at = |i: usize, msg: &str| {
            let p = &self.points[i];
            match self.lines[i] {
                Some(line) => CliError::at(path, Some(line), None, msg),
                None => CliError::at(
                    path,
                    None,
                    None,
                    &format!("at {:.3} s: {msg}", f64::from(p.time_ms) / 1000.0),
                ),
            }
        };
        let limits = JumpLimits::DEFAULT;
        for (i, p) in self.points.iter().enumerate() {
            let s = Setpoint { seq: 0, pose: p.pose, velocity: p.velocity, acceleration: [0.0; 6] };
            if !range.contains(&s) {
                return Err(at(
                    i,
                    &format!(
                        "pose {:?} / velocity {:?} outside the board's setpoint range",
                        p.pose, p.velocity
                    ),
                ));
            }
            if i == 0 {
                continue;
            }
            let q = &self.points[i - 1];
            if p.time_ms <= q.time_ms {
                return Err(at(i, "times must increase by at least 1 ms"));
            }
            let dt = p.time_ms - q.time_ms;
            if dt > MAX_SEGMENT_MS {
                return Err(at(
                    i,
                    &format!("{dt} ms after the previous pose; the board takes at most {MAX_SEGMENT_MS} ms"),
                ));
            }
            if !limits.follows(&q.pose, &q.velocity, &p.pose, &p.velocity, dt as f32 * 1e-3) {
                return Err(at(i, "the pose does not follow from the previous one by their velocities (the board's jump check: 50 mm, 0.1 rad)"));
            }
        }
        Ok(())
    }
}

impl Plan {
    /// Checks that the points fit the serial link at `baud` (8N1: ten bits a
    /// byte): their frames over any second of play time take at most
    /// [`LINK_SHARE`] of what the line carries. A denser stream than the
    /// line carries would not fail on the board: its buffer would run dry
    /// and it would play the trajectory slower than asked, stopping and
    /// starting (a feed hold each time), with no error.
    pub fn check_link(&self, path: &Path, baud: u32) -> Result<(), CliError> {
        let capacity = f64::from(baud) / 10.0;
        let allowed = LINK_SHARE * capacity;
        let mut frame = [0u8; MAX_FRAME];
        let bytes: Vec<usize> = self
            .points
            .iter()
            .map(|p| encode(&HostMessage::Point(*p), &mut frame).unwrap_or(MAX_FRAME))
            .collect();
        let largest = bytes.iter().copied().max().unwrap_or(0);
        // Bytes of the points in the window of play time (t - 1 s, t].
        let (mut first, mut window) = (0, 0usize);
        for (i, p) in self.points.iter().enumerate() {
            window += bytes[i];
            while u64::from(self.points[first].time_ms) + 1000 <= u64::from(p.time_ms) {
                window -= bytes[first];
                first += 1;
            }
            if window as f64 > allowed {
                let (from, to) = (self.points[first].time_ms, p.time_ms);
                let most = (allowed / largest as f64).floor();
                let what = format!(
                    "the points from {:.3} s to {:.3} s take {window} bytes (up to {largest} a point), more than \
                     {:.0} % of the {} bytes a second {baud} baud carries: at most about {most} points a \
                     second fit (lower --rate, or thin the table)",
                    f64::from(from) / 1000.0,
                    f64::from(to) / 1000.0,
                    LINK_SHARE * 100.0,
                    Readable(capacity),
                );
                return Err(CliError::at(path, self.lines[i], None, &what));
            }
        }
        Ok(())
    }
}

fn to_f32(v: &[f64]) -> [f32; 6] {
    core::array::from_fn(|k| v.get(k).copied().unwrap_or(0.0) as f32)
}
