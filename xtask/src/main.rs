//! `cargo xtask`: the project's two commands (after the `xtask` pattern of
//! RTIC and the knurling app-template: plain Rust instead of shell scripts).
//!
//! * `cargo xtask run`: sets up what it needs (Cortex-M target, QEMU, the
//!   QEMU runner), then runs the firmware in QEMU on its demo trajectory.
//! * `cargo xtask test`: the same set-up, then every check and test (format,
//!   lints, the `no_std` build, the host tests, the firmware under QEMU), and
//!   `N passed, N failed` last (exit code 1 if any failed).
//! * `cargo xtask e2e`: only the end-to-end serial test (part of `test`).
//! * `cargo xtask python`: only the Python package's checks and tests
//!   (part of `test`; [`python`]).
//! * `cargo xtask stress [--robot FILE] [--poses N]`: the stress set of
//!   hard poses (default 100 000) through every method on the board's code
//!   under QEMU: each method's worst solve and its pose, the barycenter's
//!   analytical bound (the test command runs a short version).
//! * `cargo xtask qemu [--robot FILE] [--tcp PORT]`: the product firmware
//!   for that robot in QEMU, in real time, its USART1 on a local TCP port
//!   (default 4444) for `cdpr stream --tcp 127.0.0.1:PORT`, until Ctrl-C.
//!
//! `run` and `e2e` take `--robot FILE` (default `robots/suspended-8.toml`;
//! a relative path is taken from the workspace root): the firmware is
//! built for that robot file (`CDPR_ROBOT`, made absolute) and the host
//! side derives the same demo trajectory and identity from it. `test` runs
//! the demo and the end-to-end test for every robot of
//! [`firmware::TEST_ROBOTS`].

mod checks;
mod e2e;
mod e2e_stream;
mod elf;
mod firmware;
mod python;

use std::process::exit;

use clap::{Parser, Subcommand};

use checks::{cargo_test, check, print_failures, Tally};
use firmware::TARGET;

/// Poses of `cargo xtask stress` unless `--poses` says otherwise.
const STRESS_POSES: u32 = 100_000;

/// The TCP port of `cargo xtask qemu` unless `--tcp` says otherwise.
const QEMU_PORT: u16 = 4444;

/// The project's tasks (`cargo xtask TASK`).
#[derive(Debug, Parser)]
#[command(
    name = "cargo xtask",
    bin_name = "cargo xtask",
    about = "The project's tasks: set-up included, on a bare clone"
)]
struct Cli {
    #[command(subcommand)]
    task: Task,
}

#[derive(Debug, Subcommand)]
enum Task {
    /// The firmware in QEMU on its demo trajectory (readable output).
    Run {
        /// Robot file (from the workspace root).
        #[arg(long, value_name = "FILE", default_value = firmware::DEFAULT_ROBOT)]
        robot: String,
    },
    /// Every check and test; `N passed, N failed` last.
    Test,
    /// Only the end-to-end serial test (part of `test`).
    E2e {
        /// Robot file (from the workspace root).
        #[arg(long, value_name = "FILE", default_value = firmware::DEFAULT_ROBOT)]
        robot: String,
    },
    /// Only the Python package's checks and tests (part of `test`).
    Python,
    /// The stress set of hard poses through every method under QEMU.
    Stress {
        /// Robot file (from the workspace root).
        #[arg(long, value_name = "FILE", default_value = firmware::DEFAULT_ROBOT)]
        robot: String,
        /// Poses in the set.
        #[arg(long, value_name = "N", default_value_t = STRESS_POSES)]
        poses: u32,
    },
    /// The product firmware in QEMU in real time, USART1 on a local TCP port.
    Qemu {
        /// Robot file (from the workspace root).
        #[arg(long, value_name = "FILE", default_value = firmware::DEFAULT_ROBOT)]
        robot: String,
        /// The local TCP port.
        #[arg(long, value_name = "PORT", default_value_t = QEMU_PORT)]
        tcp: u16,
    },
}

fn main() {
    let cli = Cli::parse();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    if let Err(e) = std::env::set_current_dir(&root) {
        eprintln!("cannot enter the workspace root: {e}");
        exit(2);
    }
    match cli.task {
        Task::Run { robot } => run(&robot),
        Task::Test => test(),
        Task::E2e { robot } => e2e(&robot),
        Task::Python => python_only(),
        Task::Stress { robot, poses } => stress(&robot_or_exit(&robot), poses),
        Task::Qemu { robot, tcp } => qemu(&robot_or_exit(&robot), tcp),
    }
}

