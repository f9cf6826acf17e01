//! `cargo xtask`: the project's two commands (after the `xtask` pattern of
//! RTIC and the knurling app-template: plain Rust instead of shell scripts).
//!
//! * `cargo xtask run`: sets up what it needs (Cortex-M target, QEMU, the
//!   QEMU runner), then runs the firmware in QEMU on its demo trajectory.
//! * `cargo xtask test`: the same set-up, then every check and test (format,
//!   lints, the `no_std` build, the host tests, the firmware under QEMU), and
//!   `N passed, N failed` last (exit code 1 if any failed).
//! * `cargo xtask e2e`: only the end-to-end serial test (part of `test`).

mod checks;
mod e2e;
mod elf;
mod firmware;

use std::process::exit;

use checks::{cargo_test, check, Tally};
use firmware::TARGET;

fn main() {
    let task = std::env::args().nth(1).unwrap_or_default();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    if let Err(e) = std::env::set_current_dir(&root) {
        eprintln!("cannot enter the workspace root: {e}");
        exit(2);
    }
    match task.as_str() {
        "run" => run(),
        "test" => test(),
        "e2e" => e2e(),
        _ => {
            eprintln!("usage: cargo xtask run | cargo xtask test | cargo xtask e2e");
            exit(2);
        }
    }
}

/// The firmware in QEMU on its demo trajectory.
fn run() {
    if let Err(e) = firmware::setup().and_then(|()| firmware::run_demo()) {
        eprintln!("error: {e}");
        exit(1);
    }
}

/// Only the end-to-end serial test (part of `test`), for working on it.
fn e2e() {
    let mut tally = Tally::default();
    match firmware::setup().and_then(|()| firmware::build_product()) {
        Ok(()) => {
            for (name, result) in e2e::run() {
                match &result {
                    Ok(detail) => println!("==> end-to-end: {name}: ok ({detail})"),
                    Err(detail) => println!("==> end-to-end: {name}: FAILED ({detail})"),
                }
                tally.add(Tally { passed: result.is_ok() as usize, failed: result.is_err() as usize });
            }
        }
        Err(e) => {
            println!("==> end-to-end: FAILED ({e})");
            tally.failed += 1;
        }
    }
    println!("{} passed, {} failed", tally.passed, tally.failed);
    exit(if tally.failed == 0 { 0 } else { 1 });
}

fn test() {
    let mut tally = Tally::default();
    if let Err(e) = firmware::setup() {
        println!("==> set-up: FAILED ({e})");
        tally.add(Tally { passed: 0, failed: 1 });
    }
    let cargo = env!("CARGO");
    tally.add(check("format", cargo, &["fmt", "--all", "--", "--check"]));
    tally.add(check("clippy (host crates)", cargo, &["clippy", "--all-targets", "--", "-D", "warnings"]));
    // The firmware's library and every program (product, demo, fault
    // injection), with each board's support module.
    for (board, features) in [("QEMU netduinoplus2", ""), ("STM32F405 board", "board")] {
        tally.add(check(
            &format!("clippy (firmware library and programs, {board}, thumbv7em-none-eabihf)"),
            cargo,
            &[
                "clippy",
                "-p",
                "firmware",
                "--target",
                TARGET,
                "--lib",
                "--bins",
                "--features",
                features,
                "--",
                "-D",
                "warnings",
            ],
        ));
    }
    tally.add(check(
        "tension-core builds for the board (no_std)",
        cargo,
        &["build", "--release", "-p", "tension-core", "--target", TARGET],
    ));
    tally.add(cargo_test(&[]));
    match firmware::test() {
        Ok((passed, failed)) => tally.add(Tally { passed, failed }),
        Err(e) => {
            println!("==> firmware: FAILED ({e})");
            tally.add(Tally { passed: 0, failed: 1 });
        }
    }
    println!("{} passed, {} failed", tally.passed, tally.failed);
    exit(if tally.failed == 0 { 0 } else { 1 });
}
