//! `cdpr solve`: the tensions of every pose of a table (conventions: CSV in and out).

use std::io::Write;
use std::path::PathBuf;

use crate::output::{num, write_atomic};
use crate::robot::{load_robot, method_help, Query};
use crate::table::{read_poses, TimeColumn};
use crate::CliError;

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
    let mut lines = Vec::with_capacity(table.rows.len());
    for row in &table.rows {
        let query = Query { pose: &row.pose, extra: row.extra.as_deref(), motion: None };
        let mut line = String::new();
        if let Some((text, _)) = &row.time {
            line.push_str(text);
            line.push(',');
        }
        match solver.solve(&query, &mut tensions) {
            Ok(_) => {
                report.ok += 1;
                for t in &tensions {
                    line.push_str(&num(*t));
                    line.push(',');
                }
                line.push_str("ok");
            }
            Err(e) => {
                count_failure(&mut report.failures, e.status());
                line.push_str(&",".repeat(m));
                line.push_str(e.status());
            }
        }
        lines.push(line);
    }
    let header = tension_header(table.has_time, m);
    write_atomic(&args.out, |w: &mut dyn Write| {
        writeln!(w, "{header}")?;
        for l in &lines {
            writeln!(w, "{l}")?;
        }
        Ok(())
    })?;
    Ok(report)
}

/// The conventions' tension table header: `[time,]t1,...,tm,status`.
pub fn tension_header(time: bool, m: usize) -> String {
    let mut cols: Vec<String> = Vec::with_capacity(m + 2);
    if time {
        cols.push("time".into());
    }
    cols.extend((1..=m).map(|i| format!("t{i}")));
    cols.push("status".into());
    cols.join(",")
}
