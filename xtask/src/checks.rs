//! Host checks and tests, each counted as passed or failed.

use std::{
    ffi::OsStr,
    io::{BufRead, BufReader},
    process::{Command, Stdio},
    sync::Mutex,
};

/// Seed of the property tests under `cargo xtask test`.
const PROPTEST_SEED: &str = "20261126";

/// Running totals; the test command prints them last as `N passed, N failed`.
#[derive(Debug, Default, Clone, Copy)]
pub struct Tally {
    pub passed: usize,
    pub failed: usize,
}

impl Tally {
    pub fn add(&mut self, other: Tally) {
        self.passed += other.passed;
        self.failed += other.failed;
    }

    /// Prints `==> {name}: ok` (with the detail, if any) or, through
    /// [`report_failure`], its failure, and counts it.
    pub fn report(&mut self, name: &str, result: Result<String, String>) {
        match result {
            Ok(detail) if detail.is_empty() => println!("==> {name}: ok"),
            Ok(detail) => println!("==> {name}: ok ({detail})"),
            Err(why) => return self.fail(name, &why),
        }
        self.passed += 1;
    }

    /// A failure: printed, kept for [`print_failures`] and counted.
    pub fn fail(&mut self, what: &str, why: &str) {
        report_failure(what, why);
        self.failed += 1;
    }
}

/// The failures of this run, each as printed: the test command repeats
/// them just before its last line, so that the tail of a long log (all a
/// CI page may show) says what failed.
static FAILURES: Mutex<Vec<String>> = Mutex::new(Vec::new());

/// Prints `==> {what}: FAILED ({why})` and keeps it for [`print_failures`].
fn report_failure(what: &str, why: &str) {
    println!("==> {what}: FAILED ({why})");
    record_failure(format!("{what} ({})", shorten(why)));
}

/// Keeps a failure printed by someone else (a cargo test's or pytest's
/// own line) for [`print_failures`].
pub fn record_failure(line: String) {
    if let Ok(mut failures) = FAILURES.lock() {
        failures.push(line);
    }
}

/// Repeats every failure of this run, one line each (nothing if none).
pub fn print_failures() {
    let Ok(failures) = FAILURES.lock() else { return };
    if !failures.is_empty() {
        println!("==> {} failure(s) in this run:", failures.len());
        for f in failures.iter() {
            println!("==>   {f}");
        }
    }
}

/// At most 600 characters of a failure's detail (the repeated list stays
/// readable; the full text is where it was first printed).
fn shorten(why: &str) -> String {
    const LIMIT: usize = 600;
    match why.char_indices().nth(LIMIT) {
        Some((at, _)) => format!("{}...", &why[..at]),
        None => why.to_string(),
    }
}

/// The target directory: `CARGO_TARGET_DIR` or `target`.
pub fn target_dir() -> std::path::PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map_or_else(|| std::path::PathBuf::from("target"), std::path::PathBuf::from)
}

/// Runs a command that counts as one check (formatting, lint, a build).
pub fn check(name: &str, program: &str, args: &[&str]) -> Tally {
    let mut tally = Tally::default();
    tally.report(name, run_step(program, args).map(|()| String::new()));
    tally
}

/// Runs a command with its output shown; an error saying what failed.
pub fn run_step(program: &str, args: &[&str]) -> Result<(), String> {
    run_step_with(program, args, &[])
}

/// [`run_step`] with environment variables set for the command.
pub fn run_step_with(program: &str, args: &[&str], env: &[(&str, &OsStr)]) -> Result<(), String> {
    let shown = if program == env!("CARGO") { "cargo" } else { program };
    println!("==> {shown} {}", args.join(" "));
    let status = Command::new(program)
        .args(args)
        .envs(env.iter().copied())
        .status()
        .map_err(|e| format!("cannot run {program}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{shown} {}` failed ({status})", args.join(" ")))
    }
}

