//! The end-to-end test: the product program (`firmware`) in QEMU,
//! its USART1 on a TCP socket this program listens on, driven like a host
//! would drive the board.
//!
//! QEMU runs with `-icount shift=3,align=off,sleep=on`: instructions still
//! take 8 ns of virtual time each, but idle time passes in real time, so
//! the firmware's 1 kHz loop and this program's stream share one clock
//! (with `sleep=off` the firmware's idle milliseconds would fly by and
//! every stream would look stale).
//!
//! The robot is the one the product was built for (`--robot FILE`,
//! suspended-8 by default); the trajectory is its demo trajectory, derived
//! from the file with the function the firmware's `build.rs` uses
//! (`cdpr_demo::derive`).
//!
//! Scenario (each step one check):
//! * `Identify` is answered with the robot file's identity (name and hash
//!   of the parsed content, `robot_file::RobotFile::identity`);
//! 0. `Enable` before homing is refused (`last_rejection` homing); `Home`
//!    with the trajectory's first pose (where the QEMU board's stand-in of
//!    the winches rests at reset) makes the board report `homed`;
//! 1. hold the trajectory's first pose at rest (100 setpoints, enabled
//!    during the hold), then stream the demo trajectory's feasible part
//!    (1200 setpoints, 2 ms apart: as fast as the serial link carries
//!    them, [`PACE`]), and compare every telemetry
//!    sample's tensions and torques with `tension-core` in `f64` on the
//!    host for the same setpoint (feed-forward, the board's default
//!    scheme), and the board's pose estimate from its encoders with the
//!    setpoint;
//! 2. a corrupted frame: counted as rejected, the state stays Enabled;
//! 3. NaN poses: Holding (bad setpoint), then Fault (held too long), torques
//!    ramped to zero with the brakes engaged; then ClearFault and Enable
//!    with good setpoints: Enabled again;
//! 4. a flood at many times the line rate while Enabled (junk between the
//!    setpoints: zero bytes, oversize runs of 0xFF, pseudo-random bytes,
//!    back-to-back duplicate setpoints; then one burst of 4 KiB): the
//!    receive work per cycle stays bounded (step cost below the period),
//!    the rejections are counted, the robot never faults;
//! 5. the stream stops: Holding (stale), then Fault;
//! 6. after ClearFault the host starts a new session: the poison
//!    frame (seq 0xFFFFFFFF, NaN x), numbering from 1 again, methods the
//!    board does not offer refused (`rejected_method`), `puncture`
//!    selected and compared with the host's f64 puncture;
//! 7. in a fresh QEMU, `cdpr stream`'s own session (`crate::e2e_stream`)
//!    drives the product at the board's line rate: identity, home, 100 Hz
//!    trajectory points into the buffer, enable, disable; tensions and
//!    torques against the host's f64 at the Hermite setpoint it played.

use std::{
    collections::HashMap,
    io::{BufRead, BufReader, Read, Write},
    net::{TcpListener, TcpStream},
    os::unix::process::CommandExt,
    path::Path,
    process::{Child, Command, Stdio},
    sync::{
        atomic::{AtomicU32, Ordering},
        Arc, Mutex,
    },
    thread,
    time::{Duration, Instant},
};

use cdpr_demo::trajectory::Params;
use cdpr_protocol::{
    encode, DeviceMessage, FrameDecoder, HostMessage, Identity, Reason, Rejection, Setpoint, State,
    Telemetry, MAX_FRAME,
};
use tension_core::nalgebra::SVector;
use tension_core::{Method, Robot, TensionSolver};

/// Stated tolerance of the firmware's f32 tensions against the host's f64
/// barycenter, as a fraction of `t_max - t_min` (345 N for suspended-8,
/// 9 N for ipanema1):
/// the f32 kinematics and solver round at about 1e-7 relative; the
/// host-side property test measured 3.7e-6 of the range on this robot.
pub const TENSION_TOLERANCE: f64 = 1e-4;

/// Telemetry every this many cycles: QEMU spends real time on every byte
/// the USART writes, and one sample per cycle (198 bytes at most since the
/// drive fault's field) slows its virtual clock below real time: every
/// 10th cycle is 19 bytes a cycle, less than the 22 of the 90-byte
/// samples every 4th cycle before.
const TELEMETRY_PERIOD: u16 = 10;

/// Setpoints at the trajectory's first pose, at rest, sent before the
/// tracking phase's stream: the board is enabled at rest, as an operator's
/// host would do it, and the held pose's step (IPAnema 1's dearest: 11 928
/// with no frame, 12 200-13 700 with one or two; issue 17, session 33) is
/// in the product's figures. Without the hold, the stream's first solve
/// met whichever setpoint the host's pace put first, with QEMU's
/// translation of the solver bunching the frames (seven to twenty a
/// 10-cycle sample):
/// IPAnema 1's worst went 12 691 to 16 993 from run to run; with it, 12 889
/// to 14 269 in twenty runs (two beside two CPU hogs, two clean-clone runs
/// of the test command), and 15 875 in a third clean-clone run: the first
/// solve (a cold start) with a burst of received bytes in its cycle, whose
/// interrupts QEMU's `-icount` miscounted by a few instructions each (up
/// to 1 518 in one step; session 34: the product's step now holds the
/// receive interrupt off under QEMU, `bsp::with_receive_held`, and
/// IPAnema 1's worst is 12 684 to 13 285, the departure from this hold).
const HELD_SETPOINTS: u32 = 100;

/// Setpoints streamed in the tracking phase (the trajectory's first 1.2 s,
/// all inside the workspace).
const TRACKING_SETPOINTS: u32 = 1200;

pub(crate) type Robot68 = Robot<f64, 6, 8>;

/// What the reader thread collected.
#[derive(Default)]
struct Received {
    telemetry: Vec<Telemetry>,
    identities: Vec<Identity>,
    rejected_frames: usize,
    /// Why the reader stopped, if it did before the session ended.
    reader_error: Option<String>,
    /// When the last telemetry sample arrived (real time).
    last_arrival: Option<Instant>,
    /// The longest real time between two telemetry samples, and the
    /// cycle of the sample that ended it.
    longest_gap: (Duration, u32),
}

struct Session {
    stream: TcpStream,
    received: Arc<Mutex<Received>>,
    qemu: Child,
    seq: u32,
    sent: HashMap<u32, Setpoint>,
    /// The demo trajectory of the robot the firmware is built for.
    params: Params,
    /// The host's clock of the stream being sent, held to the board's.
    pacer: Pacer,
    /// The largest stack high-water mark the firmware logged (bytes; it
    /// logs one at every state change).
    stack: Arc<AtomicU32>,
    /// The receive interrupt's entry and exit the firmware measured at
    /// start-up (instructions; `u32::MAX` until logged).
    entry_exit: Arc<AtomicU32>,
}

/// The host's clock of a stream, held to the board's: the host sends a
/// frame every [`PACE`] ms (of real time), but QEMU's virtual clock falls
/// behind real time when QEMU gets less than the CPU it needs (a loaded
/// 2-core machine: measured 4x slower in a CI run), and a stream paced by
/// real time alone then arrives 4x too fast for the board's clock (the
/// receive queue overflows, the stand-in of the winches trails far behind
/// the setpoint). [`Session::pace`] waits whenever the host's milliseconds
/// since [`Session::start_stream`] run more than [`PACE_LEAD`] ahead of
/// the board's cycles (from its telemetry), so that a slow QEMU sees the
/// same stream per cycle as a fast one.
#[derive(Clone, Copy, Default)]
struct Pacer {
    /// The board's last reported cycle when the stream started.
    anchor: u32,
    /// The host's milliseconds since then.
    host_ms: u32,
}

