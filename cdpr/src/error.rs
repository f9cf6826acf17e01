//! The one error type of the tool: a one-line message and the exit code.

use std::fmt;
use std::path::Path;

/// What went wrong, as one line, and whether it was the user's input
/// (exit code 2) or the machine (exit code 1: a file that could not be written).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CliError {
    /// The one-line message (no trailing newline).
    pub message: String,
    /// `true` for bad input (exit code 2), `false` for I/O failures (exit code 1).
    pub bad_input: bool,
}

impl CliError {
    /// Bad input: a file, a line and a column where known.
    pub fn input(message: impl Into<String>) -> Self {
        Self { message: one_line(&message.into()), bad_input: true }
    }

    /// Bad input located in a file: `FILE, line L, column C (NAME): MESSAGE`.
    pub fn at(path: &Path, line: Option<usize>, column: Option<(usize, &str)>, msg: &str) -> Self {
        let mut s = path.display().to_string();
        if let Some(l) = line {
            s.push_str(&format!(", line {l}"));
        }
        if let Some((c, name)) = column {
            s.push_str(&format!(", column {c}"));
            if !name.is_empty() {
                s.push_str(&format!(" ({name})"));
            }
        }
        s.push_str(": ");
        s.push_str(msg);
        Self::input(s)
    }

    /// A failure to read or write a file.
    pub fn io(path: &Path, e: &std::io::Error) -> Self {
        Self { message: one_line(&format!("{}: {e}", path.display())), bad_input: false }
    }

    /// A failure that is not the input's fault.
    pub fn other(message: impl Into<String>) -> Self {
        Self { message: one_line(&message.into()), bad_input: false }
    }

    /// The process exit code: 2 for bad input, 1 otherwise.
    pub fn exit_code(&self) -> i32 {
        if self.bad_input {
            2
        } else {
            1
        }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for CliError {}

/// A plot that could not be drawn is the machine's failure, not the input's.
impl From<cdpr_plot::PlotError> for CliError {
    fn from(e: cdpr_plot::PlotError) -> Self {
        Self::other(e.to_string())
    }
}

/// Joins the lines of a message with "; " so that every error is one line.
pub fn one_line(s: &str) -> String {
    s.lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join("; ")
}
