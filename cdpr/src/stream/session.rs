//! The conversation with a board: telemetry on, home, fill the buffer,
//! enable once the stream plays, keep the buffer ahead of the board's
//! play time (flow control from the board's own telemetry, so a board on
//! a slower or faster clock, as under QEMU, is served alike), disable at
//! the end or on an interrupt and wait for the torque ramp.

use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cdpr_control::point_buffer::{DEPTH, START_DELAY_CYCLES};
use cdpr_control::protocol::{
    encode, DeviceMessage, FrameDecoder, HostMessage, Identity, Reason, Rejection, State, Telemetry,
    TrajectoryPoint, MAX_FRAME,
};

use super::transport::{Pacer, Transport};

/// What the session does and how long it waits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// How far ahead of the board's play time the host keeps its points, ms.
    pub lead_ms: u32,
    /// `TelemetryPeriod`: a sample every this many cycles.
    pub telemetry_period: u16,
    /// A board silent this long is reported as not answering.
    pub silence: Duration,
    /// How long a request (home, enable, disable) may take to show.
    pub request_timeout: Duration,
    /// `SelectFeedback` before enabling, if any.
    pub feedback: Option<u8>,
    /// `SelectMethod` before enabling, if any.
    pub method: Option<u8>,
    /// The line rate the host paces its bytes to, baud (8N1).
    pub baud: u32,
}

impl Options {
    /// 80 ms lead, telemetry every 10 cycles, silence 500 ms, requests
    /// 1 s, the board's defaults, 460 800 baud.
    pub const DEFAULT: Self = Self {
        lead_ms: 80,
        telemetry_period: 10,
        silence: Duration::from_millis(500),
        request_timeout: Duration::from_secs(1),
        feedback: None,
        method: None,
        baud: 460_800,
    };
}

/// How a session ended without an error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ending {
    /// Every point played; disabled, the ramp finished.
    Completed,
    /// Interrupted (Ctrl-C): disabled, the ramp finished.
    Interrupted,
}

/// Why a session failed.
#[derive(Debug)]
pub enum SessionError {
    /// No telemetry for this long, and nothing else either.
    Silent(Duration),
    /// No telemetry for this long, but bytes that are none (a serial port
    /// at another baud rate, or another program on the port).
    Unintelligible {
        /// How long since the last message the host could read.
        silent_for: Duration,
        /// Bytes received since then.
        bytes: usize,
        /// Frames among them that failed their check (COBS, CRC, decoding).
        rejected: usize,
    },
    /// The board entered Fault: the reason and the hold reason.
    Fault(Reason, Reason),
    /// A request did not take effect: what, and the board's last rejection.
    Refused(&'static str, String),
    /// The board is not where a session can start.
    NotReady(String),
    /// The board was built for another robot: its identity, and the file's.
    WrongRobot(String, String),
    /// Reading or writing the link failed.
    Io(io::Error),
}

impl std::fmt::Display for SessionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SessionError::Silent(d) => {
                write!(f, "the board stopped answering (no telemetry for {:.1} s)", d.as_secs_f64())
            }
            SessionError::Unintelligible { silent_for, bytes, rejected } => write!(
                f,
                "no telemetry for {:.1} s, yet {bytes} bytes arrived ({rejected} frames rejected): is the port's \
                 baud rate the firmware's, and is this firmware on the other end?",
                silent_for.as_secs_f64()
            ),
            SessionError::Fault(r, h) if *r == Reason::HoldTimeout => {
                write!(f, "the board faulted: {} (held for {})", r.name(), h.name())
            }
            SessionError::Fault(r, _) => write!(f, "the board faulted: {}", r.name()),
            SessionError::Refused(what, why) => {
                write!(f, "{what} refused by the board (last rejection: {why})")
            }
            SessionError::NotReady(why) => write!(f, "{why}"),
            SessionError::WrongRobot(board, file) => {
                write!(f, "the board was built for {board}, not for {file}: nothing sent")
            }
            SessionError::Io(e) => write!(f, "link: {e}"),
        }
    }
}

