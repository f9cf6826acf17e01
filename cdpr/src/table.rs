//! The conventions' pose tables (CSV, comma-separated, one header line): read
//! with the `csv` crate, with errors that name the file, the line and the
//! column.

use std::path::{Path, PathBuf};

use tension_core::RobotKind;

use crate::CliError;
use robot_file::Readable;

/// Pose column names of a kind, in the conventions' order.
pub fn pose_columns(kind: RobotKind) -> &'static [&'static str] {
    match kind {
        RobotKind::Spatial6 => &["x", "y", "z", "rx", "ry", "rz"],
        RobotKind::Planar3 => &["x", "y", "theta"],
        RobotKind::Planar2 => &["x", "y"],
    }
}

/// Extra external wrench column names of a kind, in the conventions' order.
pub fn wrench_columns(kind: RobotKind) -> &'static [&'static str] {
    match kind {
        RobotKind::Spatial6 => &["fx", "fy", "fz", "mx", "my", "mz"],
        RobotKind::Planar3 => &["fx", "fy", "mz"],
        RobotKind::Planar2 => &["fx", "fy"],
    }
}

/// A CSV file split into fields, blank lines skipped.
#[derive(Debug, Clone)]
pub struct RawTable {
    /// The file.
    pub path: PathBuf,
    /// Line number of the header (1-based).
    pub header_line: usize,
    /// Header fields, trimmed.
    pub header: Vec<String>,
    /// Data rows.
    pub rows: Vec<RawRow>,
}

/// One data line.
#[derive(Debug, Clone)]
pub struct RawRow {
    /// Line number in the file (1-based).
    pub line: usize,
    /// Fields, trimmed.
    pub fields: Vec<String>,
}

impl RawTable {
    /// `row` has as many fields as the header (else the one-line error).
    pub fn check_width(&self, row: &RawRow) -> Result<(), CliError> {
        let width = self.header.len();
        if row.fields.len() == width {
            return Ok(());
        }
        Err(CliError::at(
            &self.path,
            Some(row.line),
            None,
            &format!("{} fields, the header has {width} ({})", row.fields.len(), self.header.join(",")),
        ))
    }

    /// Field `c` of `row` as a number (NaN and infinities included), or the
    /// one-line error naming the field.
    pub fn number(&self, row: &RawRow, c: usize) -> Result<f64, CliError> {
        let text = &row.fields[c];
        text.parse::<f64>().map_err(|_| {
            let shown = if text.is_empty() { "empty field" } else { text };
            CliError::at(
                &self.path,
                Some(row.line),
                Some((c + 1, self.header[c].as_str())),
                &format!("`{shown}` is not a number"),
            )
        })
    }
}

/// Reads a CSV file. A file that cannot be read is bad input (exit code 2).
pub fn read_csv(path: &Path) -> Result<RawTable, CliError> {
    let bytes = std::fs::read(path).map_err(|e| CliError::at(path, None, None, &e.to_string()))?;
    let text =
        String::from_utf8(bytes).map_err(|_| CliError::at(path, None, None, "not a UTF-8 text file"))?;
    parse_csv(path, &text)
}

/// Splits CSV text (see [`read_csv`]): fields trimmed, rows of any width
/// (checked against the header by the caller), blank lines skipped.
pub fn parse_csv(path: &Path, text: &str) -> Result<RawTable, CliError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    // A record's position is where the reader started on it, before the
    // empty lines it skips: its line is that of its first other byte. The
    // records come in file order, so the newlines are counted on from the
    // previous record's (linear in the file, not quadratic).
    let bytes = text.as_bytes();
    let mut counted = (0usize, 0usize); // (offset, newlines before it)
    let mut line_at = |p: &csv::Position| {
        let start = (p.byte() as usize).min(bytes.len());
        let skipped = bytes[start..].iter().take_while(|&&b| b == b'\n' || b == b'\r').count();
        let target = start + skipped;
        if target < counted.0 {
            counted = (0, 0);
        }
        counted.1 += bytes[counted.0..target].iter().filter(|&&b| b == b'\n').count();
        counted.0 = target;
        counted.1 + 1
    };
    let mut lines = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| {
            let line = e.position().map(&mut line_at);
            CliError::at(path, line, None, &e.to_string())
        })?;
        // A line of blanks is one empty field once trimmed.
        if record.len() == 1 && record[0].is_empty() {
            continue;
        }
        let line = record.position().map_or(0, &mut line_at);
        lines.push(RawRow { line, fields: record.iter().map(String::from).collect() });
    }
    let mut lines = lines.into_iter();
    let Some(RawRow { line: header_line, fields: header }) = lines.next() else {
        return Err(CliError::at(path, None, None, "empty file, expected a header line"));
    };
    Ok(RawTable { path: path.to_path_buf(), header_line, header, rows: lines.collect() })
}

/// Whether the table must have a `time` column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeColumn {
    /// A pose table: `time` may come first and is carried through.
    Optional,
    /// A waypoint table: `time` is required, strictly increasing.
    Required,
}