/// How far (ms) the host's stream may run ahead of the board's last
/// reported cycle: the telemetry's period (10 cycles) and its way back
/// over the link, with room to spare.
const PACE_LEAD: u32 = 25;

/// The longest the host waits for the board's clock in one
/// [`Session::pace`]; a board that falls behind by more has stalled.
const PACE_WAIT_LIMIT: Duration = Duration::from_secs(5);

/// A gap this long between two telemetry samples (sent every 10 cycles)
/// is QEMU's clock stalling, not the firmware: the session is restarted.
const STALL_GAP: Duration = Duration::from_secs(2);

impl Drop for Session {
    fn drop(&mut self) {
        let group = format!("-{}", self.qemu.id());
        let _ = Command::new("kill").args(["-KILL", "--", &group]).status();
        let _ = self.qemu.wait();
    }
}

impl Session {
    fn start(params: Params) -> Result<Self, String> {
        let listener = TcpListener::bind("127.0.0.1:0").map_err(|e| format!("cannot listen: {e}"))?;
        let port = listener.local_addr().map_err(|e| e.to_string())?.port();
        let mut qemu = Command::new(crate::firmware::QEMU_RUN)
            .args(crate::firmware::qemu_args(true))
            .args(["--arg", &format!("serial=tcp:127.0.0.1:{port}")])
            .arg(crate::firmware::elf(crate::firmware::PRODUCT))
            .stdout(Stdio::piped())
            .process_group(0)
            .spawn()
            .map_err(|e| format!("cannot start qemu-run: {e}"))?;
        // The firmware's own log, prefixed; its stack high-water marks kept.
        let stack = Arc::new(AtomicU32::new(0));
        let entry_exit = Arc::new(AtomicU32::new(u32::MAX));
        if let Some(out) = qemu.stdout.take() {
            let stack = Arc::clone(&stack);
            let entry_exit = Arc::clone(&entry_exit);
            thread::spawn(move || {
                for line in BufReader::new(out).lines().map_while(Result::ok) {
                    if let Some(bytes) = stack_mark(&line) {
                        stack.fetch_max(bytes, Ordering::Relaxed);
                    }
                    if let Some(instructions) = entry_exit_mark(&line) {
                        entry_exit.store(instructions, Ordering::Relaxed);
                    }
                    println!("    firmware| {line}");
                }
            });
        }
        listener.set_nonblocking(true).map_err(|e| e.to_string())?;
        let start = Instant::now();
        let stream = loop {
            match listener.accept() {
                Ok((s, _)) => break s,
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    if start.elapsed() > Duration::from_secs(30) {
                        return Err("QEMU did not connect its serial port within 30 s".into());
                    }
                    thread::sleep(Duration::from_millis(20));
                }
                Err(e) => return Err(format!("accept: {e}")),
            }
        };
        stream.set_nonblocking(false).map_err(|e| e.to_string())?;
        stream.set_nodelay(true).map_err(|e| e.to_string())?;
        let received = Arc::new(Mutex::new(Received::default()));
        let mut reader = stream.try_clone().map_err(|e| e.to_string())?;
        let sink = Arc::clone(&received);
        thread::spawn(move || {
            let mut decoder = FrameDecoder::new();
            let mut buf = [0u8; 4096];
            loop {
                let n = match reader.read(&mut buf) {
                    Ok(0) => break,
                    Ok(n) => n,
                    // A signal (e.g. a child's exit) interrupts the read; it
                    // is not the end of the link.
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                    Err(e) => {
                        sink.lock().unwrap().reader_error = Some(e.to_string());
                        break;
                    }
                };
                let mut got = sink.lock().unwrap();
                for &b in &buf[..n] {
                    match decoder.push::<DeviceMessage>(b) {
                        Some(Ok(DeviceMessage::Telemetry(t))) => {
                            let now = Instant::now();
                            if let Some(gap) = got.last_arrival.map(|then| now - then) {
                                if gap > got.longest_gap.0 {
                                    got.longest_gap = (gap, t.cycle);
                                }
                            }
                            got.last_arrival = Some(now);
                            got.telemetry.push(t);
                        }
                        Some(Ok(DeviceMessage::Identity(i))) => got.identities.push(i),
                        Some(Err(_)) => got.rejected_frames += 1,
                        None => {}
                    }
                }
            }
        });
        let session = Self {
            stream,
            received,
            qemu,
            seq: 0,
            sent: HashMap::new(),
            params,
            pacer: Pacer::default(),
            stack,
            entry_exit,
        };
        // USART1 drops what arrives before the firmware enables it: wait for
        // the first telemetry (sent every 10 cycles from start-up).
        if session.wait_for(0, Duration::from_secs(30), |_| true).is_none() {
            return Err("no telemetry from the firmware within 30 s of connecting".into());
        }
        Ok(session)
    }

    fn send(&mut self, message: &HostMessage) -> Result<(), String> {
        let mut frame = [0u8; MAX_FRAME];
        let n = encode(message, &mut frame).map_err(|e| format!("encode: {e:?}"))?;
        self.send_raw(&frame[..n])
    }

    fn send_raw(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.stream.write_all(bytes).map_err(|e| format!("serial link closed: {e}"))
    }

    /// Sends the trajectory's setpoint of cycle `k` with the next sequence
    /// number and remembers it.
    fn send_setpoint(&mut self, k: u32) -> Result<(), String> {
        self.send_numbered(self.params.setpoint(k).to_wire())
    }

    /// Sends `setpoint` with the next sequence number and remembers it.
    fn send_numbered(&mut self, setpoint: Setpoint) -> Result<(), String> {
        self.seq += 1;
        let wire = Setpoint { seq: self.seq, ..setpoint };
        self.sent.insert(self.seq, wire);
        self.send(&HostMessage::Setpoint(wire))
    }

    /// The board's last reported control cycle (0 before any telemetry).
    fn board_cycle(&self) -> u32 {
        self.latest().map_or(0, |t| t.cycle)
    }

    /// Starts a stream: [`Session::pace`] counts the host's milliseconds
    /// from here, against the board's cycles from its last report.
    fn start_stream(&mut self) {
        self.pacer = Pacer { anchor: self.board_cycle(), host_ms: 0 };
    }

    /// Waits `ms` milliseconds of real time, and then for as long as the
    /// board's clock is more than [`PACE_LEAD`] cycles behind the host's
    /// stream (at most [`PACE_WAIT_LIMIT`]; a board that far behind has
    /// stalled, which the session's gap check reports).
    fn pace(&mut self, ms: u32) {
        thread::sleep(Duration::from_millis(u64::from(ms)));
        self.pacer.host_ms += ms;
        let due = (self.pacer.anchor + self.pacer.host_ms).saturating_sub(PACE_LEAD);
        let start = Instant::now();
        while self.board_cycle() < due && start.elapsed() < PACE_WAIT_LIMIT {
            thread::sleep(Duration::from_millis(1));
        }
    }

    /// An error if QEMU's clock stalled during the session (a gap of
    /// [`STALL_GAP`] or more between two telemetry samples).
    fn stalled(&self) -> Result<(), String> {
        let (gap, cycle) = self.received.lock().unwrap().longest_gap;
        if gap >= STALL_GAP {
            Err(format!("no telemetry for {:.1} s before cycle {cycle}", gap.as_secs_f64()))
        } else {
            Ok(())
        }
    }

    fn telemetry_count(&self) -> usize {
        self.received.lock().unwrap().telemetry.len()
    }

    /// The last telemetry sample received, if any.
    fn latest(&self) -> Option<Telemetry> {
        self.received.lock().unwrap().telemetry.last().copied()
    }

    /// How many samples after `from` satisfy `pred`, so far.
    fn count_since(&self, from: usize, pred: impl Fn(&Telemetry) -> bool) -> usize {
        self.received
            .lock()
            .unwrap()
            .telemetry
            .get(from..)
            .map_or(0, |t| t.iter().filter(|t| pred(t)).count())
    }

    fn telemetry_since(&self, from: usize) -> Vec<Telemetry> {
        self.received.lock().unwrap().telemetry[from..].to_vec()
    }

    /// Waits until the firmware has reported the last setpoint sent.
    fn caught_up(&self, from: usize) -> Option<Telemetry> {
        let seq = self.seq;
        self.wait_for(from, Duration::from_secs(10), |t| t.setpoint_seq == seq)
    }

    /// The first sample after `from` that satisfies `pred`, so far.
    fn find_since(&self, from: usize, pred: impl Fn(&Telemetry) -> bool) -> Option<Telemetry> {
        self.received.lock().unwrap().telemetry.get(from..)?.iter().find(|t| pred(t)).copied()
    }

    /// Waits (real time) until a sample after `from` satisfies `until`.
    fn wait_for(
        &self,
        from: usize,
        timeout: Duration,
        until: impl Fn(&Telemetry) -> bool,
    ) -> Option<Telemetry> {
        let start = Instant::now();
        while start.elapsed() < timeout {
            if let Some(t) = self.find_since(from, &until) {
                return Some(t);
            }
            thread::sleep(Duration::from_millis(5));
        }
        None
    }
}

