//! One call per control cycle: the link's events, the controller and the
//! supervisor together. The firmware and `hal-sim` both drive a
//! [`ControlLoop`]:
//!
//! 1. the received bytes go to [`ControlLoop::receive_bytes`], at most
//!    [`RECEIVE_BUDGET`] a cycle, or one by one to
//!    [`ControlLoop::receive_byte`] (or a decoded message to
//!    [`ControlLoop::receive`]);
//! 2. once per period [`ControlLoop::step`] reads the winch encoders
//!    (counts -> cable lengths, [`crate::encoder`]), checks the lengths
//!    against the last feasible setpoint's, solves the newest setpoint's
//!    kinematics, estimates the pose (one Gauss-Newton step,
//!    [`crate::estimator`]), runs the selected feedback scheme
//!    ([`crate::feedback::Scheme`]) and the tension distribution, lets the
//!    supervisor decide, writes the drives and returns the telemetry due
//!    this cycle;
//! 3. the caller reports the step's measured cost with
//!    [`ControlLoop::record_cost`] (it appears in the next telemetry).

use cdpr_protocol::{
    Counters, DriveFault, FrameError, HostMessage, LineFrame, Reason, Rejection, State, Telemetry,
};
use tension_core::{Error, Method};

use crate::controller::{Controller, Cycle, PhaseTicks, Saturation, Wrench};
use crate::drives::{WinchDrives, WinchReading};
use crate::encoder::{EncoderScale, Homing, ScaleError};
use crate::estimator::{Estimate, EstimateError, Estimator, EstimatorSettings, Reference};
use crate::feedback::{
    length_rates, FeedbackLimits, Gains, JointGains, JointPid, Prediction, Scheme, TaskPid,
};
use crate::link::{Event, JumpLimits, Link, SetpointRange};
use crate::point_buffer::{Played, PointBuffer};
use crate::robot::ControlRobot;
use crate::setpoint::{Pose6, Setpoint};
use crate::supervisor::{Requests, SafetyLimits, SetpointStatus, Supervisor};
use crate::{TickCounter, CABLES};

/// Telemetry period at start-up, cycles.
pub const DEFAULT_TELEMETRY_PERIOD: u16 = 10;

/// The tracking limit at start-up: a cable length more than this (m) off
/// the last feasible setpoint's, in Enabled or Holding, faults
/// (`Reason::Tracking`).
pub const DEFAULT_TRACKING_LIMIT: f32 = 0.02;

/// The feedback bandwidth of the default gains: both schemes' triple pole
/// at `-2 pi 5 Hz` (`feedback::Gains::triple_pole`,
/// `feedback::JointGains::triple_pole`), a tenth of the estimator's speed
/// filter and well below the cables' and winches' first modes (tens of Hz
/// on a robot of this size).
pub const DEFAULT_OMEGA: f32 = 2.0 * core::f32::consts::PI * 5.0;

/// The default task-space PID's bounds: 20 N, 2 N m, integral 10 N and
/// 1 N m per axis. A suspended robot makes horizontal forces only through
/// its cables' slant: on suspended-8 a 50 N sideways push already leaves
/// the tension polygon at ordinary poses, and a feedback wrench that
/// leaves it makes the setpoint infeasible (Holding), so the bound is a
/// third of the platform's weight (62 N).
pub const DEFAULT_FEEDBACK_LIMITS: FeedbackLimits =
    FeedbackLimits { force_max: 20.0, moment_max: 2.0, integral_max: [10.0, 10.0, 10.0, 1.0, 1.0, 1.0] };

/// The weight [`DEFAULT_FEEDBACK_LIMITS`] were set for (suspended-8: 6.34 kg
/// under 9.81 m/s^2), N.
pub const REFERENCE_WEIGHT: f32 = 6.34 * 9.81;

/// A platform's weight, `mass |gravity|`, against [`REFERENCE_WEIGHT`]:
/// what the feedback bounds (the firmware's, `hal-sim`'s) scale by, so
/// that a light platform's feedback wrench stays as small against its
/// weight and its tension range (1 for suspended-8; 0.016 for IPAnema 1's
/// 0.1 kg).
pub fn weight_scale(mass: f32, gravity: [f32; 3]) -> f32 {
    let g = gravity;
    mass * libm::sqrtf(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) / REFERENCE_WEIGHT
}

/// How fast the task-space feedback comes back after it was backed off,
/// per cycle: 2 % of the full wrench a cycle (0 to full in 50 ms at 1 kHz).
///
/// When the feed-forward plus the feedback wrench has no feasible tensions
/// (the feedback pushes the wrench out of the tension polytope's image,
/// e.g. near the workspace's border where a cable is close to `t_min`),
/// the cycle holds the last feasible torques without leaving Enabled
/// (`SetpointStatus::FeedbackInfeasible`) and the next cycle carries half
/// the feedback *force* (the moment is kept whole, [`BackOff::ForceFirst`]);
/// below [`FEEDBACK_SCALE_MIN`] neither force nor moment. So the feedback
/// settles at a fraction the tension polytope admits, and a setpoint that
/// is infeasible by itself is Holding `infeasible` at most five cycles
/// later (the torques held meanwhile, as Holding would). After each
/// feasible cycle the fraction grows by this much; the PID's integral is
/// frozen while it is below full (anti-windup). One solve a cycle whatever
/// happens: the step's cost bound is unchanged. Telemetry's
/// `feedback_scale` shows the fraction of the force each cycle carried.
pub const FEEDBACK_RECOVERY_PER_CYCLE: f32 = 0.02;

/// Below this fraction a backed-off task-space feedback is cut to zero
/// (four halvings: 1/16).
pub const FEEDBACK_SCALE_MIN: f32 = 0.0625;

/// How the task-space feedback backs off where the cables cannot give it
/// ([`FEEDBACK_RECOVERY_PER_CYCLE`]).
///
/// Near the tension floor (the top of a suspended robot's workspace) the
/// feedback force is what leaves the tension polytope's image: the
/// moments the platform needs are small (at most 2-6 N m) and come from
/// tension *differences*. Scaling the whole wrench down took the moment
/// feedback with the force, and on the CAN buses the rotation then drifted
/// from 0.6 to 3.4 deg in 90 ms until the estimator faulted
/// (`hal-sim/README.md`). Either way a failing cycle holds the last
/// feasible torques and at most five failing cycles reach no feedback at
/// all, so a setpoint infeasible by itself is Holding as soon as before.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BackOff {
    /// Force and moment together, halved each failing cycle.
    Whole,
    /// The force alone halved each failing cycle, the moment kept whole;
    /// below [`FEEDBACK_SCALE_MIN`] both cut (the default). Both grow
    /// back by [`FEEDBACK_RECOVERY_PER_CYCLE`].
    ForceFirst,
}