/// One row of a pose table.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseRow {
    /// Line number in the file.
    pub line: usize,
    /// The `time` field as written, and its value.
    pub time: Option<(String, f64)>,
    /// The pose, in the conventions' order.
    pub pose: Vec<f64>,
    /// The extra external wrench, when the table has those columns.
    pub extra: Option<Vec<f64>>,
}

/// A pose table read against a robot kind.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseTable {
    /// Whether the table has a `time` column.
    pub has_time: bool,
    /// Whether the table has the extra wrench columns.
    pub has_extra: bool,
    /// The rows.
    pub rows: Vec<PoseRow>,
}

/// Reads a pose table (conventions, "Pose and tension tables") for a robot kind.
/// Columns are found by name; the pose columns are required, the extra
/// wrench columns all or none, `time` optional or required. Waypoint tables
/// (`TimeColumn::Required`) must hold finite numbers and strictly
/// increasing times.
pub fn read_poses(path: &Path, kind: RobotKind, time: TimeColumn) -> Result<PoseTable, CliError> {
    let raw = read_csv(path)?;
    poses_from_raw(&raw, kind, time)
}

/// See [`read_poses`].
pub fn poses_from_raw(raw: &RawTable, kind: RobotKind, time: TimeColumn) -> Result<PoseTable, CliError> {
    let path = raw.path.as_path();
    let hl = Some(raw.header_line);
    let pose_names = pose_columns(kind);
    let wrench_names = wrench_columns(kind);
    let mut time_col = None;
    let mut pose_cols = vec![None; pose_names.len()];
    let mut wrench_cols = vec![None; wrench_names.len()];
    for (c, name) in raw.header.iter().enumerate() {
        let at = Some((c + 1, name.as_str()));
        let slot = if name == "time" {
            &mut time_col
        } else if let Some(k) = pose_names.iter().position(|n| n == name) {
            &mut pose_cols[k]
        } else if let Some(k) = wrench_names.iter().position(|n| n == name) {
            &mut wrench_cols[k]
        } else {
            let msg = if name.is_empty() {
                "empty column name".to_string()
            } else {
                format!(
                    "unknown column `{name}` for a {} robot (expected {}{}, optionally {})",
                    kind.name(),
                    if time == TimeColumn::Optional { "[time,]" } else { "time," },
                    pose_names.join(","),
                    wrench_names.join(",")
                )
            };
            return Err(CliError::at(path, hl, at.map(|(c, _)| (c, "")), &msg));
        };
        if slot.is_some() {
            return Err(CliError::at(path, hl, Some((c + 1, "")), &format!("column `{name}` appears twice")));
        }
        *slot = Some(c);
    }
    if time == TimeColumn::Required && time_col.is_none() {
        return Err(CliError::at(
            path,
            hl,
            None,
            "missing column `time` (a waypoint table starts with time)",
        ));
    }
    for (k, col) in pose_cols.iter().enumerate() {
        if col.is_none() {
            return Err(CliError::at(
                path,
                hl,
                None,
                &format!(
                    "missing column `{}` (a {} pose is {})",
                    pose_names[k],
                    kind.name(),
                    pose_names.join(",")
                ),
            ));
        }
    }
    let has_extra = wrench_cols.iter().any(Option::is_some);
    if has_extra {
        if let Some(k) = wrench_cols.iter().position(Option::is_none) {
            return Err(CliError::at(
                path,
                hl,
                None,
                &format!(
                    "missing column `{}` (the extra wrench of a {} robot is {}, all or none)",
                    wrench_names[k],
                    kind.name(),
                    wrench_names.join(",")
                ),
            ));
        }
    }
    let mut rows = Vec::with_capacity(raw.rows.len());
    let mut last_time = f64::NEG_INFINITY;
    for row in &raw.rows {
        let line = Some(row.line);
        raw.check_width(row)?;
        let number = |c: usize| -> Result<f64, CliError> {
            let text = &row.fields[c];
            let at = Some((c + 1, raw.header[c].as_str()));
            let v = raw.number(row, c)?;
            if time == TimeColumn::Required && !v.is_finite() {
                return Err(CliError::at(path, line, at, &format!("`{text}` is not a finite number")));
            }
            Ok(v)
        };
        let t = match time_col {
            Some(c) => {
                let v = number(c)?;
                if time == TimeColumn::Required {
                    if v <= last_time {
                        return Err(CliError::at(
                            path,
                            line,
                            Some((c + 1, "time")),
                            &format!(
                                "time {} does not come after the previous waypoint's {}",
                                Readable(v),
                                Readable(last_time)
                            ),
                        ));
                    }
                    last_time = v;
                }
                Some((row.fields[c].clone(), v))
            }
            None => None,
        };
        let pose =
            pose_cols.iter().map(|c| number(c.expect("checked above"))).collect::<Result<Vec<_>, _>>()?;
        let extra = if has_extra {
            Some(
                wrench_cols
                    .iter()
                    .map(|c| number(c.expect("checked above")))
                    .collect::<Result<Vec<_>, _>>()?,
            )
        } else {
            None
        };
        rows.push(PoseRow { line: row.line, time: t, pose, extra });
    }
    Ok(PoseTable { has_time: time_col.is_some(), has_extra, rows })
}