impl From<io::Error> for SessionError {
    fn from(e: io::Error) -> Self {
        SessionError::Io(e)
    }
}

/// Whoever watches the session: every telemetry sample as it arrives
/// (with the host's time since the start, s).
pub trait Observer {
    /// A telemetry sample.
    fn telemetry(&mut self, host_time: f64, t: &Telemetry, progress: Progress);
}

/// How far the stream is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Progress {
    /// Points sent so far.
    pub sent: usize,
    /// Points in the plan.
    pub total: usize,
    /// The board's play time, ms: its `setpoint_seq` once it plays this
    /// stream, as the stream's flow control takes it (as of the poll
    /// before the sample).
    pub played_ms: u32,
    /// The plan's last time, ms.
    pub end_ms: u32,
}

/// A session over a transport.
pub struct Session {
    link: Box<dyn Transport>,
    pacer: Pacer,
    decoder: FrameDecoder,
    options: Options,
    start: Instant,
    last_heard: Instant,
    last: Option<Telemetry>,
    identity: Option<Identity>,
    /// Bytes, and frames rejected, since the last message the host read.
    unread: (usize, usize),
}

/// `name#hash` of an identity (as `robot_file::RobotIdentity` shows it).
pub fn identity_text(i: &Identity) -> String {
    format!(
        "{}#{:016x} ({} DOF x {} cables)",
        i.name().unwrap_or("<malformed name>"),
        i.hash,
        i.dof,
        i.cables
    )
}

impl Session {
    /// A session on `link`.
    pub fn new(link: Box<dyn Transport>, options: Options) -> Self {
        let now = Instant::now();
        Self {
            link,
            pacer: Pacer::new(options.baud),
            decoder: FrameDecoder::new(),
            options,
            start: now,
            last_heard: now,
            last: None,
            identity: None,
            unread: (0, 0),
        }
    }

    /// The newest telemetry sample.
    pub fn last(&self) -> Option<&Telemetry> {
        self.last.as_ref()
    }

    /// Sends one message, paced to the line rate.
    pub fn send(&mut self, message: &HostMessage) -> Result<(), SessionError> {
        let mut frame = [0u8; MAX_FRAME];
        let n = encode(message, &mut frame).map_err(|e| io::Error::other(format!("encode: {e:?}")))?;
        self.pacer.wait_for(n);
        self.link.write_all_bytes(&frame[..n])?;
        Ok(())
    }

    /// Reads what arrived; returns the samples, reports them, and fails
    /// if the board has been silent too long.
    fn poll(&mut self, observer: &mut dyn Observer, progress: Progress) -> Result<usize, SessionError> {
        let mut buf = [0u8; 512];
        let n = self.link.read_some(&mut buf)?;
        let mut got = 0;
        for &b in &buf[..n] {
            self.unread.0 += 1;
            match self.decoder.push::<DeviceMessage>(b) {
                Some(Ok(DeviceMessage::Identity(i))) => {
                    self.last_heard = Instant::now();
                    self.unread = (0, 0);
                    self.identity = Some(i);
                }
                Some(Ok(DeviceMessage::Telemetry(t))) => {
                    self.last_heard = Instant::now();
                    self.unread = (0, 0);
                    observer.telemetry(self.start.elapsed().as_secs_f64(), &t, progress);
                    self.last = Some(t);
                    got += 1;
                }
                Some(Err(_)) => self.unread.1 += 1,
                None => {}
            }
        }
        let silent_for = self.last_heard.elapsed();
        if silent_for > self.options.silence {
            return Err(match self.unread {
                (0, _) => SessionError::Silent(silent_for),
                (bytes, rejected) => SessionError::Unintelligible { silent_for, bytes, rejected },
            });
        }
        Ok(got)
    }

    /// Polls until `done` holds for a sample, within `timeout`.
    fn wait_for(
        &mut self,
        observer: &mut dyn Observer,
        progress: Progress,
        timeout: Duration,
        mut done: impl FnMut(&Telemetry) -> bool,
    ) -> Result<bool, SessionError> {
        self.wait_until(observer, progress, timeout, |s| s.last.as_ref().is_some_and(&mut done))
    }

