//! `cargo xtask`: the project's two commands (after the `xtask` pattern of
//! RTIC and the knurling app-template: plain Rust instead of shell scripts).
//!
//! * `cargo xtask run`: sets up what it needs, then runs the demo.
//! * `cargo xtask test`: sets up what it needs, runs every check and test,
//!   and prints `N passed, N failed` last (exit code 1 if any failed).

mod checks;

use std::process::{exit, Command};

use checks::{cargo_test, check, Tally};

const TARGET: &str = "thumbv7em-none-eabihf";

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
        _ => {
            eprintln!("usage: cargo xtask run | cargo xtask test");
            exit(2);
        }
    }
}

/// Installs the Cortex-M target (idempotent; `rust-toolchain.toml` alone does
/// not bring it where rustup's auto-install is off).
fn setup_target() {
    let ok =
        Command::new("rustup").args(["target", "add", TARGET]).status().map(|s| s.success()).unwrap_or(false);
    if !ok {
        eprintln!("warning: `rustup target add {TARGET}` failed");
    }
}

fn run() {
    setup_target();
    let status =
        Command::new(env!("CARGO")).args(["run", "--release", "--quiet", "--example", "host_demo"]).status();
    exit(status.map(|s| s.code().unwrap_or(1)).unwrap_or(1));
}

fn test() {
    setup_target();
    let mut tally = Tally::default();
    tally.add(check("format", env!("CARGO"), &["fmt", "--all", "--", "--check"]));
    tally.add(check(
        "clippy (host crates)",
        env!("CARGO"),
        &["clippy", "--all-targets", "--", "-D", "warnings"],
    ));
    tally.add(check(
        "tension-core builds for the board (no_std)",
        env!("CARGO"),
        &["build", "--release", "-p", "tension-core", "--target", TARGET],
    ));
    tally.add(cargo_test(&[]));
    println!("{} passed, {} failed", tally.passed, tally.failed);
    exit(if tally.failed == 0 { 0 } else { 1 });
}
