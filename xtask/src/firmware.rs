//! The firmware's tasks for `cargo xtask`: set-up (Cortex-M target, QEMU,
//! qemu-run), the demo in QEMU, the cycle-time test, the memory report and
//! the end-to-end serial test.
//!
//! Every function expects the workspace root as the current directory (the
//! xtask `main` enters it first). The programs are built with cargo and run
//! with `qemu-run` on the machine and `-icount` setting of
//! [`cdpr_demo::qemu`]; it passes the program's semihosting exit code
//! through: [`exit::PASS`], [`exit::FAIL`]` + flags` (the demo's own
//! verdict, [`exit::fail`]), [`exit::PANIC`], [`exit::HARDFAULT`]. The
//! figures the tests judge come from the records the programs log
//! ([`cdpr_demo::report`]), not from their readable output.

use crate::checks::{run_step, run_step_with, target_dir, Tally};
use cdpr_demo::exit;
use cdpr_demo::report::{self, Record, Report};
use cdpr_demo::{methods, BUDGET, EXPECTED_STATES, FRAMING_LIMIT, PERIOD_INSTRUCTIONS, RECEIVE_LIMIT};
use std::{
    ffi::OsStr,
    fs,
    io::{BufRead, BufReader},
    os::unix::process::CommandExt,
    path::{Path, PathBuf},
    process::{Child, Command, Stdio},
    thread,
    time::{Duration, Instant},
};

/// The firmware's target.
pub const TARGET: &str = "thumbv7em-none-eabihf";
/// The QEMU runner, pinned.
pub const QEMU_RUN: &str = "qemu-run";
const QEMU_RUN_VERSION: &str = "0.3.1";
/// The product program (its ELF is what the end-to-end test runs).
pub const PRODUCT: &str = "firmware";
/// The demo program.
const DEMO: &str = "demo";
/// What the test command holds the worst control step of the default robot
/// (suspended-8) to: a regression guard a little above the figure measured
/// when it was set (15,489 instructions: the step takes its setpoint as the
/// product does, a frame from the receive interrupt's queue checked and
/// decoded in the step; with the closed loop of issue 13: encoders,
/// estimator and feedback; barycenter warm-started; 19,497 before the
/// FPU's square root, the unit-normal walk and the step's copies of
/// issue 17, 16,468 before the kept polygon room and the kinematics built
/// in place, 15,827 before the setpoint and the estimate were copied once
/// instead of twice; 15,102 since the factorisation works on its columns as
/// arrays and checks what it keeps; 14,570 since the walk skips its search
/// among concurrent lines when no line ties and the estimator shares the
/// solver's factorisation; 14,343 since the step writes its report and its
/// telemetry in place, session 20; 14,114 since the factorisation's
/// reflections are applied to two columns at a time, session 22; 14,062
/// since the warm pair's check gives the first vertex's active lines and
/// margin, 13,755 since the step's finiteness checks are one sum each,
/// session 23; 13,415 since the board is built with a raised inlining
/// threshold, `.cargo/config.toml`, session 26; 13,318 since `W^T` is
/// written in place and telemetry reads the solved cycle by
/// reference, session 29; 13,387 since the cold search after a lost warm
/// start clips the cutting cable first, session 30; 13,279 since a new
/// setpoint is written over the kept one field by field, session 32; 13,280
/// since the demo also records the step without its solve, session 35), below
/// the [`BUDGET`].
const REGRESSION_CEILING: u32 = 13_450;

/// The regression ceiling of the product's worst streamed step on the
/// default robot (telemetry's `step_cost`: at most two setpoint frames
/// decoded in it, `cdpr_control::FRAME_BUDGET`; the worst was the cold
/// start at the stream's start and the lost warm start after it, and is
/// since session 30 a moving cycle with two frames). The step is timed on
/// `firmware::serial::TaskClock` (issue 17, session 27): before, the
/// receive interrupt's totals and TIM2 were read one after the other and
/// a burst of bytes between the reads made the figure depend on the
/// machine's load (13 411 to 20 418 for the same code). Since, with the
/// board's raised inlining threshold and the phases no longer timed in the
/// product: 12 402, and 12 888 with two CPU hogs beside QEMU (the host's
/// frames bunched: 208 telemetry samples for the usual 122); 11 492 to
/// 13 218 over four runs with the phases timed. `cdpr stream`'s session
/// (`e2e_stream`) is held to it too (11 021 measured). Since the cold
/// search after a lost warm start clips the cutting cable's lines first
/// (issue 17, session 30; the stream's second cycle, at the symmetric
/// start, lost its warm start): 11 159, 11 346 and 11 580 over three
/// runs, 11 509 in the clean-clone run (`cdpr stream` 11 028); 11 278 to
/// 11 516 in session 31's runs. Session 31 set it 12 500 -> 13 500: the
/// figure follows the host's pace (which setpoint the stream's cold start
/// meets, and whether a second frame lands in that cycle), and IPAnema 1's
/// went 2 700 above its usual worst in one clean-clone run. Session 33:
/// the end-to-end test holds the first pose at rest before the stream
/// (`e2e::HELD_SETPOINTS`), so the stream's first solve no longer depends
/// on the host's pace: 11 165 to 11 569 (a moving cycle) over six runs,
/// three of them clean-clone runs of the test command; but what else lands
/// in the first solve's cycle still does (IPAnema 1's first solve reached
/// 15 875 once): 13 000. Session 34: bursts of received bytes were what
/// landed there (QEMU miscounts each interrupt taken inside the step by a
/// few instructions, and delivered up to 1 518 in one step); the product's
/// step now holds the receive interrupt off under QEMU
/// (`bsp::with_receive_held`): 11 134 to 11 569 over four runs and 11 153
/// and 11 764 in two clean-clone runs of the test command (moving cycles
/// with two frames): 12 500. Other robots'
/// are in [`TEST_CEILINGS`] (the budget for a robot without figures).
pub(crate) const PRODUCT_CEILING: u32 = 12_500;