/// The default joint-space integral bound per cable, N.
pub const DEFAULT_JOINT_INTEGRAL_MAX: f32 = 10.0;

/// Most received bytes [`ControlLoop::receive_bytes`] takes in one cycle:
/// the receive work per cycle is bounded whatever arrives. On the board
/// (`cargo xtask run`'s receive flood) a cycle's 256 bytes cost at most
/// about 13 500 instructions (back-to-back valid setpoint frames, 52 a
/// byte: COBS undone as the bytes arrive, CRC-32, the setpoint decoded
/// directly, the link's checks and the event applied; 0x00 storms, 0xFF
/// runs and noise 14 to 25 a byte), so with the worst
/// step the cycle stays within a third of the 1 ms period (125 000
/// instructions under QEMU). 256 bytes a millisecond is 22 times what
/// 460 800 baud carries (46 bytes per ms) and three setpoint frames per
/// cycle; what arrives faster waits in the receive queue, and what finds
/// the queue full is dropped and counted (`Counters::dropped_bytes`).
pub const RECEIVE_BUDGET: usize = 256;

/// Most reassembled frames [`ControlLoop::receive_frames`] takes in one
/// cycle (the board's product: its receive interrupt reassembles frames as
/// the bytes arrive, the control step checks and decodes them). Two
/// setpoint frames are 170 bytes, nearly four times what 460 800 baud
/// carries in a millisecond (46 bytes), so a stream drains faster than the
/// line fills it; a burst (the stream's first points, or frames QEMU
/// holds back and delivers at once) waits in the interrupt's frame queue
/// and is taken two a cycle. Only a sustained flood of frames shorter than
/// 23 bytes (commands) outruns it, and what then finds the queue full is
/// dropped and counted. Two rather than more bounds the step's receive
/// work at about 1 160 instructions on the board (issue 17).
pub const FRAME_BUDGET: usize = 2;

/// Where [`ControlLoop::receive_frames`] takes reassembled frames from:
/// the board's receive queue, or [`SliceFrames`].
pub trait FrameSource {
    /// The oldest frame, if any, left where it is.
    fn peek(&mut self) -> Option<&LineFrame>;
    /// Drops the oldest frame (nothing if there is none).
    fn pop(&mut self);
}

/// The frames of a slice, in order, as a [`FrameSource`] (tests, the demo).
#[derive(Debug, Clone)]
pub struct SliceFrames<'a> {
    frames: &'a [LineFrame],
}

impl<'a> SliceFrames<'a> {
    /// The frames of `frames`.
    pub fn new(frames: &'a [LineFrame]) -> Self {
        Self { frames }
    }

    /// Frames not taken yet.
    pub fn remaining(&self) -> usize {
        self.frames.len()
    }
}

impl FrameSource for SliceFrames<'_> {
    fn peek(&mut self) -> Option<&LineFrame> {
        self.frames.first()
    }

    fn pop(&mut self) {
        self.frames = self.frames.get(1..).unwrap_or_default();
    }
}

/// A set of tension distribution methods (by `Method::wire_id`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MethodSet(u32);

impl MethodSet {
    /// No method.
    pub const EMPTY: Self = Self(0);
    /// Every method.
    pub const ALL: Self = Self(u32::MAX);

    /// This set and `method`.
    pub const fn with(self, method: Method) -> Self {
        Self(self.0 | 1 << method.wire_id())
    }

    /// Whether `method` is in the set.
    pub const fn contains(self, method: Method) -> bool {
        self.0 & 1 << method.wire_id() != 0
    }
}

/// The newest setpoint the link delivered.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Newest {
    /// None since start (or since the link restarted).
    Nothing,
    /// A good setpoint and the cycle it arrived in.
    Good(Setpoint, u32),
    /// The newest setpoint frame was bad (its values are not kept).
    Bad,
}

impl Newest {
    /// `Good(s, cycle)`, written over a kept good setpoint in place
    /// ([`Setpoint::assign`]: no 72-byte library copy for every frame the
    /// step takes).
    fn set_good(&mut self, s: &cdpr_protocol::Setpoint, cycle: u32) {
        match self {
            Newest::Good(kept, at) => {
                kept.assign(s);
                *at = cycle;
            }
            _ => *self = Newest::Good(Setpoint::from(s), cycle),
        }
    }
}

/// What one cycle did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    /// The cycle number.
    pub cycle: u32,
    /// The controller's result for the newest setpoint, if one was solved.
    pub solved: Option<Cycle>,
    /// State after the cycle.
    pub state: State,
    /// Why the state is Holding or Fault.
    pub reason: Reason,
    /// Torques written to the drives, N m.
    pub torques: [f32; CABLES],
    /// Brakes written to the drives.
    pub brakes: bool,
    /// Telemetry due this cycle.
    pub telemetry: Option<Telemetry>,
    /// The pose estimate this cycle, or why there is none (`None`: not
    /// homed or a drive unreadable).
    pub estimate: Option<Result<Estimate, EstimateError>>,
    /// The task-space feedback wrench the cables added (zero otherwise).
    pub feedback: Wrench,
    /// The joint-space feedback's tension changes, N (zero otherwise).
    pub offsets: [f32; CABLES],
    /// The drive that could not be read this cycle.
    pub unreadable_drive: Option<u8>,
    /// The first drive fault since the last granted `ClearFault`.
    pub drive_fault: Option<DriveFault>,
}

impl Default for StepReport {
    /// A report of no cycle (what [`ControlLoop::step_into`] overwrites).
    fn default() -> Self {
        Self {
            cycle: 0,
            solved: None,
            state: State::Disabled,
            reason: Reason::None,
            torques: [0.0; CABLES],
            brakes: true,
            telemetry: None,
            estimate: None,
            feedback: Wrench::zeros(),
            offsets: [0.0; CABLES],
            unreadable_drive: None,
            drive_fault: None,
        }
    }
}

