//! The end-to-end test's stream with the user's tool: the product in QEMU
//! with its USART1 on a TCP port QEMU listens on (as `cargo xtask qemu`
//! runs it), driven by `cdpr stream`'s own session code
//! (`cdpr::stream::session`), its bytes paced to the board's 460 800 baud.
//!
//! The session checks the board's identity, homes, streams the demo
//! trajectory's feasible part as 100 Hz trajectory points into the
//! board's buffer, enables once the stream plays and disables at the end.
//! Every Enabled telemetry sample's tensions and torques are compared with
//! `tension-core` in `f64` at the setpoint the board played: the cubic
//! Hermite of the points at the sample's play time, computed here in `f64`
//! (independently of `cdpr_control::point_buffer`).

use std::net::TcpListener;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use cdpr::stream::session::{Ending, Observer, Options, Progress, Session, SessionError};
use cdpr::stream::transport::{self, Transport};
use cdpr_protocol::{Identity, Setpoint, State, Telemetry, TrajectoryPoint};

use crate::e2e::{host_robot, reference, Check, HostRobot};

/// Points every this many ms.
const POINT_PERIOD_MS: u32 = 10;
/// The stream's length, ms (the loop's first 1.5 s, before the excursion).
const STREAM_MS: u32 = 1500;

/// A QEMU running the product with USART1 on a TCP server port.
pub struct Qemu {
    child: Child,
    /// The port QEMU listens on.
    pub port: u16,
}

impl Qemu {
    /// Waits until QEMU exits.
    pub fn wait(&mut self) -> std::io::Result<std::process::ExitStatus> {
        self.child.wait()
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let group = format!("-{}", self.child.id());
        let _ = Command::new("kill").args(["-KILL", "--", &group]).status();
        let _ = self.child.wait();
    }
}

/// A free local TCP port.
fn free_port() -> Result<u16, String> {
    let l = TcpListener::bind("127.0.0.1:0").map_err(|e| format!("cannot find a free port: {e}"))?;
    l.local_addr().map(|a| a.port()).map_err(|e| e.to_string())
}

/// Starts the product (built already) in QEMU, real time (`sleep=on`), its
/// USART1 a TCP server on `port` (a free one if `None`); `log` prints the
/// firmware's output.
pub fn start_qemu(port: Option<u16>, log: bool) -> Result<Qemu, String> {
    use std::os::unix::process::CommandExt;
    let port = match port {
        Some(p) => p,
        None => free_port()?,
    };
    let mut child = Command::new(crate::firmware::QEMU_RUN)
        .args(crate::firmware::qemu_args(true))
        .args(["--arg", &format!("serial=tcp:127.0.0.1:{port},server=on,wait=off")])
        .arg(crate::firmware::elf(crate::firmware::PRODUCT))
        .stdout(if log { Stdio::inherit() } else { Stdio::null() })
        .process_group(0)
        .spawn()
        .map_err(|e| format!("cannot start qemu-run: {e}"))?;
    // Fails at once if QEMU cannot start.
    std::thread::sleep(Duration::from_millis(50));
    if let Ok(Some(status)) = child.try_wait() {
        return Err(format!("qemu-run exited at once: {status}"));
    }
    Ok(Qemu { child, port })
}

/// Connects to QEMU's port and waits until the firmware talks (USART1
/// drops what arrives before the firmware enables it).
fn connect(port: u16) -> Result<Box<dyn Transport>, String> {
    let address = format!("127.0.0.1:{port}");
    let start = Instant::now();
    let mut link = loop {
        match transport::tcp(&address, Duration::from_secs(1)) {
            Ok(link) => break link,
            Err(_) if start.elapsed() < Duration::from_secs(30) => {
                std::thread::sleep(Duration::from_millis(50))
            }
            Err(e) => return Err(format!("QEMU's serial port {address} did not accept within 30 s: {e}")),
        }
    };
    let mut buf = [0u8; 256];
    while start.elapsed() < Duration::from_secs(30) {
        if link.read_some(&mut buf).map_err(|e| e.to_string())? > 0 {
            return Ok(link);
        }
    }
    Err("no bytes from the firmware within 30 s of connecting".into())
}