/// The worst step of the default robot's demo with the CiA 402 layer inside
/// ([`LAYER_IN_STEP_VAR`]): measured 17 671 (issue 17, session 28), 17 553
/// (session 29), 17 556 (session 30), 17 448 (session 32).
const LAYER_IN_STEP_CEILING: u32 = 17_650;

/// IPAnema 1's demo's worst step: measured 14 425 (an infeasible pose's
/// cold search at cycle 3 156; issue 17, session 28), 14 350 (session 29),
/// 14 369 (session 30), 14 261 (session 32), 14 267 (session 35).
const IPANEMA1_CEILING: u32 = 14_450;

/// IPAnema 1's demo's worst step with the CiA 402 layer inside: measured
/// 18 489 (issue 17, session 28), 18 272 (session 29), 18 220 (session
/// 30), 18 112 (session 32).
const IPANEMA1_LAYER_IN_STEP_CEILING: u32 = 18_300;

/// IPAnema 1's product's worst streamed step (telemetry's `step_cost`, the
/// stream's cold start; the streamed trajectory and `cdpr
/// stream`'s session): measured 15 449 and 15 756 in the runs of session
/// 27 (16 076-16 406 while the product still timed its phases); QEMU runs
/// the product with its clock, so the host's load moves it by several
/// hundred (as [`PRODUCT_CEILING`]'s figures). Since the cold search after
/// a lost warm start clips the cutting cable's lines first (session 30):
/// 13 154, 14 739 and 12 756 over three runs, 13 873 in the clean-clone
/// run (the stream's cold start; 14 901-15 707 before, the lost warm start
/// after it). Session 31: 12 810 to 14 184 in five runs, then **16 993** in
/// a clean-clone run (over the 16 000 set in session 30, which failed the
/// test command): set to 18 000, still within the 20 000 budget. Session
/// 33: with the first pose held at rest before the stream
/// (`e2e::HELD_SETPOINTS`), 12 889 to 13 768 in eighteen runs (two beside
/// two CPU hogs; the held pose's step with frames), and the moving
/// cycles' worst 11 100 to 12 816; in clean-clone runs of the test
/// command 14 269, 13 276 and **15 875** (the stream's first solve, a cold
/// start at the symmetric centre, at setpoint 3: what else lands in that
/// cycle still follows the host's pace): 17 000. Session 34: what landed
/// in that cycle was a burst of received bytes (the first solve reported
/// 17 275 with 1 518 interrupts inside it, 12 700 of its own: QEMU
/// miscounts each by a few instructions); with the receive interrupt held
/// off during the step under QEMU (`bsp::with_receive_held`), 12 684 to
/// 13 285 over eight runs (the departure from the held pose, a lost warm
/// start; the first solve 12 600-12 700): 14 000.
const IPANEMA1_PRODUCT_CEILING: u32 = 14_000;

/// The test command's regression ceilings for one robot: each a little
/// above what was measured when it was set, so that a change that makes
/// the step dearer fails the test command (issue 17: "the test command
/// keeps requiring 20 000 and holds a regression ceiling just above what
/// you reach").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Ceilings {
    /// The demo's worst step (deterministic: QEMU `-icount`, sleep off).
    pub demo: u32,
    /// The demo's worst step with the CiA 402 drive layer inside
    /// (deterministic).
    pub layer_in_step: u32,
    /// The product's worst streamed step with its frames (the end-to-end
    /// test's streamed trajectory and `cdpr stream`'s session).
    pub product: u32,
}

impl Ceilings {
    /// A robot without measured figures: the [`BUDGET`] for everything.
    const BUDGET: Self = Self { demo: BUDGET, layer_in_step: BUDGET, product: BUDGET };
}

/// The ceilings of the robots of [`TEST_ROBOTS`], each measured on it.
const TEST_CEILINGS: [(&str, Ceilings); 2] = [
    (
        DEFAULT_ROBOT,
        Ceilings { demo: REGRESSION_CEILING, layer_in_step: LAYER_IN_STEP_CEILING, product: PRODUCT_CEILING },
    ),
    (
        "robots/ipanema1.toml",
        Ceilings {
            demo: IPANEMA1_CEILING,
            layer_in_step: IPANEMA1_LAYER_IN_STEP_CEILING,
            product: IPANEMA1_PRODUCT_CEILING,
        },
    ),
];

/// The regression ceiling of the step's receive share under the demo's
/// receive flood: a cycle's `cdpr_control::FRAME_BUDGET` (2) of
/// back-to-back setpoint frames measured 1 160 instructions (issue 17,
/// session 19; 4 frames a cycle took 2 317 before; 895 since the board is
/// built with a raised inlining threshold, session 26), far below
/// [`RECEIVE_LIMIT`], which bounds it against the period.
const RECEIVE_CEILING: u32 = 1_000;

