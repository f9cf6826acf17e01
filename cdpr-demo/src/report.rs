//! The records the firmware's demo programs log for `cargo xtask` to
//! decode: postcard-encoded, as hexadecimal text after [`PREFIX`] on a log
//! line of their own, so that the test command reads typed figures instead
//! of searching the readable log for phrases.
//!
//! * [`Record::Finished`]: the demo's results, last before it exits;
//! * [`Record::Injecting`]: a fault-injection program is about to fault;
//! * [`Record::Stopped`]: the panic or HardFault handler has stopped the
//!   drives.

use cdpr_control::protocol::State;
use cdpr_control::CABLES;
use serde::{Deserialize, Serialize};

/// What starts a record's log line; the hexadecimal postcard bytes follow.
pub const PREFIX: &str = "demo-record: ";

/// Most state changes a report keeps.
pub const MAX_STATES: usize = 16;

/// Largest postcard encoding of a record, bytes.
pub const MAX_ENCODED: usize = 160;

/// Length of the text [`encode`] needs: the prefix and two hex digits a byte.
pub const MAX_TEXT: usize = PREFIX.len() + 2 * MAX_ENCODED;

/// One record.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Record {
    /// The demo's results (tag 0).
    Finished(Report),
    /// A fault-injection program faults now, while the drives command
    /// these torques, N m (tag 1).
    Injecting {
        /// The control cycle.
        cycle: u32,
        /// The drives' torques.
        torques: [f32; CABLES],
    },
    /// What the drives hold after the emergency stop (tag 2).
    Stopped {
        /// Torques, N m.
        torques: [f32; CABLES],
        /// Brakes engaged.
        brakes: bool,
    },
}

/// Minimum, median and maximum of a cost, in the report's unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Spread {
    /// Smallest.
    pub min: u32,
    /// Median.
    pub median: u32,
    /// Largest.
    pub max: u32,
}

/// The demo's results.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// Whether the costs are instructions (QEMU) rather than core cycles.
    pub instructions: bool,
    /// Control cycles run.
    pub cycles: u32,
    /// Cost of the control step (setpoint to drive writes).
    pub step: Spread,
    /// Cost of the solver alone in the same cycles.
    pub solver: Spread,
    /// Cycles that missed their deadline.
    pub overruns: u32,
    /// TIM2 ticks of the calibration loop.
    pub calibration_ticks: u32,
    /// The ticks the icount relation predicts for it.
    pub calibration_expected: u32,
    /// Whether the calibration must match the prediction (QEMU).
    pub calibration_exact: bool,
    /// Cycles solved.
    pub ok: u32,
    /// Cycles whose pose had no feasible tensions.
    pub infeasible: u32,
    /// Cycles that failed for another reason.
    pub other_errors: u32,
    /// The states the run went through, in order (the first `state_count`).
    pub states: [State; MAX_STATES],
    /// How many of `states` are used.
    pub state_count: u8,
    /// Deepest stack use, bytes (stack painting).
    pub stack_used: u32,
    /// The stack's size, bytes.
    pub stack_size: u32,
    /// The exit code the demo ends with (its verdict).
    pub exit_code: i32,
    /// Each method's worst solve over the demo's poses, in `Method::ALL`
    /// order (the barycenter's in the loop, the others replayed), checked
    /// against [`crate::methods::COSTS`].
    pub method_worst: [u32; 10],
    /// The control step's worst receive work of one cycle under a flood (a
    /// cycle's `cdpr_control::FRAME_BUDGET` of frames), in the report's unit.
    pub receive_worst: u32,
    /// The receive interrupt's worst framing work for one byte under a
    /// flood (a frame's completion included), in the report's unit.
    pub framing_worst: u32,
    /// Cost of the pose estimator (the forward kinematics' Gauss-Newton
    /// step) in the cycles it ran.
    pub estimator: Spread,
    /// Cost of `tension_core`'s forward kinematics, warm from the previous
    /// answer, replayed over the encoders' stand-in along the script.
    pub forward: Spread,
    /// The control step without the solver, worst over the loop's cycles
    /// (each cycle's step less its solve), in the report's unit: what
    /// [`crate::methods::STEP_REST`] states.
    pub rest_worst: u32,
}

impl Report {
    /// The states the run went through.
    pub fn states(&self) -> &[State] {
        &self.states[..usize::from(self.state_count).min(MAX_STATES)]
    }
}

/// Why a record could not be written or read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RecordError {
    /// Larger than [`MAX_ENCODED`].
    TooLarge,
    /// Not hexadecimal text of whole bytes.
    Hex,
    /// The bytes do not decode as a record.
    Decode,
}

