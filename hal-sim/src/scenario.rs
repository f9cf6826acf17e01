//! Closed-loop runs: the firmware's control loop (`cdpr_control::ControlLoop`,
//! fed byte by byte through the simulated serial link) with its task-space
//! or joint-space PID on what it reads from the winch encoders, against the
//! simulated robot, scripted by a [`Scenario`].
//!
//! Every 1 ms cycle, in this order (the firmware's order):
//!
//! 1. the host queues its frames (`TelemetryPeriod`, `SelectFeedback(1)`
//!    and `Home` with the path's start pose at the start, the reference
//!    path's trajectory points at 100 Hz [`Stream::POINTS`] ahead of time
//!    while it streams, `Enable` once), the link delivers what 460 800
//!    baud carries in 1 ms (46 bytes), each goes to
//!    `ControlLoop::receive_byte`;
//! 2. the plant is sampled (the true pose, for the records only);
//! 3. `ControlLoop::step` reads the plant's encoders, checks the lengths,
//!    estimates the pose, runs the PID and the tension distribution and
//!    writes torques and brakes into the plant (`WinchDrives`);
//! 4. telemetry frames go back over the link to the host;
//! 5. the plant integrates 1 ms (RK4, 0.1 ms steps) with those commands.

use cdpr_control::controller::FrictionCompensation;
use cdpr_control::encoder::EncoderScale;
use cdpr_control::estimator::EstimatorSettings;
use cdpr_control::feedback::{FeedbackLimits, Gains, Scheme, TaskPid};
use cdpr_control::link::SetpointRange;
use cdpr_control::protocol::{
    HostMessage, Reason, Setpoint as WireSetpoint, State, Telemetry, TrajectoryPoint,
};
use cdpr_control::supervisor::SafetyLimits;
use cdpr_control::{ControlLoop, ControlRobot, TickCounter, CABLES};
use nalgebra::{SVector, Vector3};
use tension_core::trajectory::time_law;
use tension_core::Method;

use crate::can::{CanFault, CanWinches};
use crate::link::{Host, SerialLink, SimClock, WallTicks, BAUD};
use crate::plant::{
    CableModel, Derate, Disturbance, Encoders, Mismatch, Plant, PlantFaults, PlantRobot, WinchModel,
};
use crate::site::Site;