/// `robot`'s regression ceilings ([`TEST_CEILINGS`]; `robot` absolute, as
/// [`robot_path`] gives it, or as written there): the [`BUDGET`] for a
/// robot the test command has no figures of (a user's robot file).
pub(crate) fn ceilings(robot: &Path) -> Ceilings {
    TEST_CEILINGS
        .iter()
        .find(|(file, _)| Path::new(file) == robot || robot_path(file).is_ok_and(|p| p == robot))
        .map_or(Ceilings::BUDGET, |&(_, c)| c)
}
/// Fewest control cycles a run must report.
const MIN_CYCLES: u32 = 2_000;
/// Longest a firmware run may take once built (it needs a few seconds).
const RUN_TIMEOUT: Duration = Duration::from_secs(300);
/// Limit on the worst stack depth the demo measures (stack painting), bytes.
pub(crate) const STACK_LIMIT: u32 = 16 * 1024;
/// Regression ceiling on the demo builds' stack depth, bytes, a little
/// over what they reach (13 612 in session 39, start-up's frame the
/// deepest): an inlining change there once cost 5 KB unseen (the product
/// reached 16 248 of the limit).
pub(crate) const STACK_CEILING: u32 = 14_000;
/// The same for the product's (its log's marks: 13 928 in session 39).
pub(crate) const PRODUCT_STACK_CEILING: u32 = 14_300;
/// The chip's flash and RAM (STM32F405: 1 MiB flash; `memory.x` gives the
/// firmware 112 KiB of the 128 KiB main SRAM).
const FLASH_BYTES: u64 = 1024 * 1024;
const RAM_BYTES: u64 = 112 * 1024;

const CARGO: &str = env!("CARGO");

/// Installs what the firmware needs, skipping what is already there: the
/// Cortex-M target (`rustup target add`), `qemu-system-arm` (apt-get) and
/// the `qemu-run` runner (`cargo install --locked`, pinned).
pub fn setup() -> Result<(), String> {
    ensure_target()?;
    ensure_qemu()?;
    ensure_qemu_run()
}

/// The robot file the firmware is built for when none is given.
pub const DEFAULT_ROBOT: &str = "robots/suspended-8.toml";
/// The robots `cargo xtask test` runs the demo and the end-to-end test
/// for (the first also the fault injection and the memory report).
pub const TEST_ROBOTS: [&str; 2] = [DEFAULT_ROBOT, "robots/ipanema1.toml"];

/// `file` (relative to the workspace root, the current directory, or
/// absolute) as an absolute path, checked to exist: what the firmware's
/// `build.rs` gets as `CDPR_ROBOT`.
pub fn robot_path(file: &str) -> Result<PathBuf, String> {
    let path = Path::new(file);
    path.canonicalize().map_err(|e| format!("robot file {}: {e}", path.display()))
}

/// A firmware check's name as the test command prints it:
/// `firmware test [robot] check`.
fn titled(robot: &str, check: &str) -> String {
    format!("firmware test [{robot}] {check}")
}

/// The robot's name for the checks' labels: the file's stem.
fn label(robot: &Path) -> String {
    robot.file_stem().map_or_else(|| robot.display().to_string(), |s| s.to_string_lossy().into_owned())
}

/// Builds the demo (release) for `robot` and runs it in QEMU, its output
/// streamed. An error when the build fails or the demo does not exit with
/// [`exit::PASS`] (the run's figures are printed either way).
pub fn run_demo(robot: &Path) -> Result<(), String> {
    let run = run_firmware(DEMO, robot, false)?;
    match run.code {
        Some(exit::PASS) => Ok(()),
        code => Err(format!("the firmware {}", explain(code))),
    }
}

/// Runs the firmware's tests under QEMU and returns the counts of passed
/// and failed checks:
/// * the control step stays within the regression ceiling (below the
///   budget) over at least 2000 cycles with no deadline overrun, and the
///   demo exits with its pass verdict (every step within the budget);
/// * the poses outside the workspace give `infeasible` (no other error, no
///   crash);
/// * TIM2 ticks convert to instructions as the icount relation says;
/// * the safety states follow [`EXPECTED_STATES`]; the stack stays within
///   its limit;
/// * every method's measured worst solve is within the table the board's
///   offer of methods is derived from (`cdpr_demo::methods`);
/// * a panic and a HardFault stop the drives first;
/// * the product fits the chip and passes the end-to-end serial test.
///
/// The demo and the end-to-end test run for every robot of
/// [`TEST_ROBOTS`], each with the firmware built for it; the fault
/// injection and the memory report for the first. An error only when the
/// demo cannot be built or run at all.
pub fn test() -> Result<Tally, String> {
    let mut tally = Tally::default();
    for (n, file) in TEST_ROBOTS.iter().enumerate() {
        let robot = robot_path(file)?;
        let name = label(&robot);
        let run = run_firmware(DEMO, &robot, true)?;
        for (check, result) in DEMO_CHECKS.iter().zip(judge_demo(&run, ceilings(&robot).demo)) {
            tally.report(&titled(&name, check), result);
        }
        if n == 0 {
            for (program, code, what) in
                [("inject-panic", exit::PANIC, "panic"), ("inject-hardfault", exit::HARDFAULT, "HardFault")]
            {
                let outcome = run_firmware(program, &robot, true).and_then(|run| judge_injection(&run, code));
                tally.report(
                    &titled(&name, &format!("a {what} stops the drives first (zero torque, brakes on)")),
                    outcome,
                );
            }
        }
        product_checks(&mut tally, &robot, n == 0);
        tally.report(
            &titled(&name, "the stress set of hard poses through every method (cdpr_demo::stress)"),
            run_stress(&robot, cdpr_demo::stress::SHORT_RUN),
        );
    }
    // The step with the CiA 402 drive layer inside (issue 14), last: the
    // build switch rebuilds the firmware once more per robot.
    let layer = [(LAYER_IN_STEP_VAR, OsStr::new("1"))];
    for file in TEST_ROBOTS {
        let robot = robot_path(file)?;
        tally.report(
            &titled(&label(&robot), &format!("the step with the CiA 402 drive layer inside ({LAYER_IN_STEP_VAR}) within its regression ceiling and the budget, no overrun, stack within its limit, the step without its solve within the stated rest")),
            run_firmware_with(DEMO, &robot, true, &layer, RUN_TIMEOUT)
                .and_then(|run| judge_layer_in_step(&run, ceilings(&robot).layer_in_step)),
        );
    }
    Ok(tally)
}

