//! `cdpr stream` against a board on a TCP socket: the firmware's control
//! loop (`cdpr_control::ControlLoop`, suspended-8) run here in real time,
//! 1 ms a cycle, with winches that follow its feasible setpoint, bytes in
//! and telemetry out as on the board. Checks a completed stream, Ctrl-C, a
//! fault, a board that goes silent, a port of garbage, and bad input that
//! sends nothing.

mod common;

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use cdpr::stream::session::{Ending, Options, Session, SessionError};
use cdpr::stream::{self, StreamArgs};
use cdpr_control::link::SetpointRange;
use cdpr_control::protocol::{encode, DeviceMessage, Identity, State, Telemetry, MAX_FRAME};
use cdpr_control::supervisor::SafetyLimits;
use cdpr_control::{ControlLoop, NoClock, WinchDrives, WinchReading, CABLES};
use tension_core::Method;

/// What the simulated board does wrong, from which cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Trouble {
    None,
    /// Its drives cannot be read from this cycle on (Fault `encoder`).
    Unreadable(u32),
    /// It stops sending telemetry from this cycle on (the socket stays open).
    Silent(u32),
    /// It was built for another robot (answers `Identify` with ipanema1).
    OtherRobot,
    /// Its robot file gives the platform no inertia.
    NoInertia,
}

/// The identity a board built from `robots/NAME.toml` answers with.
fn identity_of(name: &str) -> Identity {
    let id = robot_file::RobotFile::load(common::robot(name)).unwrap().identity();
    Identity::new(&id.name, id.hash, 6, 8)
}

/// Winches that follow the loop's feasible lengths at once.
struct Winches {
    readings: [WinchReading; CABLES],
    unreadable: bool,
}

impl WinchDrives for Winches {
    type Error = ();
    fn apply(&mut self, _: &[f32; CABLES]) -> Result<(), ()> {
        Ok(())
    }
    fn set_brakes(&mut self, _: bool) -> Result<(), ()> {
        Ok(())
    }
    fn read(&mut self, readings: &mut [WinchReading; CABLES]) -> Result<(), ()> {
        if self.unreadable {
            return Err(());
        }
        *readings = self.readings;
        Ok(())
    }
}

struct Board {
    address: String,
    thread: JoinHandle<BoardEnd>,
    received: Arc<AtomicU32>,
    /// Held while the board runs: one real-time board at a time in this
    /// file (the test harness runs tests in parallel, and two boards and
    /// two hosts on a 2-core machine delay each other's threads).
    _real_time: MutexGuard<'static, ()>,
}

/// See [`Board::_real_time`].
static REAL_TIME: Mutex<()> = Mutex::new(());

/// What the board saw, at its end.
#[derive(Debug)]
struct BoardEnd {
    telemetry: Vec<Telemetry>,
    states: Vec<State>,
}

fn suspended8() -> cdpr_control::ControlRobot {
    robot_file::RobotFile::load(common::robot("suspended-8")).and_then(|f| f.to_robot::<f32, 6, 8>()).unwrap()
}

