//! `cdpr stream`: operate a board from the host. Connects over a serial
//! port or TCP (the firmware in QEMU), checks the plan before anything is
//! sent, homes, enables, streams trajectory points into the board's buffer
//! (`cdpr_control::point_buffer`), shows one live status line, writes
//! every telemetry sample to a CSV, and disables at the end.
//!
//! Exit codes: 0 completed (or interrupted and disabled cleanly), 2 bad
//! input (nothing was sent), 1 the link or the board failed (a fault, a
//! refused request, a board that stopped answering).

pub mod plan;
pub mod session;
pub mod transport;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use cdpr_control::link::SetpointRange;
use cdpr_control::protocol::{Identity, Rejection, State, Telemetry};
use clap::Args;

use crate::CliError;
use plan::Plan;
use session::{Ending, Observer, Options, Progress, Session, SessionError};

/// `cdpr stream` arguments.
#[derive(Args, Debug, Clone)]
pub struct StreamArgs {
    /// Robot file the board was built for (6 DOF, 8 cables).
    #[arg(long)]
    pub robot: PathBuf,
    /// Timed pose table (`time`, then x,y,z,rx,ry,rz): one point per row.
    #[arg(long, conflicts_with = "waypoints", required_unless_present = "waypoints")]
    pub poses: Option<PathBuf>,
    /// Waypoints (`time`, then the pose) along the time law, sampled at `--rate`.
    #[arg(long)]
    pub waypoints: Option<PathBuf>,
    /// Points per second for `--waypoints`, Hz (4 to 1000, and what the link carries: about 600 at 460 800 baud).
    #[arg(long, default_value_t = 100.0)]
    pub rate: f64,
    /// Serial port of the board (e.g. /dev/ttyUSB0).
    #[arg(long, conflicts_with = "tcp", required_unless_present = "tcp")]
    pub port: Option<String>,
    /// Baud rate of the port (the firmware's: 460800); the host also paces
    /// its bytes to it over TCP.
    #[arg(long, default_value_t = 460_800)]
    pub baud: u32,
    /// TCP address of the firmware in QEMU (`cargo xtask qemu`), e.g. 127.0.0.1:4444.
    #[arg(long)]
    pub tcp: Option<String>,
    /// Write every telemetry sample to this CSV.
    #[arg(long)]
    pub telemetry: Option<PathBuf>,
    /// Feedback scheme: feed-forward, task or joint (default: the board's).
    #[arg(long)]
    pub feedback: Option<String>,
    /// How far ahead of the board's play time to keep points, ms.
    #[arg(long, default_value_t = 80)]
    pub lead: u32,
}

/// Telemetry samples to a CSV file (`--telemetry`).
pub struct TelemetryCsv {
    writer: csv::Writer<std::fs::File>,
    path: PathBuf,
    error: Option<CliError>,
}

/// The CSV's columns.
pub fn telemetry_header() -> Vec<String> {
    let mut h: Vec<String> =
        ["host_time", "cycle", "state", "reason", "hold_reason", "setpoint_seq", "solved"]
            .iter()
            .map(|s| s.to_string())
            .collect();
    h.extend((1..=8).map(|i| format!("t{i}")));
    h.extend((1..=8).map(|i| format!("tau{i}")));
    h.extend(
        [
            "brakes",
            "step_cost",
            "accepted",
            "rejected",
            "last_rejection",
            "dropped_bytes",
            "infeasible",
            "faults",
            "buffer_fill",
            "buffer_lead_ms",
            "homed",
            "residual",
            "feedback_scale",
            "unreadable_drive",
            "drive_fault_drive",
            "drive_fault_cause",
            "drive_fault_code",
            "overruns",
        ]
        .iter()
        .map(|s| s.to_string()),
    );
    h
}

/// Every rejection counter of the board, added up (wrapping).
pub fn rejected_total(c: &cdpr_control::protocol::Counters) -> u32 {
    [
        c.rejected_framing,
        c.rejected_crc,
        c.rejected_decode,
        c.rejected_order,
        c.rejected_range,
        c.rejected_state,
        c.rejected_jump,
        c.rejected_method,
    ]
    .iter()
    .fold(0u32, |a, &b| a.wrapping_add(b))
}