/// The host's reference: `f64` barycenter tensions and conventions motor torques
/// for a setpoint, from the robot file.
pub(crate) fn reference(
    robot: &Robot68,
    method: Method,
    s: &Setpoint,
) -> Result<([f64; 8], [f64; 8]), String> {
    let v = |a: &[f32; 6]| SVector::<f64, 6>::from_fn(|i, _| f64::from(a[i]));
    let (w, f) = robot
        .wrench_problem(&v(&s.pose), &SVector::zeros(), Some((&v(&s.velocity), &v(&s.acceleration))))
        .map_err(|e| format!("host kinematics: {}", e.status()))?;
    let solution = TensionSolver::<f64, 8>::new(method)
        .solve(&w, &f, robot.limits())
        .map_err(|e| format!("host barycenter: {}", e.status()))?;
    let winch = robot.winch().ok_or("no winch in the robot file")?;
    let tensions: [f64; 8] = core::array::from_fn(|i| solution.tensions[i]);
    let mut torques = [0.0; 8];
    for (t, &tension) in torques.iter_mut().zip(&tensions) {
        *t = winch.motor_torque(tension).map_err(|e| e.status().to_string())?.torque;
    }
    Ok((tensions, torques))
}

/// The firmware's tensions and torques against the host's f64 `method`
/// for the same setpoints, over the `samples` that `used` selects.
struct Comparison {
    samples: usize,
    worst_tension: f64,
    worst_torque: f64,
}

fn compare(
    robot: &Robot68,
    method: Method,
    sent: &HashMap<u32, Setpoint>,
    samples: &[Telemetry],
    used: impl Fn(&Telemetry) -> bool,
) -> Result<Comparison, String> {
    let mut c = Comparison { samples: 0, worst_tension: 0.0, worst_torque: 0.0 };
    for t in samples.iter().filter(|t| used(t)) {
        let sent = sent
            .get(&t.setpoint_seq)
            .ok_or_else(|| format!("telemetry names setpoint {} that was never sent", t.setpoint_seq))?;
        let (tensions, torques) = reference(robot, method, sent)?;
        for i in 0..8 {
            c.worst_tension = c.worst_tension.max((f64::from(t.tensions[i]) - tensions[i]).abs());
            c.worst_torque = c.worst_torque.max((f64::from(t.torques[i]) - torques[i]).abs());
        }
        c.samples += 1;
    }
    Ok(c)
}

/// The tracking phase's verdict: enough samples compared, every error within
/// its tolerance, no frame rejected; the figures, with the step cost the
/// telemetry reports, whose worst is held to `ceiling` (at most the
/// budget, for every robot the test command runs).
fn judge_tracking(
    c: Comparison,
    samples: &[Telemetry],
    last: Option<Telemetry>,
    tolerances: (f64, f64),
    ceiling: u32,
) -> Result<String, String> {
    let (tension_tol, torque_tol) = tolerances;
    let Comparison { samples: compared, worst_tension, worst_torque } = c;
    let enabled = samples.iter().filter(|t| t.state == State::Enabled).count();
    if compared < (TRACKING_SETPOINTS / u32::from(TELEMETRY_PERIOD) / 4) as usize {
        Err(format!(
            "only {compared} enabled samples with a solution out of {} telemetry samples",
            samples.len()
        ))
    } else if worst_tension > tension_tol || worst_torque > torque_tol {
        Err(format!(
            "worst tension error {worst_tension:.3e} N (tolerance {tension_tol:.3e}), torque {worst_torque:.3e} N m (tolerance {torque_tol:.3e})"
        ))
    } else if last.is_some_and(|t| {
        t.counters.rejected_crc
            + t.counters.rejected_framing
            + t.counters.rejected_decode
            + t.counters.rejected_range
            + t.counters.rejected_order
            > 0
    }) {
        Err(format!("frames rejected during a clean stream: {:?}", last.map(|t| t.counters)))
    } else {
        let mut costs: Vec<u32> = samples.iter().map(|t| t.step_cost).filter(|&c| c > 0).collect();
        costs.sort_unstable();
        let cost = |q: usize| costs.get(q * costs.len().saturating_sub(1) / 100).copied().unwrap_or(0);
        // Where the worst was: the cycle of the sample that reported it
        // (the worst of the ten cycles before it) and its setpoint.
        let worst_at = samples
            .iter()
            .max_by_key(|t| t.step_cost)
            .map_or(String::new(), |t| format!(" (cycle {}, setpoint {})", t.cycle, t.setpoint_seq));
        let figures = format!(
            "step cost with frame decoding (telemetry): median {} max {}{worst_at} instructions (budget {}, ceiling {ceiling}); {compared} samples compared ({enabled} enabled of {} received); worst |t - t_host| {worst_tension:.2e} N, |tau - tau_host| {worst_torque:.2e} N m (tolerances {tension_tol:.2e} N = {TENSION_TOLERANCE:e} of the range, {torque_tol:.2e} N m)",
            cost(50),
            cost(100),
            cdpr_demo::BUDGET,
            samples.len()
        );
        // The product's step (the setpoint frames received and decoded in
        // it) is held to the budget and its ceiling as the demo's is
        // (issue 17).
        match costs.last() {
            None => Err(format!("{figures}: no step cost reported")),
            Some(&worst) => match within_ceiling(worst, ceiling) {
                Ok(()) => Ok(figures),
                Err(e) => Err(format!("{figures}: {e}")),
            },
        }
    }
}

/// The product's worst step against the budget and `ceiling`.
pub(crate) fn within_ceiling(worst: u32, ceiling: u32) -> Result<(), String> {
    if worst > cdpr_demo::BUDGET {
        Err("the product's worst step is over the budget".into())
    } else if worst > ceiling {
        Err(format!("the product's worst step is over its regression ceiling {ceiling}"))
    } else {
        Ok(())
    }
}