/// `x` as a description shows it: up to four decimals, no trailing zeros.
fn shown(x: f64) -> String {
    let s = format!("{x:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

/// Control period, s.
pub const PERIOD: f64 = 0.001;

/// A pose and its first two time derivatives (conventions: pose order).
pub type Reference = ([f64; 6], [f64; 6], [f64; 6]);

/// The pose the host asks for over time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Path {
    /// One pose, at rest.
    Hold([f64; 6]),
    /// From `base` (at rest), one closed loop of `period` s starting at
    /// `start` s, back to `base` at rest: with `phi = 2 pi s(u)`, `s` the
    /// 7th-degree time law and `u = (t - start) / period`, the pose is
    /// `base + [AX sin phi, AY sin 2 phi, AZ (1 - cos phi), RX sin 2 phi,
    /// RY sin phi, RZ sin phi]` with `amplitudes` (suspended-8's:
    /// [`LOOP_AMPLITUDES`]).
    Loop {
        /// Start and end pose.
        base: [f64; 6],
        /// Start time, s.
        start: f64,
        /// Duration, s.
        period: f64,
        /// `[AX, AY, AZ, RX, RY, RZ]`, m and rad.
        amplitudes: [f64; 6],
    },
    /// `from` until `at` s, then `to` (both at rest): a step.
    Jump {
        /// Before the step.
        from: [f64; 6],
        /// After the step.
        to: [f64; 6],
        /// Step time, s.
        at: f64,
    },
}

/// `[AX, AY, AZ, RX, RY, RZ]` of suspended-8's [`Path::Loop`], m and rad.
pub const LOOP_AMPLITUDES: [f64; 6] = [0.8, 0.35, 0.35, 0.05, 0.05, 0.1];

impl Path {
    /// The reference at time `t`, s.
    pub fn at(&self, t: f64) -> Reference {
        match *self {
            Path::Hold(p) => (p, [0.0; 6], [0.0; 6]),
            Path::Jump { from, to, at } => (if t < at { from } else { to }, [0.0; 6], [0.0; 6]),
            Path::Loop { base, start, period, amplitudes } => {
                let (s, ds, dds) = time_law((t - start) / period);
                let tau = 2.0 * core::f64::consts::PI;
                let (phi, dphi, ddphi): (f64, f64, f64) =
                    (tau * s, tau * ds / period, tau * dds / (period * period));
                let a = amplitudes;
                let (s1, c1) = phi.sin_cos();
                let (s2, c2) = (2.0 * phi).sin_cos();
                let f = [a[0] * s1, a[1] * s2, a[2] * (1.0 - c1), a[3] * s2, a[4] * s1, a[5] * s1];
                let df = [a[0] * c1, 2.0 * a[1] * c2, a[2] * s1, 2.0 * a[3] * c2, a[4] * c1, a[5] * c1];
                let ddf = [-a[0] * s1, -4.0 * a[1] * s2, a[2] * c1, -4.0 * a[3] * s2, -a[4] * s1, -a[5] * s1];
                let mut out = ([0.0; 6], [0.0; 6], [0.0; 6]);
                for k in 0..6 {
                    out.0[k] = base[k] + f[k];
                    out.1[k] = df[k] * dphi;
                    out.2[k] = ddf[k] * dphi * dphi + df[k] * ddphi;
                }
                out
            }
        }
    }

    /// The pose at time 0 (where the platform starts, at rest).
    pub fn start(&self) -> [f64; 6] {
        self.at(0.0).0
    }
}

/// One scripted run.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Name (`--scenario`), also the output files' stem.
    pub name: String,
    /// One line on what it shows.
    pub description: String,
    /// Simulated duration, s.
    pub duration: f64,
    /// What the host asks for.
    pub path: Path,
    /// When the host sends `Enable`, s (the platform starts at rest on its
    /// brakes at the path's start pose).
    pub enable_at: f64,
    /// The host stops streaming setpoints at this time (a lost stream).
    pub stream_until: Option<f64>,
    /// Differences between the simulated robot and the robot file.
    pub mismatch: Mismatch,
    /// Disturbance wrenches.
    pub disturbances: Vec<Disturbance>,
    /// Injected plant faults.
    pub faults: PlantFaults,
    /// The time of the injected event (fault, step, lost stream), if any.
    pub event: Option<f64>,
    /// The feedback scheme the host selects (`SelectFeedback`).
    pub scheme: Scheme,
    /// Where the platform really starts, relative to where the host
    /// believes it is (the path's start, which it homes at): zero but for
    /// a wrong homing. Added to the pose components (m, rad).
    pub start_error: [f64; 6],
    /// A drive or bus fault at `event` (runs on the CAN buses only:
    /// [`Config::can`]).
    pub can_fault: Option<CanFault>,
    /// The robot file: the plant's robot and the controller's.
    pub robot: std::path::PathBuf,
}

/// The anchor error of every scenario, m: each of the plant's anchors is
/// this far from the robot file's (`plant::anchor_offsets`).
pub const ANCHOR_ERROR: f64 = 0.002;

/// The model error of every scenario: the payload 2 % heavier than the
/// robot file, its centre of mass 2-3 mm off, and every anchor
/// [`ANCHOR_ERROR`] off in a fixed pattern (`plant::anchor_offsets`).
pub fn mismatch() -> Mismatch {
    Mismatch {
        mass_factor: 1.02,
        com_offset: [0.002, -0.002, 0.003],
        anchor_offsets: crate::plant::anchor_offsets(ANCHOR_ERROR),
    }
}

/// The suffix of the joint-space variant of each scenario's name.
pub const JOINT_SUFFIX: &str = "-joint";

pub use crate::site::{FAULT_POSE, HOLD_POSES, TRACK};

impl Scenario {
    fn base(site: &Site, name: &str, description: &str, duration: f64, path: Path) -> Self {
        Self {
            name: name.into(),
            description: description.into(),
            duration,
            path,
            enable_at: 0.05,
            stream_until: None,
            mismatch: mismatch(),
            disturbances: Vec::new(),
            faults: PlantFaults::default(),
            event: None,
            // `all` adds the joint-space variant of each.
            scheme: Scheme::TaskSpace,
            start_error: [0.0; 6],
            can_fault: None,
            robot: site.file.clone(),
        }
    }

    /// [`Self::base`] with its event at `event` s (what the run reports
    /// before and after).
    fn at_event(site: &Site, name: &str, description: &str, duration: f64, path: Path, event: f64) -> Self {
        Self { event: Some(event), ..Self::base(site, name, description, duration, path) }
    }