/// A board listening on a free port; it runs until the host disconnects
/// (or 20 s).
fn board(trouble: Trouble) -> Board {
    // A test that failed while holding it leaves it poisoned; the next
    // runs all the same.
    let real_time = REAL_TIME.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let received = Arc::new(AtomicU32::new(0));
    let counted = received.clone();
    let thread = std::thread::spawn(move || {
        let mut robot = suspended8();
        if trouble == Trouble::NoInertia {
            let platform = tension_core::Platform {
                inertia: tension_core::nalgebra::Matrix3::zeros(),
                ..*robot.platform()
            };
            robot.set_platform(platform).unwrap();
        }
        let range = SetpointRange::for_robot(&robot);
        let mut control = ControlLoop::new(robot, Method::Barycenter, range, SafetyLimits::DEFAULT).unwrap();
        // The platform rests at the waypoints' first pose.
        let start = cdpr_control::setpoint::Pose6::from([0.0, 0.0, 1.8, 0.0, 0.0, 0.0]);
        let lengths = control.controller().robot().cables(&start).unwrap().lengths;
        let mut winches = Winches { readings: [WinchReading::default(); CABLES], unreadable: false };
        let set = |w: &mut Winches, control: &ControlLoop, l: &[f32]| {
            for (i, r) in w.readings.iter_mut().enumerate() {
                r.counts = control.encoder().counts_of(i, l[i], 0).unwrap();
            }
        };
        set(&mut winches, &control, lengths.as_slice());
        let (mut socket, _) = listener.accept().unwrap();
        socket.set_nonblocking(true).unwrap();
        let mut end = BoardEnd { telemetry: Vec::new(), states: Vec::new() };
        let mut frame = [0u8; MAX_FRAME];
        let identity = identity_of(if trouble == Trouble::OtherRobot { "ipanema1" } else { "suspended-8" });
        let t0 = Instant::now();
        for k in 0..20_000u32 {
            // Real time: cycle k starts at k ms.
            let due = t0 + Duration::from_millis(u64::from(k));
            if let Some(wait) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
            let mut buf = [0u8; 256];
            match socket.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => {
                    counted.fetch_add(n as u32, Ordering::Relaxed);
                    for &b in &buf[..n] {
                        control.receive_byte(b);
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
                Err(_) => break,
            }
            winches.unreadable = matches!(trouble, Trouble::Unreadable(at) if k >= at);
            let report = control.step(&NoClock, &mut winches, false);
            if let Some(l) = control.last_feasible_lengths().copied() {
                set(&mut winches, &control, &l);
            }
            if end.states.last() != Some(&report.state) {
                end.states.push(report.state);
            }
            if matches!(trouble, Trouble::Silent(at) if k >= at) {
                continue;
            }
            if control.take_identify() {
                let n = encode(&DeviceMessage::Identity(identity), &mut frame).unwrap();
                let _ = socket.set_nonblocking(false);
                if socket.write_all(&frame[..n]).is_err() {
                    break;
                }
                let _ = socket.set_nonblocking(true);
            }
            if let Some(t) = report.telemetry {
                end.telemetry.push(t);
                let n = encode(&DeviceMessage::Telemetry(t), &mut frame).unwrap();
                // Non-blocking: a full socket would be the host's problem.
                let _ = socket.set_nonblocking(false);
                if socket.write_all(&frame[..n]).is_err() {
                    break;
                }
                let _ = socket.set_nonblocking(true);
            }
        }
        end
    });
    Board { address, thread, received, _real_time: real_time }
}

/// A waypoint table: from the board's start pose out and back in 2 s.
fn waypoints(dir: &Path) -> std::path::PathBuf {
    let path = dir.join("waypoints.csv");
    std::fs::write(
        &path,
        "time,x,y,z,rx,ry,rz\n0.0,0.0,0.0,1.8,0.0,0.0,0.0\n1.0,0.15,-0.1,1.85,0.01,0.0,0.02\n2.0,0.0,0.0,1.8,0.0,0.0,0.0\n",
    )
    .unwrap();
    path
}

fn args(dir: &Path, address: &str) -> StreamArgs {
    StreamArgs {
        robot: common::robot("suspended-8"),
        poses: None,
        waypoints: Some(waypoints(dir)),
        rate: 100.0,
        port: None,
        baud: 460_800,
        tcp: Some(address.to_string()),
        telemetry: Some(dir.join("telemetry.csv")),
        feedback: Some("joint".into()),
        lead: 80,
    }
}

#[test]
fn a_stream_homes_enables_plays_every_point_and_disables() {
    let dir = common::scratch("stream-complete");
    let b = board(Trouble::None);
    let a = args(&dir, &b.address);
    let mut status = Vec::new();
    let report = stream::run(&a, &mut status, &AtomicBool::new(false)).unwrap();
    assert_eq!(report.ending, Ending::Completed);
    assert_eq!(report.points, 201);
    let end = b.thread.join().unwrap();
    assert_eq!(end.states, vec![State::Disabled, State::Enabled, State::Disabled], "{:?}", end.states);
    let last = end.telemetry.last().unwrap();
    // Every point reached the board and none was refused; the trajectory
    // played to its end (2000 ms) before the Disable.
    assert_eq!(last.counters.rejected_order + last.counters.rejected_jump + last.counters.rejected_range, 0);
    assert!(end.telemetry.iter().any(|t| t.state == State::Enabled && t.setpoint_seq == 2000));
    assert!(last.torques.iter().all(|&x| x == 0.0) && last.brakes);
    assert_eq!(last.feedback, 2);
    // The host kept the buffer ahead: at least two points in it in nine
    // samples out of ten before the end. (The board here runs in real time
    // on a shared machine: a host thread descheduled for longer than its
    // 80 ms lead drains it for a moment, as it would a real board's; the
    // states above say it never went stale. A host without lead has one
    // point or none in most samples.)
    let enabled: Vec<&Telemetry> = end.telemetry.iter().filter(|t| t.state == State::Enabled).collect();
    let before_end: Vec<&&Telemetry> = enabled.iter().filter(|t| t.setpoint_seq < 1900).collect();
    let short = before_end.iter().filter(|t| t.buffer_fill < 2).count();
    assert!(
        before_end.len() > 150 && short * 10 <= before_end.len(),
        "{short} of {} samples short: {:?}",
        before_end.len(),
        enabled.iter().map(|t| t.buffer_fill).collect::<Vec<_>>()
    );
    let lead_max = enabled.iter().map(|t| t.buffer_lead_ms).max().unwrap();
    assert!(lead_max <= 80 + 20 + 10, "{lead_max}");
    // The CSV has the header and a row per sample the host received.
    let csv = std::fs::read_to_string(dir.join("telemetry.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next().unwrap(), stream::telemetry_header().join(","));
    assert_eq!(lines.count(), report.samples);
    assert!(report.samples > 100);
    // The status line was shown.
    let status = String::from_utf8(status).unwrap();
    assert!(status.contains("enabled") && status.contains("points"), "{status}");
    // All the points arrived (at most 60 bytes each, at least 55 here).
    assert!(b.received.load(Ordering::Relaxed) >= 201 * 55);
    // The board played at the pace asked: it waited for points at most
    // for a moment (a host descheduled past its lead, as above), and
    // refused none.
    let p = report.playback;
    assert!(p.played_ms > 1800 && p.waited_ms < 200, "{p:?}");
    assert_eq!(p.refused, 0, "{report}");
}

/// What a stream that did not play as planned reports, after "completed":
/// the points the board refused, and how long it waited for points.
#[test]
fn the_report_says_what_did_not_play_as_planned() {
    let clean = stream::Report {
        ending: Ending::Completed,
        samples: 600,
        points: 601,
        tensions: (11.6, 23.2),
        playback: stream::Playback::default(),
    };
    assert_eq!(
        clean.to_string(),
        "completed: 601 points sent, 600 telemetry samples, tensions 11.60..23.20 N"
    );
    let mut playback = stream::Playback::default();
    (playback.waited_ms, playback.played_ms) = (924, 1906);
    (playback.refused, playback.last_rejection) = (144, cdpr_control::protocol::Rejection::BufferFull);
    let late = stream::Report { playback, ..clean };
    let text = late.to_string();
    assert!(text.starts_with("completed: 601 points sent"), "{text}");
    assert!(text.contains("; the board refused 144 points (last rejection: buffer-full)"), "{text}");
    assert!(text.contains("; the board waited 0.924 s for points while it played 1.906 s"), "{text}");
    let mut playback = stream::Playback::default();
    playback.overruns = 3;
    let text = stream::Report { playback, ..clean }.to_string();
    assert!(text.contains("; the board missed 3 control deadlines"), "{text}");
}

/// An Enabled board's sample at `cycle`, with `overruns` deadlines missed
/// since it started.
fn sample(cycle: u32, overruns: u32) -> Telemetry {
    Telemetry {
        cycle,
        setpoint_seq: cycle,
        state: State::Enabled,
        reason: cdpr_control::protocol::Reason::None,
        hold_reason: cdpr_control::protocol::Reason::None,
        solved: true,
        tensions: [15.0; CABLES],
        torques: [0.08; CABLES],
        brakes: false,
        step_cost: 9_000,
        counters: cdpr_control::protocol::Counters { accepted: cycle, overruns, ..Default::default() },
        method: 0,
        estimate: [0.0; 6],
        residual: 0.0,
        homed: true,
        feedback: 0,
        unreadable_drive: None,
        tension_limited: 0,
        feedback_scale: 100,
        buffer_fill: 8,
        buffer_lead_ms: 80,
        drive_fault: None,
    }
}

/// The deadlines the board missed during a stream, from its counter (which
/// runs on from stream to stream, and wraps): in the report and in the
/// telemetry CSV's last column.
#[test]
fn a_stream_counts_the_deadlines_the_board_missed() {
    let mut clean = stream::Playback::default();
    for cycle in 100..200 {
        clean.sample(&sample(cycle, 7), 1_000);
    }
    assert_eq!(clean.overruns, 0);
    let mut late = stream::Playback::default();
    for (cycle, overruns) in [(100, u32::MAX - 1), (101, u32::MAX), (102, 0), (103, 0), (104, 1)] {
        late.sample(&sample(cycle, overruns), 1_000);
    }
    assert_eq!(late.overruns, 3, "{late:?}");
    let header = stream::telemetry_header();
    let row = stream::telemetry_row(0.5, &sample(104, 1));
    assert_eq!(
        (header.last().map(String::as_str), row.last().map(String::as_str)),
        (Some("overruns"), Some("1"))
    );
    assert_eq!(header.len(), row.len());
}

#[test]
fn an_interrupt_disables_and_waits_for_the_ramp() {
    let dir = common::scratch("stream-interrupt");
    let b = board(Trouble::None);
    let a = args(&dir, &b.address);
    let interrupt = Arc::new(AtomicBool::new(false));
    let flag = interrupt.clone();
    std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(600));
        flag.store(true, Ordering::Relaxed);
    });
    let report = stream::run(&a, &mut Vec::new(), &interrupt).unwrap();
    assert_eq!(report.ending, Ending::Interrupted);
    let end = b.thread.join().unwrap();
    let last = end.telemetry.last().unwrap();
    assert_eq!(last.state, State::Disabled);
    assert!(last.torques.iter().all(|&x| x == 0.0));
    // It stopped partway: the end of the trajectory never played.
    assert!(end.telemetry.iter().all(|t| t.setpoint_seq < 2000));
}

