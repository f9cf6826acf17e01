//! The firmware's tasks for `cargo xtask`: set-up (Cortex-M target, QEMU,
//! qemu-run), the demo in QEMU, the cycle-time test, the memory report and
//! the end-to-end serial test.
//!
//! Every function expects the workspace root as the current directory (the
//! xtask `main` enters it first). The firmware runs through the runner of
//! `.cargo/config.toml` (`qemu-run ... -icount shift=3,align=off,sleep=off`),
//! so `cargo run` passes the firmware's semihosting exit code through:
//! 0 = pass, 32 + flags = its own verdict "fail" (1 over budget, 2 deadline
//! overrun, 4 timer check, 8 unexpected status, 16 unexpected state
//! sequence), 101 = panic, 102 = HardFault (see `firmware/src/demo.rs`).

use crate::checks::run_step;
use std::{
    io::{BufRead, BufReader},
    os::unix::process::CommandExt,
    path::Path,
    process::{Child, Command, Stdio},
    thread,
    time::{Duration, Instant},
};

/// The firmware's target.
pub const TARGET: &str = "thumbv7em-none-eabihf";
/// The QEMU runner, pinned.
const QEMU_RUN: &str = "qemu-run";
const QEMU_RUN_VERSION: &str = "0.3.1";
/// Instruction budget of one control step (the firmware's `BUDGET`, issue 4).
/// Met: the firmware exits with 0 only when every step is within it (with
/// code 33 when this budget is its only failure), and 0 is now required.
const BUDGET: u64 = 20_000;
/// What the test command holds the worst control step to: a regression guard
/// a little above the figure measured when it was set (18,691 instructions,
/// barycenter warm-started, suspended-8 trajectory).
const REGRESSION_CEILING: u64 = 19_500;
/// Fewest control cycles a run must report.
const MIN_CYCLES: u64 = 2_000;
/// Longest a firmware run may take once built (it needs a few seconds).
const RUN_TIMEOUT: Duration = Duration::from_secs(300);
/// Limit on the worst stack depth the demo measures (stack painting), bytes.
const STACK_LIMIT: u64 = 16 * 1024;
/// The chip's flash and RAM (STM32F405: 1 MiB flash; `memory.x` gives the
/// firmware 112 KiB of the 128 KiB main SRAM).
const FLASH_BYTES: u64 = 1024 * 1024;
const RAM_BYTES: u64 = 112 * 1024;
/// The demo's state sequence (Enabled -> Holding -> Fault -> Disabled -> Enabled).
const DEMO_STATES: &str = "states: [Disabled, Enabled, Holding, Fault, Disabled, Enabled]";

const CARGO: &str = env!("CARGO");

/// Installs what the firmware needs, skipping what is already there: the
/// Cortex-M target (`rustup target add`), `qemu-system-arm` (apt-get) and
/// the `qemu-run` runner (`cargo install --locked`, pinned).
pub fn setup() -> Result<(), String> {
    ensure_target()?;
    ensure_qemu()?;
    ensure_qemu_run()
}

/// Builds the firmware (release) and runs it in QEMU, its output streamed.
/// An error when the build fails or the firmware does not exit with 0
/// (the run's figures are printed either way).
pub fn run_demo() -> Result<(), String> {
    let run = run_firmware("demo", false)?;
    match run.code {
        Some(0) => Ok(()),
        code => Err(format!("the firmware {}", explain(code))),
    }
}