    /// The scheme's name suffix: `""` (task space) or [`JOINT_SUFFIX`].
    pub fn suffix(scheme: Scheme) -> &'static str {
        if scheme == Scheme::JointSpace {
            JOINT_SUFFIX
        } else {
            ""
        }
    }

    /// This scenario with `scheme`, named `NAME` (task space) or `NAME-joint`.
    pub fn with_scheme(&self, scheme: Scheme) -> Self {
        let base = self.name.strip_suffix(JOINT_SUFFIX).unwrap_or(&self.name);
        Self { name: format!("{base}{}", Self::suffix(scheme)), scheme, ..self.clone() }
    }

    /// Every scenario on suspended-8 ([`Site::suspended_8`]), each with
    /// the task-space PID (`NAME`) and with the joint-space PID
    /// (`NAME-joint`).
    pub fn all() -> Vec<Scenario> {
        Self::all_at(&Site::suspended_8())
    }

    /// Every scenario on `site`'s robot and poses, each with the
    /// task-space PID (`NAME`) and with the joint-space PID (`NAME-joint`).
    pub fn all_at(site: &Site) -> Vec<Scenario> {
        let mut out = Vec::new();
        for s in Self::task_space(site) {
            let joint = s.with_scheme(Scheme::JointSpace);
            out.push(s);
            out.push(joint);
        }
        out
    }

    /// The four static holds, the tracking loop, the faults and the
    /// homing errors, with the task-space PID.
    fn task_space(site: &Site) -> Vec<Scenario> {
        let mut out = Vec::new();
        let push = crate::site::PUSH.map(|x| x * site.weight_scale);
        let pushed = format!(
            "static hold for 10 s with a 2 % payload error and a 3-6 s push of ({}, {}, {}) N, ({}, {}, {}) N m",
            shown(push[0]),
            shown(push[1]),
            shown(push[2]),
            shown(push[3]),
            shown(push[4]),
            shown(push[5])
        );
        for (name, pose) in site.holds {
            let mut s = Self::base(site, name, &pushed, 10.05, Path::Hold(pose));
            s.disturbances.push(Disturbance { start: 3.0, end: 6.0, wrench: push });
            out.push(s);
        }
        let (fault_pose, track) = (site.fault_pose, site.track);
        out.push(Self::base(site, "track", "one 8 s loop through the workspace and back", 8.5, track));

        let event = 1.0;
        let mut s = Self::at_event(
            site,
            "cable-break",
            "cable 1 breaks at 1 s while holding",
            2.0,
            Path::Hold(fault_pose),
            event,
        );
        s.faults.cable_break = Some((0, event));
        out.push(s);

        // 0.03 N m on suspended-8's winches, less than holding takes.
        let derated = 0.03 * site.motor_scale;
        let mut s = Self::at_event(
            site,
            "winch-saturation",
            &format!("at 1 s drive 3 can deliver only {} N m and reports its current limit", shown(derated)),
            2.0,
            Path::Hold(fault_pose),
            event,
        );
        s.faults.derate = Some(Derate { cable: 2, at: event, torque: derated, report: true });
        out.push(s);

        let (to, what) = &site.infeasible;
        out.push(Self::at_event(
            site,
            "infeasible-setpoint",
            &format!("at 1 s the setpoint jumps to {what}: rejected as a jump"),
            2.0,
            Path::Jump { from: fault_pose, to: *to, at: event },
            event,
        ));

        let (to, what) = &site.out_of_range;
        out.push(Self::at_event(
            site,
            "out-of-range-setpoint",
            &format!("at 1 s the setpoint jumps {what}"),
            2.0,
            Path::Jump { from: fault_pose, to: *to, at: event },
            event,
        ));

        let mut s = Self::at_event(
            site,
            "lost-stream",
            "the host stops streaming at 1 s while holding",
            2.0,
            Path::Hold(fault_pose),
            event,
        );
        s.stream_until = Some(event);
        out.push(s);

        let stop = 3.0;
        let mut s = Self::at_event(
            site,
            "lost-stream-moving",
            &format!("the host stops streaming at 3 s, {}", site.motion.0),
            4.0,
            track,
            stop,
        );
        s.stream_until = Some(stop);
        out.push(s);

        let stuck = 2.0;
        let mut s = Self::at_event(
            site,
            "encoder-stuck",
            &format!("encoder 1 stops counting at 2 s, {}", site.motion.1),
            3.0,
            track,
            stuck,
        );
        s.faults.encoder_stuck = Some((0, stuck));
        out.push(s);

        // On the CAN buses (`Config::can`), mid-loop like `encoder-stuck`.
        for (name, description, fault) in [
            (
                "can-drive-fault",
                "cable 3's drive faults (EMCY 0x2310 over-current) at 2 s, mid-loop",
                CanFault::DriveFault { cable: 2, code: 0x2310 },
            ),
            (
                "can-drive-drop",
                "cable 6's drive drops off the bus at 2 s, mid-loop",
                CanFault::DropOff { cable: 5 },
            ),
            ("can-bus-off", "CAN2 goes bus-off at the board at 2 s, mid-loop", CanFault::BusOff { bus: 1 }),
        ] {
            let mut s = Self::at_event(site, name, description, 3.0, track, stuck);
            s.can_fault = Some(fault);
            out.push(s);
        }

        let mut s = Self::base(
            site,
            "wrong-homing",
            "the host homes (and starts its loop) 20 mm off the true pose, along x",
            8.5,
            track,
        );
        s.start_error = [0.02, 0.0, 0.0, 0.0, 0.0, 0.0];
        out.push(s);

        let mut s = Self::base(
            site,
            "wrong-homing-rotation",
            "the host homes (and starts its loop) 0.1 rad off the true pose, about z",
            8.5,
            track,
        );
        s.start_error = [0.0, 0.0, 0.0, 0.0, 0.0, 0.1];
        out.push(s);

        let mut s = Self::at_event(
            site,
            "drive-unreadable",
            "from 1 s drive 5 cannot be read, while holding",
            2.0,
            Path::Hold(fault_pose),
            event,
        );
        s.faults.unreadable = Some((4, event));
        out.push(s);
        out
    }

    /// Where the platform really starts (`path.start() + start_error`).
    pub fn true_start(&self) -> [f64; 6] {
        let mut p = self.path.start();
        for (a, e) in p.iter_mut().zip(self.start_error) {
            *a += e;
        }
        p
    }

    /// The scenario called `name`, on suspended-8.
    pub fn named(name: &str) -> Option<Scenario> {
        Self::all().into_iter().find(|s| s.name == name)
    }

    /// The scenario called `name`, on `site`.
    pub fn named_at(site: &Site, name: &str) -> Option<Scenario> {
        Self::all_at(site).into_iter().find(|s| s.name == name)
    }
}

