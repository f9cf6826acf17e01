//! The Python package's part of `cargo xtask test` (and `cargo xtask
//! python`, the same part alone): every pytest test counts in `N passed, N
//! failed`.
//!
//! 1. A virtual environment under the target directory
//!    (`target/python-venv`, `CARGO_TARGET_DIR` honoured) made with
//!    `python3 -m venv`, with the pinned versions of
//!    `python/requirements-test.txt` installed by pip; kept while that file
//!    is unchanged (a stamp in the environment records it), remade when it
//!    changes.
//! 2. clippy on the package's crate (`cdpr-py`, not a default member, so
//!    the host clippy does not see it), `-D warnings` (while pip works on
//!    the environment, in a thread).
//! 3. The `cdpr` CLI in the workspace's `wheel` profile (release without
//!    fat LTO), which the tests compare the package with (`CDPR_CLI`).
//! 4. The wheel: `maturin build` in the same profile
//!    (`python/pyproject.toml`), checked to be an abi3 wheel, installed
//!    into the environment.
//! 5. pytest on `python/tests`, its summary line read into the tally.
//!
//! A missing `python3`, `venv` module or pip is a failed check with what to
//! install, never a crash; a step that fails skips the ones that need it.

use std::{
    ffi::OsStr,
    io::{BufRead, BufReader},
    path::{Path, PathBuf},
    process::{Command, Stdio},
    time::Instant,
};

use crate::checks::{check, run_step_with, target_dir, Tally};

/// The pinned requirements (relative to the workspace root).
const REQUIREMENTS: &str = "python/requirements-test.txt";
/// The stamp in the environment: the requirements it was made with.
const STAMP: &str = ".cdpr-requirements";

/// Runs the Python part; see the module's text.
pub fn test() -> Tally {
    let start = Instant::now();
    let mut tally = Tally::default();
    let target = target_dir();
    let venv = target.join("python-venv");
    let python = venv.join("bin").join("python");
    let cargo = env!("CARGO");

    // pip downloads and unpacks while cargo compiles: the environment is
    // only needed from maturin on.
    let making = {
        let (venv, python) = (venv.clone(), python.clone());
        std::thread::spawn(move || environment(&venv, &python))
    };
    // clippy and the CLI need no environment: PyO3's build script asks the
    // system's python3 for its version (the crate is abi3 anyway).
    let pyo3: [(&str, &OsStr); 1] = [("PYO3_PYTHON", OsStr::new("python3"))];
    let clippy = ["clippy", "-p", "cdpr-py", "--all-targets", "--", "-D", "warnings"];
    let result = run_step_with(cargo, &clippy, &pyo3);
    tally.report("clippy (python package, cdpr-py)", result.map(|()| String::new()));
    // The CLI with the features resolved for the package's crate too
    // (`-p cdpr-py`, only the `cdpr` binary built): the crates both need are
    // then compiled once, and maturin's build reuses them.
    tally.add(check(
        "python: the cdpr CLI for the comparisons",
        cargo,
        &["build", "--profile", "wheel", "-p", "cdpr", "-p", "cdpr-py", "--bin", "cdpr"],
    ));

    let made = making.join().unwrap_or_else(|_| Err("the set-up thread panicked".into()));
    let no_environment = made.is_err();
    tally.report(&format!("python: virtual environment {}", venv.display()), made.map(|()| String::new()));
    if no_environment {
        tally.fail("python: the wheel and pytest", "not run: no environment");
        return tally;
    }
    let wheel = build_wheel(&venv, &python, &target);
    tally.report(
        "python: the wheel (maturin, abi3), installed",
        wheel.as_ref().map(|_| String::new()).map_err(Clone::clone),
    );
    if wheel.is_err() {
        tally.fail("python: pytest", "not run: no wheel");
        return tally;
    }
    let cli = target.join("wheel").join("cdpr");
    tally.add(pytest(&venv, &cli));
    println!("==> python: {:.0} s in all", start.elapsed().as_secs_f64());
    tally
}

/// Makes (or keeps) the environment with the pinned requirements.
fn environment(venv: &Path, python: &Path) -> Result<(), String> {
    let wanted =
        std::fs::read_to_string(REQUIREMENTS).map_err(|e| format!("cannot read {REQUIREMENTS}: {e}"))?;
    let stamp = venv.join(STAMP);
    if python.is_file() && std::fs::read_to_string(&stamp).is_ok_and(|s| s == wanted) {
        return Ok(());
    }
    match Command::new("python3").arg("--version").output() {
        Ok(out) if out.status.success() => {}
        Ok(_) | Err(_) => return Err(
            "python3 not found: install Python 3.9 or later (Debian: apt-get install python3 python3-venv)"
                .into(),
        ),
    }
    let venv_text = venv.to_string_lossy();
    run_step_with("python3", &["-m", "venv", "--clear", &venv_text], &[]).map_err(|e| {
        format!("{e}: python3 has no working venv module (Debian: apt-get install python3-venv)")
    })?;
    let python_text = python.to_string_lossy();
    run_step_with(&python_text, &["-m", "pip", "--version"], &[])
        .map_err(|e| format!("{e}: the environment has no pip (Debian: apt-get install python3-pip)"))?;
    run_step_with(
        &python_text,
        &["-m", "pip", "install", "--quiet", "--disable-pip-version-check", "-r", REQUIREMENTS],
        &[],
    )
    .map_err(|e| format!("{e}: pip could not install the pinned requirements"))?;
    std::fs::write(&stamp, wanted).map_err(|e| format!("cannot write {}: {e}", stamp.display()))
}

