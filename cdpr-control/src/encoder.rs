//! Winch encoder counts to cable lengths (`docs/conventions.md`, "Robot
//! files"):
//!
//! ```text
//! L_i = L_home_i + s_i * (counts_i - counts_home_i) * 2 pi r / (cpr * G)
//! ```
//!
//! with `r` the drum radius, `G` the gear ratio, `cpr` the motor encoder's
//! counts per motor revolution and `s_i` the cable's encoder sign (`+1`:
//! the counts rise as the cable pays out). Counts are 32-bit and wrap, so
//! their difference is taken with `wrapping_sub` (modulo 2^32, as an
//! encoder's counter does) and read as signed: a cable may move at most
//! 2^31 counts from its homing (for suspended-8's 7.7 um a count, 16 km).
//!
//! A cable whose length could move farther than that from its homing would
//! wrap and read as a length it does not have: [`EncoderScale::check_reach`]
//! refuses a scale that cannot count the robot's longest cable (a
//! high-resolution encoder behind a gearbox: a 24-bit encoder at a gear
//! ratio of 10 on a 4 cm drum counts 3.2 m).
//!
//! [`EncoderScale`] is the robot's conversion (pure, no state);
//! [`Homing`] the offsets a `Home` sets: the lengths of the home pose's
//! inverse kinematics and the counts read at that moment.

use crate::drives::WinchReading;
use crate::CABLES;

/// The largest count difference (and count rate) a 32-bit counter, or a
/// drive's position object, carries: `2^31 - 1`.
pub const COUNT_SPAN: f32 = 2_147_483_647.0;

/// Why an [`EncoderScale`] could not be made, or cannot count a robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ScaleError {
    /// A drum radius or gear ratio that is not finite and positive, or
    /// zero counts per revolution.
    Winch,
    /// An encoder sign other than `+1` or `-1` (cable index).
    Sign(usize),
    /// [`COUNT_SPAN`] counts are `reach` metres of cable, less than the
    /// `longest` cable the robot may have (m): a cable moving farther from
    /// its homing would wrap. `counts_max` is the most counts per motor
    /// revolution that count it.
    Reach {
        /// m of cable in [`COUNT_SPAN`] counts.
        reach: f32,
        /// m, the longest cable ([`crate::link::SetpointRange::longest_cable`]).
        longest: f32,
        /// The largest `counts_per_revolution` whose reach covers `longest`.
        counts_max: u32,
    },
}

impl core::fmt::Display for ScaleError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            ScaleError::Winch => f.write_str(
                "the encoders need a finite, positive drum radius and gear ratio and counts_per_revolution > 0",
            ),
            ScaleError::Sign(i) => write!(f, "cable {}: encoder_sign must be 1 or -1", i + 1),
            ScaleError::Reach { reach, longest, counts_max } => write!(
                f,
                "2^31 encoder counts are {reach:.3} m of cable, and a cable within the setpoint range may be \
                 {longest:.3} m long: its 32-bit count would wrap; counts_per_revolution must be at most \
                 {counts_max} (a drive's position units coarser)"
            ),
        }
    }
}

/// Metres of cable per encoder count, with each cable's sign.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EncoderScale {
    /// `s_i * 2 pi r / (cpr * G)`, m per count.
    per_count: [f32; CABLES],
    /// `cpr`, for [`ScaleError::Reach`]'s advice.
    counts_per_revolution: u32,
}

impl EncoderScale {
    /// The scale of winches with `drum_radius` (m), `gear_ratio` (motor
    /// turns per drum turn), `counts_per_revolution` (per motor turn) and
    /// one encoder sign per cable.
    pub fn new(
        drum_radius: f32,
        gear_ratio: f32,
        counts_per_revolution: u32,
        signs: [i8; CABLES],
    ) -> Result<Self, ScaleError> {
        let positive = |x: f32| x.is_finite() && x > 0.0;
        if !(positive(drum_radius) && positive(gear_ratio) && counts_per_revolution > 0) {
            return Err(ScaleError::Winch);
        }
        let step = 2.0 * core::f32::consts::PI * drum_radius / (counts_per_revolution as f32 * gear_ratio);
        if !positive(step) {
            return Err(ScaleError::Winch);
        }
        let mut per_count = [0.0; CABLES];
        for (i, (p, &s)) in per_count.iter_mut().zip(&signs).enumerate() {
            *p = match s {
                1 => step,
                -1 => -step,
                _ => return Err(ScaleError::Sign(i)),
            };
        }
        Ok(Self { per_count, counts_per_revolution })
    }

    /// The robot file's defaults for `drum_radius` and `gear_ratio`:
    /// 4096 counts per revolution, every sign `+1`.
    pub fn with_defaults(drum_radius: f32, gear_ratio: f32) -> Result<Self, ScaleError> {
        Self::new(drum_radius, gear_ratio, 4096, [1; CABLES])
    }

    /// Signed metres per count of each cable (`s_i * 2 pi r / (cpr G)`).
    pub fn per_count(&self) -> &[f32; CABLES] {
        &self.per_count
    }

    /// Metres of cable in [`COUNT_SPAN`] counts: the farthest a cable may
    /// move from its homing before its count difference wraps.
    pub fn reach(&self) -> f32 {
        COUNT_SPAN * libm::fabsf(self.per_count[0])
    }

    /// Whether the counts reach a cable `longest` metres long (a length
    /// moves at most that far from any homing, lengths being at least 0):
    /// [`ScaleError::Reach`] otherwise, with the counts per revolution
    /// that would (this scale's scaled down by the shortfall).
    pub fn check_reach(&self, longest: f32) -> Result<(), ScaleError> {
        let reach = self.reach();
        // NaN fails the comparison.
        if longest < reach {
            return Ok(());
        }
        let fraction = if longest.is_finite() && longest > 0.0 { reach / longest } else { 0.0 };
        // Rounded down, a little under (f32), so that it passes this check.
        let counts_max =
            libm::floor(f64::from(self.counts_per_revolution) * f64::from(fraction) * (1.0 - 1e-6));
        Err(ScaleError::Reach { reach, longest, counts_max: counts_max as u32 })
    }