    /// Polls until `done` holds for the session, within `timeout`.
    fn wait_until(
        &mut self,
        observer: &mut dyn Observer,
        progress: Progress,
        timeout: Duration,
        mut done: impl FnMut(&Self) -> bool,
    ) -> Result<bool, SessionError> {
        let until = Instant::now() + timeout;
        while Instant::now() < until {
            self.poll(observer, progress)?;
            if done(self) {
                return Ok(true);
            }
        }
        Ok(false)
    }

    fn rejection(&self) -> String {
        self.last.map_or_else(|| "none".into(), |t| t.counters.last_rejection.name().to_string())
    }

    /// Connects: telemetry on, the first sample within the silence limit.
    pub fn connect(&mut self, observer: &mut dyn Observer) -> Result<Telemetry, SessionError> {
        self.last_heard = Instant::now();
        self.unread = (0, 0);
        self.send(&HostMessage::TelemetryPeriod(self.options.telemetry_period))?;
        let silence = self.options.silence;
        self.wait_for(observer, Progress::default(), silence, |_| true)?;
        self.last.ok_or(SessionError::Silent(silence))
    }

    /// Asks the board which robot it was built for (`Identify`), within
    /// the request timeout.
    pub fn identify(&mut self, observer: &mut dyn Observer) -> Result<Identity, SessionError> {
        self.identity = None;
        self.send(&HostMessage::Identify)?;
        let timeout = self.options.request_timeout;
        self.wait_until(observer, Progress::default(), timeout, |s| s.identity.is_some())?;
        self.identity.ok_or_else(|| SessionError::Refused("Identify", self.rejection()))
    }