/// Runs the scenario; each entry is one check's name and outcome.
/// `robot` is the robot file the product was built for (absolute).
pub fn run(robot: &Path) -> Vec<Check> {
    let mut stalls = Vec::new();
    for attempt in 1..=SESSION_ATTEMPTS {
        let mut results = Vec::new();
        match scenario(robot, &mut results) {
            Ok(()) => {
                if !stalls.is_empty() {
                    // Printed, not counted: a restart is no check that passed.
                    println!(
                        "==> end-to-end: {} of {attempt} QEMU sessions stalled and were restarted",
                        stalls.len()
                    );
                }
                results.push(crate::e2e_stream::run(robot));
                return results;
            }
            Err(e) if attempt < SESSION_ATTEMPTS => {
                println!("==> end-to-end: session {attempt} stalled ({e}); restarting QEMU");
                stalls.push(e);
            }
            Err(e) => {
                results.push((format!("end-to-end session ({SESSION_ATTEMPTS} attempts)"), Err(e)));
                return results;
            }
        }
    }
    Vec::new()
}

/// Sessions tried before the end-to-end test fails. A session stops short
/// (a phase's wait for telemetry times out) when QEMU 7.2's STM32 timer
/// model, under `-icount ... sleep=on`, lets TIM5's count run past `ARR`
/// after an update it handled late: the next update, and with it the next
/// control cycle, comes only when the 32-bit count wraps, 4.3 s later
/// (diagnosed with gdb on a stalled session: the core idle in `wfi`, TIM5
/// enabled with its interrupt unmasked and nothing pending, `CNT` at 9e8
/// with `ARR` at 999 999), and the receive queue overflows meanwhile. How
/// often depends on how much real time QEMU spends per virtual millisecond:
/// about half the sessions before the closed loop, 7 of 8 to 10 of 11 since
/// (the step's estimator and feedback, the QEMU stand-in of the encoders:
/// measured on the idle 2-core machine at the merge of issue 13 and after
/// it; with another build running, 12 of 12). A stalled session costs
/// about 15 s; 40 attempts leave about 0.6 % of runs failing at a 7-in-8
/// stall rate. Rewriting `CNT` from the idle loop when it is past `ARR` did
/// not lower the rate (tried, reverted). A check that fails is not
/// retried: only a session that stops, or one whose telemetry stopped for
/// [`STALL_GAP`] or more (a stall that a phase's waits outlasted: the
/// checks after it saw the receive queue overflow, as in a CI run of
/// session 7 that failed five checks on a loaded machine). Measured again with the derived
/// trajectories of issue 15 (idle 2-core machine, `cargo xtask e2e` run
/// back to back, and in one `cargo xtask test`): suspended-8 5 stalled
/// sessions of 13, ipanema1 1 of 9 (6 of 22, 27 %), none in the
/// `cargo xtask test` run.
const SESSION_ATTEMPTS: usize = 40;

/// One check's name and outcome.
pub(crate) type Check = (String, Result<String, String>);

/// The host's tolerances on the firmware's tensions, N, and torques, N m.
#[derive(Clone, Copy)]
pub(crate) struct Tolerances {
    pub(crate) tension: f64,
    pub(crate) torque: f64,
}

/// What the host knows of the firmware's robot: the robot in `f64`, the
/// tolerances for it, its identity and its demo trajectory.
pub(crate) struct HostRobot {
    pub(crate) robot: Robot68,
    pub(crate) tolerances: Tolerances,
    pub(crate) identity: robot_file::RobotIdentity,
    pub(crate) params: Params,
}

/// The robot file's robot in `f64`, the tolerances for it, its identity
/// and its demo trajectory (derived as the firmware's `build.rs` does,
/// with the same function).
pub(crate) fn host_robot(file: &Path) -> Result<HostRobot, String> {
    let shown = file.display();
    let parsed = robot_file::RobotFile::load(file).map_err(|e| format!("{shown}: {e}"))?;
    let robot = parsed.to_robot::<f64, 6, 8>().map_err(|e| format!("{shown}: {e}"))?;
    let params =
        cdpr_demo::derive::derive(&robot).map_err(|e| format!("{shown}: demo trajectory: {e}"))?.params;
    // The stretches streamed before the excursion must be feasible.
    let streamed = f64::from(TRACKING_SETPOINTS + 40 + FLOOD_SETPOINTS + 100) / 1000.0;
    if f64::from(params.excursion_start) <= streamed {
        return Err(format!(
            "the excursion starts at {} s, within the {streamed} s streamed",
            params.excursion_start
        ));
    }
    let range = robot.limits().max()[0] - robot.limits().min()[0];
    let winch = *robot.winch().ok_or("no winch")?;
    let tension = TENSION_TOLERANCE * range;
    let torque = tension * winch.drum_radius / (winch.gear_ratio * winch.efficiency);
    Ok(HostRobot { robot, tolerances: Tolerances { tension, torque }, identity: parsed.identity(), params })
}

/// The phases in order; the tracking comparison is computed last (the
/// stream must not pause while the host solves, or it would go stale) but
/// reported first.
fn scenario(file: &Path, results: &mut Vec<Check>) -> Result<(), String> {
    let HostRobot { robot, tolerances, identity, params } = host_robot(file)?;
    let mut s = Session::start(params)?;
    results.push(identify(&mut s, &identity)?);
    results.push(homing(&mut s)?);
    let tracking = track(&mut s)?;
    let last = tracking.last().copied();
    results.push(corrupted_frame(&mut s, last)?);
    let nan_start = s.telemetry_count();
    results.push(nan_poses(&mut s, nan_start)?);
    results.push(ramp_and_recover(&mut s, nan_start)?);
    results.push(flood(&mut s, crate::firmware::ceilings(file).product)?);
    let stop_start = s.telemetry_count();
    results.push(stream_stops(&s, stop_start));
    // The next phase renumbers from 1: keep what the tracking phase sent.
    let tracking_sent = s.sent.clone();
    results.push(method_over_the_link(&mut s, &robot, stop_start, tolerances)?);

    let tracked = compare(&robot, Method::Barycenter, &tracking_sent, &tracking, |t| {
        t.state == State::Enabled && t.solved
    });
    let check = match tracked {
        Err(e) => Err(e),
        Ok(c) => judge_tracking(
            c,
            &tracking,
            last,
            (tolerances.tension, tolerances.torque),
            crate::firmware::ceilings(file).product,
        ),
    };
    results.insert(
        2,
        (
            "streamed trajectory: tensions and torques match the host's f64, the step within its ceiling and the budget"
                .into(),
            check,
        ),
    );
    results.insert(3, estimates(&tracking_sent, &tracking));

    results.push(deadlines(&s));
    results.push(product_stack(s.stack.load(Ordering::Relaxed)));
    results.push(interrupt_entry_exit(s.entry_exit.load(Ordering::Relaxed)));

    // A session whose QEMU stalled is restarted whatever its checks said:
    // its timings are not the firmware's.
    s.stalled()?;
    let garbage = s.received.lock().unwrap().rejected_frames;
    if garbage > 0 {
        results.push(("telemetry frames decode on the host".into(), Err(format!("{garbage} bad frames"))));
    }
    Ok(())
}

/// The number that follows `marker` in a firmware log line.
fn logged_number(line: &str, marker: &str) -> Option<u32> {
    let rest = line.split(marker).nth(1)?;
    rest.split(' ').next()?.parse().ok()
}

/// The bytes of a firmware log line's "stack high-water mark N bytes".
fn stack_mark(line: &str) -> Option<u32> {
    logged_number(line, "stack high-water mark ")
}

/// The instructions of a firmware log line's "the receive interrupt's
/// entry and exit: N instructions".
fn entry_exit_mark(line: &str) -> Option<u32> {
    logged_number(line, "the receive interrupt's entry and exit: ")
}