#[test]
fn a_board_built_for_another_robot_is_refused_before_anything_moves() {
    let dir = common::scratch("stream-other-robot");
    let b = board(Trouble::OtherRobot);
    let a = args(&dir, &b.address);
    let e = stream::run(&a, &mut Vec::new(), &AtomicBool::new(false)).unwrap_err();
    assert_eq!(e.exit_code(), 1);
    assert!(e.message.contains("built for ipanema1#") && e.message.contains("not for suspended-8#"), "{e}");
    let end = b.thread.join().unwrap();
    // Only TelemetryPeriod and Identify arrived: never homed, never enabled.
    let last = end.telemetry.last().unwrap();
    assert!(!last.homed && last.buffer_fill == 0, "{last:?}");
    assert_eq!(end.states, vec![State::Disabled]);
    assert!(last.counters.accepted <= 2, "{:?}", last.counters);
}

/// `--feedback task` on a board whose robot file gives the platform no
/// inertia: the board refuses the task-space PID (its rotation gains
/// would be zero), and the tool says why before anything moves.
#[test]
fn task_space_feedback_on_a_platform_without_inertia_is_refused_and_said_why() {
    let dir = common::scratch("stream-no-inertia");
    let b = board(Trouble::NoInertia);
    let mut a = args(&dir, &b.address);
    a.feedback = Some("task".into());
    let e = stream::run(&a, &mut Vec::new(), &AtomicBool::new(false)).unwrap_err();
    assert_eq!(e.exit_code(), 1);
    assert!(e.message.contains("SelectFeedback refused") && e.message.contains("no inertia"), "{e}");
    let end = b.thread.join().unwrap();
    assert_eq!(end.states, vec![State::Disabled]);
    assert_eq!(end.telemetry.last().unwrap().feedback, 0);
}