/// The points: the demo loop's setpoints every 10 ms from 0 to 1.5 s.
fn points(host: &HostRobot) -> Vec<TrajectoryPoint> {
    (0..=STREAM_MS / POINT_PERIOD_MS)
        .map(|j| {
            let t = j * POINT_PERIOD_MS;
            let s = host.params.setpoint_at(t as f32 * 1e-3);
            TrajectoryPoint { time_ms: t, pose: s.pose.into(), velocity: s.velocity.into() }
        })
        .collect()
}

/// The cubic Hermite of `points` at `t_ms`, in `f64`: pose, velocity,
/// acceleration (as a protocol setpoint for [`reference`]).
fn hermite(points: &[TrajectoryPoint], t_ms: u32) -> Option<Setpoint> {
    let k = points.iter().rposition(|p| p.time_ms <= t_ms)?;
    let a = &points[k];
    let Some(b) = points.get(k + 1) else {
        return (a.time_ms == t_ms).then_some(Setpoint {
            seq: t_ms,
            pose: a.pose,
            velocity: a.velocity,
            acceleration: [0.0; 6],
        });
    };
    let h = f64::from(b.time_ms - a.time_ms) * 1e-3;
    let s = f64::from(t_ms - a.time_ms) * 1e-3 / h;
    let mut out = Setpoint { seq: t_ms, pose: [0.0; 6], velocity: [0.0; 6], acceleration: [0.0; 6] };
    for i in 0..6 {
        let (p0, v0, p1, v1) =
            (f64::from(a.pose[i]), f64::from(a.velocity[i]), f64::from(b.pose[i]), f64::from(b.velocity[i]));
        // p(s) = (2s^3 - 3s^2 + 1) p0 + (s^3 - 2s^2 + s) h v0 + (-2s^3 + 3s^2) p1 + (s^3 - s^2) h v1
        let p = (2.0 * s.powi(3) - 3.0 * s * s + 1.0) * p0
            + (s.powi(3) - 2.0 * s * s + s) * h * v0
            + (-2.0 * s.powi(3) + 3.0 * s * s) * p1
            + (s.powi(3) - s * s) * h * v1;
        let v = ((6.0 * s * s - 6.0 * s) * p0
            + (3.0 * s * s - 4.0 * s + 1.0) * h * v0
            + (-6.0 * s * s + 6.0 * s) * p1
            + (3.0 * s * s - 2.0 * s) * h * v1)
            / h;
        let acc = ((12.0 * s - 6.0) * p0
            + (6.0 * s - 4.0) * h * v0
            + (6.0 - 12.0 * s) * p1
            + (6.0 * s - 2.0) * h * v1)
            / (h * h);
        out.pose[i] = p as f32;
        out.velocity[i] = v as f32;
        out.acceleration[i] = acc as f32;
    }
    Some(out)
}

struct Collect(Vec<Telemetry>);

impl Observer for Collect {
    fn telemetry(&mut self, _: f64, t: &Telemetry, _: Progress) {
        self.0.push(*t);
    }
}

/// Sessions tried before the check fails (QEMU's timer stall: see
/// `e2e::SESSION_ATTEMPTS`); only a board that stops answering is retried.
const ATTEMPTS: usize = 20;

/// The check: `cdpr stream`'s session drives the product through the
/// demo trajectory at the board's line rate, and the board's tensions
/// match the host's `f64` for the setpoints it played.
pub fn run(robot: &Path) -> Check {
    let name = "cdpr stream's session: identity, home, 100 Hz points paced to 460 800 baud, enable, disable; tensions match the host's f64".to_string();
    let host = match host_robot(robot) {
        Ok(h) => h,
        Err(e) => return (name, Err(e)),
    };
    let id = host.identity.clone();
    let identity = Identity::new(&id.name, id.hash, 6, 8);
    let points = points(&host);
    let ceiling = crate::firmware::ceilings(robot).product;
    for attempt in 1..=ATTEMPTS {
        match attempt_once(&host, &identity, &points, ceiling) {
            Err(Retry(e)) if attempt < ATTEMPTS => {
                println!("==> end-to-end (cdpr stream): session {attempt} stalled ({e}); restarting QEMU");
            }
            Err(Retry(e)) => return (name, Err(format!("{e} ({ATTEMPTS} attempts)"))),
            Ok(result) => return (name, result),
        }
    }
    (name, Err("no attempt".into()))
}