/// The receive interrupt's cost outside its measured body (exception entry
/// and exit, the handler's prologue and epilogue), which the product
/// measures at start-up and takes out of each step's reported cost with
/// every interrupt that fell within the step (without it, a QEMU backlog
/// landing in one step put a stream's step at 21 405 in a loaded run, over
/// the budget; with it, the stream's first steps reported 13 400-15 300 in
/// six runs with QEMU stopped on purpose for 30-200 ms at a time): present, and
/// within what those few instructions can cost. Zero (every trial
/// interrupted by a byte) would only overstate the step; a figure above
/// the bound would hide the step's own work behind a burst.
fn interrupt_entry_exit(instructions: u32) -> Check {
    const MOST: u32 = 64;
    let name = "the receive interrupt's entry and exit, taken out of the step's cost, measured at start-up";
    let check = match instructions {
        u32::MAX => Err("the firmware logged no measurement".into()),
        n if (1..=MOST).contains(&n) => Ok(format!("{n} instructions an interrupt (at most {MOST})")),
        n => Err(format!("{n} instructions an interrupt (expected 1 to {MOST})")),
    };
    (name.into(), check)
}

/// The product's deepest stack over the whole session (its log's marks)
/// within the limit the demo is held to: the memory check reserves that
/// much beside the static RAM.
fn product_stack(used: u32) -> Check {
    let (ceiling, limit) = (crate::firmware::PRODUCT_STACK_CEILING, crate::firmware::STACK_LIMIT);
    let figures = format!(
        "the product's stack high-water mark {used} bytes (regression ceiling {ceiling}, limit {limit})"
    );
    let check = if used > 0 && used <= ceiling.min(limit) { Ok(figures) } else { Err(figures) };
    ("the product's stack stays within the limit (stack painting)".into(), check)
}

/// Largest distance (m) of the board's pose estimate from the setpoint
/// it reports while Enabled: the QEMU stand-in of the winches follows the
/// setpoints with a 5 ms lag, so at the trajectory's 1.4 m/s it trails by
/// 7 mm; 20 mm is the length check's limit.
const ESTIMATE_TOLERANCE: f64 = 0.02;

/// The tracking phase's estimates: homed, a residual, and the estimated
/// position near the setpoint's in every Enabled sample.
fn estimates(sent: &HashMap<u32, Setpoint>, samples: &[Telemetry]) -> Check {
    let mut worst = 0.0f64;
    let mut residual = 0.0f64;
    let mut n = 0;
    let mut bad = None;
    for t in samples.iter().filter(|t| t.state == State::Enabled) {
        let Some(sp) = sent.get(&t.setpoint_seq) else { continue };
        if !t.homed || !t.residual.is_finite() {
            bad = Some(*t);
            break;
        }
        let d = (0..3).map(|k| f64::from(t.estimate[k] - sp.pose[k]).powi(2)).sum::<f64>().sqrt();
        worst = worst.max(d);
        residual = residual.max(f64::from(t.residual));
        n += 1;
    }
    let figures = format!(
        "{n} Enabled samples: estimated position within {:.2} mm of the setpoint (tolerance {:.0} mm: the stand-in lags 5 ms), worst residual {:.1} um",
        worst * 1e3,
        ESTIMATE_TOLERANCE * 1e3,
        residual * 1e6
    );
    (
        "the board's pose estimate from its encoders follows the stream".into(),
        match bad {
            Some(t) => Err(format!("sample without an estimate: {t:?}")),
            None if n < 20 || worst > ESTIMATE_TOLERANCE => Err(figures),
            None => Ok(figures),
        },
    )
}

/// The pause between two setpoints of a stream, ms ([`Session::pace`]):
/// as fast as the board's serial link carries them. A setpoint frame
/// (about 80 bytes, 10 bits each on the line) takes 1.7 ms at the board's
/// 460 800 baud. Until session 36 the host sent one a millisecond, twice
/// what the line carries, and the frames queued behind the line without
/// bound (the board read setpoint 138 when the host had sent 310, and a
/// request sent after a setpoint waited as long): a stream no host can
/// send over the real link. (`cdpr stream` sends trajectory points at
/// 100 Hz and the board interpolates; this raw stream is the protocol's
/// plain `Setpoint`, one a solve.)
const PACE: u32 = 2;

/// Before phase 0: `Identify` is answered with the identity of the robot
/// file the firmware was built from (name, as the protocol truncates it,
/// hash, shape).
fn identify(s: &mut Session, expected: &robot_file::RobotIdentity) -> Result<Check, String> {
    let before = s.received.lock().unwrap().identities.len();
    s.send(&HostMessage::Identify)?;
    let start = Instant::now();
    let answer = loop {
        if let Some(&id) = s.received.lock().unwrap().identities.get(before) {
            break Some(id);
        }
        if start.elapsed() > Duration::from_secs(10) {
            break None;
        }
        thread::sleep(Duration::from_millis(5));
    };
    let Some(answer) = answer else {
        return Err("no answer to Identify within 10 s".into());
    };
    let wanted = Identity::new(&expected.name, expected.hash, 6, 8);
    let shown = format!(
        "{}#{:016x}, {} DOF x {} cables",
        answer.name().unwrap_or("(malformed name)"),
        answer.hash,
        answer.dof,
        answer.cables
    );
    Ok((
        "Identify: the board answers with the identity of the robot file it was built from".into(),
        if answer == wanted {
            Ok(format!("{shown} (robot file: {expected})"))
        } else {
            Err(format!("{shown}; the robot file says {expected}, 6 DOF x 8 cables"))
        },
    ))
}

/// Phase 0: Enable before Home is refused; Home makes the board homed.
fn homing(s: &mut Session) -> Result<Check, String> {
    let from = s.telemetry_count();
    s.send(&HostMessage::Enable)?;
    let refused = s.wait_for(from, Duration::from_secs(10), |t| {
        t.counters.last_rejection == Rejection::Homing && t.state == State::Disabled && !t.homed
    });
    let from = s.telemetry_count();
    let pose = s.params.setpoint(0).pose;
    s.send(&HostMessage::Home(pose.into()))?;
    let homed = s.wait_for(from, Duration::from_secs(10), |t| t.homed);
    Ok((
        "Enable refused before homing; Home homes the board".into(),
        match (refused, homed) {
            (Some(r), Some(h)) => Ok(format!(
                "Enable refused at cycle {} (last rejection {}), homed at cycle {}: estimate {:?}, residual {:.1} um",
                r.cycle,
                r.counters.last_rejection.name(),
                h.cycle,
                h.estimate,
                h.residual * 1e6
            )),
            (r, h) => Err(format!("refused: {r:?}; homed: {h:?}")),
        },
    ))
}

/// Tracking (phase 1): stream the trajectory's first setpoints, enable;
/// returns the telemetry of the stream.
fn track(s: &mut Session) -> Result<Vec<Telemetry>, String> {
    s.send(&HostMessage::TelemetryPeriod(TELEMETRY_PERIOD))?;
    let from = s.telemetry_count();
    s.start_stream();
    // The trajectory's first pose at rest.
    let held = Setpoint { velocity: [0.0; 6], acceleration: [0.0; 6], ..s.params.setpoint(0).to_wire() };
    for k in 0..HELD_SETPOINTS + TRACKING_SETPOINTS {
        if k < HELD_SETPOINTS {
            s.send_numbered(held)?;
        } else {
            s.send_setpoint(k - HELD_SETPOINTS)?;
        }
        if k == 5 {
            s.send(&HostMessage::Enable)?;
        }
        s.pace(PACE);
    }
    if s.caught_up(from).is_none() {
        let last = s.telemetry_since(from).last().copied();
        let reader = s.received.lock().unwrap().reader_error.clone();
        let qemu = s.qemu.try_wait().map_err(|e| e.to_string())?;
        return Err(format!(
            "the firmware never reported the last tracking setpoint ({} sent; last telemetry: {last:?}; reader: {reader:?}; QEMU exit: {qemu:?})",
            s.seq
        ));
    }
    Ok(s.telemetry_since(from))
}