/// How the host sends the reference path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// Trajectory points (`HostMessage::Point`) every `period_ms`, each
    /// sent `lead_ms` before its time: the board buffers and interpolates.
    Points {
        /// Time between points, ms.
        period_ms: u32,
        /// How far ahead of its time the host sends a point, ms.
        lead_ms: u32,
    },
    /// A `HostMessage::Setpoint` every cycle (80 bytes a millisecond: more
    /// than 460 800 baud carries).
    EveryCycle,
}

impl Stream {
    /// 100 Hz points, 30 ms ahead (the firmware README's link budget).
    pub const POINTS: Self = Self::Points { period_ms: 10, lead_ms: 30 };
}

/// Settings shared by every run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config {
    /// Integration step, s.
    pub dt: f64,
    /// Cable-length tracking limit of `ControlLoop::step` (`set_tracking_limit`), m.
    pub length_limit: f32,
    /// The feedback's bandwidth, Hz (the robot file's `[control]
    /// bandwidth`, as on the board): the joint-space PID's triple pole
    /// (`ControlLoop::set_bandwidth`); [`Config::for_site`] puts `gains`'
    /// there too.
    pub bandwidth_hz: f32,
    /// The task-space PID's gains.
    pub gains: Gains,
    /// PID limits.
    pub limits: FeedbackLimits,
    /// The line rate, baud (8N1).
    pub baud: u32,
    /// What the host streams.
    pub stream: Stream,
    /// Winch model.
    pub winch: WinchModel,
    /// Cable model.
    pub cable: CableModel,
    /// The friction the controller compensates.
    pub friction: Option<FrictionCompensation>,
    /// The winches behind CiA 402 drives on two simulated CAN buses
    /// ([`crate::can`]) instead of read and written directly.
    pub can: bool,
    /// The estimator's settings.
    pub estimator: EstimatorSettings,
    /// How the task-space feedback backs off.
    pub back_off: cdpr_control::BackOff,
    /// The loop delay the task-space PID predicts over, s.
    pub loop_delay: f32,
}