/// A session that stalled (worth restarting QEMU).
struct Retry(String);

fn attempt_once(
    host: &HostRobot,
    identity: &Identity,
    points: &[TrajectoryPoint],
    ceiling: u32,
) -> Result<Result<String, String>, Retry> {
    let qemu = start_qemu(None, false).map_err(Retry)?;
    let link = connect(qemu.port).map_err(Retry)?;
    let mut session = Session::new(link, Options::DEFAULT);
    let mut seen = Collect(Vec::new());
    let started = Instant::now();
    let ending = match session.stream(points, identity, &mut seen, &AtomicBool::new(false)) {
        Ok(e) => e,
        Err(SessionError::Silent(d)) => {
            return Err(Retry(format!("no telemetry for {:.1} s", d.as_secs_f64())))
        }
        Err(e) => return Ok(Err(e.to_string())),
    };
    let took = started.elapsed().as_secs_f64();
    drop(qemu);
    if ending != Ending::Completed {
        return Ok(Err(format!("ended {ending:?}")));
    }
    let samples = &seen.0;
    let (mut compared, mut worst_t, mut worst_tau) = (0, 0.0f64, 0.0f64);
    for t in samples.iter().filter(|t| t.state == State::Enabled && t.solved) {
        let Some(setpoint) = hermite(points, t.setpoint_seq) else {
            return Ok(Err(format!("the board played {} ms, outside the stream", t.setpoint_seq)));
        };
        let (tensions, torques) = match reference(&host.robot, tension_core::Method::Barycenter, &setpoint) {
            Ok(r) => r,
            Err(e) => return Ok(Err(e)),
        };
        for i in 0..8 {
            worst_t = worst_t.max((f64::from(t.tensions[i]) - tensions[i]).abs());
            worst_tau = worst_tau.max((f64::from(t.torques[i]) - torques[i]).abs());
        }
        compared += 1;
    }
    let last = samples.last().copied();
    let rejected = last.map_or(0, |t| {
        let c = t.counters;
        c.rejected_order
            + c.rejected_range
            + c.rejected_jump
            + c.rejected_crc
            + c.rejected_framing
            + c.rejected_decode
    });
    let dry = samples
        .iter()
        .filter(|t| t.state == State::Enabled && t.setpoint_seq + 100 < STREAM_MS)
        .filter(|t| t.buffer_fill == 0)
        .count();
    let (tol_t, tol_tau) = (host.tolerances.tension, host.tolerances.torque);
    // The product's whole cycle (the frames' checks and decoding and the
    // step; the receive interrupt's time taken out,
    // `firmware::serial::TaskClock`) as the board reports it (the
    // costliest step between two samples), while a stream at the line's
    // rate plays: within the step budget and the product's ceiling.
    let mut costs: Vec<u32> = samples
        .iter()
        .filter(|t| matches!(t.state, State::Enabled | State::Holding))
        .map(|t| t.step_cost)
        .collect();
    costs.sort_unstable();
    let cost_max = costs.last().copied().unwrap_or(0);
    let cost_median = costs.get(costs.len() / 2).copied().unwrap_or(0);
    let figures = format!(
        "{} points in {took:.1} s; product step with decoding median {cost_median}, max {cost_max} instructions (budget {}, ceiling {ceiling}); {compared} Enabled samples compared: worst |t - t_host| {worst_t:.2e} N (tolerance {tol_t:.2e}), |tau - tau_host| {worst_tau:.2e} N m (tolerance {tol_tau:.2e}); buffer lead at most {} ms; {rejected} frames rejected",
        points.len(),
        cdpr_demo::BUDGET,
        samples.iter().map(|t| t.buffer_lead_ms).max().unwrap_or(0)
    );
    Ok(if compared < (STREAM_MS / 10 / 2) as usize {
        Err(format!("too few samples: {figures}"))
    } else if worst_t > tol_t || worst_tau > tol_tau || rejected > 0 || dry > 0 {
        Err(format!("{figures}; {dry} samples with the buffer dry mid-stream"))
    } else {
        match crate::e2e::within_ceiling(cost_max, ceiling) {
            Ok(()) => Ok(figures),
            Err(e) => Err(format!("{e}: {figures}")),
        }
    })
}
