//! `cdpr forward`: the pose of every row of a cable-length table
//! (`tension_core`'s forward kinematics, conventions: "Forward kinematics").
//!
//! Input: an optional `time` column first, then `l1,...,lm` (m), found by
//! name. Each row is warm-started from the previous row's `ok` pose, and
//! falls back to the cold start by itself. Output: `[time,]` the pose
//! columns of the robot's kind, `status` (`ok` or the forward kinematics'
//! status word), `residual` (the worst cable's `|a_i - p - R b_i| - L_i`, m,
//! of the answer, or of the closest pose found; empty when no run could
//! start); the pose cells are empty where the status is not `ok`.
//!
//! Bad input (exit 2, one line, nothing written): a file that cannot be
//! read, an unknown, missing or repeated column, a row with another number
//! of fields than the header, a field that is not a number, a `time` that is
//! not finite or comes before the previous row's (equal times are allowed:
//! rows in the order of the motion is what the warm start relies on). A
//! length that is NaN, infinite or negative is not bad input: that row's
//! status is `nonfinite`.

use std::path::PathBuf;

use crate::output::{num, write_csv};
use crate::robot::load_robot;
use crate::solve::count_failure;
use crate::table::{pose_columns, read_csv};
use crate::CliError;
use robot_file::Readable;

/// Arguments of `cdpr forward`.
#[derive(Debug, Clone, clap::Args)]
pub struct ForwardArgs {
    /// Robot description file (TOML).
    #[arg(long)]
    pub robot: PathBuf,
    /// Cable-length table: [time,]l1,...,lm (m).
    #[arg(long)]
    pub lengths: PathBuf,
    /// Pose table to write: [time,]pose columns,status,residual.
    #[arg(long)]
    pub out: PathBuf,
}

/// What `cdpr forward` did.
#[derive(Debug, Clone, PartialEq)]
pub struct ForwardReport {
    /// Rows read.
    pub rows: usize,
    /// Rows with a pose.
    pub ok: usize,
    /// Count per failure status, in order of first appearance.
    pub failures: Vec<(&'static str, usize)>,
}

impl std::fmt::Display for ForwardReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} of {} rows have a pose", self.ok, self.rows)?;
        if !self.failures.is_empty() {
            let parts: Vec<String> = self.failures.iter().map(|(s, n)| format!("{n} {s}")).collect();
            write!(f, " ({})", parts.join(", "))?;
        }
        Ok(())
    }
}

/// Runs `cdpr forward`: every input error is reported before anything is
/// written.
pub fn run(args: &ForwardArgs) -> Result<ForwardReport, CliError> {
    let robot = load_robot(&args.robot)?;
    let model = robot.model()?;
    let m = model.cables();
    let raw = read_csv(&args.lengths)?;
    let path = raw.path.as_path();
    let hl = Some(raw.header_line);
    let names: Vec<String> = (1..=m).map(|i| format!("l{i}")).collect();
    let mut time_col = None;
    let mut cols = vec![None; m];
    for (c, name) in raw.header.iter().enumerate() {
        let slot = if name == "time" {
            &mut time_col
        } else if let Some(k) = names.iter().position(|n| n == name) {
            &mut cols[k]
        } else {
            let msg = if name.is_empty() {
                "empty column name".to_string()
            } else {
                format!("unknown column `{name}` for a robot with {m} cables (expected [time,]l1,...,l{m})")
            };
            return Err(CliError::at(path, hl, Some((c + 1, "")), &msg));
        };
        if slot.is_some() {
            return Err(CliError::at(path, hl, Some((c + 1, "")), &format!("column `{name}` appears twice")));
        }
        *slot = Some(c);
    }
    if let Some(k) = cols.iter().position(Option::is_none) {
        return Err(CliError::at(
            path,
            hl,
            None,
            &format!("missing column `l{}` ({} has {m} cables: l1,...,l{m})", k + 1, args.robot.display()),
        ));
    }
    let mut table = Vec::with_capacity(raw.rows.len());
    let mut last_time = f64::NEG_INFINITY;
    for row in &raw.rows {
        let line = Some(row.line);
        raw.check_width(row)?;
        let number = |c: usize| raw.number(row, c);
        let time = match time_col {
            Some(c) => {
                let t = number(c)?;
                let at = Some((c + 1, "time"));
                if !t.is_finite() {
                    return Err(CliError::at(
                        path,
                        line,
                        at,
                        &format!("`{}` is not a finite number", row.fields[c]),
                    ));
                }
                if t < last_time {
                    return Err(CliError::at(
                        path,
                        line,
                        at,
                        &format!(
                            "time {} comes before the previous row's {}",
                            Readable(t),
                            Readable(last_time)
                        ),
                    ));
                }
                last_time = t;
                Some(row.fields[c].clone())
            }
            None => None,
        };
        let lengths =
            cols.iter().map(|c| number(c.expect("checked above"))).collect::<Result<Vec<_>, _>>()?;
        table.push((time, lengths));
    }
    let pose_names = pose_columns(robot.kind());
    let mut header: Vec<String> = Vec::with_capacity(pose_names.len() + 3);
    if time_col.is_some() {
        header.push("time".into());
    }
    header.extend(pose_names.iter().map(|s| s.to_string()));
    header.push("status".into());
    header.push("residual".into());
    let mut report = ForwardReport { rows: table.len(), ok: 0, failures: vec![] };
    let mut warm: Option<Vec<f64>> = None;
    let mut rows = Vec::with_capacity(table.len());
    for (time, lengths) in table {
        let result = model.forward(&lengths, warm.as_deref());
        let mut out: Vec<String> = Vec::with_capacity(header.len());
        out.extend(time);
        match &result.pose {
            Ok(pose) => {
                report.ok += 1;
                out.extend(pose.iter().map(|x| num(*x)));
                out.push("ok".into());
                warm = Some(pose.clone());
            }
            Err(e) => {
                count_failure(&mut report.failures, e.status());
                out.extend(std::iter::repeat_n(String::new(), pose_names.len()));
                out.push(e.status().into());
            }
        }
        out.push(result.residual.map(num).unwrap_or_default());
        rows.push(out);
    }
    write_csv(&args.out, header, rows)?;
    Ok(report)
}