/// The controller's friction model: 80 % of the simulated winches'
/// Coulomb and viscous friction (an identification that is 20 % short).
pub const FRICTION_ESTIMATE: FrictionCompensation = friction_estimate(WinchModel::DEFAULT);

/// [`FRICTION_ESTIMATE`]'s rule for `winch`: 80 % of its friction.
pub const fn friction_estimate(winch: WinchModel) -> FrictionCompensation {
    FrictionCompensation {
        coulomb: 0.8 * winch.coulomb as f32,
        coulomb_speed: winch.coulomb_speed as f32,
        viscous: 0.8 * winch.viscous as f32,
    }
}

impl Config {
    /// The settings of `hal-sim/README.md` for suspended-8 (panics if the
    /// shipped robot file cannot be read).
    pub fn standard() -> Self {
        Self::for_site(&Site::suspended_8()).unwrap_or_else(|e| panic!("{e}"))
    }

    /// The settings of `hal-sim/README.md` for `site`'s robot: the gains
    /// from its platform (the triple pole at its file's bandwidth, 5 Hz
    /// unless `[control] bandwidth` says otherwise), the feedback's bounds
    /// scaled by its weight ([`Site::weight_scale`]: the firmware's rule),
    /// the winches' inertia and friction scaled by their motors
    /// ([`Site::motor_scale`]).
    pub fn for_site(site: &Site) -> Result<Self, String> {
        let file = read_robot_file(&site.file)?;
        let robot: PlantRobot = robot_of(&file, &site.file)?;
        let bandwidth_hz = file.bandwidth_hz() as f32;
        let omega = 2.0 * core::f32::consts::PI * bandwidth_hz;
        let platform = robot.platform();
        let mass = platform.mass as f32;
        let inertia = platform.inertia.map(|x| x as f32);
        let k = site.weight_scale as f32;
        let winch = WinchModel::DEFAULT.scaled(site.motor_scale);
        Ok(Self {
            bandwidth_hz,
            dt: 1.0e-4,
            length_limit: 0.02,
            gains: Gains::triple_pole(
                mass,
                [inertia[(0, 0)], inertia[(1, 1)], inertia[(2, 2)]],
                omega,
                omega,
            ),
            limits: FeedbackLimits {
                force_max: 50.0 * k,
                moment_max: 6.0 * k,
                integral_max: [20.0, 20.0, 20.0, 2.0, 2.0, 2.0].map(|x| x * k),
            },
            baud: BAUD,
            stream: Stream::POINTS,
            winch,
            cable: CableModel::DEFAULT,
            friction: Some(friction_estimate(winch)),
            can: false,
            estimator: EstimatorSettings::DEFAULT,
            back_off: cdpr_control::BackOff::ForceFirst,
            loop_delay: 0.0,
        })
    }

    /// [`Config::standard`] with the winches on the CAN buses.
    pub fn can() -> Self {
        Self::standard().on_can_buses()
    }

    /// These settings with the winches on the CAN buses.
    pub fn on_can_buses(self) -> Self {
        let delay_ns = canopen_drives::added_loop_delay_ns(
            crate::can::STEP_NS as u32,
            4,
            1_000_000,
            canopen_drives::Timing::DEFAULT.cycle_hz,
        );
        Self {
            can: true,
            loop_delay: delay_ns as f32 * 1e-9,
            estimator: EstimatorSettings::FIELD_BUS,
            ..self
        }
    }
}

/// One control cycle's record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Time at the start of the cycle, s.
    pub t: f64,
    /// State after the cycle's step.
    pub state: State,
    /// Its reason.
    pub reason: Reason,
    /// Brakes commanded.
    pub brakes: bool,
    /// Brakes holding the drums (after the engagement delay).
    pub locked: bool,
    /// True pose of the platform.
    pub pose: [f64; 6],
    /// The trajectory time the board played this cycle (its setpoint's), s.
    pub played: f64,
    /// The reference pose at `played`.
    pub reference: [f64; 6],
    /// `reference - pose`: position (m) and rotation vector (rad), base frame.
    pub error: [f64; 6],
    /// Speed of the platform origin, m/s.
    pub speed: f64,
    /// True cable tensions, N.
    pub tensions: [f64; CABLES],
    /// Tensions the controller solved for this cycle (NaN when none).
    pub commanded: [f32; CABLES],
    /// Torques written to the drives, N m.
    pub torques: [f32; CABLES],
    /// The PID's wrench (what the cables add to the feed-forward; base
    /// frame, about the platform origin), N and N m.
    pub feedback: [f32; 6],
    /// The control loop's pose estimate this cycle (NaN when none; from
    /// its `StepReport`, recorded only, never fed back).
    pub estimate: [f32; 6],
    /// The estimator's worst cable residual this cycle, m (NaN when none).
    pub residual: f32,
    /// The drive the loop could not read this cycle.
    pub unreadable_drive: Option<u8>,
    /// On the CAN buses: the drives whose brake is engaged at the cycle's
    /// end, one bit per cable (`None` without the buses).
    pub drive_brakes: Option<u8>,
}