/// Builds the wheel with maturin into `target/wheels/cdpr-py` and installs
/// it; the wheel's path.
fn build_wheel(venv: &Path, python: &Path, target: &Path) -> Result<PathBuf, String> {
    let out = target.join("wheels").join("cdpr-py");
    let _ = std::fs::remove_dir_all(&out);
    let maturin = venv.join("bin").join("maturin");
    let (maturin, python_text, out_text) =
        (maturin.to_string_lossy(), python.to_string_lossy(), out.to_string_lossy());
    let args = ["build", "-m", "python/Cargo.toml", "--out", &out_text, "-i", &python_text];
    run_step_with(&maturin, &args, &[])?;
    let wheel = std::fs::read_dir(&out)
        .map_err(|e| format!("{}: {e}", out.display()))?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|x| x == "whl"))
        .ok_or_else(|| format!("maturin wrote no wheel into {}", out.display()))?;
    let name = wheel.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    if !name.contains("-abi3-") {
        return Err(format!("{name} is not an abi3 wheel"));
    }
    let wheel_text = wheel.to_string_lossy();
    run_step_with(
        &python_text,
        &[
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "--force-reinstall",
            "--no-deps",
            &wheel_text,
        ],
        &[],
    )?;
    Ok(wheel)
}

/// Runs pytest with its output shown and counts its summary line; a run
/// that fails without one (a crash, no tests collected) is one failure.
fn pytest(venv: &Path, cli: &Path) -> Tally {
    let pytest = venv.join("bin").join("pytest");
    println!("==> {} python/tests -q -rfE", pytest.display());
    let mut child = match Command::new(&pytest)
        .args(["python/tests", "-q", "-rfE"])
        .env("CDPR_CLI", cli.canonicalize().unwrap_or_else(|_| cli.to_path_buf()))
        .env("MPLBACKEND", "Agg")
        .stdout(Stdio::piped())
        .spawn()
    {
        Ok(child) => child,
        Err(e) => {
            let mut tally = Tally::default();
            tally.fail("python: pytest", &format!("cannot run {}: {e}", pytest.display()));
            return tally;
        }
    };
    let mut tally = None;
    if let Some(out) = child.stdout.take() {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            println!("{line}");
            if let Some(test) = line.strip_prefix("FAILED ").or_else(|| line.strip_prefix("ERROR ")) {
                crate::checks::record_failure(format!("python: pytest: {test}"));
            }
            if let Some(t) = parse_summary(&line) {
                tally = Some(t);
            }
        }
    }
    let ok = child.wait().is_ok_and(|s| s.success());
    let mut tally = tally.unwrap_or_default();
    if !ok && tally.failed == 0 {
        tally.failed += 1;
        crate::checks::record_failure("python: pytest: failed without a failed test".to_string());
    }
    println!("==> python: pytest: {} passed, {} failed", tally.passed, tally.failed);
    tally
}

/// pytest's summary, `3 failed, 80 passed, 2 skipped, 1 error in 4.20s`
/// (with or without the `=` rule around it): passed (and xpassed) count as
/// passed, failed and errors as failed; skipped, xfailed, deselected and
/// warnings do not count.
fn parse_summary(line: &str) -> Option<Tally> {
    let text = line.trim().trim_matches('=').trim();
    let (counts, time) = text.rsplit_once(" in ")?;
    if !time.trim_end().ends_with('s') || !time.trim_start().starts_with(|c: char| c.is_ascii_digit()) {
        return None;
    }
    let mut tally = Tally::default();
    let mut any = false;
    for part in counts.split(", ") {
        let (n, word) = part.trim().split_once(' ')?;
        let n: usize = n.parse().ok()?;
        match word {
            "passed" | "xpassed" => tally.passed += n,
            "failed" | "error" | "errors" => tally.failed += n,
            "skipped" | "xfailed" | "deselected" | "warning" | "warnings" => {}
            _ => return None,
        }
        any = true;
    }
    any.then_some(tally)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_pytest_summaries() {
        let t = parse_summary("85 passed in 3.86s").unwrap();
        assert_eq!((t.passed, t.failed), (85, 0));
        let t = parse_summary("1 failed, 18 passed in 1.32s").unwrap();
        assert_eq!((t.passed, t.failed), (18, 1));
        let t = parse_summary(
            "===== 2 failed, 80 passed, 3 skipped, 1 xpassed, 2 errors, 4 warnings in 12.01s =====",
        )
        .unwrap();
        assert_eq!((t.passed, t.failed), (81, 4));
        let t = parse_summary("4 errors in 0.47s").unwrap();
        assert_eq!((t.passed, t.failed), (0, 4));
        assert!(parse_summary("no tests ran in 0.01s").is_none());
        assert!(parse_summary("tests/test_cli.py ....  [ 20%]").is_none());
        assert!(parse_summary("the check ran in the loop").is_none());
        assert!(parse_summary("running 3 tests").is_none());
    }
}