/// Runs `cargo test` with `args`, echoing its output, and adds up the
/// `test result:` lines. A run that fails without any result line (a build
/// error) counts as one failure.
pub fn cargo_test(args: &[&str]) -> Tally {
    println!("==> cargo test {}", args.join(" "));
    // A fixed seed makes the property tests' cases the same on every run of
    // this command (CI); a plain `cargo test` still draws new ones.
    let mut child = match Command::new(env!("CARGO"))
        .arg("test")
        .args(args)
        .env("PROPTEST_RNG_SEED", PROPTEST_SEED)
        // A clean clone's build (CI) gains nothing from incremental
        // compilation's records, and writing them costs time.
        .env("CARGO_INCREMENTAL", "0")
        .stdout(Stdio::piped())
        .spawn()
    {
        Ok(child) => child,
        Err(e) => {
            let mut tally = Tally::default();
            tally.fail("cargo test", &format!("cannot run it: {e}"));
            return tally;
        }
    };
    let mut tally = Tally::default();
    let mut saw_result = false;
    if let Some(out) = child.stdout.take() {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            println!("{line}");
            if let Some(name) = failed_test(&line) {
                record_failure(format!("cargo test {}: {name}", args.join(" ")));
            }
            if let Some(result) = parse_result(&line) {
                saw_result = true;
                tally.add(result);
            }
        }
    }
    let ok = child.wait().map(|s| s.success()).unwrap_or(false);
    if !ok && (!saw_result || tally.failed == 0) {
        tally.failed += 1;
        record_failure(format!(
            "cargo test {}: failed without a failed test (a build error?)",
            args.join(" ")
        ));
    }
    tally
}

/// `test polygon::tests::clips ... FAILED` -> `polygon::tests::clips`.
fn failed_test(line: &str) -> Option<&str> {
    line.strip_prefix("test ")?.strip_suffix(" ... FAILED")
}

/// `test result: ok. 12 passed; 0 failed; ...` -> (12, 0).
fn parse_result(line: &str) -> Option<Tally> {
    let rest = line.trim().strip_prefix("test result: ")?;
    let count = |word: &str| -> Option<usize> {
        let at = rest.find(&format!(" {word}"))?;
        rest[..at].rsplit(|c: char| !c.is_ascii_digit()).next()?.parse().ok()
    };
    Some(Tally { passed: count("passed")?, failed: count("failed")? })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_cargo_result_lines() {
        let t = parse_result(
            "test result: ok. 12 passed; 0 failed; 0 ignored; 0 measured; 0 filtered out; finished in 0.02s",
        )
        .unwrap();
        assert_eq!((t.passed, t.failed), (12, 0));
        let t = parse_result("test result: FAILED. 3 passed; 2 failed; 0 ignored").unwrap();
        assert_eq!((t.passed, t.failed), (3, 2));
        assert!(parse_result("running 3 tests").is_none());
    }

    #[test]
    fn names_failed_tests() {
        assert_eq!(failed_test("test walk::tests::holds ... FAILED"), Some("walk::tests::holds"));
        assert_eq!(failed_test("test walk::tests::holds ... ok"), None);
        assert_eq!(failed_test("test result: FAILED. 3 passed; 2 failed"), None);
    }

    #[test]
    fn counts_and_keeps_what_it_reports() {
        let mut tally = Tally::default();
        tally.report("a check", Ok(String::new()));
        tally.report("a measured check", Ok("12 instructions".into()));
        tally.report("a failing check", Err("over its ceiling".into()));
        tally.fail("a step not run", "no build");
        assert_eq!((tally.passed, tally.failed), (2, 2));
        let kept = FAILURES.lock().unwrap().clone();
        assert!(kept.contains(&"a failing check (over its ceiling)".to_string()), "{kept:?}");
        assert!(kept.contains(&"a step not run (no build)".to_string()), "{kept:?}");
        assert!(!kept.iter().any(|f| f.starts_with("a check") || f.starts_with("a measured")), "{kept:?}");
    }

    #[test]
    fn shortens_long_details_only() {
        assert_eq!(shorten("short"), "short");
        let long = "é".repeat(700);
        let cut = shorten(&long);
        assert_eq!(cut.chars().count(), 603);
        assert!(cut.ends_with("..."));
    }
}