/// The per-cycle logic with its state.
pub struct ControlLoop {
    controller: Controller,
    supervisor: Supervisor,
    link: Link,
    counters: Counters,
    newest: Newest,
    requests: Requests,
    telemetry_period: u16,
    cycle: u32,
    /// The costliest step since the last telemetry sample.
    worst_cost: u32,
    /// The methods `SelectMethod` may choose.
    offered: MethodSet,
    scale: EncoderScale,
    homing: Option<Homing>,
    pending_home: Option<Pose6>,
    readings: [WinchReading; CABLES],
    /// The first drive fault since the last granted `ClearFault`.
    drive_fault: Option<DriveFault>,
    estimator: Estimator,
    scheme: Scheme,
    task_pid: TaskPid,
    joint_pid: Option<JointPid>,
    tracking_limit: Option<f32>,
    /// The inverse kinematics of the newest setpoint that solved feasibly
    /// (what the winches hold).
    feasible_lengths: Option<[f32; CABLES]>,
    /// The fraction of the task-space feedback wrench applied
    /// ([`FEEDBACK_RECOVERY_PER_CYCLE`]).
    feedback_scale: f32,
    /// The fraction of the task-space feedback moment applied
    /// ([`BackOff::ForceFirst`]).
    moment_scale: f32,
    /// How the feedback backs off.
    back_off: BackOff,
    /// The loop delay the task-space PID predicts over.
    prediction: Prediction,
    /// The trajectory points waiting to be played.
    buffer: PointBuffer,
    /// An `Identify` arrived that the caller has not answered yet.
    identify: bool,
}

/// Why the board refuses its robot with the robot file's encoders
/// ([`check_board_robot`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RobotRefusal {
    /// The encoders' 32-bit counts do not reach the longest cable of the
    /// setpoint range ([`EncoderScale::check_reach`]).
    Encoders(ScaleError),
    /// A winch cannot pull its cable's `t_max`
    /// ([`crate::controller::check_winch_reach`]).
    Winch(crate::controller::WinchReachError),
}

impl core::fmt::Display for RobotRefusal {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Encoders(e) => write!(f, "[winch]: {e}"),
            Self::Winch(e) => write!(f, "[winch]: {e}"),
        }
    }
}

/// What the board refuses of its robot with the file's encoders `scale`,
/// checked before anything runs (the firmware's build, `hal-sim`): the
/// encoders must count the longest cable of the robot's setpoint range
/// ([`SetpointRange::for_robot`]) and every winch must pull its cable's
/// `t_max`. [`ControlLoop::new`] and [`ControlLoop::set_encoder`] repeat
/// both at run time. Out of line, as the start-up's other checks are.
#[inline(never)]
pub fn check_board_robot(robot: &ControlRobot, scale: &EncoderScale) -> Result<(), RobotRefusal> {
    let longest = SetpointRange::for_robot(robot).longest_cable(robot);
    scale.check_reach(longest).map_err(RobotRefusal::Encoders)?;
    crate::controller::check_winch_reach(robot).map_err(RobotRefusal::Winch)
}

/// Both feedback schemes' gains, the triple pole at `-omega` (rad/s): the
/// task-space PID's for the platform's mass and the diagonal of its
/// inertia, and the joint-space PID's at the centre of `range`'s box,
/// unrotated (`None` where that pose has no kinematics).
fn feedback_gains(
    robot: &ControlRobot,
    range: &SetpointRange,
    omega: f32,
    joint_integral_max: f32,
) -> (Gains, Option<JointGains>) {
    let platform = robot.platform();
    let inertia = [platform.inertia[(0, 0)], platform.inertia[(1, 1)], platform.inertia[(2, 2)]];
    let gains = Gains::triple_pole(platform.mass, inertia, omega, omega);
    let centre = Pose6::new(
        0.5 * (range.position_min[0] + range.position_max[0]),
        0.5 * (range.position_min[1] + range.position_max[1]),
        0.5 * (range.position_min[2] + range.position_max[2]),
        0.0,
        0.0,
        0.0,
    );
    (gains, JointGains::triple_pole(robot, &centre, omega, joint_integral_max).ok())
}

impl ControlLoop {
    /// A loop for `robot` with `method`, accepting setpoints within `range`,
    /// with the supervisor's `limits`. Starts Disabled, unhomed, with
    /// feed-forward only; the encoders are the robot file's defaults for
    /// the robot's winch (4096 counts per revolution, every sign +1:
    /// [`ControlLoop::set_encoder`] sets the file's; `InvalidLimits` for a
    /// robot whose longest cable they cannot count, and for one whose
    /// winches cannot pull its `t_max`,
    /// [`crate::controller::check_winch_reach`]), the estimator's
    /// [`EstimatorSettings::DEFAULT`], the tracking limit
    /// [`DEFAULT_TRACKING_LIMIT`], and both feedback schemes' gains the
    /// triple pole at [`DEFAULT_OMEGA`] (the joint-space gains at the
    /// centre of the setpoint range's box, unrotated; without them, e.g.
    /// where that pose has no kinematics, `SelectFeedback(2)` is refused).
    /// The task-space gains come from the platform's mass and the diagonal
    /// of its inertia: a robot file without `[platform] inertia` gives
    /// zero rotation gains, and `SelectFeedback(1)` is refused while the
    /// PID leaves an axis without feedback ([`TaskPid::acts_on_every_axis`]).
    pub fn new(
        robot: ControlRobot,
        method: Method,
        range: SetpointRange,
        limits: SafetyLimits,
    ) -> Result<Self, Error> {
        let winch = *robot.winch().ok_or(Error::UnsupportedShape)?;
        // Tensions within the limits that the motors cannot pull: the
        // robot file's contradiction, named by `check_winch_reach`.
        crate::controller::check_winch_reach(&robot).map_err(|_| Error::InvalidLimits)?;
        let scale = EncoderScale::with_defaults(winch.drum_radius, winch.gear_ratio)
            .and_then(|scale| scale.check_reach(range.longest_cable(&robot)).map(|()| scale))
            .map_err(|_| Error::InvalidLimits)?;
        let (gains, joint_gains) = feedback_gains(&robot, &range, DEFAULT_OMEGA, DEFAULT_JOINT_INTEGRAL_MAX);
        let joint_pid = joint_gains.and_then(|gains| JointPid::new(gains).ok());
        Ok(Self {
            scale,
            homing: None,
            pending_home: None,
            readings: [WinchReading::default(); CABLES],
            drive_fault: None,
            estimator: Estimator::new(EstimatorSettings::DEFAULT),
            scheme: Scheme::FeedForward,
            task_pid: TaskPid::new(gains, DEFAULT_FEEDBACK_LIMITS)?,
            joint_pid,
            tracking_limit: Some(DEFAULT_TRACKING_LIMIT),
            feasible_lengths: None,
            feedback_scale: 1.0,
            moment_scale: 1.0,
            back_off: BackOff::ForceFirst,
            prediction: Prediction::NONE,
            buffer: PointBuffer::new(),
            identify: false,
            controller: Controller::new(robot, method)?,
            supervisor: Supervisor::new(limits),
            link: Link::new(range),
            counters: Counters::default(),
            newest: Newest::Nothing,
            requests: Requests::default(),
            telemetry_period: DEFAULT_TELEMETRY_PERIOD,
            cycle: 0,
            worst_cost: 0,
            offered: MethodSet::ALL,
        })
    }