#[test]
fn a_fault_ends_the_stream_with_its_reason() {
    let dir = common::scratch("stream-fault");
    let b = board(Trouble::Unreadable(500));
    let a = args(&dir, &b.address);
    let e = stream::run(&a, &mut Vec::new(), &AtomicBool::new(false)).unwrap_err();
    assert_eq!(e.exit_code(), 1);
    assert!(e.message.contains("faulted: encoder"), "{e}");
    drop(b.thread.join());
}

#[test]
fn a_board_that_stops_answering_is_reported_within_the_silence_limit() {
    let b = board(Trouble::Silent(400));
    let link = cdpr::stream::transport::tcp(&b.address, Duration::from_secs(2)).unwrap();
    let mut session = Session::new(link, Options::DEFAULT);
    let dir = common::scratch("stream-silent");
    let plan = cdpr::stream::plan::Plan::from_waypoints(&waypoints(&dir), 100.0).unwrap();
    struct Quiet;
    impl cdpr::stream::session::Observer for Quiet {
        fn telemetry(&mut self, _: f64, _: &Telemetry, _: cdpr::stream::session::Progress) {}
    }
    let started = Instant::now();
    let e = session
        .stream(&plan.points, &identity_of("suspended-8"), &mut Quiet, &AtomicBool::new(false))
        .unwrap_err();
    let took = started.elapsed();
    // Reported once the 500 ms limit has passed, not before; the upper
    // bounds leave room for a loaded machine's scheduling (a host that
    // never gave up, or waited for its 2 s connect timeout, fails them).
    match e {
        SessionError::Silent(d) => {
            assert!(d >= Duration::from_millis(500) && d < Duration::from_millis(1000), "{d:?}")
        }
        other => panic!("{other}"),
    }
    // Silent from cycle 400 (about 0.4 s after connecting), reported 0.5 s later.
    assert!(took > Duration::from_millis(850) && took < Duration::from_millis(1900), "{took:?}");
    drop(session);
    drop(b.thread.join());
}