/// One sample as the CSV's row.
pub fn telemetry_row(host_time: f64, t: &Telemetry) -> Vec<String> {
    let c = &t.counters;
    let rejected = rejected_total(c);
    let mut r = vec![
        format!("{host_time:.4}"),
        t.cycle.to_string(),
        t.state.name().to_string(),
        t.reason.name().to_string(),
        t.hold_reason.name().to_string(),
        t.setpoint_seq.to_string(),
        u8::from(t.solved).to_string(),
    ];
    r.extend(t.tensions.iter().map(|x| format!("{x}")));
    r.extend(t.torques.iter().map(|x| format!("{x}")));
    r.extend([
        u8::from(t.brakes).to_string(),
        t.step_cost.to_string(),
        c.accepted.to_string(),
        rejected.to_string(),
        c.last_rejection.name().to_string(),
        c.dropped_bytes.to_string(),
        c.infeasible.to_string(),
        c.faults.to_string(),
        t.buffer_fill.to_string(),
        t.buffer_lead_ms.to_string(),
        u8::from(t.homed).to_string(),
        if t.residual.is_finite() { format!("{}", t.residual) } else { String::new() },
        t.feedback_scale.to_string(),
        t.unreadable_drive.map_or(String::new(), |d| d.to_string()),
        t.drive_fault.map_or(String::new(), |f| f.drive.to_string()),
        t.drive_fault.map_or(String::new(), |f| f.cause.name().to_string()),
        t.drive_fault.map_or(String::new(), |f| format!("{:#x}", f.code)),
        c.overruns.to_string(),
    ]);
    r
}

impl TelemetryCsv {
    /// Creates `path` with the header.
    pub fn create(path: &Path) -> Result<Self, CliError> {
        let file = std::fs::File::create(path).map_err(|e| CliError::io(path, &e))?;
        let mut writer = csv::Writer::from_writer(file);
        writer
            .write_record(telemetry_header())
            .map_err(|e| CliError::other(format!("{}: {e}", path.display())))?;
        Ok(Self { writer, path: path.to_path_buf(), error: None })
    }

    fn write(&mut self, host_time: f64, t: &Telemetry) {
        if self.error.is_none() {
            if let Err(e) = self.writer.write_record(telemetry_row(host_time, t)) {
                self.error = Some(CliError::other(format!("{}: {e}", self.path.display())));
            }
        }
    }

    /// Flushes; the first write error, if any.
    pub fn finish(mut self) -> Result<(), CliError> {
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        self.writer.flush().map_err(|e| CliError::io(&self.path, &e))
    }
}

/// The live status line and the CSV.
struct Watch<'a> {
    csv: Option<TelemetryCsv>,
    status: &'a mut dyn Write,
    shown: Option<Instant>,
    samples: usize,
    tensions: (f32, f32),
    playback: Playback,
}

impl Observer for Watch<'_> {
    fn telemetry(&mut self, host_time: f64, t: &Telemetry, progress: Progress) {
        self.samples += 1;
        self.playback.sample(t, progress.end_ms);
        if let Some(csv) = &mut self.csv {
            csv.write(host_time, t);
        }
        if t.solved {
            for &x in &t.tensions {
                self.tensions = (self.tensions.0.min(x), self.tensions.1.max(x));
            }
        }
        if self.shown.is_none_or(|s| s.elapsed() > Duration::from_millis(200)) {
            self.shown = Some(Instant::now());
            let (lo, hi) = if t.solved {
                t.tensions.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)))
            } else {
                (f32::NAN, f32::NAN)
            };
            let _ = write!(self.status, "\r{}", status_line(t, progress, lo, hi));
            let _ = self.status.flush();
        }
    }
}