/// Phase 2, a corrupted frame among good ones: rejected and counted, nothing else.
fn corrupted_frame(s: &mut Session, last: Option<Telemetry>) -> Result<Check, String> {
    let before = s.telemetry_count();
    let k0 = TRACKING_SETPOINTS;
    let rejected_before = last.map_or(0, |t| t.counters.rejected_crc + t.counters.rejected_framing);
    let mut frame = [0u8; MAX_FRAME];
    let bad = Setpoint { seq: s.seq + 1, ..s.sent[&s.seq] };
    let n = encode(&HostMessage::Setpoint(bad), &mut frame).map_err(|e| format!("{e:?}"))?;
    frame[12] ^= 0x10;
    s.send_raw(&frame[..n])?;
    s.start_stream();
    for k in k0..k0 + 50 {
        s.send_setpoint(k)?;
        s.pace(PACE);
    }
    s.caught_up(before).ok_or("the firmware never reported the setpoints after the corrupted frame")?;
    let after = s.telemetry_since(before);
    let rejected_after = after.last().map_or(0, |t| t.counters.rejected_crc + t.counters.rejected_framing);
    // The corrupted frame must change nothing: no bad-setpoint hold, no
    // fault. (A hold for a stale stream would be this host pausing more
    // than 50 ms, not the frame; it is reported but not failed on.)
    let acted_on = after.iter().any(|t| t.reason == Reason::BadSetpoint || t.state == State::Fault);
    let enabled = after.iter().filter(|t| t.state == State::Enabled).count();
    Ok((
        "corrupted frame rejected and counted, state unchanged".into(),
        if rejected_after == rejected_before + 1 && !acted_on && enabled > 0 {
            Ok(format!(
                "CRC/framing rejections {rejected_before} -> {rejected_after}, Enabled in {enabled} of {} samples after it",
                after.len()
            ))
        } else {
            Err(format!(
                "rejections {rejected_before} -> {rejected_after}, states {:?}",
                after.iter().map(|t| t.state).collect::<Vec<_>>()
            ))
        },
    ))
}

/// Phase 3, NaN poses from telemetry sample `before` on: hold, then fault.
fn nan_poses(s: &mut Session, before: usize) -> Result<Check, String> {
    // NaN setpoints until the firmware reports a fault (at most 10 s).
    let start = Instant::now();
    s.start_stream();
    while start.elapsed() < Duration::from_secs(10)
        && s.find_since(before, |t| t.state == State::Fault).is_none()
    {
        s.seq += 1;
        let nan = Setpoint { seq: s.seq, pose: [f32::NAN, 0.0, 2.0, 0.0, 0.0, 0.0], ..s.sent[&(s.seq - 1)] };
        s.sent.insert(s.seq, nan);
        s.send(&HostMessage::Setpoint(nan))?;
        s.pace(PACE);
    }
    let holding = s.wait_for(before, Duration::from_secs(2), |t| t.state == State::Holding);
    let fault = s.wait_for(before, Duration::from_secs(2), |t| t.state == State::Fault);
    let check = match (holding, fault) {
        (Some(h), Some(f)) if h.reason == Reason::BadSetpoint
            && f.reason == Reason::HoldTimeout
            && f.hold_reason == Reason::BadSetpoint
            && f.brakes
            && f.counters.rejected_range > 0 =>
        {
            Ok(format!(
                "Holding (bad setpoint) at cycle {}, Fault (held too long) at cycle {} ({} cycles later), {} setpoints rejected as out of range",
                h.cycle,
                f.cycle,
                f.cycle - h.cycle,
                f.counters.rejected_range
            ))
        }
        other => Err(format!("expected Holding(BadSetpoint) then Fault(HoldTimeout): {other:?}")),
    };
    Ok(("NaN pose: holding, then fault".into(), check))
}

/// The fault from sample `before` on ramps to zero with the brakes on;
/// then ClearFault and Enable with good setpoints recover.
fn ramp_and_recover(s: &mut Session, before: usize) -> Result<Check, String> {
    let ramped = s.wait_for(before, Duration::from_secs(10), |t| {
        t.state == State::Fault && t.torques.iter().all(|&x| x == 0.0) && t.brakes
    });
    let from = s.telemetry_count();
    let k0 = TRACKING_SETPOINTS;
    s.start_stream();
    for k in k0..k0 + 40 {
        s.send_setpoint(k)?;
        if k == k0 + 10 {
            s.send(&HostMessage::ClearFault)?;
        }
        if k == k0 + 20 {
            s.send(&HostMessage::Enable)?;
        }
        s.pace(PACE);
    }
    let back = s.wait_for(from, Duration::from_secs(10), |t| t.state == State::Enabled);
    Ok((
        "fault ramps the torques to zero; ClearFault and Enable recover".into(),
        match (ramped, back) {
            (Some(r), Some(b)) => Ok(format!(
                "torques zero with brakes on at cycle {}, Enabled again at cycle {}",
                r.cycle, b.cycle
            )),
            (r, b) => Err(format!("ramped to zero: {}, enabled again: {}", r.is_some(), b.is_some())),
        },
    ))
}

/// Junk bytes sent after each setpoint in the flood, one setpoint every
/// [`FLOOD_PACE`]: with the 80-byte setpoint about 40 bytes a millisecond,
/// most of what the board's 460 800 baud carries (46 bytes a millisecond;
/// 3.5 times the former 115 200 baud). More would exceed what QEMU's USART
/// delivers here (about 50 bytes a millisecond, measured), and the
/// setpoints would queue behind the junk until stale; floods beyond the
/// line rate are the demo's receive flood (256 bytes a cycle).
const FLOOD_JUNK: usize = 40;

/// The pause between two setpoints of the flood, ms ([`Session::pace`]).
const FLOOD_PACE: u32 = 3;

/// Setpoints streamed in the flood.
const FLOOD_SETPOINTS: u32 = 300;