    /// The controller (robot and solver).
    pub fn controller(&self) -> &Controller {
        &self.controller
    }

    /// The controller, to configure it (e.g. `Controller::set_friction`).
    pub fn controller_mut(&mut self) -> &mut Controller {
        &mut self.controller
    }

    /// The supervisor.
    pub fn supervisor(&self) -> &Supervisor {
        &self.supervisor
    }

    /// The counters.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// The newest good setpoint, if the newest setpoint frame was good.
    pub fn newest_setpoint(&self) -> Option<&Setpoint> {
        match &self.newest {
            Newest::Good(s, _) => Some(s),
            _ => None,
        }
    }

    /// Cycles since the newest good setpoint arrived (0: this cycle), if
    /// the newest setpoint frame was good.
    pub fn newest_setpoint_age(&self) -> Option<u32> {
        match &self.newest {
            Newest::Good(_, arrived) => Some(self.cycle.wrapping_sub(*arrived)),
            _ => None,
        }
    }

    /// The inverse kinematics of the newest setpoint that solved feasibly
    /// (the one whose torques the winches get in Enabled or hold in
    /// Holding): what the length check compares the encoders with, m.
    pub fn last_feasible_lengths(&self) -> Option<&[f32; CABLES]> {
        self.feasible_lengths.as_ref()
    }

    /// The winch encoders' scale (from the robot file: `[winch]`'s
    /// `counts_per_revolution` and `encoder_sign`); forgets the homing.
    /// Refused ([`ScaleError::Reach`], nothing changed) when its 32-bit
    /// counts cannot count the longest cable the setpoint range allows
    /// ([`SetpointRange::longest_cable`]): such a cable's length would wrap.
    pub fn set_encoder(&mut self, scale: EncoderScale) -> Result<(), ScaleError> {
        self.reaches(&scale)?;
        self.scale = scale;
        self.homing = None;
        self.estimator.forget();
        Ok(())
    }

    /// [`EncoderScale::check_reach`] against this loop's longest cable.
    /// Out of line: inlined into the firmware's start-up, it made that
    /// frame hold a third 5 KB copy of the loop (`Board::start_in` 9 856
    /// -> 15 232 bytes; the product's stack high-water mark is start-up's;
    /// out of line 12 928).
    #[inline(never)]
    fn reaches(&self, scale: &EncoderScale) -> Result<(), ScaleError> {
        scale.check_reach(self.link.range().longest_cable(self.controller.robot()))
    }

    /// The encoder scale.
    pub fn encoder(&self) -> &EncoderScale {
        &self.scale
    }

    /// The homing offsets, once homed.
    pub fn homing(&self) -> Option<&Homing> {
        self.homing.as_ref()
    }

    /// Whether the loop is homed (Enable is refused until it is).
    pub fn homed(&self) -> bool {
        self.homing.is_some()
    }

    /// The last encoder readings.
    pub fn readings(&self) -> &[WinchReading; CABLES] {
        &self.readings
    }

    /// The estimator.
    pub fn estimator(&self) -> &Estimator {
        &self.estimator
    }

    /// The estimator's settings (the estimate's speed restarts).
    pub fn set_estimator(&mut self, settings: EstimatorSettings) {
        let last = self.estimator.last().copied();
        self.estimator = Estimator::new(settings);
        if let Some(pose) = last {
            self.estimator.reset(&pose);
        }
    }

    /// The feedback scheme in use.
    pub fn scheme(&self) -> Scheme {
        self.scheme
    }

    /// Both feedback schemes' gains for a closed-loop bandwidth of
    /// `hertz` (the robot file's `[control] bandwidth`): the triple pole
    /// at `-2 pi hertz` that [`ControlLoop::new`] places at
    /// [`DEFAULT_OMEGA`], for the same rigid body and the same pose; the
    /// task-space bounds and the joint-space integral bound stay, and both
    /// integrals restart. [`Error::InvalidLimits`] for a bandwidth that is
    /// not finite and positive (nothing changes then). Out of line, as the
    /// other start-up settings are (the firmware's start-up frame).
    #[inline(never)]
    pub fn set_bandwidth(&mut self, hertz: f32) -> Result<(), Error> {
        let omega = 2.0 * core::f32::consts::PI * hertz;
        if !(omega.is_finite() && omega > 0.0) {
            return Err(Error::InvalidLimits);
        }
        let integral_max =
            self.joint_pid.as_ref().map_or(DEFAULT_JOINT_INTEGRAL_MAX, |p| p.gains().integral_max);
        let (gains, joint) = feedback_gains(self.controller.robot(), self.link.range(), omega, integral_max);
        let task = TaskPid::new(gains, *self.task_pid.limits())?;
        // Only where the scheme was offered: a robot refused it for its
        // pose keeps it refused.
        let joint = match (&self.joint_pid, joint) {
            (Some(_), Some(gains)) => Some(JointPid::new(gains)?),
            _ => None,
        };
        self.set_task_pid(task);
        self.joint_pid = joint;
        if self.joint_pid.is_none() && self.scheme == Scheme::JointSpace {
            self.scheme = Scheme::FeedForward;
        }
        Ok(())
    }

    /// The task-space PID (gains and bounds; its integral restarts).
    pub fn set_task_pid(&mut self, pid: TaskPid) {
        self.task_pid = pid;
        self.task_pid.reset();
    }

    /// How the task-space feedback backs off.
    pub fn set_back_off(&mut self, back_off: BackOff) {
        self.back_off = back_off;
    }

    /// The loop delay (s) the task-space PID predicts its errors over
    /// beyond the direct path's: 0 for directly wired winches.
    /// (`feedback::Prediction`; a delay that is not positive and finite
    /// predicts nothing).
    pub fn set_loop_delay(&mut self, delay_s: f32) {
        let p = self.controller.robot().platform();
        let inertia = [p.inertia[(0, 0)], p.inertia[(1, 1)], p.inertia[(2, 2)]];
        self.prediction = Prediction::new(delay_s, p.mass, inertia);
    }

    /// The task-space PID's prediction.
    pub fn prediction(&self) -> &Prediction {
        &self.prediction
    }

    /// The task-space PID.
    pub fn task_pid(&self) -> &TaskPid {
        &self.task_pid
    }

    /// The joint-space gains (`None`: the scheme is not offered). Errors:
    /// [`Error::InvalidLimits`] for an integral bound that is NaN or below
    /// zero (nothing changes then).
    pub fn set_joint_gains(&mut self, gains: Option<JointGains>) -> Result<(), Error> {
        self.joint_pid = gains.map(JointPid::new).transpose()?;
        if self.joint_pid.is_none() && self.scheme == Scheme::JointSpace {
            self.scheme = Scheme::FeedForward;
        }
        Ok(())
    }