/// A robot from which no demo trajectory derives still gets its product:
/// suspended-8 with its first cable limited to 30-31 N (written to
/// `target/xtask/`; static poses hold it, no loop keeps 2 % of that range
/// from its limits). The product and the stress program must build for it
/// (`cargo clippy`, which checks them and reuses the lint's build), and the
/// demo program must refuse with the derivation's reason.
pub fn no_demo_robot() -> Result<String, String> {
    let text = fs::read_to_string(DEFAULT_ROBOT).map_err(|e| format!("{DEFAULT_ROBOT}: {e}"))?;
    let first = "attach = [0.2, -0.15, 0.15]\n";
    if text.matches(first).count() != 1 {
        return Err(format!("{DEFAULT_ROBOT} no longer has its first cable's `{}`", first.trim()));
    }
    let narrow = text.replacen(first, &format!("{first}t_min = 30.0\nt_max = 31.0\n"), 1);
    let dir = target_dir().join("xtask");
    fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let file = dir.join("suspended-8-narrow-cable.toml");
    fs::write(&file, narrow).map_err(|e| format!("{}: {e}", file.display()))?;
    let robot = robot_path(&file.to_string_lossy())?;
    let vars = [("CDPR_ROBOT", robot.as_os_str())];
    let lint = |bins: &[&'static str]| {
        let mut args = vec!["clippy", "-p", "firmware", "--target", TARGET];
        for bin in bins {
            args.extend(["--bin", bin]);
        }
        args.extend(["--", "-D", "warnings"]);
        args
    };
    run_step_with(CARGO, &lint(&[PRODUCT, STRESS]), &vars)?;
    let demo = lint(&[DEMO]);
    println!("==> cargo {} (must fail)", demo.join(" "));
    let out =
        Command::new(CARGO).args(&demo).envs(vars).output().map_err(|e| format!("cannot run cargo: {e}"))?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    let reason = "no demo trajectory (no loop around the centre";
    match stderr.lines().find(|l| l.starts_with("error: ") && l.contains(reason)) {
        Some(line) if !out.status.success() => {
            Ok(format!("the demo program refuses: {}", line.trim_start_matches("error: ")))
        }
        _ => Err(format!(
            "the demo program for {} should refuse with \"{reason}\" ({}): {stderr}",
            robot.display(),
            out.status
        )),
    }
}

/// The build-time variable that puts the drive layer in the demo's measured
/// step (`firmware::loopback::LAYER_IN_STEP`).
const LAYER_IN_STEP_VAR: &str = "CDPR_DEMO_CAN_LAYER";

/// The demo built with [`LAYER_IN_STEP_VAR`], judged as the demo is
/// ([`judge_demo`]) with `ceiling` (at most the [`BUDGET`]), on its step
/// (the layer's `read`, `set_brakes` and `apply` of eight drives inside,
/// frames looped back in memory: worst step, overruns, its own verdict) and
/// its stack; for every robot of [`TEST_ROBOTS`].
fn judge_layer_in_step(run: &Run, ceiling: u32) -> Result<String, String> {
    let [step, _, _, _, stack, _, _] = judge_demo(run, ceiling.min(BUDGET));
    let rest = finished(run).map_or_else(|| Err("no final report".to_string()), judge_rest);
    match (step, stack, rest) {
        (Ok(step), Ok(stack), Ok(rest)) => Ok(format!("{step}; stack {stack}; {rest}")),
        (step, stack, rest) => Err(format!(
            "{}; stack {}; {}",
            step.unwrap_or_else(|e| e),
            stack.unwrap_or_else(|e| e),
            rest.unwrap_or_else(|e| e)
        )),
    }
}

/// The step without its solve, worst over the demo's cycles, against the
/// rest the board's offer adds to each method's stated worst solve
/// ([`methods::STEP_REST`]): held by the demo and by the demo with the
/// drive layer inside (the board with CAN drives).
fn judge_rest(r: &Report) -> Result<String, String> {
    let rest = format!("the step without its solve at most {} (stated {})", r.rest_worst, methods::STEP_REST);
    if r.rest_worst > 0 && r.rest_worst <= methods::STEP_REST {
        Ok(rest)
    } else {
        Err(rest)
    }
}

/// The names of [`judge_demo`]'s checks, in its order.
const DEMO_CHECKS: [&str; 7] = [
    "control step within the regression ceiling, no overrun",
    "out-of-workspace poses give infeasible",
    "timer ticks convert to instructions",
    "safety states on the demo: enabled, holding, fault, disabled, enabled",
    "worst stack depth within its regression ceiling and the limit (stack painting)",
    "every method's measured worst solve, and the step without it, within the board's table (cdpr_demo::methods)",
    "receive work under a flood bounded (the interrupt a byte, the step a cycle)",
];

