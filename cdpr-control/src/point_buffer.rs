//! The board's trajectory buffer: timed points in
//! ([`cdpr_protocol::TrajectoryPoint`], pose and velocity at a trajectory
//! time in ms), one interpolated setpoint per control cycle out.
//!
//! The serial link carries about 46 bytes a millisecond at 460 800 baud,
//! not the 80-byte setpoint frame every cycle that the 1 kHz loop uses
//! (firmware README, "Link budget"). So the host sends points at 50-250 Hz,
//! ahead of time, and the board plays them on its own clock:
//!
//! * **Clock.** A stream's first point plays [`START_DELAY_CYCLES`] after it
//!   arrives; every later point at its time from there (one cycle per ms).
//!   The clock never passes the newest point: when the buffer runs dry the
//!   clock stops there (a feed hold), and the next point continues the
//!   trajectory from it.
//! * **Interpolation.** Between consecutive points `(t0, p0, v0)` and
//!   `(t1, p1, v1)`, `h = t1 - t0`, `s = (t - t0) / h`, the cubic Hermite
//!   `p(s) = h00 p0 + h10 h v0 + h01 p1 + h11 h v1` with
//!   `h00 = 2s^3 - 3s^2 + 1`, `h10 = s^3 - 2s^2 + s`, `h01 = -2s^3 + 3s^2`,
//!   `h11 = s^3 - s^2`; its first and second derivatives are the setpoint's
//!   velocity and acceleration (continuous position and velocity at the
//!   points; the acceleration is linear in each segment). For a trajectory
//!   with bounded fourth derivative the position error is at most
//!   `h^4 max|p''''| / 384`: 26 nm for 1 m/s^4 at 100 Hz.
//! * **Rules.** Each point must be later than the newest in the buffer
//!   (else [`Rejection::Late`]: out of order, a duplicate, or a time the
//!   clock has played), at most [`MAX_SEGMENT_MS`] after it and the buffer
//!   must have room ([`Rejection::BufferFull`]), and it must follow from
//!   the newest by the trapezoid rule over the exact time between them
//!   (`JumpLimits`, [`Rejection::Jump`]). These apply while the link is
//!   bound (Enabled, Holding); while free (Disabled, Fault) a point that
//!   does not continue the stream starts a new one, as a setpoint with any
//!   number does (`crate::link`).
//! * **Stale.** A dry buffer gives no new setpoint: the last one ages, and
//!   the supervisor's stale rule (50 cycles) applies to the buffer, not to
//!   the last frame's arrival.
//! * **Refused points.** A point refused for its values (out of range, a
//!   jump) marks the stream ([`PointBuffer::refuse`]): the points before
//!   it still play, and where the buffer runs dry it gives
//!   [`Played::Refused`] instead of nothing (the control loop's bad
//!   setpoint: Holding, then Fault), as an unbuffered bad setpoint does at
//!   once. The next accepted point clears the mark.
//!
//! Every operation is bounded by [`DEPTH`]; nothing allocates.

use cdpr_protocol::{Rejection, TrajectoryPoint};

use crate::link::JumpLimits;
use crate::setpoint::{Pose6, Setpoint};

/// Points the buffer holds: 32, i.e. 320 ms of trajectory at 100 Hz.
pub const DEPTH: usize = 32;

/// A stream's first point plays this many cycles after it arrives: the
/// time for the host's next points to arrive behind it (a 60-byte point
/// takes 1.3 ms at 460 800 baud).
pub const START_DELAY_CYCLES: u32 = 20;

/// Longest time between consecutive points, ms: 250 (4 Hz), well below
/// what the interpolation's error bound needs for slow motions.
pub const MAX_SEGMENT_MS: u32 = 250;

/// `a - b` in wrapping time (ms or cycles), signed.
fn ahead(a: u32, b: u32) -> i32 {
    a.wrapping_sub(b) as i32
}

/// What the buffer plays in a cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Played {
    /// The interpolated setpoint (its `seq` is the play time, ms).
    Setpoint(Setpoint),
    /// Dry where the host's next point was refused.
    Refused,
}