/// Runs the firmware's cycle-time test under QEMU and returns the counts of
/// passed and failed checks:
/// * the control step stays within the regression ceiling (below the 20000
///   budget) over at least 2000 cycles with no deadline overrun, and the
///   firmware exits with 0 (every step within the budget);
/// * the poses outside the workspace give `infeasible` (no other error, no
///   crash);
/// * TIM2 ticks convert to instructions as the icount relation says.
///
/// An error only when the firmware cannot be built or run at all.
pub fn test() -> Result<(usize, usize), String> {
    let run = run_firmware("demo", true)?;
    let crashed = matches!(run.code, None | Some(1) | Some(EXIT_PANIC) | Some(EXIT_HARDFAULT));
    let mut passed = 0;
    let mut failed = 0;
    let mut report = |name: &str, result: Result<String, String>| {
        match &result {
            Ok(detail) => println!("==> firmware test {name}: ok ({detail})"),
            Err(detail) => println!("==> firmware test {name}: FAILED ({detail})"),
        }
        if result.is_ok() {
            passed += 1;
        } else {
            failed += 1;
        }
    };

    report(
        "control step within the regression ceiling, no overrun",
        match find_map(&run.lines, parse_step_line) {
            None => Err(format!("no `control-step instructions:` line; the firmware {}", explain(run.code))),
            Some(s) => {
                let figures = format!(
                    "min {} median {} max {} instructions over {} cycles, overruns {}",
                    s.min, s.median, s.max, s.cycles, s.overruns
                );
                let verdict_ok = run.code == Some(0);
                let budget = if s.max <= BUDGET {
                    format!("within the {BUDGET} budget")
                } else {
                    format!("OVER the {BUDGET} budget of issue 4")
                };
                if s.max <= REGRESSION_CEILING && s.overruns == 0 && s.cycles >= MIN_CYCLES && verdict_ok {
                    Ok(format!("{figures}; {budget}; ceiling {REGRESSION_CEILING}"))
                } else if !verdict_ok {
                    Err(format!("{figures}; the firmware {}", explain(run.code)))
                } else {
                    Err(format!("{figures}; ceiling {REGRESSION_CEILING}, at least {MIN_CYCLES} cycles"))
                }
            }
        },
    );

    report(
        "out-of-workspace poses give infeasible",
        match find_map(&run.lines, parse_status_line) {
            Some((infeasible, other)) if infeasible > 0 && other == 0 && !crashed => {
                Ok(format!("{infeasible} infeasible cycles, no other error"))
            }
            Some((infeasible, other)) => Err(format!(
                "{infeasible} infeasible cycles, {other} other errors; the firmware {}",
                explain(run.code)
            )),
            None => Err(format!("no `cycles:` line; the firmware {}", explain(run.code))),
        },
    );

    report(
        "timer ticks convert to instructions",
        match run.lines.iter().find(|l| l.contains("timer check")) {
            Some(line) if !line.contains("FAILED") => {
                Ok("icount shift=3: 8 TIM2 ticks per instruction".into())
            }
            Some(line) => Err(line.trim().to_string()),
            None => Err(format!("no `timer check` line; the firmware {}", explain(run.code))),
        },
    );

    report(
        "safety states on the demo: enabled, holding, fault, disabled, enabled",
        match run.lines.iter().find(|l| l.contains("states: [")) {
            Some(line) if line.contains(DEMO_STATES) => Ok(line.trim().to_string()),
            Some(line) => Err(format!("{} (expected `{DEMO_STATES}`)", line.trim())),
            None => Err(format!("no `states:` line; the firmware {}", explain(run.code))),
        },
    );

    report(
        "worst stack depth within the limit (stack painting)",
        match find_map(&run.lines, parse_stack_line) {
            Some((used, size)) if used <= STACK_LIMIT && used < size => {
                Ok(format!("{used} bytes used of {size}, limit {STACK_LIMIT}"))
            }
            Some((used, size)) => Err(format!("{used} bytes used of {size}, limit {STACK_LIMIT}")),
            None => Err(format!("no `stack high-water mark` line; the firmware {}", explain(run.code))),
        },
    );

    // Fault injection: a panic and a HardFault in the middle of the demo
    // (drives commanding torques) must stop the drives before exiting.
    for (feature, code, what) in
        [("inject-panic", EXIT_PANIC, "panic"), ("inject-hardfault", EXIT_HARDFAULT, "HardFault")]
    {
        let outcome = run_firmware(feature, true).and_then(|run| {
            let before = run.lines.iter().find(|l| l.contains("injecting a")).cloned();
            let after = run.lines.iter().find(|l| l.contains("drives after the emergency stop")).cloned();
            match (run.code, before, after) {
                (Some(c), Some(before), Some(after))
                    if c == code
                        && stopped(&after)
                        && !before.contains("[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]") =>
                {
                    Ok(format!("exit {c}; {} / {}", before.trim(), after.trim()))
                }
                (c, before, after) => Err(format!(
                    "exit {c:?} (expected {code}), before: {before:?}, after: {after:?}; the firmware {}",
                    explain(c)
                )),
            }
        });
        report(&format!("a {what} stops the drives first (zero torque, brakes on)"), outcome);
    }

    // The product build: sizes, then the end-to-end serial test.
    let product = build_product();
    report(
        "product firmware memory (.text, .data, .bss)",
        product.and_then(|()| {
            let s = crate::elf::sizes(Path::new(crate::e2e::ELF))?;
            let figures = format!(
                ".text {} B, .rodata {} B, .data {} B, .bss {} B, .uninit {} B: flash {} of {} KiB, static RAM {} of {} KiB",
                s.text,
                s.rodata,
                s.data,
                s.bss,
                s.uninit,
                s.flash().div_ceil(1024),
                FLASH_BYTES / 1024,
                s.static_ram().div_ceil(1024),
                RAM_BYTES / 1024
            );
            if s.flash() <= FLASH_BYTES && s.static_ram() + STACK_LIMIT <= RAM_BYTES && s.text > 0 {
                Ok(figures)
            } else {
                Err(format!("{figures}; static RAM plus the {STACK_LIMIT}-byte stack limit must fit"))
            }
        }),
    );
    println!("==> end-to-end: the product firmware in QEMU, driven over its serial link");
    for (name, result) in crate::e2e::run() {
        report(&format!("end-to-end: {name}"), result);
    }

    Ok((passed, failed))
}