/// The demo run's final report against the bounds (`ceiling`: the worst
/// step's).
fn judge_demo(run: &Run, ceiling: u32) -> [Result<String, String>; 7] {
    match finished(run) {
        Some(r) => judge_report(r, run.code, ceiling),
        None => core::array::from_fn(|_| Err(format!("no final report; the firmware {}", explain(run.code)))),
    }
}

/// The run's final report, if it printed one.
fn finished(run: &Run) -> Option<&Report> {
    run.records.iter().find_map(|r| match r {
        Record::Finished(report) => Some(report),
        _ => None,
    })
}

/// The demo's report against the bounds; `code` is the process's exit code.
fn judge_report(r: &Report, code: Option<i32>, ceiling: u32) -> [Result<String, String>; 7] {
    let crashed = matches!(code, None | Some(1) | Some(exit::PANIC) | Some(exit::HARDFAULT));
    let s = r.step;
    let (e, fk) = (r.estimator, r.forward);
    let figures = format!(
        "min {} median {} max {} instructions over {} cycles, overruns {}; of it the estimator (one Gauss-Newton step of the forward kinematics) min {} median {} max {}; tension-core's forward kinematics replayed (warm, not in the step) median {} max {}",
        s.min, s.median, s.max, r.cycles, r.overruns, e.min, e.median, e.max, fk.median, fk.max
    );
    let verdict_ok = code == Some(exit::PASS) && r.exit_code == exit::PASS;
    let budget = if s.max <= BUDGET {
        format!("within the {BUDGET} budget")
    } else {
        format!("OVER the {BUDGET} budget")
    };
    let step = if s.max <= ceiling && r.overruns == 0 && r.cycles >= MIN_CYCLES && verdict_ok {
        Ok(format!("{figures}; {budget}; ceiling {ceiling}"))
    } else if !verdict_ok {
        Err(format!("{figures}; the firmware {}", explain(code)))
    } else {
        Err(format!("{figures}; ceiling {ceiling}, at least {MIN_CYCLES} cycles"))
    };
    let statuses = if r.infeasible > 0 && r.other_errors == 0 && !crashed {
        Ok(format!("{} infeasible cycles, no other error", r.infeasible))
    } else {
        Err(format!(
            "{} infeasible cycles, {} other errors; the firmware {}",
            r.infeasible,
            r.other_errors,
            explain(code)
        ))
    };
    let expected = u64::from(r.calibration_expected);
    let timer = format!(
        "the calibration loop took {} TIM2 ticks, {expected} expected (icount shift={})",
        r.calibration_ticks,
        cdpr_demo::qemu::ICOUNT_SHIFT
    );
    let within = u64::from(r.calibration_ticks).abs_diff(expected) * 100 <= expected;
    let timer = if r.calibration_exact && within { Ok(timer) } else { Err(timer) };
    let states = if r.states() == EXPECTED_STATES {
        Ok(format!("{:?}", r.states()))
    } else {
        Err(format!("{:?} (expected {EXPECTED_STATES:?})", r.states()))
    };
    let stack = format!(
        "{} bytes used of {}, regression ceiling {STACK_CEILING}, limit {STACK_LIMIT}",
        r.stack_used, r.stack_size
    );
    let stack = if r.stack_used <= STACK_CEILING.min(STACK_LIMIT) && r.stack_used < r.stack_size {
        Ok(stack)
    } else {
        Err(stack)
    };
    let receive = format!(
        "worst {} instructions for a cycle's {} frames of 0x00, 0xFF, random bytes or valid setpoints in the step (regression ceiling {RECEIVE_CEILING}; limit {RECEIVE_LIMIT}: with a step at the {BUDGET} budget, 3/4 of the {PERIOD_INSTRUCTIONS}-instruction period); the receive interrupt's framing at most {} a byte (limit {FRAMING_LIMIT})",
        r.receive_worst,
        cdpr_control::FRAME_BUDGET,
        r.framing_worst,
    );
    let receive = if r.receive_worst > 0
        && r.receive_worst <= RECEIVE_CEILING.min(RECEIVE_LIMIT)
        && r.framing_worst > 0
        && r.framing_worst <= FRAMING_LIMIT
    {
        Ok(receive)
    } else {
        Err(receive)
    };
    [step, statuses, timer, states, stack, judge_methods(r), receive]
}

/// Each method's measured worst solve against the table the board's offer
/// is derived from, and the rest of the step it adds them to
/// ([`judge_rest`]).
fn judge_methods(r: &Report) -> Result<String, String> {
    let rows: Vec<String> = tension_core::Method::ALL
        .iter()
        .zip(r.method_worst)
        .map(|(&m, measured)| {
            let offer = if methods::is_offered(m) { "offered" } else { "not offered" };
            format!("{} {measured} <= {} ({offer})", m.name(), methods::stated_worst(m))
        })
        .collect();
    let over: Vec<&str> = tension_core::Method::ALL
        .iter()
        .zip(r.method_worst)
        .filter(|&(&m, measured)| methods::exceeded(m, measured) || measured == 0)
        .map(|(m, _)| m.name())
        .collect();
    match (over.is_empty(), judge_rest(r)) {
        (true, Ok(rest)) => Ok(format!("{}; {rest}", rows.join(", "))),
        (true, Err(rest)) => Err(format!("{}; {rest}", rows.join(", "))),
        (false, rest) => Err(format!(
            "over the table (or not measured): {}; {}; {}",
            over.join(", "),
            rows.join(", "),
            rest.unwrap_or_else(|e| e)
        )),
    }
}