    /// The joint-space PID, if offered.
    pub fn joint_pid(&self) -> Option<&JointPid> {
        self.joint_pid.as_ref()
    }

    /// The tracking limit of the step's own length check (m; `None`: off).
    pub fn set_tracking_limit(&mut self, limit: Option<f32>) {
        self.tracking_limit = limit;
    }

    /// The next cycle's number.
    pub fn cycle(&self) -> u32 {
        self.cycle
    }

    /// Restricts `SelectMethod` to `offered` (all methods by default); a
    /// request for another is refused and counted (`rejected_method`,
    /// [`Rejection::MethodOverBudget`]). The firmware offers the methods
    /// whose worst case fits its step budget (`cdpr_demo::methods`).
    pub fn offer_only(&mut self, offered: MethodSet) {
        self.offered = offered;
    }

    /// The methods `SelectMethod` may choose.
    pub fn offered(&self) -> MethodSet {
        self.offered
    }

    /// The link's jump check (`None`: off; on by default with
    /// [`JumpLimits::DEFAULT`]).
    pub fn set_jump_limits(&mut self, limits: Option<JumpLimits>) {
        self.link.set_jump_limits(limits);
    }

    /// Takes one byte from the serial link.
    pub fn receive_byte(&mut self, byte: u8) {
        if self.link.take_byte(byte) {
            self.frame_ended();
        }
    }

    /// Takes the bytes `next` yields, at most [`RECEIVE_BUDGET`] (the rest
    /// stays with the caller for the next cycle); returns how many it took.
    pub fn receive_bytes(&mut self, mut next: impl FnMut() -> Option<u8>) -> usize {
        let mut taken = 0;
        while taken < RECEIVE_BUDGET {
            let (n, ended) = self.link.take_bytes(&mut next, RECEIVE_BUDGET - taken);
            taken += n;
            if !ended {
                // `next` has no more, or the budget is spent.
                break;
            }
            self.frame_ended();
        }
        taken
    }

    /// A delimiter arrived: the frame's event, if any, applied.
    #[inline(never)]
    fn frame_ended(&mut self) {
        if let Some(outcome) = self.link.finish() {
            self.judge(&outcome);
        }
    }

    /// A decoded frame (or why it failed), judged by the link and applied.
    fn judge(&mut self, outcome: &Result<HostMessage, FrameError>) {
        if let Some(event) = self.link.judge(outcome, self.cycle, &mut self.counters) {
            self.apply(event);
        }
    }

    /// Takes the frames `source` holds (reassembled by the receive
    /// interrupt: [`cdpr_protocol::FrameDecoder::finish_line`]), at most
    /// [`FRAME_BUDGET`] (the rest stays in `source` for the next cycle);
    /// returns how many it took. Each is checked like the same bytes
    /// through [`ControlLoop::receive_bytes`]; frames are read where they
    /// lie (a frame is 212 bytes: no copy).
    pub fn receive_frames(&mut self, source: &mut impl FrameSource) -> usize {
        for taken in 0..FRAME_BUDGET {
            let Some(frame) = source.peek() else { return taken };
            let outcome = Link::decode(frame);
            source.pop();
            self.judge(&outcome);
        }
        FRAME_BUDGET
    }

    /// Reports the bytes the receiver dropped so far (its running total),
    /// shown as `Counters::dropped_bytes`.
    pub fn record_dropped(&mut self, total: u32) {
        self.counters.dropped_bytes = total;
    }

    /// Takes one decoded message (checked like a received frame).
    pub fn receive(&mut self, message: HostMessage) {
        if let Some(event) = self.link.accept(&message, self.cycle, &mut self.counters) {
            self.apply(event);
        }
    }

    fn apply(&mut self, event: Event<'_>) {
        match event {
            // A setpoint of its own ends a buffered stream.
            Event::Setpoint(s) => {
                self.buffer.clear();
                self.newest.set_good(s, self.cycle);
            }
            Event::Point(p) => {
                let bound = matches!(self.supervisor.state(), State::Enabled | State::Holding);
                // While bound, a stream's first point must follow from the
                // setpoint the winches have, over the start delay and its age.
                let joins = match (self.buffer.active(), bound, self.newest, self.link.jump_limits()) {
                    (false, true, Newest::Good(s, arrived), Some(limits)) => {
                        let dt = (self.cycle.wrapping_sub(arrived) + crate::point_buffer::START_DELAY_CYCLES)
                            as f32
                            * limits.period_s;
                        limits.follows(&s.pose.into(), &s.velocity.into(), &p.pose, &p.velocity, dt)
                    }
                    _ => true,
                };
                let pushed = if joins {
                    self.buffer.push(&p, self.cycle, bound, self.link.jump_limits())
                } else {
                    Err(Rejection::Jump)
                };
                match pushed {
                    Ok(()) => self.counters.accepted = self.counters.accepted.wrapping_add(1),
                    Err(why) => {
                        self.counters.reject(why);
                        if why == Rejection::Jump {
                            self.buffer.refuse();
                        }
                    }
                }
            }
            Event::BadPoint => self.buffer.refuse(),
            Event::BadSetpoint => self.newest = Newest::Bad,
            Event::Enable => {
                if self.homing.is_some() {
                    self.requests.enable = true;
                } else {
                    self.counters.reject(Rejection::Homing);
                }
            }
            // Carried out in the next step, which reads the encoders.
            Event::Home(pose) => {
                if self.supervisor.state() == State::Disabled {
                    self.pending_home = Some(pose);
                } else {
                    self.counters.reject(Rejection::State);
                }
            }
            Event::SelectFeedback(scheme) => {
                // A PID that cannot act on every axis is not offered: the
                // host would take the platform's pose to be held when its
                // orientation (no inertia in the robot file) is not.
                let offered = match scheme {
                    Scheme::JointSpace => self.joint_pid.is_some(),
                    Scheme::TaskSpace => self.task_pid.acts_on_every_axis(),
                    Scheme::FeedForward => true,
                };
                if !offered {
                    self.counters.reject(Rejection::Range);
                } else if self.supervisor.state() != State::Disabled {
                    self.counters.reject(Rejection::State);
                } else {
                    self.scheme = scheme;
                    self.task_pid.reset();
                    if let Some(pid) = &mut self.joint_pid {
                        pid.reset();
                    }
                }
            }
            Event::Disable => self.requests.disable = true,
            Event::ClearFault => self.requests.clear_fault = true,
            Event::TelemetryPeriod(p) => self.telemetry_period = p,
            Event::Identify => self.identify = true,
            // Only methods that fit the budget, and only while disabled: a
            // switch in motion would jump the tensions.
            Event::SelectMethod(method) => {
                if !self.offered.contains(method) {
                    self.counters.reject(Rejection::MethodOverBudget);
                } else if !(self.supervisor.state() == State::Disabled
                    && self.controller.set_method(method).is_ok())
                {
                    self.counters.reject(Rejection::State);
                }
            }
        }
    }