    /// The offsets that make `readings` correspond to `lengths` (m): what
    /// a `Home` stores.
    pub fn home(&self, lengths: &[f32; CABLES], readings: &[WinchReading; CABLES]) -> Homing {
        Homing { lengths: *lengths, counts: readings.map(|r| r.counts) }
    }

    /// Cable lengths (m) from `readings` with the homing offsets `home`.
    pub fn lengths(&self, home: &Homing, readings: &[WinchReading; CABLES]) -> [f32; CABLES] {
        let mut out = [0.0; CABLES];
        for (i, o) in out.iter_mut().enumerate() {
            let moved = readings[i].counts.wrapping_sub(home.counts[i]);
            *o = home.lengths[i] + self.per_count[i] * moved as f32;
        }
        out
    }

    /// Cable length rates (m/s, positive paying out) from the drives'
    /// speeds.
    pub fn rates(&self, readings: &[WinchReading; CABLES]) -> [f32; CABLES] {
        let mut out = [0.0; CABLES];
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.per_count[i] * readings[i].counts_per_second as f32;
        }
        out
    }

    /// The counts (relative to count 0 at length 0, plus `offset`) of
    /// `length` metres of cable `i`, rounded to the nearest count, wrapping:
    /// the inverse of [`EncoderScale::lengths`], for plant models that
    /// stand in for real encoders. `None` past the last cable or for a
    /// non-finite length.
    pub fn counts_of(&self, i: usize, length: f32, offset: i32) -> Option<i32> {
        let per = *self.per_count.get(i)?;
        let counts = libm::roundf(length / per);
        // Beyond +-2^31 counts the length is not a cable's.
        if !counts.is_finite() || libm::fabsf(counts) >= 2.147_483_6e9 {
            return None;
        }
        Some(offset.wrapping_add(counts as i32))
    }
}

/// The offsets a `Home` sets: each cable's length and count at homing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Homing {
    /// `L_home_i`, m.
    pub lengths: [f32; CABLES],
    /// `counts_home_i`.
    pub counts: [i32; CABLES],
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reading(counts: i32) -> WinchReading {
        WinchReading { counts, counts_per_second: 0 }
    }

    #[test]
    fn hand_computed_lengths_with_signs_and_wrap() {
        // r = 0.04 m, G = 8, cpr = 4096: 2 pi 0.04 / 32768 = 7.6699e-6 m a count.
        let mut signs = [1i8; CABLES];
        signs[1] = -1;
        let scale = EncoderScale::new(0.04, 8.0, 4096, signs).unwrap();
        let step = 7.669_904e-6f32;
        assert!((scale.per_count()[0] - step).abs() < 1e-11);
        assert!((scale.per_count()[1] + step).abs() < 1e-11);
        let mut at_home = [reading(0); CABLES];
        at_home[0] = reading(1000);
        at_home[1] = reading(i32::MAX - 10); // about to wrap
        let home = scale.home(&[2.0; CABLES], &at_home);
        let mut now = at_home;
        now[0] = reading(1000 + 32768); // one drum turn paid out: + 2 pi r
        now[1] = reading((i32::MAX - 10).wrapping_add(32768)); // wrapped; sign -1: reeled in
        now[2] = reading(-32768);
        let l = scale.lengths(&home, &now);
        let turn = 2.0 * core::f32::consts::PI * 0.04;
        assert!((l[0] - (2.0 + turn)).abs() < 2e-6, "{}", l[0]);
        assert!((l[1] - (2.0 - turn)).abs() < 2e-6, "{}", l[1]);
        assert!((l[2] - (2.0 - turn)).abs() < 2e-6, "{}", l[2]);
        assert_eq!(l[3], 2.0);
    }

    #[test]
    fn rates_and_inverse() {
        let scale = EncoderScale::new(0.04, 8.0, 4096, [-1; CABLES]).unwrap();
        let r = scale.rates(&[WinchReading { counts: 0, counts_per_second: 32768 }; CABLES]);
        let turn = 2.0 * core::f32::consts::PI * 0.04;
        assert!((r[0] + turn).abs() < 1e-6);
        // counts_of inverts lengths (to one count), through the wrap.
        let offset = i32::MAX - 5;
        let c = scale.counts_of(0, 1.5, offset).unwrap();
        let home = Homing { lengths: [0.0; CABLES], counts: [offset; CABLES] };
        let l = scale.lengths(&home, &[reading(c); CABLES]);
        assert!((l[0] - 1.5).abs() <= 4e-6, "{}", l[0]);
        assert_eq!(scale.counts_of(0, f32::NAN, 0), None);
        assert_eq!(scale.counts_of(CABLES, 1.0, 0), None);
    }

    #[test]
    fn bad_winches_and_signs_are_refused() {
        assert_eq!(EncoderScale::new(0.0, 8.0, 4096, [1; CABLES]), Err(ScaleError::Winch));
        assert_eq!(EncoderScale::new(0.04, f32::NAN, 4096, [1; CABLES]), Err(ScaleError::Winch));
        assert_eq!(EncoderScale::new(0.04, 8.0, 0, [1; CABLES]), Err(ScaleError::Winch));
        let mut signs = [1; CABLES];
        signs[5] = 0;
        assert_eq!(EncoderScale::new(0.04, 8.0, 4096, signs), Err(ScaleError::Sign(5)));
    }
}