/// Exit codes of the firmware's panic and HardFault handlers.
const EXIT_PANIC: i32 = 101;
const EXIT_HARDFAULT: i32 = 102;

/// Whether the emergency-stop line reports zero torque on every drive and
/// the brakes engaged.
fn stopped(line: &str) -> bool {
    let Some(list) = line.split_once("torques [").and_then(|(_, rest)| rest.split_once(']')) else {
        return false;
    };
    let zeros = list.0.split(',').map(|x| x.trim().parse::<f32>()).collect::<Result<Vec<_>, _>>();
    matches!(zeros, Ok(v) if v.len() == 8 && v.iter().all(|&t| t == 0.0))
        && line.contains("brakes engaged true")
}

/// Builds the product firmware (default features: the serial link).
pub fn build_product() -> Result<(), String> {
    run_step(CARGO, &["build", "--release", "-p", "firmware", "--target", TARGET])
}

/// `(used, size)` of `stack high-water mark: A of B bytes`.
fn parse_stack_line(line: &str) -> Option<(u64, u64)> {
    let rest = line.split_once("stack high-water mark: ")?.1;
    Some((number_after(rest, "")?, number_after(rest, "of ")?))
}

fn ensure_target() -> Result<(), String> {
    let installed = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .map_err(|e| format!("cannot run rustup: {e}"))?;
    if String::from_utf8_lossy(&installed.stdout).lines().any(|l| l.trim() == TARGET) {
        return Ok(());
    }
    run_step("rustup", &["target", "add", TARGET])
}

fn ensure_qemu() -> Result<(), String> {
    if succeeds("qemu-system-arm", &["--version"]) {
        return Ok(());
    }
    // apt-get needs root; use sudo when not root and it is there.
    let root = Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
        .unwrap_or(false);
    let (program, prefix): (&str, &[&str]) = if root { ("apt-get", &[]) } else { ("sudo", &["apt-get"]) };
    let args = |rest: &[&'static str]| -> Vec<&str> { prefix.iter().chain(rest).copied().collect() };
    run_step(program, &args(&["update"]))?;
    run_step(program, &args(&["install", "-y", "qemu-system-arm"]))?;
    if succeeds("qemu-system-arm", &["--version"]) {
        Ok(())
    } else {
        Err("qemu-system-arm is still not on PATH after apt-get install".into())
    }
}

fn ensure_qemu_run() -> Result<(), String> {
    let wanted = format!("{QEMU_RUN} {QEMU_RUN_VERSION}");
    if qemu_run_version().as_deref() == Some(wanted.as_str()) {
        return Ok(());
    }
    run_step(CARGO, &["install", "--locked", QEMU_RUN, "--version", QEMU_RUN_VERSION])?;
    match qemu_run_version() {
        Some(v) if v == wanted => Ok(()),
        Some(v) => {
            Err(format!("`{QEMU_RUN} --version` says `{v}`, wanted `{wanted}` (another one first on PATH?)"))
        }
        None => Err(format!("{QEMU_RUN} is not on PATH after `cargo install` (add ~/.cargo/bin)")),
    }
}

/// First line of `qemu-run --version` (`qemu-run 0.3.1`), if it runs.
fn qemu_run_version() -> Option<String> {
    let out = Command::new(QEMU_RUN).arg("--version").output().ok()?;
    let text = String::from_utf8_lossy(&out.stdout);
    out.status.success().then(|| text.lines().next().unwrap_or("").trim().to_string())
}

fn succeeds(program: &str, args: &[&str]) -> bool {
    Command::new(program)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false)
}

/// A finished firmware run: its exit code and output lines.
struct Run {
    code: Option<i32>,
    lines: Vec<String>,
}

/// Builds the firmware, then runs it with the configured runner, echoing
/// its output; with `capture` the lines are also kept for parsing.
fn run_firmware(features: &str, capture: bool) -> Result<Run, String> {
    if !Path::new("firmware/Cargo.toml").is_file() {
        return Err("run from the workspace root (firmware/Cargo.toml not found)".into());
    }
    let cargo_args = ["--release", "-p", "firmware", "--target", TARGET, "--features", features];
    run_step(CARGO, &[&["build"][..], &cargo_args].concat())?;
    println!("==> firmware in QEMU (netduinoplus2, -icount shift=3,align=off,sleep=off)");
    let mut child = Command::new(CARGO)
        .arg("run")
        .args(["--quiet"])
        .args(cargo_args)
        .stdout(Stdio::piped())
        .process_group(0) // so that a timeout can stop cargo, qemu-run and QEMU together
        .spawn()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    let out = child.stdout.take().ok_or("no stdout from cargo run")?;
    let reader = thread::spawn(move || {
        let mut lines = Vec::new();
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            println!("{line}");
            if capture {
                lines.push(line);
            }
        }
        lines
    });
    let code = wait_with_timeout(&mut child, RUN_TIMEOUT)?;
    let lines = reader.join().map_err(|_| "the output reader panicked")?;
    Ok(Run { code, lines })
}