/// A session's observer for the tests: how the board played the stream
/// (`cdpr stream`'s own account of it) and the states it went through.
#[derive(Default)]
struct Watched {
    playback: stream::Playback,
    states: Vec<State>,
}

impl cdpr::stream::session::Observer for Watched {
    fn telemetry(&mut self, _: f64, t: &Telemetry, p: cdpr::stream::session::Progress) {
        self.playback.sample(t, p.end_ms);
        if self.states.last() != Some(&t.state) {
            self.states.push(t.state);
        }
    }
}

/// Streams in a row on one board, as an operator runs `cdpr stream` again:
/// each later one starts while the board still reports the last one's
/// play time (2000 ms) until it plays the new points. Taken for the new
/// stream's play time, that sent every point at once into the 32-point
/// buffer (`buffer-full`: points lost, the motion played without them, or
/// Enable refused; seen on the firmware in QEMU). And at 500 Hz the 80 ms
/// lead is 40 points, more than the buffer holds: the host keeps at most
/// 31 ahead of the play time. At 400 Hz the period is 2.5 ms, off the
/// board's millisecond times: each point is the trajectory at its own
/// millisecond (sampled between and rounded, poses 0.5 ms off their times
/// gave the board's cubic accelerations of hundreds of m/s^2, and the
/// setpoints were infeasible: Holding). No point is refused, none waited
/// for, never Holding.
#[test]
fn streams_in_a_row_at_any_rate_lose_no_point() {
    let dir = common::scratch("stream-twice");
    let b = board(Trouble::None);
    let link = cdpr::stream::transport::tcp(&b.address, Duration::from_secs(2)).unwrap();
    let mut session = Session::new(link, Options::DEFAULT);
    for (run, rate) in [500.0, 250.0, 400.0].into_iter().enumerate() {
        let plan = cdpr::stream::plan::Plan::from_waypoints(&waypoints(&dir), rate).unwrap();
        let mut seen = Watched::default();
        let ending =
            session.stream(&plan.points, &identity_of("suspended-8"), &mut seen, &AtomicBool::new(false));
        assert_eq!(ending.unwrap(), Ending::Completed, "run {run}");
        // The counters run on from session to session: the points refused
        // (late, out of order, the buffer full) are this stream's.
        let p = seen.playback;
        assert_eq!(p.refused, 0, "run {run}: points refused ({})", p.last_rejection.name());
        assert_eq!(seen.states, [State::Disabled, State::Enabled, State::Disabled], "run {run}");
        assert!(p.played_ms > 1800 && p.waited_ms < 200, "run {run}: {p:?}");
    }
    drop(session);
    drop(b.thread.join());
}