    /// Streams `points` (times from 0 ms) to a board built for `expected`
    /// (refused before anything else is sent otherwise): homes at the first pose, selects
    /// the feedback and method if asked, fills the buffer, enables once the
    /// stream plays, keeps the buffer `lead_ms` ahead, and disables when
    /// the last point has played or `interrupt` is set.
    pub fn stream(
        &mut self,
        points: &[TrajectoryPoint],
        expected: &Identity,
        observer: &mut dyn Observer,
        interrupt: &AtomicBool,
    ) -> Result<Ending, SessionError> {
        self.connect(observer)?;
        let board = self.identify(observer)?;
        if board != *expected {
            return Err(SessionError::WrongRobot(identity_text(&board), identity_text(expected)));
        }
        let first = self.last.ok_or(SessionError::Silent(self.options.silence))?;
        let total = points.len();
        let end_ms = points.last().map_or(0, |p| p.time_ms);
        let mut progress = Progress { sent: 0, total, played_ms: 0, end_ms };
        match first.state {
            State::Disabled => {}
            State::Fault => {
                return Err(SessionError::NotReady(format!(
                    "the board is in fault ({}); clear it first",
                    first.reason.name()
                )))
            }
            s => {
                return Err(SessionError::NotReady(format!(
                    "the board is {} (another host streams?)",
                    s.name()
                )))
            }
        }
        let timeout = self.options.request_timeout;
        let start = points.first().ok_or_else(|| SessionError::NotReady("nothing to stream".into()))?;
        self.send(&HostMessage::Home(start.pose))?;
        if !self.wait_for(observer, progress, timeout, |t| t.homed)? {
            return Err(SessionError::Refused("Home", self.rejection()));
        }
        if let Some(f) = self.options.feedback {
            self.send(&HostMessage::SelectFeedback(f))?;
        }
        if let Some(m) = self.options.method {
            self.send(&HostMessage::SelectMethod(m))?;
            let want = m;
            if !self.wait_for(observer, progress, timeout, |t| t.method == want)? {
                return Err(SessionError::Refused("SelectMethod", self.rejection()));
            }
        }
        if let Some(f) = self.options.feedback {
            if !self.wait_for(observer, progress, timeout, |t| t.feedback == f)? {
                // `range`: the board has no such PID for its robot.
                let range = self.last.is_some_and(|t| t.counters.last_rejection == Rejection::Range);
                let why = match (range, f) {
                    (true, 1) => {
                        "range: no task-space PID for this robot, whose file gives the platform no inertia \
                                  (its rotation gains would be zero)"
                            .to_string()
                    }
                    (true, 2) => {
                        "range: no joint-space PID for this robot (no kinematics at the centre of its \
                                  setpoint range)"
                            .to_string()
                    }
                    _ => self.rejection(),
                };
                return Err(SessionError::Refused("SelectFeedback", why));
            }
        }
        // The stream: flow control on the board's play time. Until the
        // board reports it, the play time is taken as the first point's
        // less the start delay.
        let t0 = start.time_ms;
        let mut played = t0.saturating_sub(START_DELAY_CYCLES);
        let mut enable_sent: Option<Instant> = None;
        let mut enabled = false;
        let mut started = false;
        loop {
            if interrupt.load(Ordering::Relaxed) {
                self.disable(observer, progress)?;
                return Ok(Ending::Interrupted);
            }
            // Points `lead_ms` ahead of the play time, but never more than
            // the board's buffer holds: it keeps the point that starts the
            // segment it plays, and at most `DEPTH - 1` after it. The play
            // time comes from telemetry, so it lags the board's: the count
            // of points ahead is an upper bound (at 100 Hz the lead bounds
            // first; from 400 Hz, 80 ms of points are more than the buffer).
            while progress.sent < total
                && points[progress.sent].time_ms <= played.saturating_add(self.options.lead_ms)
                && progress.sent - points.partition_point(|p| p.time_ms <= played).min(progress.sent)
                    < DEPTH - 1
            {
                self.send(&HostMessage::Point(points[progress.sent]))?;
                progress.sent += 1;
            }
            self.poll(observer, progress)?;
            let Some(t) = self.last else { continue };
            // The board's play time is its setpoint number once the stream
            // plays (and stays so when the buffer has played out). Until it
            // plays this stream's points (the start delay), the board still
            // reports the last stream's play time: never beyond the newest
            // point sent, which tells the two apart (taken for this one's, a
            // last stream's end sent every point at once into the buffer).
            let playing = t.buffer_fill > 0 || t.buffer_lead_ms > 0;
            started |= playing;
            let newest = progress.sent.checked_sub(1).map_or(t0, |i| points[i].time_ms);
            if started && (t0..=newest).contains(&t.setpoint_seq) {
                played = played.max(t.setpoint_seq);
            }
            progress.played_ms = played;
            match t.state {
                State::Fault => return Err(SessionError::Fault(t.reason, t.hold_reason)),
                State::Enabled | State::Holding => enabled = true,
                State::Disabled if enabled => {
                    return Err(SessionError::NotReady("the board disabled itself (another host?)".into()))
                }
                State::Disabled => {}
            }
            if !enabled {
                match enable_sent {
                    None if playing && t.solved => {
                        self.send(&HostMessage::Enable)?;
                        enable_sent = Some(Instant::now());
                    }
                    Some(at) if at.elapsed() > timeout => {
                        return Err(SessionError::Refused("Enable", self.rejection()));
                    }
                    _ => {}
                }
            }
            let all_played = progress.sent == total && played >= end_ms && !playing;
            if enabled && all_played {
                self.disable(observer, progress)?;
                return Ok(Ending::Completed);
            }
        }
    }

    /// Disable, then wait for Disabled with the torque ramp finished.
    fn disable(&mut self, observer: &mut dyn Observer, progress: Progress) -> Result<(), SessionError> {
        self.send(&HostMessage::Disable)?;
        // The ramp is 200 ms; allow the request timeout on top.
        let timeout = self.options.request_timeout + Duration::from_millis(200);
        let done = self.wait_for(observer, progress, timeout, |t| {
            t.state == State::Disabled && t.torques.iter().all(|&x| x == 0.0)
        })?;
        if !done {
            return match self.last {
                Some(t) if t.state == State::Fault => Err(SessionError::Fault(t.reason, t.hold_reason)),
                _ => Err(SessionError::Refused("Disable", self.rejection())),
            };
        }
        Ok(())
    }
}
