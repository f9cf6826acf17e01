//! `cdpr`: tensions, trajectories and workspaces of cable robots from the
//! the conventions' robot files and pose tables. Exit code 0 on success, 2 for bad
//! input (one line on stderr naming the file, line and column), 1 when an
//! output file could not be written.

use std::path::PathBuf;
use std::process::ExitCode;

use cdpr::{profiles, solve, workspace, CliError};
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
    Solve {
        /// Robot description file (TOML).
        #[arg(long)]
        robot: PathBuf,
        /// barycenter, barycenter-brute, analytic-centre, closed-form, improved-closed-form,
        /// puncture, improved-puncture, min-2-norm, min-1-norm or optimally-safe.
        #[arg(long)]
        method: String,
        /// Pose table: [time,]pose columns[,extra wrench columns].
        #[arg(long)]
        poses: PathBuf,
        /// Tension table to write: [time,]t1,...,tm,status.
        #[arg(long)]
        out: PathBuf,
    },
    /// Tensions along a smooth trajectory through timed waypoints, with plots.
    Trajectory {
        /// Robot description file (TOML).
        #[arg(long)]
        robot: PathBuf,
        /// Waypoint table: time, then the pose columns.
        #[arg(long)]
        waypoints: PathBuf,
        /// Methods (repeat or separate by commas; default: every method that applies).
        #[arg(long = "method")]
        methods: Vec<String>,
        /// Sample rate in Hz.
        #[arg(long, default_value_t = 1000.0, allow_hyphen_values = true)]
        rate: f64,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Wrench-feasible workspace at a constant orientation on a grid.
    Workspace {
        /// Robot description file (TOML).
        #[arg(long)]
        robot: PathBuf,
        /// rx,ry,rz (spatial6) or theta (planar3), radians; default zero.
        #[arg(long, allow_hyphen_values = true)]
        orientation: Option<String>,
        /// Grid step in metres.
        #[arg(long, default_value_t = 0.05, allow_hyphen_values = true)]
        step: f64,
        /// Method (default: barycenter where it applies, else improved-closed-form).
        #[arg(long)]
        method: Option<String>,
        /// Payload sweep a:b:n, kg added to the platform mass.
        #[arg(long, allow_hyphen_values = true)]
        mass_sweep: Option<String>,
        /// Box x0:x1,y0:y1[,z0:z1] instead of the anchors' bounding box.
        #[arg(long, allow_hyphen_values = true)]
        bounds: Option<String>,
        /// Worker threads (default: every core).
        #[arg(long)]
        threads: Option<usize>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Every method on the same trajectory, side by side.
    Compare {
        /// Robot description file (TOML).
        #[arg(long)]
        robot: PathBuf,
        /// Waypoint table: time, then the pose columns.
        #[arg(long)]
        waypoints: PathBuf,
        /// Sample rate in Hz.
        #[arg(long, default_value_t = 1000.0, allow_hyphen_values = true)]
        rate: f64,
        /// CSV file to write the table to.
        #[arg(long, default_value = "compare.csv")]
        out: PathBuf,
    },
}

fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Solve { robot, method, poses, out } => {
            let report = solve::run(&solve::SolveArgs { robot, method, poses, out: out.clone() })?;
            println!("{report}; wrote {}", out.display());
        }
        Command::Trajectory { robot, waypoints, methods, rate, out } => {
            let report = profiles::run_trajectory(&profiles::TrajectoryArgs {
                robot,
                waypoints,
                methods,
                rate,
                out: out.clone(),
            })?;
            print!("{}", report.summary);
            println!("\nwrote {} files to {}", report.files.len(), out.display());
        }
        Command::Workspace { robot, orientation, step, method, mass_sweep, bounds, threads, out } => {
            let report = workspace::run(&workspace::WorkspaceArgs {
                robot,
                orientation,
                step,
                method,
                mass_sweep,
                bounds,
                threads,
                progress: true,
                out: out.clone(),
            })?;
            print!("{}", report.summary);
            println!("wrote {} files to {}", report.files.len(), out.display());
        }
        Command::Compare { robot, waypoints, rate, out } => {
            let report =
                profiles::run_compare(&profiles::CompareArgs { robot, waypoints, rate, out: out.clone() })?;
            print!("{}", report.table);
            println!("\nwrote {}", out.display());
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