/// The robot file `file` (from the workspace root) as an absolute path, or exit.
fn robot_or_exit(file: &str) -> std::path::PathBuf {
    match firmware::robot_path(file) {
        Ok(path) => path,
        Err(e) => {
            eprintln!("error: {e}");
            exit(2);
        }
    }
}

/// `cargo xtask stress`: the stress program for the robot and the number
/// of poses, under QEMU; exits 0 when it passes.
fn stress(robot: &std::path::Path, poses: u32) -> ! {
    match firmware::setup().and_then(|()| firmware::run_stress(robot, poses)) {
        Ok(verdict) => {
            println!("==> stress run: ok ({verdict})");
            exit(0)
        }
        Err(e) => {
            eprintln!("error: {e}");
            exit(1)
        }
    }
}

/// `cargo xtask qemu`: builds the product for the robot and runs it in
/// QEMU (real time, `sleep=on`) with USART1 on a TCP server port; exits
/// with QEMU (Ctrl-C ends both).
fn qemu(robot: &std::path::Path, port: u16) -> ! {
    if let Err(e) = firmware::setup().and_then(|()| firmware::build_product(robot)) {
        eprintln!("error: {e}");
        exit(1);
    }
    match e2e_stream::start_qemu(Some(port), true) {
        Ok(mut q) => {
            println!(
                "==> the firmware for {} runs in QEMU; its serial link is tcp 127.0.0.1:{port}",
                robot.display()
            );
            println!(
                "==> e.g. cargo run -p cdpr --release -- stream --robot {} --waypoints WAYPOINTS.csv --tcp 127.0.0.1:{port}",
                robot.display()
            );
            println!("==> Ctrl-C stops it");
            let status = q.wait();
            exit(if status.is_ok_and(|s| s.success()) { 0 } else { 1 });
        }
        Err(e) => {
            eprintln!("error: {e}");
            exit(1);
        }
    }
}

/// The firmware for `robot` in QEMU on its demo trajectory.
fn run(robot: &str) {
    let robot = robot_or_exit(robot);
    if let Err(e) = firmware::setup().and_then(|()| firmware::run_demo(&robot)) {
        eprintln!("error: {e}");
        exit(1);
    }
}

/// Only the end-to-end serial test (part of `test`) for `robot`, for
/// working on it.
fn e2e(robot: &str) {
    let robot = robot_or_exit(robot);
    let mut tally = Tally::default();
    match firmware::setup().and_then(|()| firmware::build_product(&robot)) {
        Ok(()) => {
            for (name, result) in e2e::run(&robot) {
                tally.report(&format!("end-to-end: {name}"), result);
            }
        }
        Err(e) => tally.fail("end-to-end", &e),
    }
    print_failures();
    println!("{} passed, {} failed", tally.passed, tally.failed);
    exit(if tally.failed == 0 { 0 } else { 1 });
}

/// Only the Python package's part of `test`, for working on it.
fn python_only() {
    let tally = python::test();
    print_failures();
    println!("{} passed, {} failed", tally.passed, tally.failed);
    exit(if tally.failed == 0 { 0 } else { 1 });
}

fn test() {
    let mut tally = Tally::default();
    if let Err(e) = firmware::setup() {
        tally.fail("set-up", &e);
    }
    let cargo = env!("CARGO");
    tally.add(check("format", cargo, &["fmt", "--all", "--", "--check"]));
    tally.add(check("clippy (host crates)", cargo, &["clippy", "--all-targets", "--", "-D", "warnings"]));
    // The firmware's library and every program (product, demo, fault
    // injection), with each board's support module.
    for (board, features) in [
        ("QEMU netduinoplus2", ""),
        ("STM32F405 board, CAN drives", "board"),
        ("STM32F405 board, direct PWM path", "direct"),
    ] {
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
    tally.report(
        "firmware: a robot with no demo trajectory gets its product and stress programs (clippy-checked), and its demo program says why not",
        firmware::no_demo_robot(),
    );
    tally.add(check(
        "tension-core builds for the board (no_std)",
        cargo,
        &["build", "--release", "-p", "tension-core", "--target", TARGET],
    ));
    tally.add(cargo_test(&[]));
    tally.add(python::test());
    match firmware::test() {
        Ok(firmware) => tally.add(firmware),
        Err(e) => tally.fail("firmware", &e),
    }
    print_failures();
    println!("{} passed, {} failed", tally.passed, tally.failed);
    exit(if tally.failed == 0 { 0 } else { 1 });
}