/// The buffer.
#[derive(Debug, Clone)]
pub struct PointBuffer {
    /// A ring: `points[head]` is the oldest (the start of the segment
    /// being played), `len` of them.
    points: [TrajectoryPoint; DEPTH],
    head: usize,
    len: usize,
    /// The cycle at which trajectory time 0 plays.
    epoch: u32,
    /// A point after the newest was refused for its values.
    refused: bool,
}

impl Default for PointBuffer {
    fn default() -> Self {
        Self::new()
    }
}

impl PointBuffer {
    /// Empty: no stream.
    pub const fn new() -> Self {
        Self {
            points: [TrajectoryPoint { time_ms: 0, pose: [0.0; 6], velocity: [0.0; 6] }; DEPTH],
            head: 0,
            len: 0,
            epoch: 0,
            refused: false,
        }
    }

    /// Whether a stream is in the buffer.
    pub fn active(&self) -> bool {
        self.len > 0
    }

    /// Forgets the stream (a `Setpoint`, a `Disable`, a fault).
    pub fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
        self.refused = false;
    }

    /// Marks the stream: the host's point after the newest was refused
    /// (out of range, a jump). Nothing without a stream.
    pub fn refuse(&mut self) {
        self.refused = self.len > 0;
    }

    fn at(&self, k: usize) -> &TrajectoryPoint {
        &self.points[(self.head + k) % DEPTH]
    }

    fn newest(&self) -> Option<&TrajectoryPoint> {
        self.len.checked_sub(1).map(|k| self.at(k))
    }

    /// The trajectory time cycle `now` plays (not past the newest point).
    fn play_time(&self, now: u32) -> u32 {
        let t = now.wrapping_sub(self.epoch);
        match self.newest() {
            Some(last) if ahead(t, last.time_ms) > 0 => last.time_ms,
            _ => t,
        }
    }

    /// Drops the points whose segment has been played by `play`, keeping
    /// the start of the segment `play` lies in.
    fn drop_played(&mut self, play: u32) {
        while self.len >= 2 && ahead(play, self.at(1).time_ms) >= 0 {
            self.head = (self.head + 1) % DEPTH;
            self.len -= 1;
        }
    }

    fn start(&mut self, point: &TrajectoryPoint, now: u32) {
        self.clear();
        self.points[0] = *point;
        self.len = 1;
        self.epoch = now.wrapping_add(START_DELAY_CYCLES).wrapping_sub(point.time_ms);
    }

    /// Takes `point` (range-checked by the link) in cycle `now`. `bound`:
    /// the link is bound (Enabled, Holding), so the rules apply; `jumps`:
    /// the jump check's tolerances, if on. A rejected point changes
    /// nothing.
    pub fn push(
        &mut self,
        point: &TrajectoryPoint,
        now: u32,
        bound: bool,
        jumps: Option<&JumpLimits>,
    ) -> Result<(), Rejection> {
        let Some(last) = self.newest().copied() else {
            self.start(point, now);
            return Ok(());
        };
        let dt = ahead(point.time_ms, last.time_ms);
        let continues = dt > 0 && dt as u32 <= MAX_SEGMENT_MS;
        if !continues {
            if !bound {
                self.start(point, now);
                return Ok(());
            }
            return Err(if dt <= 0 { Rejection::Late } else { Rejection::BufferFull });
        }
        self.drop_played(self.play_time(now));
        if self.len == DEPTH {
            return Err(Rejection::BufferFull);
        }
        if let (true, Some(limits)) = (bound, jumps) {
            let dt_s = dt as f32 * 0.001;
            if !limits.follows(&last.pose, &last.velocity, &point.pose, &point.velocity, dt_s) {
                return Err(Rejection::Jump);
            }
        }
        let k = (self.head + self.len) % DEPTH;
        self.points[k] = *point;
        self.len += 1;
        self.refused = false;
        // A dry buffer's clock waited at `last`: it resumes from there.
        let t = now.wrapping_sub(self.epoch);
        if ahead(t, last.time_ms) > 0 {
            self.epoch = now.wrapping_sub(last.time_ms);
        }
        Ok(())
    }

    /// What cycle `now` plays: the Hermite interpolation at the play time.
    /// `None` before the stream's first point plays, without a stream, and
    /// once the buffer has run dry (the clock waits at the newest point,
    /// whose setpoint was the last one given), unless the host's next
    /// point was refused ([`Played::Refused`]).
    pub fn sample(&mut self, now: u32) -> Option<Played> {
        let played = self.interpolate(now);
        match played {
            None if self.refused && self.len > 0 && self.lead_ms(now) == 0 => Some(Played::Refused),
            _ => played.map(Played::Setpoint),
        }
    }

    fn interpolate(&mut self, now: u32) -> Option<Setpoint> {
        if self.len == 0 {
            return None;
        }
        let first = *self.at(0);
        let t = now.wrapping_sub(self.epoch);
        if ahead(t, first.time_ms) < 0 {
            return None;
        }
        let last = *self.newest()?;
        if ahead(t, last.time_ms) > 0 {
            // Dry: the clock waits at the newest point.
            self.epoch = now.wrapping_sub(last.time_ms);
            return None;
        }
        self.drop_played(t);
        let a = *self.at(0);
        if self.len == 1 {
            return Some(Setpoint {
                seq: t,
                pose: Pose6::from(a.pose),
                velocity: Pose6::from(a.velocity),
                acceleration: Pose6::zeros(),
            });
        }
        let b = *self.at(1);
        let h_ms = ahead(b.time_ms, a.time_ms) as f32;
        let s = ahead(t, a.time_ms) as f32 / h_ms;
        Some(hermite(&a, &b, h_ms * 0.001, s, t))
    }

    /// Points not yet played at cycle `now`.
    pub fn fill(&self, now: u32) -> usize {
        let play = self.play_time(now);
        (0..self.len).filter(|&k| ahead(self.at(k).time_ms, play) > 0).count()
    }

    /// How far the newest point lies ahead of the play time at cycle
    /// `now`, ms (0 without a stream or when dry).
    pub fn lead_ms(&self, now: u32) -> u32 {
        match self.newest() {
            Some(last) => ahead(last.time_ms, self.play_time(now)).max(0) as u32,
            None => 0,
        }
    }
}