/// A fault-injection run: it exits with `code`, the drives commanded
/// torques before the fault and hold zero torque with the brakes on after.
fn judge_injection(run: &Run, code: i32) -> Result<String, String> {
    let before = run.records.iter().find_map(|r| match r {
        Record::Injecting { cycle, torques } => Some((*cycle, *torques)),
        _ => None,
    });
    let after = run.records.iter().find_map(|r| match r {
        Record::Stopped { torques, brakes } => Some((*torques, *brakes)),
        _ => None,
    });
    match (run.code, before, after) {
        (Some(c), Some((cycle, moving)), Some((stopped, brakes)))
            if c == code && moving.iter().any(|&t| t != 0.0) && stopped.iter().all(|&t| t == 0.0) && brakes =>
        {
            Ok(format!(
                "exit {c}; at cycle {cycle} the drives commanded {moving:?} N m, after the stop {stopped:?} N m, brakes engaged"
            ))
        }
        (c, before, after) => Err(format!(
            "exit {c:?} (expected {code}), before: {before:?}, after: {after:?}; the firmware {}",
            explain(c)
        )),
    }
}

/// The product for `robot`: its sizes (with `memory`), then the
/// end-to-end serial test.
fn product_checks(tally: &mut Tally, robot: &Path, memory: bool) {
    let name = label(robot);
    let built = build_product(robot);
    if !memory {
        if let Err(e) = built {
            tally.report(&titled(&name, "end-to-end: the product builds"), Err(e));
            return;
        }
    }
    let sizes = built.and_then(|()| {
        let s = crate::elf::sizes(&elf(PRODUCT))?;
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
        if s.flash() <= FLASH_BYTES && s.static_ram() + u64::from(STACK_LIMIT) <= RAM_BYTES && s.text > 0 {
            Ok(figures)
        } else {
            Err(format!("{figures}; static RAM plus the {STACK_LIMIT}-byte stack limit must fit"))
        }
    });
    if memory {
        tally.report(&titled(&name, "product firmware memory (.text, .data, .bss)"), sizes);
    }
    println!("==> end-to-end ({name}): the product firmware in QEMU, driven over its serial link");
    for (check, result) in crate::e2e::run(robot) {
        tally.report(&titled(&name, &format!("end-to-end: {check}")), result);
    }
}

/// Builds the product program (the serial link) for `robot`.
pub fn build_product(robot: &Path) -> Result<(), String> {
    build(PRODUCT, robot)
}

/// Builds a firmware program (release, for the QEMU board) for the robot
/// file `robot` (absolute: `CDPR_ROBOT` for the firmware's `build.rs`).
fn build(program: &str, robot: &Path) -> Result<(), String> {
    build_with(program, robot, &[])
}

/// [`build`] with more build-time variables (e.g. `CDPR_STRESS_POSES`).
fn build_with(program: &str, robot: &Path, env: &[(&str, &OsStr)]) -> Result<(), String> {
    println!("==> CDPR_ROBOT={}", robot.display());
    let mut vars = vec![("CDPR_ROBOT", robot.as_os_str())];
    vars.extend_from_slice(env);
    run_step_with(
        CARGO,
        &["build", "--release", "-p", "firmware", "--target", TARGET, "--bin", program],
        &vars,
    )
}

/// The stress program's name (`firmware/src/bin/stress.rs`).
const STRESS: &str = "stress";

/// Longest stress run: 100 000 poses of every method take about 7
/// minutes per robot under QEMU.
const STRESS_TIMEOUT: Duration = Duration::from_secs(1800);

/// The stress run (`cargo xtask stress`, and the test command's short
/// run): the stress program built for `robot` and `poses`, run under QEMU;
/// `Ok` with its verdict when it passes.
pub fn run_stress(robot: &Path, poses: u32) -> Result<String, String> {
    let poses_var = poses.to_string();
    let env = [("CDPR_STRESS_POSES", OsStr::new(&poses_var))];
    let run = run_firmware_with(STRESS, robot, false, &env, STRESS_TIMEOUT)?;
    match run.code {
        Some(exit::PASS) => {
            // The program judges the ceilings in the short run only.
            let ceilings = if poses <= cdpr_demo::stress::SHORT_RUN {
                "its regression ceiling (cdpr_demo::stress::CEILINGS) and "
            } else {
                ""
            };
            Ok(format!(
                "{poses} poses: every method within {ceilings}its stated worst (cdpr_demo::methods::COSTS, the board's offer table), the barycenter within its analytical bound"
            ))
        }
        code => Err(format!("the stress program {}", explain(code))),
    }
}

/// The ELF of a firmware program (release).
pub fn elf(program: &str) -> PathBuf {
    Path::new("target").join(TARGET).join("release").join(program)
}