    /// The pose of a `Home` the next step carries out, if one is pending.
    pub fn pending_home(&self) -> Option<&Pose6> {
        self.pending_home.as_ref()
    }

    /// Whether an `Identify` arrived since the last call (which clears
    /// it): the caller, which knows the robot it was built for, sends
    /// `DeviceMessage::Identity` (the firmware does after the cycle's step).
    pub fn take_identify(&mut self) -> bool {
        core::mem::take(&mut self.identify)
    }

    /// Records the measured cost of the last step (instructions or cycles);
    /// the next telemetry sample reports the costliest since the one before.
    pub fn record_cost(&mut self, cost: u32) {
        self.worst_cost = self.worst_cost.max(cost);
    }

    /// [`ControlLoop::step_into`] returning the report: one control cycle.
    pub fn step<C: TickCounter, D: WinchDrives>(
        &mut self,
        clock: &C,
        drives: &mut D,
        overrun: bool,
    ) -> StepReport {
        let mut report = StepReport::default();
        self.step_into(clock, drives, overrun, &mut report);
        report
    }

    /// One control cycle into `report` (every field written; the firmware
    /// keeps one report in place rather than copying 484 bytes a cycle out
    /// of a returned value): reads the drives (counts -> lengths), carries
    /// out a pending `Home`, checks the lengths against the last feasible
    /// setpoint's, solves the newest setpoint with the selected feedback
    /// (pose estimate -> task-space wrench or joint-space tension changes),
    /// lets the supervisor decide and writes the drives. `overrun` says
    /// whether the previous cycle missed its deadline; `clock` times the
    /// phases.
    ///
    /// * An unreadable drive: Fault (`Reason::Encoder`) from Enabled or
    ///   Holding; in any state the homing is forgotten (the count may have
    ///   jumped) and the drive is named in telemetry.
    /// * Encoder lengths that fit no pose (the estimator's residual beyond
    ///   its limit): Fault (`Reason::Estimator`) from Enabled or Holding.
    /// * Another estimator failure while a setpoint solved: Holding
    ///   (`Reason::Estimator`, the last feasible torques held, feedback
    ///   off), a fault if it lasts `hold_cycles`; in Disabled it refuses
    ///   Enable.
    pub fn step_into<C: TickCounter, D: WinchDrives>(
        &mut self,
        clock: &C,
        drives: &mut D,
        overrun: bool,
        report: &mut StepReport,
    ) {
        let now = self.cycle;
        let state_before = self.supervisor.state();
        // The fraction of the task-space feedback this cycle's solve carries.
        let mut carried = self.feedback_scale;
        let mut ticks = PhaseTicks::default();

        // The encoders.
        let t_read = clock.ticks();
        let read = drives.read(&mut self.readings);
        let mut unreadable_drive = None;
        let mut encoder_fault = false;
        let mut faulted = false;
        if let Err(e) = &read {
            unreadable_drive = Some(drives.failed_drive(e).map_or(u8::MAX, |i| i.min(254) as u8));
            self.homing = None;
            self.estimator.forget();
            encoder_fault = true;
            // A drive's own fault: Fault `drive` in any state.
            if let Some(f) = drives.drive_fault(e) {
                self.drive_fault.get_or_insert(f);
                faulted |= self.supervisor.fault(now, Reason::Drive);
            }
        }
        if let Some(pose) = self.pending_home.take() {
            self.carry_out_home(&pose, read.is_ok());
        }
        let measured = self
            .homing
            .as_ref()
            .map(|h| (self.scale.lengths(h, &self.readings), self.scale.rates(&self.readings)));
        ticks.read = clock.since(t_read);

        // The length check: in Enabled or Holding, a cable more than the
        // tracking limit off the last feasible setpoint's inverse
        // kinematics (cached) faults (`Reason::Tracking`): a broken cable
        // (its unloaded winch reels in), a winch that cannot deliver its
        // torque (its cable pays out as the platform sags), the platform
        // coasting past a frozen setpoint. In Disabled it refuses Enable.
        if matches!(state_before, State::Enabled | State::Holding)
            && self.off_track(measured.as_ref().map(|(l, _)| l))
            && self.supervisor.fault(now, Reason::Tracking)
        {
            faulted = true;
        }
        if encoder_fault
            && matches!(self.supervisor.state(), State::Enabled | State::Holding)
            && self.supervisor.fault(now, Reason::Encoder)
        {
            faulted = true;
        }

        let closed = state_before == State::Enabled;
        if matches!(state_before, State::Disabled | State::Fault) {
            self.task_pid.reset();
            if let Some(pid) = &mut self.joint_pid {
                pid.reset();
            }
        }
        // The buffer's setpoint for this cycle (none while it waits or is
        // dry: the last one ages, and goes stale; bad where the stream's
        // next point was refused or the interpolation leaves the range).
        match self.buffer.sample(now) {
            Some(Played::Setpoint(s)) if self.link.range().contains(&s.to_wire()) => {
                self.newest = Newest::Good(s, now);
            }
            Some(_) => self.newest = Newest::Bad,
            None => {}
        }
        report.solved = None;
        report.estimate = None;
        let mut feedback = Wrench::zeros();
        let mut offsets = [0.0; CABLES];
        // By reference: the setpoint (about 90 bytes) is copied only where
        // it is kept (`last_feasible`).
        let status = match &self.newest {
            Newest::Nothing => SetpointStatus::Stale,
            Newest::Bad => SetpointStatus::Bad,
            Newest::Good(_, arrived)
                if now.wrapping_sub(*arrived) > self.supervisor.limits().stale_cycles =>
            {
                SetpointStatus::Stale
            }
            Newest::Good(setpoint, arrived) => {
                let arrived = *arrived;
                let t0 = clock.ticks();
                let kinematics = self.controller.kinematics(setpoint);
                let t1 = clock.ticks();
                ticks.kinematics = t1.wrapping_sub(t0);
                // By reference: the kinematics (about 300 bytes) stay where
                // they were returned.
                let result = match &kinematics {
                    Err(e) => Err(*e),
                    Ok(k) => {
                        // `W` factored once, for the estimator and the solver.
                        let prepared = self.controller.prepare(k, clock);
                        let t_estimate = clock.ticks();
                        // The estimate, about the setpoint.
                        // Written where it stays (an estimate is about 80
                        // bytes: no copy through a closure's return).
                        if let Some((lengths, _)) = &measured {
                            let factorization = self.controller.factorization(&prepared);
                            let reference = Reference::of_setpoint(&setpoint.pose, k, factorization);
                            self.estimator.about_into(reference, lengths, &mut report.estimate);
                        }
                        let t2 = clock.ticks();
                        ticks.estimator = t2.wrapping_sub(t_estimate);
                        let age = now.wrapping_sub(arrived) as f32 * self.estimator.settings().period_s;
                        let dt = self.estimator.settings().period_s;
                        let joint = match (self.scheme, &measured, &report.estimate) {
                            (Scheme::TaskSpace, _, Some(Ok(est))) => {
                                // The integral is frozen while the
                                // feedback is backed off (anti-windup).
                                feedback = task_feedback(
                                    &mut self.task_pid,
                                    self.controller.robot(),
                                    setpoint,
                                    k,
                                    est,
                                    age,
                                    dt,
                                    closed,
                                    [self.feedback_scale, self.moment_scale],
                                    &self.prediction,
                                );
                                None
                            }
                            (Scheme::JointSpace, Some((lengths, rates)), Some(Ok(_))) => {
                                let rates_d = length_rates(&k.w, &setpoint.velocity, &k.omega);
                                let mut lengths_d = [0.0; CABLES];
                                for (i, l) in lengths_d.iter_mut().enumerate() {
                                    // Extrapolated over the setpoint's age.
                                    *l = k.lengths[i] + rates_d[i] * age;
                                }
                                self.joint_pid.as_mut().and_then(|pid| {
                                    pid.update(lengths, rates, &lengths_d, &rates_d, dt, closed).ok()
                                })
                            }
                            _ => None,
                        };
                        if let Some(j) = joint {
                            offsets = j;
                        }
                        ticks.feedback = clock.since(t2);
                        self.controller
                            .finish(setpoint, prepared, &feedback, joint.as_ref(), clock, &mut ticks)
                            .map(|c| {
                                let mut lengths = [0.0; CABLES];
                                lengths.copy_from_slice(k.lengths.as_slice());
                                (c, lengths)
                            })
                    }
                };
                let cycle = Cycle { result: result.map(|(c, _)| c), ticks };
                report.solved = Some(cycle);
                // The feedback, not the setpoint, left the feasible set.
                let feedback_infeasible =
                    matches!(result, Err(Error::Infeasible)) && feedback.iter().any(|f| *f != 0.0);
                match result {
                    Err(Error::Infeasible) if feedback_infeasible => {
                        carried = 0.0;
                        self.task_pid.discard_output();
                        let halve = |s: f32| if s > FEEDBACK_SCALE_MIN { 0.5 * s } else { 0.0 };
                        match self.back_off {
                            BackOff::Whole => {
                                self.feedback_scale = halve(self.feedback_scale);
                                self.moment_scale = self.feedback_scale;
                            }
                            BackOff::ForceFirst => {
                                self.feedback_scale = halve(self.feedback_scale);
                                if self.feedback_scale == 0.0 {
                                    self.moment_scale = 0.0;
                                }
                            }
                        }
                        SetpointStatus::FeedbackInfeasible
                    }
                    Ok((c, lengths)) if tension_core::all_finite(c.torques.iter().copied()) => {
                        // `tension_core::min`, a plain comparison: `f32::min`
                        // is libm's software `fminf` on the Cortex-M4F.
                        let recovered =
                            |scale: f32| tension_core::min(scale + FEEDBACK_RECOVERY_PER_CYCLE, 1.0);
                        self.feedback_scale = recovered(self.feedback_scale);
                        self.moment_scale = recovered(self.moment_scale);
                        // The setpoint is feasible whatever the estimate:
                        // the length check and the stand-in plant follow it.
                        self.feasible_lengths = Some(lengths);
                        if matches!(report.estimate, Some(Err(_))) {
                            SetpointStatus::Unobservable
                        } else {
                            SetpointStatus::Feasible(c.torques)
                        }
                    }
                    Ok(_) => SetpointStatus::Bad,
                    Err(Error::Infeasible) => {
                        self.counters.infeasible = self.counters.infeasible.wrapping_add(1);
                        SetpointStatus::Infeasible
                    }
                    Err(_) => SetpointStatus::Bad,
                }
            }
        };
        // No setpoint solved: the estimate from the last one (plain
        // Gauss-Newton; the solver did not run, so its time is free).
        if report.estimate.is_none() {
            if let Some((lengths, _)) = &measured {
                let t = clock.ticks();
                report.estimate = Some(self.estimator.from_last(self.controller.robot(), lengths));
                ticks.estimator = clock.since(t);
                if let Some(c) = &mut report.solved {
                    c.ticks.estimator = ticks.estimator;
                }
            }
        }
        // Lengths that fit no pose (a broken, slack or slipping cable, an
        // encoder that stopped, a wrong homing once the platform moves):
        // Fault at once, unlike the estimator's other failures.
        if matches!(report.estimate, Some(Err(EstimateError::Residual)))
            && matches!(self.supervisor.state(), State::Enabled | State::Holding)
            && self.supervisor.fault(now, Reason::Estimator)
        {
            faulted = true;
        }
        if overrun {
            self.counters.overruns = self.counters.overruns.wrapping_add(1);
        }

        let mut requests = core::mem::take(&mut self.requests);
        // Enable only where the platform is: within the tracking limit of
        // the setpoint just solved (it would fault on `tracking` at once
        // otherwise).
        if requests.enable && self.off_track(measured.as_ref().map(|(l, _)| l)) {
            requests.enable = false;
            self.counters.reject(Rejection::State);
        }
        let (mut output, decisions) = self.supervisor.cycle(now, requests, &status, overrun);
        for _ in 0..decisions.refused {
            self.counters.reject(Rejection::State);
        }
        faulted |= decisions.faulted;
        if decisions.disabled {
            self.link.restart_sequence();
        }

        if state_before == State::Fault && decisions.disabled {
            // ClearFault granted.
            drives.clear_faults();
            self.drive_fault = None;
        }
        let written = drives.set_brakes(output.brakes).and_then(|()| drives.apply(&output.torques));
        let written_fault = written.as_ref().err().and_then(|e| drives.drive_fault(e));
        if let Some(f) = written_fault {
            self.drive_fault.get_or_insert(f);
        }
        let output_reason = if written_fault.is_some() { Reason::Drive } else { Reason::Output };
        if written.is_err() && self.supervisor.fault(now, output_reason) {
            faulted = true;
            output.torques = *self.supervisor.torques();
            output.brakes = true;
            // Best effort: the drives just failed; try to engage the brakes and
            // write the ramp's first value anyway.
            let _ = drives.set_brakes(true);
            let _ = drives.apply(&output.torques);
        }
        if faulted {
            self.counters.faults = self.counters.faults.wrapping_add(1);
        }
        // A stream ends with the motion it drove.
        if faulted || decisions.disabled {
            self.buffer.clear();
        }

        let state = self.supervisor.state();
        let reason = self.supervisor.reason();
        // Setpoints drive the winches only in Enabled and Holding: only
        // then do the order and jump checks apply (`crate::link`).
        self.link.bind(matches!(state, State::Enabled | State::Holding));
        // Built in place when due (a cycle without telemetry writes only
        // `None`).
        report.telemetry = None;
        if self.telemetry_period != 0 && now.is_multiple_of(u32::from(self.telemetry_period)) {
            report.telemetry = Some({
                // By reference: the solved cycle's command is not copied
                // (about 250 instructions of `memcpy` on the board).
                let ok = report.solved.as_ref().and_then(|c| c.result.as_ref().ok());
                let limited = ok.map_or(Saturation::NONE, |c| c.limited);
                Telemetry {
                    cycle: now,
                    setpoint_seq: self.newest_setpoint().map_or(0, |s| s.seq),
                    state,
                    reason,
                    hold_reason: self.supervisor.hold_reason(),
                    solved: ok.is_some(),
                    tensions: ok.map_or([0.0; CABLES], |c| c.tensions),
                    torques: output.torques,
                    brakes: output.brakes,
                    step_cost: core::mem::take(&mut self.worst_cost),
                    counters: self.counters,
                    method: self.controller.method().wire_id(),
                    estimate: self.estimator.last().map_or([0.0; 6], |p| (*p).into()),
                    residual: match &report.estimate {
                        Some(Ok(e)) => e.residual,
                        _ => f32::NAN,
                    },
                    homed: self.homing.is_some(),
                    feedback: self.scheme.wire_id(),
                    unreadable_drive,
                    tension_limited: limited
                        .0
                        .iter()
                        .enumerate()
                        .fold(0u8, |bits, (i, &l)| bits | (u8::from(l) << i)),
                    feedback_scale: if self.scheme == Scheme::TaskSpace {
                        (carried * 100.0 + 0.5) as u8
                    } else {
                        100
                    },
                    buffer_fill: self.buffer.fill(now).min(255) as u8,
                    buffer_lead_ms: self.buffer.lead_ms(now).min(u32::from(u16::MAX)) as u16,
                    drive_fault: self.drive_fault,
                }
            });
        }
        self.cycle = self.cycle.wrapping_add(1);
        report.cycle = now;
        report.state = state;
        report.reason = reason;
        report.torques = output.torques;
        report.brakes = output.brakes;
        report.feedback = feedback;
        report.offsets = offsets;
        report.unreadable_drive = unreadable_drive;
        report.drive_fault = self.drive_fault;
    }