/// A line slower than the points (38 400 baud, 3 840 bytes a second, for
/// 100 points a second of about 57 bytes): `cdpr stream` refuses such a
/// plan before anything is sent; a session made to stream it anyway
/// completes, but the board plays slower than asked, waiting for points,
/// and the report says how long. The complete stream at the line's rate
/// above waits at most a moment.
#[test]
fn a_stream_the_line_cannot_carry_is_refused_and_its_waits_are_counted() {
    let dir = common::scratch("stream-slow-line");
    let b = board(Trouble::None);
    let mut a = args(&dir, &b.address);
    a.baud = 38_400;
    let e = stream::plan(&a).unwrap_err();
    assert!(e.bad_input && e.message.contains("more than 75 % of the 3840 bytes a second"), "{e:?}");
    let plan = cdpr::stream::plan::Plan::from_waypoints(&waypoints(&dir), 100.0).unwrap();
    let link = cdpr::stream::transport::tcp(&b.address, Duration::from_secs(2)).unwrap();
    let mut session = Session::new(link, Options { baud: 38_400, ..Options::DEFAULT });
    let mut seen = Watched::default();
    let ending =
        session.stream(&plan.points, &identity_of("suspended-8"), &mut seen, &AtomicBool::new(false));
    assert_eq!(ending.unwrap(), Ending::Completed);
    let f = seen.playback;
    // 2 s of points at two thirds of the rate they need: the board waits
    // about half as long again as it plays.
    println!("waited {} ms while playing {} ms", f.waited_ms, f.played_ms);
    assert!(f.played_ms > 1500 && f.waited_ms > 400, "{f:?}");
    drop(session);
    drop(b.thread.join());
}

/// A port that carries bytes but no frame of this firmware (another baud
/// rate, another program): said so, with the bytes and rejected frames
/// counted, not "stopped answering"; a port that carries nothing is still
/// silent.
#[test]
fn a_port_of_garbage_is_told_from_a_silent_board() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let noise = std::thread::spawn(move || {
        let (mut socket, _) = listener.accept().unwrap();
        socket.set_read_timeout(Some(Duration::from_millis(1))).unwrap();
        // Pseudo-random bytes with a frame delimiter now and then, as a
        // line at the wrong baud rate reads.
        let mut x: u32 = 12345;
        let until = Instant::now() + Duration::from_secs(3);
        while Instant::now() < until {
            let mut chunk = [0u8; 64];
            for b in chunk.iter_mut() {
                x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                *b = (x >> 24) as u8;
            }
            if socket.write_all(&chunk).is_err() {
                break;
            }
            let mut sink = [0u8; 256];
            let _ = socket.read(&mut sink);
            std::thread::sleep(Duration::from_millis(5));
        }
    });
    let link = cdpr::stream::transport::tcp(&address, Duration::from_secs(2)).unwrap();
    let mut session = Session::new(link, Options::DEFAULT);
    let dir = common::scratch("stream-garbage");
    let plan = cdpr::stream::plan::Plan::from_waypoints(&waypoints(&dir), 100.0).unwrap();
    struct Quiet;
    impl cdpr::stream::session::Observer for Quiet {
        fn telemetry(&mut self, _: f64, _: &Telemetry, _: cdpr::stream::session::Progress) {
            panic!("telemetry out of noise");
        }
    }
    let e = session
        .stream(&plan.points, &identity_of("suspended-8"), &mut Quiet, &AtomicBool::new(false))
        .unwrap_err();
    match &e {
        SessionError::Unintelligible { silent_for, bytes, rejected } => {
            assert!(*silent_for >= Duration::from_millis(500), "{e}");
            // About 64 bytes each 5 ms for the 0.5 s.
            assert!(*bytes > 1000 && *rejected > 0, "{e}");
            assert!(e.to_string().contains("baud rate"), "{e}");
        }
        other => panic!("{other}"),
    }
    drop(session);
    drop(noise.join());
}