/// `qemu-run`'s arguments before the ELF: the machine of [`cdpr_demo::qemu`]
/// and `-icount shift=N,align=off,sleep=...`. With `sleep` idle time passes
/// in real time (for a host on the serial link); without it QEMU skips it.
pub fn qemu_args(sleep: bool) -> Vec<String> {
    let icount = format!(
        "icount=shift={},align=off,sleep={}",
        cdpr_demo::qemu::ICOUNT_SHIFT,
        if sleep { "on" } else { "off" }
    );
    ["--machine", cdpr_demo::qemu::MACHINE, "--cpu", cdpr_demo::qemu::CPU, "--arg", &icount]
        .map(String::from)
        .to_vec()
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

/// A finished firmware run: its exit code and the records it logged.
struct Run {
    code: Option<i32>,
    records: Vec<Record>,
}

/// Builds a firmware program, then runs it in QEMU, echoing its readable
/// output; the records it logs are decoded and kept.
fn run_firmware(program: &str, robot: &Path, capture: bool) -> Result<Run, String> {
    run_firmware_with(program, robot, capture, &[], RUN_TIMEOUT)
}

/// [`run_firmware`] with more build-time variables and its own timeout.
fn run_firmware_with(
    program: &str,
    robot: &Path,
    capture: bool,
    env: &[(&str, &OsStr)],
    timeout: Duration,
) -> Result<Run, String> {
    if !Path::new("firmware/Cargo.toml").is_file() {
        return Err("run from the workspace root (firmware/Cargo.toml not found)".into());
    }
    build_with(program, robot, env)?;
    let args = qemu_args(false);
    println!("==> {QEMU_RUN} {} {}", args.join(" "), elf(program).display());
    let mut child = Command::new(QEMU_RUN)
        .args(&args)
        .arg(elf(program))
        .stdout(Stdio::piped())
        .process_group(0) // so that a timeout can stop qemu-run and QEMU together
        .spawn()
        .map_err(|e| format!("cannot run {QEMU_RUN}: {e}"))?;
    let out = child.stdout.take().ok_or("no stdout from qemu-run")?;
    let reader = thread::spawn(move || {
        let mut records = Vec::new();
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            match report::decode(&line) {
                // Encoded records are for this program, not for reading.
                Some(Ok(record)) if capture => records.push(record),
                Some(Ok(_)) => {}
                Some(Err(e)) => println!("{line} (undecodable record: {e:?})"),
                None => println!("{line}"),
            }
        }
        records
    });
    let code = wait_with_timeout(&mut child, timeout)?;
    let records = reader.join().map_err(|_| "the output reader panicked")?;
    Ok(Run { code, records })
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

/// What a firmware program's exit code says.
fn explain(code: Option<i32>) -> String {
    match code {
        Some(exit::PASS) => "exited with 0 (pass)".into(),
        Some(c) if (exit::FAIL..exit::FAIL * 2).contains(&c) => {
            let flags = c - exit::FAIL;
            let reasons: Vec<&str> =
                exit::fail::ALL.iter().filter(|(bit, _)| flags & bit != 0).map(|&(_, why)| why).collect();
            format!("exited with {c}: {}", reasons.join(", "))
        }
        Some(exit::PANIC) => format!("panicked (exit code {})", exit::PANIC),
        Some(exit::HARDFAULT) => format!("hit a HardFault (exit code {})", exit::HARDFAULT),
        Some(c) => format!("exited with {c} (runner or QEMU failure?)"),
        None => "was killed by a signal".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cdpr_control::protocol::State;
    use cdpr_control::CABLES;
    use cdpr_demo::report::{Spread, MAX_STATES};

    fn report() -> Report {
        let mut states = [State::Disabled; MAX_STATES];
        states[..EXPECTED_STATES.len()].copy_from_slice(&EXPECTED_STATES);
        Report {
            instructions: true,
            cycles: 4000,
            step: Spread { min: 9_454, median: 10_121, max: 13_415 },
            solver: Spread { min: 5_696, median: 5_775, max: 9_440 },
            overruns: 0,
            calibration_ticks: 160_000,
            calibration_expected: 160_000,
            calibration_exact: true,
            ok: 3651,
            infeasible: 349,
            other_errors: 0,
            states,
            state_count: EXPECTED_STATES.len() as u8,
            stack_used: 7912,
            stack_size: 77_780,
            exit_code: exit::PASS,
            method_worst: tension_core::Method::ALL.map(methods::stated_worst),
            receive_worst: 895,
            framing_worst: 300,
            estimator: Spread { min: 1_000, median: 1_200, max: 1_500 },
            forward: Spread { min: 3_000, median: 3_500, max: 90_000 },
            rest_worst: 4_700,
        }
    }

    /// The layer-in-step build is held to its ceiling (never above the
    /// budget), its overruns, its verdict and its stack.
    #[test]
    fn judges_the_step_with_the_drive_layer() {
        let run = |r: Report, code| Run { code: Some(code), records: vec![Record::Finished(r)] };
        let layer = Report { step: Spread { min: 13_107, median: 13_763, max: 17_448 }, ..report() };
        assert!(judge_layer_in_step(&run(layer, 0), LAYER_IN_STEP_CEILING).is_ok());
        let dearer = Report { step: Spread { max: LAYER_IN_STEP_CEILING + 1, ..layer.step }, ..report() };
        assert!(judge_layer_in_step(&run(dearer, 0), LAYER_IN_STEP_CEILING).is_err());
        assert!(judge_layer_in_step(&run(dearer, 0), BUDGET).is_ok());
        let over = Report { step: Spread { max: BUDGET + 1, ..layer.step }, ..report() };
        assert!(judge_layer_in_step(&run(over, 0), BUDGET).is_err());
        assert!(judge_layer_in_step(&run(over, 0), u32::MAX).is_err());
        let late = Report { overruns: 1, ..layer };
        assert!(judge_layer_in_step(&run(late, 0), BUDGET).is_err());
        let deep = Report { stack_used: STACK_LIMIT + 4, ..layer };
        assert!(judge_layer_in_step(&run(deep, 0), BUDGET).is_err());
        let deeper = Report { stack_used: STACK_CEILING + 4, ..layer };
        assert!(judge_layer_in_step(&run(deeper, 0), BUDGET).is_err());
        assert!(judge_layer_in_step(&run(layer, 33), BUDGET).is_err());
        // The step without its solve: over the stated rest, or not measured.
        let rest = Report { rest_worst: methods::STEP_REST, ..layer };
        assert!(judge_layer_in_step(&run(rest, 0), LAYER_IN_STEP_CEILING).is_ok());
        for rest_worst in [methods::STEP_REST + 1, 0] {
            let rest = Report { rest_worst, ..layer };
            assert!(judge_layer_in_step(&run(rest, 0), LAYER_IN_STEP_CEILING).is_err());
        }
        assert!(judge_layer_in_step(&Run { code: Some(0), records: Vec::new() }, BUDGET).is_err());
    }

    /// Every robot the test command runs has its own ceilings, each below
    /// the budget; a robot file it has no figures of gets the budget.
    #[test]
    fn every_test_robot_has_ceilings_below_the_budget() {
        for file in TEST_ROBOTS {
            let c = ceilings(Path::new(file));
            assert_ne!(c, Ceilings::BUDGET, "{file}");
            assert!(c.demo < BUDGET && c.layer_in_step < BUDGET && c.product < BUDGET, "{file}: {c:?}");
            // The demo's step is the layer's step without the layer.
            assert!(c.demo < c.layer_in_step, "{file}: {c:?}");
            if let Ok(absolute) = robot_path(file) {
                assert_eq!(ceilings(&absolute), c, "{file}");
            }
        }
        assert_eq!(TEST_CEILINGS.map(|(file, _)| file), TEST_ROBOTS);
        assert_eq!(ceilings(Path::new("robots/spatial6-10.toml")), Ceilings::BUDGET);
        assert_eq!(ceilings(Path::new("/tmp/my-robot.toml")), Ceilings::BUDGET);
        assert_eq!(ceilings(Path::new(DEFAULT_ROBOT)).demo, REGRESSION_CEILING);
    }

    #[test]
    fn judges_the_demo_report() {
        assert!(judge_report(&report(), Some(0), REGRESSION_CEILING).iter().all(|r| r.is_ok()));
        let slow = Report { step: Spread { max: REGRESSION_CEILING + 1, ..report().step }, ..report() };
        assert!(judge_report(&slow, Some(0), REGRESSION_CEILING)[0].is_err());
        assert!(judge_report(&slow, Some(0), BUDGET)[0].is_ok());
        let failed = Report { exit_code: exit::FAIL | exit::fail::BUDGET, ..report() };
        assert!(judge_report(&failed, Some(33), REGRESSION_CEILING)[0].is_err());
        let states = Report { state_count: 3, ..report() };
        assert!(judge_report(&states, Some(48), REGRESSION_CEILING)[3].is_err());
        let stack = Report { stack_used: 20_000, ..report() };
        assert!(judge_report(&stack, Some(0), REGRESSION_CEILING)[4].is_err());
        let mut slow_method = report();
        slow_method.method_worst[0] = methods::stated_worst(tension_core::Method::Barycenter) + 1;
        assert!(judge_report(&slow_method, Some(0), REGRESSION_CEILING)[5].is_err());
        let dear_rest = Report { rest_worst: methods::STEP_REST + 1, ..report() };
        assert!(judge_report(&dear_rest, Some(0), REGRESSION_CEILING)[5].is_err());
        let unmeasured_rest = Report { rest_worst: 0, ..report() };
        assert!(judge_report(&unmeasured_rest, Some(0), REGRESSION_CEILING)[5].is_err());
        let flooded = Report { receive_worst: 150_000, ..report() };
        assert!(judge_report(&flooded, Some(0), REGRESSION_CEILING)[6].is_err());
        let slower_receive = Report { receive_worst: RECEIVE_CEILING + 1, ..report() };
        assert!(judge_report(&slower_receive, Some(0), REGRESSION_CEILING)[6].is_err());
        let slow_interrupt = Report { framing_worst: FRAMING_LIMIT + 1, ..report() };
        assert!(judge_report(&slow_interrupt, Some(0), REGRESSION_CEILING)[6].is_err());
        let timer = Report { calibration_ticks: 170_000, ..report() };
        assert!(judge_report(&timer, Some(36), REGRESSION_CEILING)[2].is_err());
        assert!(judge_report(&report(), Some(exit::PANIC), REGRESSION_CEILING)[1].is_err());
        let none = Run { code: Some(101), records: vec![] };
        assert!(judge_demo(&none, REGRESSION_CEILING).iter().all(|r| r.is_err()));
    }

    #[test]
    fn judges_fault_injection() {
        let run = |code, after: [f32; CABLES], brakes| Run {
            code: Some(code),
            records: vec![
                Record::Injecting { cycle: 1000, torques: [0.1; CABLES] },
                Record::Stopped { torques: after, brakes },
            ],
        };
        let mut leak = [0.0; CABLES];
        leak[7] = 0.1;
        assert!(judge_injection(&run(101, [0.0; CABLES], true), exit::PANIC).is_ok());
        assert!(judge_injection(&run(102, [0.0; CABLES], true), exit::PANIC).is_err());
        assert!(judge_injection(&run(101, leak, true), exit::PANIC).is_err());
        assert!(judge_injection(&run(101, [0.0; CABLES], false), exit::PANIC).is_err());
    }

    #[test]
    fn explains_exit_codes() {
        assert!(explain(Some(33)).contains("over budget"));
        assert!(explain(Some(48)).contains("state sequence"));
        assert!(explain(Some(101)).contains("panicked"));
        assert_eq!(qemu_args(true).last().map(String::as_str), Some("icount=shift=3,align=off,sleep=on"));
    }
}