impl Row {
    /// `|position error|`, m.
    pub fn position_error(&self) -> f64 {
        Vector3::new(self.error[0], self.error[1], self.error[2]).norm()
    }

    /// Rotation error angle, rad.
    pub fn rotation_error(&self) -> f64 {
        Vector3::new(self.error[3], self.error[4], self.error[5]).norm().min(1.0).asin()
    }

    /// Position of the estimate less the true position, m (NaN when no estimate).
    pub fn estimate_error(&self) -> [f64; 3] {
        core::array::from_fn(|k| f64::from(self.estimate[k]) - self.pose[k])
    }
}

/// Everything a run produced.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The scenario.
    pub scenario: Scenario,
    /// One row per cycle.
    pub rows: Vec<Row>,
    /// Telemetry as the host decoded it from the link.
    pub telemetry: Vec<Telemetry>,
    /// State changes: time, new state, reason, hold reason.
    pub transitions: Vec<(f64, State, Reason, Reason)>,
    /// Mean and largest wall-clock time of `ControlLoop::step`, ns.
    pub step_ns: (u64, u64),
    /// The control loop's counters at the end.
    pub counters: cdpr_control::protocol::Counters,
}

fn to_wire(seq: u32, r: &Reference) -> WireSetpoint {
    WireSetpoint {
        seq,
        pose: r.0.map(|v| v as f32),
        velocity: r.1.map(|v| v as f32),
        acceleration: r.2.map(|v| v as f32),
    }
}

/// Base-frame error `reference - pose` (position, rotation vector).
fn pose_error(robot: &PlantRobot, reference: &[f64; 6], pose: &[f64; 6]) -> [f64; 6] {
    let frame = |p: &[f64; 6]| robot.frame(&SVector::from(*p)).ok();
    match (frame(reference), frame(pose)) {
        (Some((pd, rd)), Some((p, r))) => {
            let e = rd * r.transpose();
            let ep = pd - p;
            let er = Vector3::new(e[(2, 1)] - e[(1, 2)], e[(0, 2)] - e[(2, 0)], e[(1, 0)] - e[(0, 1)]) * 0.5;
            [ep.x, ep.y, ep.z, er.x, er.y, er.z]
        }
        _ => [f64::NAN; 6],
    }
}