const HEX: &[u8; 16] = b"0123456789abcdef";

/// The log line of `record`: [`PREFIX`] and the hexadecimal postcard bytes.
pub fn encode<'a>(record: &Record, text: &'a mut [u8; MAX_TEXT]) -> Result<&'a str, RecordError> {
    let mut bytes = [0u8; MAX_ENCODED];
    let n = postcard::to_slice(record, &mut bytes).map_err(|_| RecordError::TooLarge)?.len();
    text[..PREFIX.len()].copy_from_slice(PREFIX.as_bytes());
    for (i, b) in bytes[..n].iter().enumerate() {
        text[PREFIX.len() + 2 * i] = HEX[usize::from(b >> 4)];
        text[PREFIX.len() + 2 * i + 1] = HEX[usize::from(b & 0xF)];
    }
    core::str::from_utf8(&text[..PREFIX.len() + 2 * n]).map_err(|_| RecordError::Hex)
}

/// The record on a log line (after [`PREFIX`], anywhere in the line), if
/// the line carries one.
pub fn decode(line: &str) -> Option<Result<Record, RecordError>> {
    let at = line.find(PREFIX)? + PREFIX.len();
    let hex = line[at..].trim_end().as_bytes();
    Some(decode_hex(hex))
}

fn decode_hex(hex: &[u8]) -> Result<Record, RecordError> {
    if !hex.len().is_multiple_of(2) || hex.len() > 2 * MAX_ENCODED {
        return Err(RecordError::Hex);
    }
    let digit = |c: u8| match c {
        b'0'..=b'9' => Ok(c - b'0'),
        b'a'..=b'f' => Ok(c - b'a' + 10),
        _ => Err(RecordError::Hex),
    };
    let mut bytes = [0u8; MAX_ENCODED];
    for (i, pair) in hex.chunks_exact(2).enumerate() {
        bytes[i] = digit(pair[0])? << 4 | digit(pair[1])?;
    }
    postcard::from_bytes(&bytes[..hex.len() / 2]).map_err(|_| RecordError::Decode)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report() -> Report {
        let mut states = [State::Disabled; MAX_STATES];
        states[..6].copy_from_slice(&crate::EXPECTED_STATES);
        Report {
            instructions: true,
            cycles: 4000,
            step: Spread { min: 12_900, median: 13_977, max: 18_830 },
            solver: Spread { min: 8_532, median: 9_610, max: 14_462 },
            overruns: 0,
            calibration_ticks: 160_000,
            calibration_expected: 160_000,
            calibration_exact: true,
            ok: 3651,
            infeasible: 349,
            other_errors: 0,
            states,
            state_count: 6,
            stack_used: 7912,
            stack_size: 77_780,
            exit_code: u32::MAX as i32,
            method_worst: [u32::MAX; 10],
            receive_worst: u32::MAX,
            framing_worst: u32::MAX,
            estimator: Spread { min: u32::MAX, median: u32::MAX, max: u32::MAX },
            forward: Spread { min: u32::MAX, median: u32::MAX, max: u32::MAX },
            rest_worst: u32::MAX,
        }
    }

    #[test]
    fn records_round_trip_through_their_log_line() {
        let records = [
            Record::Finished(report()),
            Record::Injecting { cycle: 1000, torques: [0.1, -0.2, 0.3, 2.5, -2.5, 0.0, 1.0, f32::MAX] },
            Record::Stopped { torques: [0.0; CABLES], brakes: true },
        ];
        for record in records {
            let mut text = [0u8; MAX_TEXT];
            let line = encode(&record, &mut text).unwrap();
            assert!(line.starts_with(PREFIX));
            // As qemu-run prints it: a timestamp or level may come first.
            let mut shown = [0u8; MAX_TEXT + 8];
            shown[..6].copy_from_slice(b"INFO  ");
            shown[6..6 + line.len()].copy_from_slice(line.as_bytes());
            let shown = core::str::from_utf8(&shown[..6 + line.len()]).unwrap();
            assert_eq!(decode(shown), Some(Ok(record)));
        }
        assert_eq!(report().states(), &crate::EXPECTED_STATES);
        assert_eq!(decode("no record here"), None);
        assert_eq!(decode("demo-record: 0"), Some(Err(RecordError::Hex)));
        assert_eq!(decode("demo-record: zz"), Some(Err(RecordError::Hex)));
        assert_eq!(decode("demo-record: 07"), Some(Err(RecordError::Decode)));
    }
}