/// The cubic Hermite between `a` and `b`, `h` s apart, at `s` in [0, 1].
/// Written in the change `dp = p1 - p0` (`h00 + h01 = 1`, and the
/// derivatives of `h00` and `h01` are opposite), so that in `f32` the
/// derivatives do not subtract two poses of metres divided by `h` or `h^2`
/// (at 10 ms that cancellation alone would make 0.01-0.1 m/s^2 of noise
/// in the acceleration, a newton of feed-forward on a 6 kg platform).
fn hermite(a: &TrajectoryPoint, b: &TrajectoryPoint, h: f32, s: f32, seq: u32) -> Setpoint {
    let (s2, s3) = (s * s, s * s * s);
    let (h10, h01, h11) = (s3 - 2.0 * s2 + s, -2.0 * s3 + 3.0 * s2, s3 - s2);
    // d/ds and d2/ds2 of the basis.
    let (d10, d01, d11) = (3.0 * s2 - 4.0 * s + 1.0, -6.0 * s2 + 6.0 * s, 3.0 * s2 - 2.0 * s);
    let (e10, e01, e11) = (6.0 * s - 4.0, -12.0 * s + 6.0, 6.0 * s - 2.0);
    let mut pose = Pose6::zeros();
    let mut velocity = Pose6::zeros();
    let mut acceleration = Pose6::zeros();
    for i in 0..6 {
        let (dp, v0, v1) = (b.pose[i] - a.pose[i], a.velocity[i] * h, b.velocity[i] * h);
        pose[i] = a.pose[i] + (h01 * dp + h10 * v0 + h11 * v1);
        velocity[i] = (d01 * dp + d10 * v0 + d11 * v1) / h;
        acceleration[i] = (e01 * dp + e10 * v0 + e11 * v1) / (h * h);
    }
    Setpoint { seq, pose, velocity, acceleration }
}