/// The one status line: state, reason, progress, tensions, link counters.
pub fn status_line(t: &Telemetry, p: Progress, lo: f32, hi: f32) -> String {
    let c = &t.counters;
    let rejected = rejected_total(c);
    // A drive's fault names the drive (1-based, as the robot file's cables), the cause and its code.
    let reason = match t.drive_fault {
        Some(f) if t.reason == cdpr_control::protocol::Reason::Drive => {
            format!("drive {} {} {:#x}", u32::from(f.drive) + 1, f.cause.name(), f.code)
        }
        _ => t.reason.name().to_string(),
    };
    format!(
        "{:<8} {:<13} {:>6.2}/{:.2} s  points {}/{}  buffer {:>2} ({:>3} ms)  tensions {:.1}..{:.1} N  link: {} ok, {} rejected ({}), {} dropped",
        t.state.name(),
        reason,
        f64::from(p.played_ms) / 1000.0,
        f64::from(p.end_ms) / 1000.0,
        p.sent,
        p.total,
        t.buffer_fill,
        t.buffer_lead_ms,
        lo,
        hi,
        c.accepted,
        rejected,
        c.last_rejection.name(),
        c.dropped_bytes,
    )
}

/// How the board played a stream against its plan, from its telemetry:
/// * how long it waited for points: the control cycles of the Enabled
///   board beyond the play time they advanced (each cycle the buffer had
///   run dry, a feed hold, the play clock stood still), until the play
///   time reaches the last point. Zero when the link and the host keep
///   up: the board then plays one millisecond a cycle;
/// * the points it refused (late or out of order, its buffer full, out of
///   range, a jump: its counters `rejected_order`, `rejected_range` and
///   `rejected_jump`, which run on across sessions: a stream's are the
///   difference between its last and first samples), and the last
///   rejection. The board plays on without them;
/// * the control deadlines it missed (its counter `overruns`, over the
///   stream as the refusals): five in a row fault the robot.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Playback {
    /// The last Enabled sample's cycle and play time (ms).
    last: Option<(u32, u32)>,
    /// Cycles waited, ms.
    pub waited_ms: u64,
    /// Play time those samples covered, ms.
    pub played_ms: u64,
    /// The refusal counters' sum at the first sample.
    refusals_at_start: Option<u32>,
    /// Points the board refused during the stream.
    pub refused: u32,
    /// The last rejection the board reported.
    pub last_rejection: Rejection,
    /// The overrun counter at the first sample.
    overruns_at_start: Option<u32>,
    /// Control deadlines the board missed during the stream.
    pub overruns: u32,
}

impl Playback {
    /// Takes a telemetry sample of a stream whose last point is at
    /// `end_ms`.
    pub fn sample(&mut self, t: &Telemetry, end_ms: u32) {
        let c = &t.counters;
        let refusals = c.rejected_order.wrapping_add(c.rejected_range).wrapping_add(c.rejected_jump);
        self.refused = refusals.wrapping_sub(*self.refusals_at_start.get_or_insert(refusals));
        self.last_rejection = c.last_rejection;
        self.overruns = c.overruns.wrapping_sub(*self.overruns_at_start.get_or_insert(c.overruns));
        if t.state != State::Enabled {
            self.last = None;
            return;
        }
        let now = (t.cycle, t.setpoint_seq);
        if let Some((cycle, played)) = self.last {
            // An interval that reaches the last point ends in the stop the
            // play clock makes there, not a wait: left out.
            if now.1 < end_ms && now.0 > cycle && now.1 >= played {
                let (cycles, advanced) = (now.0 - cycle, now.1 - played);
                self.waited_ms += u64::from(cycles.saturating_sub(advanced));
                self.played_ms += u64::from(advanced);
            }
        }
        self.last = Some(now);
    }
}

