//! A stand-in for the winches' encoders on a board without winches (QEMU):
//! each cable follows its commanded length, the inverse kinematics of the
//! setpoint the control loop is tracking, with a first-order lag of
//! [`TIME_CONSTANT_S`], and reads as encoder counts with the robot file's
//! counts per revolution and signs, quantised to one count, from an
//! arbitrary offset per drive (some near the 32-bit wrap, so the loop's
//! wrapping arithmetic runs). The speed is the lag's rate in counts per
//! second.
//!
//! It is no dynamics model: the torques do not move it, so the feedback
//! closes no loop here. It exists so that the board's control step reads
//! real-looking encoders and runs the estimator and the feedback at their
//! real cost, and so that homing, the residual and the length check have
//! lengths to work on. It is advanced outside the measured step.

use cdpr_control::encoder::EncoderScale;
use cdpr_control::setpoint::Pose6;
use cdpr_control::{ControlRobot, WinchReading, CABLES};

/// The lag's time constant, s: a stiff winch position servo. At the demo
/// trajectory's fastest cable (about 1.3 m/s) it trails by 6.5 mm, within
/// the 20 mm length check.
pub const TIME_CONSTANT_S: f32 = 0.005;

/// `1 - exp(-T / tau)` for the 1 ms period: the lag's step.
pub const LAG_STEP: f32 = 0.181_269_25;

/// The encoder offsets (the count at zero cable length) of the stand-in.
pub const OFFSETS: [i32; CABLES] =
    [0x7fff_0000, -0x7fff_8000, 0x1234_5678, -0x0765_4321, 0x7ff0_0000, 0, -0x4000_0000, 0x3fff_ffff];

/// The stand-in's cables.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LagWinches {
    scale: EncoderScale,
    lengths: [f32; CABLES],
    rates: [f32; CABLES],
    /// The encoders, converted when the cables move (a drive's read is a
    /// copy of what it counted).
    readings: [WinchReading; CABLES],
}

impl LagWinches {
    /// At rest with the cables at `pose`'s inverse kinematics; `None` if
    /// the pose has none.
    pub fn at_pose(robot: &ControlRobot, scale: EncoderScale, pose: &Pose6) -> Option<Self> {
        let cables = robot.cables(pose).ok()?;
        let mut lengths = [0.0; CABLES];
        lengths.copy_from_slice(cables.lengths.as_slice());
        let mut w =
            Self { scale, lengths, rates: [0.0; CABLES], readings: [WinchReading::default(); CABLES] };
        w.convert();
        Some(w)
    }

    /// One 1 ms period towards the cable lengths `target` (the control
    /// loop's for its tracked setpoint; stays put if `None`).
    pub fn follow(&mut self, target: Option<&[f32; CABLES]>, period_s: f32) {
        match target {
            Some(target) => {
                for ((length, rate), goal) in self.lengths.iter_mut().zip(&mut self.rates).zip(target) {
                    let step = (goal - *length) * LAG_STEP;
                    *length += step;
                    *rate = step / period_s;
                }
            }
            None => self.rates = [0.0; CABLES],
        }
        self.convert();
    }

    fn convert(&mut self) {
        let per_count = self.scale.per_count();
        for (i, r) in self.readings.iter_mut().enumerate() {
            r.counts = self.scale.counts_of(i, self.lengths[i], OFFSETS[i]).unwrap_or(OFFSETS[i]);
            r.counts_per_second = (self.rates[i] / per_count[i]) as i32;
        }
    }

    /// The cables' lengths, m.
    pub fn lengths(&self) -> &[f32; CABLES] {
        &self.lengths
    }

    /// The encoders now.
    pub fn readings(&self) -> &[WinchReading; CABLES] {
        &self.readings
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lag_step_is_the_time_constant() {
        assert!((LAG_STEP - (1.0 - libm_exp(-0.001 / TIME_CONSTANT_S))).abs() < 1e-6);
    }

    /// `exp` by its series (enough terms for |x| < 1).
    fn libm_exp(x: f32) -> f32 {
        let mut term = 1.0f32;
        let mut sum = 1.0f32;
        for n in 1..20 {
            term *= x / n as f32;
            sum += term;
        }
        sum
    }
}