    /// Whether a measured cable length is more than the tracking limit off
    /// the last feasible setpoint's (a NaN counts as off; no limit, no
    /// lengths or no feasible setpoint: not off).
    fn off_track(&self, lengths: Option<&[f32; CABLES]>) -> bool {
        let (Some(lengths), Some(limit), Some(feasible)) =
            (lengths, self.tracking_limit, &self.feasible_lengths)
        else {
            return false;
        };
        // Off unless within the limit: a NaN compares as unordered, off.
        lengths.iter().zip(feasible).any(|(l, f)| {
            let e = libm::fabsf(l - f);
            !matches!(e.partial_cmp(&limit), Some(core::cmp::Ordering::Less | core::cmp::Ordering::Equal))
        })
    }

    /// A `Home` (Disabled when it was accepted; still Disabled now): the
    /// offsets from the pose's inverse kinematics and this cycle's counts.
    fn carry_out_home(&mut self, pose: &Pose6, readable: bool) {
        if self.supervisor.state() != State::Disabled {
            self.counters.reject(Rejection::State);
            return;
        }
        if !readable {
            self.counters.reject(Rejection::Homing);
            return;
        }
        // The cable lengths at the home pose, by the step's own kinematics
        // (one pass, the frame's sines and cosines once).
        let at_rest =
            Setpoint { seq: 0, pose: *pose, velocity: Pose6::zeros(), acceleration: Pose6::zeros() };
        match self.controller.kinematics(&at_rest) {
            Ok(k) => {
                let mut lengths = [0.0; CABLES];
                lengths.copy_from_slice(k.lengths.as_slice());
                self.homing = Some(self.scale.home(&lengths, &self.readings));
                self.estimator.reset(pose);
            }
            Err(_) => self.counters.reject(Rejection::Range),
        }
    }
}

