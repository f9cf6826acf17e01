//! `cdpr`: tensions, trajectories and workspaces of cable robots from the
//! the conventions' robot files and pose tables. Exit code 0 on success, 2 for bad
//! input (one line on stderr naming the file, line and column), 1 when an
//! output file could not be written.

use std::process::ExitCode;

use cdpr::{forward, profiles, solve, stream, workspace, CliError};
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "cdpr",
    version,
    about = "Cable robot tensions, trajectories and workspaces (conventions: robot files and CSV tables)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Tensions for every pose of a table: CSV in, CSV out (conventions: formats).
    Solve(solve::SolveArgs),
    /// Tensions along a smooth trajectory through timed waypoints, with plots.
    Trajectory(profiles::TrajectoryArgs),
    /// Wrench-feasible workspace at a constant orientation on a grid.
    Workspace(workspace::WorkspaceArgs),
    /// Every method on the same trajectory, side by side.
    Compare(profiles::CompareArgs),
    /// Poses from measured cable lengths (forward kinematics): CSV in, CSV out.
    Forward(forward::ForwardArgs),
    /// Operate a board: home, enable, stream a trajectory into its buffer, disable.
    Stream(stream::StreamArgs),
}

fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Solve(args) => {
            let report = solve::run(&args)?;
            println!("{report}; wrote {}", args.out.display());
        }
        Command::Trajectory(args) => {
            let report = profiles::run_trajectory(&args)?;
            print!("{}", report.summary);
            println!("\nwrote {} files to {}", report.files.len(), args.out.display());
        }
        Command::Workspace(args) => {
            let report = workspace::run(&args)?;
            print!("{}", report.summary);
            println!("wrote {} files to {}", report.files.len(), args.out.display());
        }
        Command::Forward(args) => {
            let report = forward::run(&args)?;
            println!("{report}; wrote {}", args.out.display());
        }
        Command::Stream(args) => {
            // Ctrl-C: Disable, wait for the ramp, then exit.
            static INTERRUPT: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
            let _ = ctrlc::set_handler(|| INTERRUPT.store(true, std::sync::atomic::Ordering::Relaxed));
            let report = stream::run(&args, &mut std::io::stderr(), &INTERRUPT)?;
            println!("{report}");
        }
        Command::Compare(args) => {
            let report = profiles::run_compare(&args)?;
            print!("{}", report.table);
            println!("\nwrote {}", args.out.display());
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                e.exit();
            }
            // A usage error: one line, like every other bad input.
            // clap's message is its first paragraph (e.g. a list of
            // missing arguments on the lines below the first).
            let text = e.to_string();
            let first: Vec<&str> = text.lines().take_while(|l| !l.trim().is_empty()).map(str::trim).collect();
            let first = first.join(" ");
            let first = first.strip_prefix("error: ").unwrap_or(&first);
            eprintln!("cdpr: error: {first} (see cdpr --help)");
            return ExitCode::from(2);
        }
    };
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("cdpr: error: {e}");
            ExitCode::from(e.exit_code() as u8)
        }
    }
}
