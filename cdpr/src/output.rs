//! Output files written whole or not at all: into a temporary file in the
//! same directory, renamed over the target only once everything is written.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::CliError;
use robot_file::Readable;

fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    dir.join(format!(".{name}.tmp-{}", std::process::id()))
}

/// Writes `path` through `body`, atomically (temp file + rename); on any
/// error the temporary file is removed and `path` is left as it was.
pub fn write_atomic(
    path: &Path,
    body: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), CliError> {
    let tmp = temp_path(path);
    let result = (|| {
        let mut w = BufWriter::new(File::create(&tmp)?);
        body(&mut w)?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        CliError::io(path, &e)
    })
}

/// Writes a CSV table atomically with the `csv` crate: the header, then the
/// rows, every record (the last one too) ended by a newline.
pub fn write_csv<H, R>(path: &Path, header: H, rows: impl IntoIterator<Item = R>) -> Result<(), CliError>
where
    H: IntoIterator,
    H::Item: AsRef<[u8]>,
    R: IntoIterator,
    R::Item: AsRef<[u8]>,
{
    write_atomic(path, |w| {
        let mut csv = csv::WriterBuilder::new().terminator(csv::Terminator::Any(b'\n')).from_writer(w);
        csv.write_record(header)?;
        for row in rows {
            csv.write_record(row)?;
        }
        csv.flush()
    })
}

/// Writes bytes atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    write_atomic(path, |w| w.write_all(bytes))
}

/// Creates the output directory (and its parents).
pub fn ensure_dir(dir: &Path) -> Result<(), CliError> {
    std::fs::create_dir_all(dir).map_err(|e| CliError::io(dir, &e))
}

/// Formats a number for the CSV tables: the shortest digits that read back
/// as the same `f64`, in exponent form below `1e-4` and from `1e9` up
/// ([`Readable`]: a pose's rounding off zero reads `-2.516726746174481e-32`,
/// not in 48 characters).
pub fn num(x: f64) -> String {
    Readable(x).to_string()
}

/// Formats a sample time: at most nine decimals, trailing zeros dropped.
pub fn time(t: f64) -> String {
    let s = format!("{t:.9}");
    let s = s.trim_end_matches('0');
    let s = s.trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}
