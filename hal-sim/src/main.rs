//! `hal-sim`: runs the closed-loop scenarios and writes their CSV tables
//! and plots.
//!
//! ```text
//! cargo run -p hal-sim --release -- --scenario NAME|all --out DIR [--robot FILE]
//! cargo run -p hal-sim --release -- --list [--robot FILE]
//! ```
//!
//! Without `--robot`, suspended-8 with the poses `hal-sim/README.md`'s
//! figures are for; with it, any 6-DOF, 8-cable robot file, its poses
//! derived from its workspace (`hal_sim::site`).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;

use hal_sim::output::{figures, write};
use hal_sim::{run, Config, Scenario, Site};

/// Runs the closed-loop scenarios and writes their CSV tables and plots.
#[derive(Debug, Parser)]
#[command(name = "hal-sim", version, about)]
struct Args {
    /// The scenario to run (`--list` names them), or `all`.
    #[arg(long, value_name = "NAME|all", required_unless_present = "list", requires = "out")]
    scenario: Option<String>,
    /// Directory for the CSV tables and the plots (created if missing).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Lists the scenarios with what each does, and exits.
    #[arg(long, conflicts_with_all = ["scenario", "out"])]
    list: bool,
    /// The robot file (6 DOF, 8 cables): the scenarios' poses are derived
    /// from its workspace. Default: suspended-8 with the README's poses.
    #[arg(long, value_name = "FILE")]
    robot: Option<PathBuf>,
}

/// `1.038` or `-`.
fn seconds(t: Option<f64>) -> String {
    t.map_or_else(|| "-".into(), |t| format!("{t:.3}"))
}

fn main() -> ExitCode {
    let args = Args::parse();
    let site = match &args.robot {
        None => Site::suspended_8(),
        Some(file) => match Site::derived(file) {
            Ok(site) => site,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(2);
            }
        },
    };
    let config = match Config::for_site(&site) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if args.list {
        for s in Scenario::all_at(&site) {
            println!("{:<24} {}", s.name, s.description);
        }
        return ExitCode::SUCCESS;
    }
    let (Some(name), Some(out)) = (args.scenario, args.out) else {
        // clap requires both unless `--list`.
        return ExitCode::from(2);
    };
    let scenarios = if name == "all" {
        Scenario::all_at(&site)
    } else {
        match Scenario::named_at(&site, &name) {
            Some(s) => vec![s],
            None => {
                let names: Vec<String> = Scenario::all_at(&site).into_iter().map(|s| s.name).collect();
                eprintln!("error: unknown scenario `{name}` (scenarios: {}, or all)", names.join(", "));
                return ExitCode::from(2);
            }
        }
    };
    for s in scenarios {
        // The drive and bus faults are the CAN buses' (`Config::can`).
        let config = if s.can_fault.is_some() { config.on_can_buses() } else { config };
        let outcome = match run(&s, &config) {
            Ok(o) => o,
            Err(e) => {
                eprintln!("{}: {e}", s.name);
                return ExitCode::FAILURE;
            }
        };
        let f = figures(&outcome, 0.0);
        let (csv, png) = match write(&outcome, &out) {
            Ok(p) => p,
            Err(e) => {
                eprintln!("{}: {e}", s.name);
                return ExitCode::FAILURE;
            }
        };
        println!("{}: {}", s.name, s.description);
        println!(
            "  up to the event: position error max {:.3} mm, rotation error max {:.4} deg, estimate off the true position by at most {:.3} mm, residual at most {:.3} mm, tensions {:.2}..{:.2} N (commanded {:.2}..{:.2} N)",
            f.position_error * 1e3,
            f.rotation_error.to_degrees(),
            f.estimate_error * 1e3,
            f.residual * 1e3,
            f.tension_min,
            f.tension_max,
            f.commanded.0,
            f.commanded.1
        );
        if s.event.is_some() {
            println!(
                "  after the event: displacement max {:.2} mm, drop max {:.2} mm, speed max {:.3} m/s, after the brakes held {:.3} m/s; fault at {} s, brakes held at {} s",
                f.displacement * 1e3,
                f.drop * 1e3,
                f.speed,
                f.speed_locked,
                seconds(f.fault_at),
                seconds(f.locked_at)
            );
        }
        for (t, state, reason, hold) in &outcome.transitions {
            println!("  {t:7.3} s: {} ({}, hold reason {})", state.name(), reason.name(), hold.name());
        }
        println!(
            "  control step on this host: mean {} ns, max {} ns; telemetry samples received {}; {} and {}",
            outcome.step_ns.0,
            outcome.step_ns.1,
            outcome.telemetry.len(),
            csv.display(),
            png.display()
        );
    }
    ExitCode::SUCCESS
}