/// Phase 4, a flood while Enabled (after [`ramp_and_recover`]): the
/// junk is the receive interrupt's (bounded apart: the demo's receive
/// flood), and the step, which takes at most two frames a cycle, is held
/// to the robot's product ceiling `ceiling`, as the stream's is. (Until
/// session 34 it was held to 90 000, well below the 1 ms period: under
/// QEMU the step's figure also carried a miscount of the interrupts taken
/// inside it, `bsp::with_receive_held`; without the receive budget a
/// flood once made steps of 137 000 to 156 000.)
fn flood(s: &mut Session, ceiling: u32) -> Result<Check, String> {
    let from = s.telemetry_count();
    let before = s.find_since(from.saturating_sub(1), |_| true).map(|t| t.counters);
    let mut x = 0x2545_f491u32;
    let mut sent_bytes = 0usize;
    // Cycles 1240..1640 of the trajectory: all inside the workspace (the
    // excursion out of it starts later: `host_robot` checks).
    let k0 = TRACKING_SETPOINTS + 40;
    s.start_stream();
    for (i, k) in (k0..k0 + FLOOD_SETPOINTS).enumerate() {
        s.send_setpoint(k)?;
        let junk: Vec<u8> = match i % 4 {
            0 => vec![0x00; FLOOD_JUNK],
            1 => {
                let mut v = vec![0xFF; FLOOD_JUNK - 1];
                v.push(0x00);
                v
            }
            2 => {
                let mut v: Vec<u8> = (0..FLOOD_JUNK - 1)
                    .map(|_| {
                        x ^= x << 13;
                        x ^= x >> 17;
                        x ^= x << 5;
                        x as u8
                    })
                    .collect();
                v.push(0x00);
                v
            }
            // The same setpoint again, back to back: out of order.
            _ => {
                let mut frame = [0u8; MAX_FRAME];
                let n = encode(&HostMessage::Setpoint(s.sent[&s.seq]), &mut frame)
                    .map_err(|e| format!("{e:?}"))?;
                frame[..n].to_vec()
            }
        };
        s.send_raw(&junk)?;
        sent_bytes += junk.len() + 80;
        if i == FLOOD_SETPOINTS as usize / 2 {
            let mut burst = vec![0xA5u8; 1024];
            sent_bytes += burst.len() + 1;
            burst.push(0);
            s.send_raw(&burst)?;
        }
        s.pace(FLOOD_PACE);
    }
    // The stream goes on cleanly until the firmware has caught up.
    let k1 = k0 + FLOOD_SETPOINTS;
    let mut caught = None;
    for k in k1..k1 + 100 {
        s.send_setpoint(k)?;
        s.pace(PACE);
        caught = s.find_since(from, |t| t.setpoint_seq == s.seq);
        if caught.is_some() {
            break;
        }
    }
    let caught = caught.or_else(|| s.caught_up(from));
    let samples = s.telemetry_since(from);
    let worst = samples.iter().map(|t| t.step_cost).max().unwrap_or(0);
    let span = match (samples.first(), samples.last()) {
        (Some(a), Some(b)) => b.cycle.saturating_sub(a.cycle).max(1),
        _ => 1,
    };
    let faulted = samples.iter().any(|t| t.state == State::Fault);
    let last = samples.last().map(|t| t.counters);
    let rejected = |c: &cdpr_protocol::Counters| {
        c.rejected_framing + c.rejected_crc + c.rejected_decode + c.rejected_order
    };
    let figures = format!(
        "{FLOOD_SETPOINTS} setpoints with {FLOOD_JUNK} junk bytes after each and a 1 KiB burst ({sent_bytes} bytes over {span} cycles: {:.0} bytes per ms); worst step {worst} instructions (budget {}, ceiling {ceiling}); rejected frames {} -> {}; dropped bytes {}; overruns {} -> {}; states {:?}",
        sent_bytes as f64 / f64::from(span),
        cdpr_demo::BUDGET,
        before.map_or(0, |c| rejected(&c)),
        last.map_or(0, |c| rejected(&c)),
        last.map_or(0, |c| c.dropped_bytes),
        before.map_or(0, |c| c.overruns),
        last.map_or(0, |c| c.overruns),
        {
            let mut states: Vec<State> = samples.iter().map(|t| t.state).collect();
            states.dedup();
            states
        }
    );
    let ok = worst > 0
        && within_ceiling(worst, ceiling).is_ok()
        && !faulted
        && caught.is_some_and(|t| t.state == State::Enabled)
        && last.zip(before).is_some_and(|(l, b)| rejected(&l) > rejected(&b));
    Ok((
        "a flood of junk at about the line rate: the step within its ceiling, counted, no fault".into(),
        if ok { Ok(figures) } else { Err(figures) },
    ))
}

/// Phase 5, the stream stops (from sample `before` on): hold (stale), then fault.
fn stream_stops(s: &Session, before: usize) -> Check {
    let _ = s.wait_for(before, Duration::from_secs(10), |t| t.state == State::Fault);
    let samples = s.telemetry_since(before);
    let first_hold = samples.iter().find(|t| t.state == State::Holding);
    let first_fault = samples.iter().find(|t| t.state == State::Fault);
    let enabled_until = samples.iter().take_while(|t| t.state == State::Enabled).last();
    (
        "stream stops: holding (stale), then fault".into(),
        match (first_hold, first_fault) {
            (Some(h), Some(f)) if h.reason == Reason::Stale && f.hold_reason == Reason::Stale => Ok(format!(
                "last Enabled at cycle {}, Holding (stale) at cycle {}, Fault at cycle {}",
                enabled_until.map_or(0, |t| t.cycle),
                h.cycle,
                f.cycle
            )),
            (h, f) => Err(format!("expected Holding(Stale) then Fault: {h:?} / {f:?}")),
        },
    )
}

/// No state change costs the board a control deadline. Each change is a
/// log line (the states, the counters, the stack's high-water mark),
/// which the idle loop writes (`firmware::state_log`); written from the
/// control task, each made the next release late, and a change was
/// followed by an overrun every time (9 of 9 in this session). A change
/// counts as followed by one when the overrun counter grew between the
/// sample before it and the second sample after it (about 20 ms). Late
/// wake-ups of QEMU's process on a loaded host also count as overruns
/// (`-icount ... sleep=on`), anywhere in the session: one such
/// coincidence is let pass.
fn deadlines(s: &Session) -> Check {
    let samples = s.telemetry_since(0);
    let changes: Vec<usize> =
        (1..samples.len()).filter(|&i| samples[i - 1].state != samples[i].state).collect();
    let followed = changes
        .iter()
        .filter(|&&i| {
            let after = samples[(i + 2).min(samples.len() - 1)].counters.overruns;
            after != samples[i - 1].counters.overruns
        })
        .count();
    let overruns = samples.last().map_or(0, |t| t.counters.overruns);
    let shown = format!(
        "{followed} of {} state changes followed by an overrun; {overruns} overruns in the session's {} samples",
        changes.len(),
        samples.len()
    );
    (
        "no state change costs the board a control deadline".into(),
        if changes.len() >= 4 && followed <= 1 {
            Ok(shown)
        } else if changes.len() < 4 {
            Err(format!("{shown}: the check needs at least 4 changes"))
        } else {
            Err(shown)
        },
    )
}

/// The frame: a setpoint with seq 0xFFFFFFFF and a NaN x (it used
/// to lock the sequence check until a reset).
fn poison_frame() -> Vec<u8> {
    let mut frame =
        vec![0x01, 0x06, 0xff, 0xff, 0xff, 0xff, 0x0f, 0x01, 0x03, 0xc0, 0x7f, 0x01, 0x01, 0x01, 0x05];
    frame.extend([0x66, 0x66, 0xe6, 0x3f]);
    frame.extend([0x01; 59]);
    frame.extend([0x05, 0xcc, 0xfa, 0xaa, 0x4d, 0x00]);
    frame
}

/// Setpoints the new session of [`method_over_the_link`] streams at
/// least, and at most (it goes on until [`METHOD_SAMPLES_MIN`] samples
/// compare).
const METHOD_SETPOINTS: u32 = 300;
const METHOD_SETPOINTS_MAX: u32 = 1000;

/// Enabled samples of the selected method the comparison needs (one
/// sample every 10 cycles).
const METHOD_SAMPLES_MIN: usize = 20;

/// Setpoints the board must report beyond the one a request followed
/// before the host takes the request as read (a frame is decoded in the
/// step after it arrives, two at most a step).
const REQUEST_READ_MARGIN: u32 = 3;