/// What a finished stream reports.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// How it ended.
    pub ending: Ending,
    /// Telemetry samples received.
    pub samples: usize,
    /// Points sent.
    pub points: usize,
    /// Smallest and largest tension the board solved, N.
    pub tensions: (f32, f32),
    /// How the board played it: its waits for points, the points it
    /// refused.
    pub playback: Playback,
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} points sent, {} telemetry samples, tensions {:.2}..{:.2} N",
            match self.ending {
                Ending::Completed => "completed",
                Ending::Interrupted => "interrupted, disabled",
            },
            self.points,
            self.samples,
            self.tensions.0,
            self.tensions.1
        )?;
        let playback = &self.playback;
        if playback.refused > 0 {
            write!(
                f,
                "; the board refused {} points (last rejection: {}): the motion was played without them",
                playback.refused,
                playback.last_rejection.name()
            )?;
        }
        if playback.overruns > 0 {
            write!(
                f,
                "; the board missed {} control deadlines (its step or something beside it took longer than \
                 its period: five in a row fault it)",
                playback.overruns
            )?;
        }
        if playback.waited_ms > 0 {
            write!(
                f,
                "; the board waited {:.3} s for points while it played {:.3} s of the trajectory (the link or \
                 the host fell behind: the motion was slower than asked, with stops)",
                playback.waited_ms as f64 / 1000.0,
                playback.played_ms as f64 / 1000.0
            )?;
        }
        Ok(())
    }
}

/// The plan from the arguments, checked against the robot's setpoint
/// range: every input error before anything is sent.
pub fn plan(args: &StreamArgs) -> Result<(Plan, Identity), CliError> {
    let file = robot_file::RobotFile::load(&args.robot).map_err(|e| CliError::input(e.to_string()))?;
    let id = file.identity();
    let identity = Identity::new(&id.name, id.hash, 6, 8);
    let robot = file.to_robot::<f32, 6, 8>().map_err(|e| {
        CliError::input(format!("{}: {e} (the firmware runs 6 DOF x 8 cables)", args.robot.display()))
    })?;
    let (path, plan) = match (&args.poses, &args.waypoints) {
        (Some(p), _) => (p, Plan::from_pose_table(p)?),
        (None, Some(w)) => (w, Plan::from_waypoints(w, args.rate)?),
        (None, None) => return Err(CliError::input("give --poses or --waypoints")),
    };
    plan.check(path, &SetpointRange::for_robot(&robot))?;
    plan.check_link(path, args.baud)?;
    Ok((plan, identity))
}

/// The feedback scheme's wire number from its name.
pub fn feedback_id(name: &str) -> Result<u8, CliError> {
    match name {
        "feed-forward" => Ok(0),
        "task" => Ok(1),
        "joint" => Ok(2),
        other => Err(CliError::input(format!("--feedback {other}: expected feed-forward, task or joint"))),
    }
}

/// Runs `cdpr stream`; `status` gets the live line, `interrupt` is set by
/// Ctrl-C.
pub fn run(args: &StreamArgs, status: &mut dyn Write, interrupt: &AtomicBool) -> Result<Report, CliError> {
    let (plan, identity) = plan(args)?;
    let feedback = args.feedback.as_deref().map(feedback_id).transpose()?;
    if args.lead == 0 || args.lead > 250 {
        return Err(CliError::input(format!(
            "--lead {}: 1 to 250 ms (the board buffers 320 ms at 100 Hz)",
            args.lead
        )));
    }
    let csv = args.telemetry.as_deref().map(TelemetryCsv::create).transpose()?;
    let link = match (&args.port, &args.tcp) {
        (Some(port), _) => {
            transport::serial(port, args.baud).map_err(|e| CliError::input(format!("--port {port}: {e}")))?
        }
        (None, Some(address)) => transport::tcp(address, Duration::from_secs(2))
            .map_err(|e| CliError::input(format!("--tcp {address}: {e}")))?,
        (None, None) => return Err(CliError::input("give --port or --tcp")),
    };
    let options = Options { lead_ms: args.lead, feedback, baud: args.baud, ..Options::DEFAULT };
    let mut session = Session::new(link, options);
    let mut watch = Watch {
        csv,
        status,
        shown: None,
        samples: 0,
        tensions: (f32::INFINITY, f32::NEG_INFINITY),
        playback: Playback::default(),
    };
    let result = session.stream(&plan.points, &identity, &mut watch, interrupt);
    let _ = writeln!(watch.status);
    if let Some(csv) = watch.csv.take() {
        csv.finish()?;
    }
    let ending = result.map_err(|e: SessionError| CliError::other(e.to_string()))?;
    Ok(Report {
        ending,
        samples: watch.samples,
        points: plan.points.len(),
        tensions: watch.tensions,
        playback: watch.playback,
    })
}
