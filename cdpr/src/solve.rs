//! `cdpr solve`: the tensions of every pose of a table (conventions: CSV in and out).

use std::path::PathBuf;

use crate::output::{num, write_csv};
use crate::robot::{load_robot, method_help, Query};
use crate::table::{read_poses, TimeColumn};
use crate::CliError;
use tension_core::Error;

/// Arguments of `cdpr solve`.
#[derive(Debug, Clone, clap::Args)]
pub struct SolveArgs {
    /// Robot description file (TOML).
    #[arg(long)]
    pub robot: PathBuf,
    /// Tension method (the conventions' name).
    #[arg(long, help = method_help("Tension method"))]
    pub method: String,
    /// Pose table: [time,]pose columns[,extra wrench columns].
    #[arg(long)]
    pub poses: PathBuf,
    /// Tension table to write: [time,]t1,...,tm,status.
    #[arg(long)]
    pub out: PathBuf,
}

/// What `cdpr solve` did.
#[derive(Debug, Clone, PartialEq)]
pub struct SolveReport {
    /// Rows read.
    pub rows: usize,
    /// Rows solved.
    pub ok: usize,
    /// Count per failure status, in order of first appearance.
    pub failures: Vec<(&'static str, usize)>,
}

impl std::fmt::Display for SolveReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} of {} poses solved", self.ok, self.rows)?;
        if !self.failures.is_empty() {
            let parts: Vec<String> = self.failures.iter().map(|(s, n)| format!("{n} {s}")).collect();
            write!(f, " ({})", parts.join(", "))?;
        }
        Ok(())
    }
}

/// Adds one failure to a per-status count.
pub fn count_failure(failures: &mut Vec<(&'static str, usize)>, status: &'static str) {
    match failures.iter_mut().find(|(s, _)| *s == status) {
        Some((_, n)) => *n += 1,
        None => failures.push((status, 1)),
    }
}

/// Runs `cdpr solve`: every input error is reported before anything is
/// written; rows that cannot be solved carry their status.
pub fn run(args: &SolveArgs) -> Result<SolveReport, CliError> {
    let robot = load_robot(&args.robot)?;
    let method = robot.method(&args.method)?;
    let table = read_poses(&args.poses, robot.kind(), TimeColumn::Optional)?;
    let model = robot.model()?;
    let m = model.cables();
    let mut solver = model.solver(method);
    let mut tensions = vec![0.0; m];
    let mut report = SolveReport { rows: table.rows.len(), ok: 0, failures: vec![] };
    let mut rows = Vec::with_capacity(table.rows.len());
    for row in &table.rows {
        let query = Query { pose: &row.pose, extra: row.extra.as_deref(), motion: None };
        let result = solver.solve(&query, &mut tensions);
        match &result {
            Ok(_) => report.ok += 1,
            Err(e) => count_failure(&mut report.failures, e.status()),
        }
        let time = row.time.as_ref().map(|(text, _)| text.clone());
        rows.push(tension_row(time, &tensions, result.map(|_| ())));
    }
    write_csv(&args.out, tension_columns(table.has_time, m), rows)?;
    Ok(report)
}

/// The conventions' tension table header: `[time,]t1,...,tm,status`.
pub fn tension_columns(time: bool, m: usize) -> Vec<String> {
    let mut cols: Vec<String> = Vec::with_capacity(m + 2);
    if time {
        cols.push("time".into());
    }
    cols.extend((1..=m).map(|i| format!("t{i}")));
    cols.push("status".into());
    cols
}

/// One row of a tension table: `[time,]t1,...,tm,status`, the tensions
/// empty where the status is not `ok`.
pub fn tension_row(time: Option<String>, tensions: &[f64], result: Result<(), Error>) -> Vec<String> {
    let mut row = Vec::with_capacity(tensions.len() + 2);
    row.extend(time);
    match result {
        Ok(()) => {
            row.extend(tensions.iter().map(|t| num(*t)));
            row.push("ok".into());
        }
        Err(e) => {
            row.extend(std::iter::repeat_n(String::new(), tensions.len()));
            row.push(e.status().into());
        }
    }
    row
}