/// Waits for `child`; past `timeout` kills its whole process group.
fn wait_with_timeout(child: &mut Child, timeout: Duration) -> Result<Option<i32>, String> {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            return Ok(status.code());
        }
        if start.elapsed() > timeout {
            let group = format!("-{}", child.id());
            let _ = Command::new("kill").args(["-KILL", "--", &group]).status();
            let _ = child.wait();
            return Err(format!("the firmware run did not finish within {} s (killed)", timeout.as_secs()));
        }
        thread::sleep(Duration::from_millis(50));
    }
}

/// What an exit code of `cargo run` says about the firmware.
fn explain(code: Option<i32>) -> String {
    match code {
        Some(0) => "exited with 0 (pass)".into(),
        Some(c @ 32..=63) => {
            let flags = c - 32;
            let reasons: Vec<&str> = [
                (1, "a control step over budget"),
                (2, "deadline overruns"),
                (4, "the timer check failed"),
                (8, "unexpected statuses"),
                (16, "unexpected state sequence"),
            ]
            .iter()
            .filter(|(bit, _)| flags & bit != 0)
            .map(|&(_, why)| why)
            .collect();
            format!("exited with {c}: {}", reasons.join(", "))
        }
        Some(EXIT_PANIC) => format!("panicked (exit code {EXIT_PANIC})"),
        Some(EXIT_HARDFAULT) => format!("hit a HardFault (exit code {EXIT_HARDFAULT})"),
        Some(c) => format!("exited with {c} (runner or QEMU failure?)"),
        None => "was killed by a signal".into(),
    }
}

/// The first line `parse` accepts.
fn find_map<T>(lines: &[String], parse: fn(&str) -> Option<T>) -> Option<T> {
    lines.iter().find_map(|l| parse(l))
}

/// The figures of `control-step instructions: min A median B max C over K
/// cycles, overruns N`.
#[derive(Debug, PartialEq, Eq)]
struct StepLine {
    min: u64,
    median: u64,
    max: u64,
    cycles: u64,
    overruns: u64,
}

fn number_after(text: &str, key: &str) -> Option<u64> {
    let at = text.find(key)? + key.len();
    text[at..].split(|c: char| !c.is_ascii_digit()).next()?.parse().ok()
}

fn parse_step_line(line: &str) -> Option<StepLine> {
    let rest = line.split_once("control-step instructions: ")?.1;
    Some(StepLine {
        min: number_after(rest, "min ")?,
        median: number_after(rest, "median ")?,
        max: number_after(rest, "max ")?,
        cycles: number_after(rest, "over ")?,
        overruns: number_after(rest, "overruns ")?,
    })
}

/// `(infeasible, other errors)` of the `cycles: ...` line.
fn parse_status_line(line: &str) -> Option<(u64, u64)> {
    let rest = line.trim().strip_prefix("cycles: ")?;
    Some((number_after(rest, "infeasible ")?, number_after(rest, "other errors ")?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_firmware_lines() {
        let s = parse_step_line(
            "control-step instructions: min 41047 median 53069 max 66542 over 4000 cycles, overruns 0",
        );
        assert_eq!(s, Some(StepLine { min: 41047, median: 53069, max: 66542, cycles: 4000, overruns: 0 }));
        assert_eq!(
            parse_step_line("barycenter solver instructions: min 1 median 2 max 3 over 4 cycles"),
            None
        );
        assert_eq!(
            parse_status_line(
                "cycles: 3651 ok, infeasible 349 (torques held), other errors 0; warm start held 3648"
            ),
            Some((349, 0))
        );
        assert!(explain(Some(33)).contains("over budget"));
        assert!(explain(Some(48)).contains("state sequence"));
        assert_eq!(parse_stack_line("stack high-water mark: 6520 of 78908 bytes"), Some((6520, 78908)));
        assert!(stopped("ERROR drives after the emergency stop: torques [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0] N m, brakes engaged true"));
        assert!(!stopped("drives after the emergency stop: torques [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.1] N m, brakes engaged true"));
        assert!(!stopped("drives after the emergency stop: torques [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0] N m, brakes engaged false"));
        assert!(explain(Some(101)).contains("panicked"));
    }
}