/// The task-space PID's wrench from the estimate about the setpoint: the
/// pose error is minus the estimator's correction (`e = -delta`), moved
/// by the setpoint's velocity over its `age` (s) so that the reference
/// keeps moving while a frame is late; the rate error is the setpoint's
/// velocity less the estimate's, its rotational part mapped to angular
/// velocity at the setpoint's angles; `R c` at the setpoint's rotation
/// (the kinematics' sines and cosines). Zero if the numbers are not
/// finite.
#[allow(clippy::too_many_arguments)]
fn task_feedback(
    pid: &mut TaskPid,
    robot: &crate::robot::ControlRobot,
    setpoint: &Setpoint,
    k: &crate::controller::SetpointKinematics,
    estimate: &Estimate,
    age: f32,
    dt: f32,
    integrate: bool,
    scale: [f32; 2],
    prediction: &Prediction,
) -> Wrench {
    use tension_core::nalgebra::Vector3;
    let v = &setpoint.velocity;
    let omega_d = k.omega;
    let ev = estimate.velocity;
    let omega = k.trig.euler_rate_matrix() * Vector3::new(ev[3], ev[4], ev[5]);
    let d = &estimate.delta;
    let error = [
        -d[0] + v[0] * age,
        -d[1] + v[1] * age,
        -d[2] + v[2] * age,
        -d[3] + omega_d.x * age,
        -d[4] + omega_d.y * age,
        -d[5] + omega_d.z * age,
    ];
    let rates = [
        v[0] - ev[0],
        v[1] - ev[1],
        v[2] - ev[2],
        omega_d.x - omega.x,
        omega_d.y - omega.y,
        omega_d.z - omega.z,
    ];
    let rc = k.trig.rotation() * robot.platform().com;
    pid.update_error(&error, &rates, &rc, dt, integrate, scale, prediction)
        .unwrap_or_else(|_| Wrench::zeros())
}