/// Reads the robot file.
fn read_robot_file(path: &std::path::Path) -> Result<robot_file::RobotFile, String> {
    robot_file::RobotFile::load(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// The robot file's robot in `T` (`f64` for the plant, `f32` for the
/// controller, as on the board).
fn robot_of<T: tension_core::Real>(
    file: &robot_file::RobotFile,
    path: &std::path::Path,
) -> Result<tension_core::Robot<T, 6, CABLES>, String> {
    file.to_robot::<T, 6, CABLES>().map_err(|e| format!("{}: {e}", path.display()))
}

/// Loads the robot file as the plant's robot.
pub fn load_robot(path: &std::path::Path) -> Result<PlantRobot, String> {
    robot_of(&read_robot_file(path)?, path)
}

/// Loads the robot file as the controller's robot (`f32`, as on the board).
pub fn load_controller_robot(path: &std::path::Path) -> Result<ControlRobot, String> {
    robot_of(&read_robot_file(path)?, path)
}

/// The robot file's encoders: the control loop's scale and the plant's
/// counting (whether they count the robot's cables is the control loop's
/// check, `ControlLoop::set_encoder`, as on the board).
pub(crate) fn encoders_of(
    file: &robot_file::RobotFile,
    path: &std::path::Path,
) -> Result<(EncoderScale, [i8; CABLES], u32), String> {
    let winch = file.winch.ok_or_else(|| format!("{}: no [winch]", path.display()))?;
    let signs = <[i8; CABLES]>::try_from(file.encoder.signs.as_slice())
        .map_err(|_| format!("{}: [winch] encoder_sign: not one per cable of {CABLES}", path.display()))?;
    let cpr = file.encoder.counts_per_revolution;
    let scale = EncoderScale::new(winch[0] as f32, winch[1] as f32, cpr, signs)
        .map_err(|e| format!("{}: [winch]: {e}", path.display()))?;
    Ok((scale, signs, cpr))
}

/// Cycles the CAN drives have to start up in (`Config::can`).
pub const CAN_START_CYCLES: u32 = 500;

/// Runs `scenario` with `config`.
pub fn run(scenario: &Scenario, config: &Config) -> Result<Outcome, String> {
    // The robot file, read once: the plant's robot, the controller's, the
    // encoders and the drives.
    let path = &scenario.robot;
    let file = read_robot_file(path)?;
    let file_robot: PlantRobot = robot_of(&file, path)?;
    let mut plant = Plant::new(
        file_robot.clone(),
        config.winch,
        config.cable,
        scenario.mismatch,
        scenario.true_start(),
        config.dt,
    )
    .map_err(|e| format!("start pose: {}", e.status()))?;
    let (scale, signs, cpr) = encoders_of(&file, path)?;
    plant.set_encoders(Encoders { counts_per_revolution: cpr, signs, ..plant.encoders() });
    plant.set_faults(scenario.faults);
    for d in &scenario.disturbances {
        plant.add_disturbance(*d);
    }
    let controller_robot: ControlRobot = robot_of(&file, path)?;
    let range = SetpointRange::for_robot(&controller_robot);
    let mut control = ControlLoop::new(controller_robot, Method::Barycenter, range, SafetyLimits::DEFAULT)
        .map_err(|e| format!("control loop: {}", e.status()))?;
    control.set_bandwidth(config.bandwidth_hz).map_err(|e| format!("bandwidth: {}", e.status()))?;
    control.controller_mut().set_friction(config.friction);
    control.set_encoder(scale).map_err(|e| format!("{}: [winch]: {e}", path.display()))?;
    control.set_task_pid(
        TaskPid::new(config.gains, config.limits).map_err(|e| format!("feedback limits: {}", e.status()))?,
    );
    control.set_estimator(config.estimator);
    control.set_back_off(config.back_off);
    control.set_loop_delay(config.loop_delay);
    control.set_tracking_limit(Some(config.length_limit));
    // The board refuses a scheme it has no PID for (`range`): said here,
    // rather than a run labelled with a PID that never acted.
    let refused = match scenario.scheme {
        Scheme::TaskSpace if !control.task_pid().acts_on_every_axis() => Some(
            "no task-space PID: its gains leave an axis without feedback (a robot file without [platform] \
             inertia gives zero rotation gains), and the board refuses SelectFeedback(1)",
        ),
        Scheme::JointSpace if control.joint_pid().is_none() => Some(
            "no joint-space PID: no kinematics at the setpoint range's centre, and the board refuses \
             SelectFeedback(2)",
        ),
        _ => None,
    };
    if let Some(why) = refused {
        return Err(format!("{}: {why}", scenario.robot.display()));
    }
    let mut link = SerialLink::at_baud(config.baud);
    let mut next_point_ms = 0u32;
    let mut host = Host::new();
    let mut clock = SimClock::default();
    let wall = WallTicks::new();
    let mut frame = [0u8; cdpr_control::protocol::MAX_FRAME];

    let cycles = (scenario.duration / PERIOD).round() as u32;
    let enable_cycle = (scenario.enable_at / PERIOD).round() as u32;
    let mut rows = Vec::with_capacity(cycles as usize);
    let mut transitions = Vec::new();
    let mut last_state = control.supervisor().state();
    let (mut step_sum, mut step_max) = (0u64, 0u64);
    let send = |host: &Host, link: &mut SerialLink, m: HostMessage| {
        host.send(link, &m).map_err(|e| format!("encode: {e:?}"))
    };
    // On the CAN buses the drives start up first (boot-up, configuration,
    // NMT start: about 60 ms) with the platform on its brakes; the host's
    // script (and the records) start once they are ready.
    let mut can = if config.can {
        let mut c = CanWinches::for_robot_file(&file)?;
        let mut ready = false;
        for _ in 0..CAN_START_CYCLES {
            c.before_step();
            control.step(&clock, &mut c.layer, false);
            c.advance(&mut plant, PERIOD);
            clock.micros += 1000;
            if c.layer.ready() {
                ready = true;
                break;
            }
        }
        if !ready {
            return Err(format!("the CAN drives were not ready after {CAN_START_CYCLES} cycles"));
        }
        plant.rebase_time();
        Some(c)
    } else {
        None
    };
    send(&host, &mut link, HostMessage::TelemetryPeriod(10))?;
    // The host believes the platform rests at the path's start on its
    // brakes (it does, but with a wrong homing): it homes there.
    send(&host, &mut link, HostMessage::SelectFeedback(scenario.scheme.wire_id()))?;
    send(&host, &mut link, HostMessage::Home(scenario.path.start().map(|v| v as f32)))?;

    for k in 0..cycles {
        let t = f64::from(k) * PERIOD;
        if scenario.stream_until.is_none_or(|stop| t < stop) {
            match config.stream {
                Stream::Points { period_ms, lead_ms } => {
                    while next_point_ms <= k + lead_ms {
                        let r = scenario.path.at(f64::from(next_point_ms) * 1e-3);
                        let point = TrajectoryPoint {
                            time_ms: next_point_ms,
                            pose: r.0.map(|v| v as f32),
                            velocity: r.1.map(|v| v as f32),
                        };
                        send(&host, &mut link, HostMessage::Point(point))?;
                        next_point_ms += period_ms.max(1);
                    }
                }
                Stream::EveryCycle => {
                    send(&host, &mut link, HostMessage::Setpoint(to_wire(k + 1, &scenario.path.at(t))))?;
                }
            }
        }
        if k == enable_cycle {
            send(&host, &mut link, HostMessage::Enable)?;
        }
        for b in link.device_read() {
            control.receive_byte(b);
        }

        if let (Some(c), Some(fault), Some(at)) = (&mut can, scenario.can_fault, scenario.event) {
            if k == (at / PERIOD).round() as u32 {
                c.inject(fault);
            }
        }
        let sample = plant.sample();
        let start = wall.ticks();
        let report = match &mut can {
            Some(c) => {
                c.before_step();
                control.step(&clock, &mut c.layer, false)
            }
            None => control.step(&clock, &mut plant, false),
        };
        // The reference is what the board plays: the points' time (their
        // number) or, streaming setpoints, the newest one's cycle.
        let played = match (config.stream, control.newest_setpoint()) {
            (Stream::Points { .. }, Some(s)) => f64::from(s.seq) * 1e-3,
            (Stream::EveryCycle, Some(s)) => f64::from(s.seq.saturating_sub(1)) * PERIOD,
            (_, None) => 0.0,
        };
        let reference = scenario.path.at(played);
        let cost = wall.since(start);
        control.record_cost(cost);
        step_sum += u64::from(cost);
        step_max = step_max.max(u64::from(cost));
        if let Some(tm) = report.telemetry {
            let n = cdpr_control::protocol::encode(
                &cdpr_control::protocol::DeviceMessage::Telemetry(tm),
                &mut frame,
            )
            .map_err(|e| format!("encode telemetry: {e:?}"))?;
            link.device_write(&frame[..n]);
        }
        host.receive(&mut link);
        if report.state != last_state {
            transitions.push((t, report.state, report.reason, control.supervisor().hold_reason()));
            last_state = report.state;
        }
        let commanded = report.solved.and_then(|c| c.result.ok()).map_or([f32::NAN; CABLES], |c| c.tensions);
        rows.push(Row {
            t,
            state: report.state,
            reason: report.reason,
            brakes: report.brakes,
            locked: sample.locked,
            pose: sample.pose,
            played,
            reference: reference.0,
            error: pose_error(&file_robot, &reference.0, &sample.pose),
            speed: sample.velocity.norm(),
            tensions: sample.tensions,
            commanded,
            torques: report.torques,
            feedback: report.feedback.into(),
            estimate: match report.estimate {
                Some(Ok(e)) => e.pose.into(),
                _ => [f32::NAN; 6],
            },
            residual: match report.estimate {
                Some(Ok(e)) => e.residual,
                _ => f32::NAN,
            },
            unreadable_drive: report.unreadable_drive,
            drive_brakes: None,
        });
        match &mut can {
            Some(c) => {
                c.advance(&mut plant, PERIOD);
                if let Some(row) = rows.last_mut() {
                    row.drive_brakes = Some(c.brakes());
                }
            }
            None => plant.advance(PERIOD),
        }
        clock.micros += 1000;
    }
    Ok(Outcome {
        scenario: scenario.clone(),
        rows,
        telemetry: host.telemetry,
        transitions,
        step_ns: (step_sum / u64::from(cycles.max(1)), step_max),
        counters: *control.counters(),
    })
}