/// Phase 6, a new host session once the stale fault (from sample `before`
/// on) has ramped down: the poison frame, ClearFault, numbering from 1,
/// methods the board does not offer refused, `puncture` selected while
/// disabled and compared with the host's.
fn method_over_the_link(
    s: &mut Session,
    robot: &Robot68,
    before: usize,
    tolerances: Tolerances,
) -> Result<Check, String> {
    let ramped = s.wait_for(before, Duration::from_secs(10), |t| {
        t.state == State::Fault && t.torques.iter().all(|&x| x == 0.0)
    });
    let method = Method::Puncture;
    let id = method.wire_id();
    let refused = [Method::OptimallySafe, Method::Min2Norm];
    let from = s.telemetry_count();
    s.send_raw(&poison_frame())?;
    s.seq = 0;
    s.start_stream();
    let used = |t: &Telemetry| t.state == State::Enabled && t.solved && t.method == id;
    let mut requests = Vec::new();
    for k in 0..METHOD_SETPOINTS_MAX {
        s.send_setpoint(k)?;
        match k {
            5 => s.send(&HostMessage::ClearFault)?,
            8 => s.send_raw(&poison_frame())?,
            10 => {
                for m in refused {
                    s.send(&HostMessage::SelectMethod(m.wire_id()))?;
                }
                s.send(&HostMessage::SelectMethod(id))?
            }
            // From 60 on, after the stand-in of the winches (QEMU) has
            // followed the new session's first pose (5 ms lag). A loaded
            // machine delays the request (it waits in the link's queue
            // behind the setpoints sent before it), and Enable is refused
            // while a cable is off the setpoint by more than the length
            // check; a refused request is not kept. So the host asks
            // again, as an operator would, once the board has read past
            // the last request and still reports itself disabled (or in
            // fault).
            _ if k >= 60 => {
                let latest = s.latest();
                let request = match latest.map(|t| t.state) {
                    Some(State::Fault) => Some(HostMessage::ClearFault),
                    Some(State::Disabled) | None => Some(HostMessage::Enable),
                    Some(State::Enabled | State::Holding) => None,
                };
                // Of this session's numbering: not the last session's
                // higher numbers, which the board reports until it reads
                // this session's first setpoint.
                let sent = s.seq;
                let read_past = |seq: u32| {
                    latest.is_some_and(|t| (seq + REQUEST_READ_MARGIN..=sent).contains(&t.setpoint_seq))
                };
                if let Some(r) = request.filter(|_| requests.last().is_none_or(|&(seq, _)| read_past(seq))) {
                    s.send(&r)?;
                    requests.push((s.seq, r));
                }
            }
            _ => {}
        }
        s.pace(PACE);
        // A loaded machine delays the board's clock or the host's, and
        // with them the Enable: the stream goes on until the comparison
        // has its samples.
        if k + 1 >= METHOD_SETPOINTS && s.count_since(from, used) >= METHOD_SAMPLES_MIN {
            break;
        }
    }
    s.caught_up(from).ok_or("the firmware never reported the setpoints of the new session")?;
    let switched = s.telemetry_since(from);
    let counters_before =
        s.find_since(from.saturating_sub(1), |_| true).map(|t| t.counters).unwrap_or_default();
    let counters = switched.last().map(|t| t.counters).unwrap_or_default();
    let chosen = compare(robot, method, &s.sent, &switched, used);
    let tension_tol = tolerances.tension;
    let refusals = counters.rejected_method - counters_before.rejected_method;
    let states = {
        let mut states: Vec<(u32, State)> = switched.iter().map(|t| (t.cycle, t.state)).collect();
        states.dedup_by_key(|(_, state)| *state);
        states
    };
    let session = format!(
        "{} setpoints, states (from cycle) {states:?}, requests {}; poison frames rejected as range {} -> {}, order rejections {} -> {}, methods refused as over budget {refusals} (last rejection {})",
        s.seq,
        requests.iter().map(|(seq, r)| format!("{r:?} after setpoint {seq}")).collect::<Vec<_>>().join(", "),
        counters_before.rejected_range,
        counters.rejected_range,
        counters_before.rejected_order,
        counters.rejected_order,
        counters.last_rejection.name()
    );
    Ok((
        "new session: poison frame, renumbering from 1, unoffered methods refused, puncture matches the host's f64".into(),
        match chosen {
            _ if ramped.is_none() => Err("the stale fault's ramp never finished".into()),
            _ if refusals != refused.len() as u32
                || counters.rejected_order != counters_before.rejected_order
                || counters.rejected_range < counters_before.rejected_range + 2 =>
            {
                Err(session)
            }
            Err(e) => Err(format!("{e}; {session}")),
            Ok(c) if c.samples < METHOD_SAMPLES_MIN => {
                Err(format!("only {} enabled puncture samples of {}; {session}", c.samples, switched.len()))
            }
            Ok(c) if c.worst_tension > tension_tol => Err(format!(
                "worst tension error {:.3e} N (tolerance {tension_tol:.3e}); {session}",
                c.worst_tension
            )),
            Ok(c) => Ok(format!("{} samples, worst |t - t_host| {:.2e} N; {session}", c.samples, c.worst_tension)),
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_raw_stream_fits_the_serial_link() {
        let mut longest = 0;
        for robot in crate::firmware::TEST_ROBOTS {
            let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(robot);
            let params = host_robot(&file).unwrap().params;
            for k in 0..HELD_SETPOINTS + TRACKING_SETPOINTS + METHOD_SETPOINTS_MAX {
                let setpoint = Setpoint { seq: u32::MAX, ..params.setpoint(k).to_wire() };
                let mut frame = [0u8; MAX_FRAME];
                longest = longest.max(encode(&HostMessage::Setpoint(setpoint), &mut frame).unwrap());
            }
        }
        // The longest frame's time on the line (8N1: 10 bits a byte), us,
        // within the pace, at the rate `cdpr stream` paces to (the
        // firmware's `serial::BAUD`).
        let baud = cdpr::stream::session::Options::DEFAULT.baud;
        let on_line_us = longest as u64 * 10 * 1_000_000 / u64::from(baud);
        assert!(longest > 60, "{longest} bytes");
        assert!(on_line_us <= u64::from(PACE) * 1000, "{longest} bytes take {on_line_us} us");
    }

    #[test]
    fn holds_the_product_step_to_its_ceiling_and_the_budget() {
        assert!(within_ceiling(crate::firmware::PRODUCT_CEILING, crate::firmware::PRODUCT_CEILING).is_ok());
        assert!(
            within_ceiling(crate::firmware::PRODUCT_CEILING + 1, crate::firmware::PRODUCT_CEILING).is_err()
        );
        assert!(within_ceiling(cdpr_demo::BUDGET, cdpr_demo::BUDGET).is_ok());
        assert!(within_ceiling(cdpr_demo::BUDGET + 1, u32::MAX).is_err());
        assert_eq!(
            crate::firmware::ceilings(Path::new(crate::firmware::DEFAULT_ROBOT)).product,
            crate::firmware::PRODUCT_CEILING
        );
    }

    #[test]
    fn reads_the_stack_mark_of_a_state_change_line() {
        let line = "cycle 140: Disabled -> Enabled (None); drives [0.0] N m, brakes false; counters Counters { accepted: 11 }; stack high-water mark 15856 bytes";
        assert_eq!(stack_mark(line), Some(15_856));
        assert_eq!(stack_mark("cycle 1: Disabled -> Enabled"), None);
    }

    #[test]
    fn reads_the_interrupt_entry_and_exit_line() {
        let line =
            "the receive interrupt's entry and exit: 18 instructions (taken out of each step with its body)";
        assert_eq!(entry_exit_mark(line), Some(18));
        assert_eq!(entry_exit_mark("cycle 1: Disabled -> Enabled"), None);
        assert!(interrupt_entry_exit(18).1.is_ok());
        assert!(interrupt_entry_exit(0).1.is_err());
        assert!(interrupt_entry_exit(65).1.is_err());
        assert!(interrupt_entry_exit(u32::MAX).1.is_err());
        assert_eq!(stack_mark("stack high-water mark lots bytes"), None);
        assert!(product_stack(13_928).1.is_ok());
        assert!(product_stack(crate::firmware::PRODUCT_STACK_CEILING + 4).1.is_err());
        assert!(product_stack(crate::firmware::STACK_LIMIT + 4).1.is_err());
        assert!(product_stack(0).1.is_err(), "no mark logged is no pass");
    }
}