#[test]
fn bad_input_is_one_line_and_nothing_is_sent() {
    let dir = common::scratch("stream-bad");
    let b = board(Trouble::None);
    let mut a = args(&dir, &b.address);
    // Times that go backwards in a pose table.
    let poses = dir.join("poses.csv");
    std::fs::write(
        &poses,
        "time,x,y,z,rx,ry,rz\n0.0,0,0,1.8,0,0,0\n0.05,0,0,1.8,0,0,0\n0.04,0,0,1.8,0,0,0\n",
    )
    .unwrap();
    a.waypoints = None;
    a.poses = Some(poses.clone());
    let e = stream::run(&a, &mut Vec::new(), &AtomicBool::new(false)).unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(e.message.contains("poses.csv") && !e.message.contains('\n'), "{e}");
    // A pose outside the setpoint range (x = 9 m), with its line.
    std::fs::write(&poses, "time,x,y,z,rx,ry,rz\n0.0,0,0,1.8,0,0,0\n0.05,9,0,1.8,0,0,0\n").unwrap();
    let e = stream::run(&a, &mut Vec::new(), &AtomicBool::new(false)).unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(e.message.contains("line 3") && e.message.contains("setpoint range"), "{e}");
    // A jump the board would refuse: 0.3 m in 50 ms at rest.
    std::fs::write(
        &poses,
        "time,x,y,z,rx,ry,rz\n0.0,0,0,1.8,0,0,0\n0.05,0.3,0,1.8,0,0,0\n0.1,0.3,0,1.8,0,0,0\n",
    )
    .unwrap();
    let e = stream::run(&a, &mut Vec::new(), &AtomicBool::new(false)).unwrap_err();
    assert!(e.message.contains("line 3") && e.message.contains("jump"), "{e}");
    // Rows between the board's milliseconds (a 400 Hz table).
    std::fs::write(
        &poses,
        "time,x,y,z,rx,ry,rz
0.0,0,0,1.8,0,0,0
0.0025,0,0,1.8,0,0,0
0.005,0,0,1.8,0,0,0
",
    )
    .unwrap();
    let e = stream::run(&a, &mut Vec::new(), &AtomicBool::new(false)).unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(
        e.message.contains("line 3") && e.message.contains("0.0025 s after the first row is not a whole"),
        "{e}"
    );
    // Points denser than the line carries: 1 ms apart.
    let rows: String = (0..2000).map(|k| format!("{},0,0,1.8,0,0,0\n", k as f64 / 1000.0)).collect();
    std::fs::write(&poses, format!("time,x,y,z,rx,ry,rz\n{rows}")).unwrap();
    let e = stream::run(&a, &mut Vec::new(), &AtomicBool::new(false)).unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(
        e.message.contains("poses.csv, line") && e.message.contains("more than 75 % of the 46080 bytes"),
        "{e}"
    );
    // Waypoints too far apart for the board's u32 ms clock, and too many
    // samples (both used to abort the tool, sizing the samples first).
    let waypoints = dir.join("far.csv");
    a.poses = None;
    a.waypoints = Some(waypoints.clone());
    for (last, expect) in [("1e13", "49 days"), ("1e5", "more than 2000000 samples")] {
        std::fs::write(&waypoints, format!("time,x,y,z,rx,ry,rz\n0,0,0,1.8,0,0,0\n{last},0.1,0,1.8,0,0,0\n"))
            .unwrap();
        let e = stream::run(&a, &mut Vec::new(), &AtomicBool::new(false)).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(
            e.message.contains("far.csv") && e.message.contains(expect) && !e.message.contains('\n'),
            "{e}"
        );
    }
    // A robot the firmware cannot be built for.
    a.robot = common::robot("planar3-5");
    let e = stream::run(&a, &mut Vec::new(), &AtomicBool::new(false)).unwrap_err();
    assert!(e.message.contains("6 DOF x 8 cables"), "{e}");
    // Nothing reached the board (it is still waiting to be connected to).
    assert_eq!(b.received.load(Ordering::Relaxed), 0);
    // An unknown port: one line, exit 2.
    let mut a = args(&dir, &b.address);
    a.tcp = None;
    a.port = Some("/dev/no-such-port".into());
    let e = stream::run(&a, &mut Vec::new(), &AtomicBool::new(false)).unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(e.message.starts_with("--port /dev/no-such-port"), "{e}");
    // Let the board thread end.
    drop(TcpStream::connect(&b.address));
    drop(b.thread.join());
}

/// The link check's window near the end of the board's u32 ms clock (49.7
/// days): no overflow, and two points fit.
#[test]
fn the_link_check_holds_at_the_end_of_the_clock() {
    use cdpr_control::protocol::TrajectoryPoint;
    let point =
        |time_ms| TrajectoryPoint { time_ms, pose: [0.0, 0.0, 1.8, 0.0, 0.0, 0.0], velocity: [0.0; 6] };
    let plan = cdpr::stream::plan::Plan {
        points: vec![point(u32::MAX - 500), point(u32::MAX - 250), point(u32::MAX)],
        lines: vec![Some(2), Some(3), Some(4)],
    };
    plan.check_link(Path::new("late.csv"), 460_800).unwrap();
    let e = plan.check_link(Path::new("late.csv"), 300).unwrap_err();
    assert!(
        e.message.contains("late.csv, line 2") && e.message.contains("30 bytes a second 300 baud"),
        "{e:?}"
    );
}
