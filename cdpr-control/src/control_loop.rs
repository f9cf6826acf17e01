//! One call per control cycle: the link's events, the controller and the
//! supervisor together. The firmware and `hal-sim` both drive a
//! [`ControlLoop`]:
//!
//! 1. the received bytes go to [`ControlLoop::receive_bytes`], at most
//!    [`RECEIVE_BUDGET`] a cycle, or one by one to
//!    [`ControlLoop::receive_byte`] (or a decoded message to
//!    [`ControlLoop::receive`]);
//! 2. once per period [`ControlLoop::step`] solves the newest setpoint,
//!    lets the supervisor decide, writes the drives and returns the
//!    telemetry due this cycle;
//! 3. the caller reports the step's measured cost with
//!    [`ControlLoop::record_cost`] (it appears in the next telemetry).

use cdpr_protocol::{Counters, HostMessage, Reason, Rejection, State, Telemetry};
use tension_core::{Error, Method};

use crate::controller::{Controller, Cycle, Wrench};
use crate::drives::WinchDrives;
use crate::link::{Event, JumpLimits, Link, SetpointRange};
use crate::robot::ControlRobot;
use crate::setpoint::Setpoint;
use crate::supervisor::{Requests, SafetyLimits, SetpointStatus, Supervisor};
use crate::{TickCounter, CABLES};

/// Telemetry period at start-up, cycles.
pub const DEFAULT_TELEMETRY_PERIOD: u16 = 10;

/// Most received bytes [`ControlLoop::receive_bytes`] takes in one cycle:
/// the receive work per cycle is bounded whatever arrives. On the board
/// (`cargo xtask run`'s receive flood) a cycle's 256 bytes cost at most
/// about 24 000 instructions (back-to-back valid setpoint frames, 92 a
/// byte: COBS, CRC-32, postcard, the canonical re-encoding, the checks;
/// 0x00 storms, 0xFF runs and noise 17 to 29 a byte), so with the worst
/// step the cycle stays within a third of the 1 ms period (125 000
/// instructions under QEMU). 256 bytes a millisecond is 22 times what
/// 115 200 baud carries (11.5 bytes per ms) and three setpoint frames per
/// cycle; what arrives faster waits in the receive queue, and what finds
/// the queue full is dropped and counted (`Counters::dropped_bytes`).
pub const RECEIVE_BUDGET: usize = 256;

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
    last_cost: u32,
    /// The newest setpoint that solved feasibly (what the winches hold).
    last_feasible: Option<Setpoint>,
    /// The methods `SelectMethod` may choose.
    offered: MethodSet,
}

impl ControlLoop {
    /// A loop for `robot` with `method`, accepting setpoints within `range`,
    /// with the supervisor's `limits`. Starts Disabled.
    pub fn new(
        robot: ControlRobot,
        method: Method,
        range: SetpointRange,
        limits: SafetyLimits,
    ) -> Result<Self, Error> {
        Ok(Self {
            controller: Controller::new(robot, method)?,
            supervisor: Supervisor::new(limits),
            link: Link::new(range),
            counters: Counters::default(),
            newest: Newest::Nothing,
            requests: Requests::default(),
            telemetry_period: DEFAULT_TELEMETRY_PERIOD,
            cycle: 0,
            last_cost: 0,
            last_feasible: None,
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

    /// The newest setpoint that solved feasibly: the one whose torques the
    /// winches get (Enabled) or hold (Holding).
    pub fn last_feasible_setpoint(&self) -> Option<&Setpoint> {
        self.last_feasible.as_ref()
    }

    /// Supervision from the winch encoders: in Enabled or Holding, compares
    /// the measured cable `lengths` (m) with the inverse kinematics of the
    /// last feasible setpoint and enters Fault (`Reason::Tracking`) when one
    /// differs by more than `limit` (m). Call before [`ControlLoop::step`]
    /// of the same cycle, which then starts the fault's torque ramp with the
    /// brakes engaged. Returns the cable with the largest error if it
    /// faulted. A broken cable shows here within tens of milliseconds (its
    /// unloaded winch reels in), and so does a winch that cannot deliver
    /// its torque (its cable pays out as the platform sags).
    pub fn check_lengths(&mut self, lengths: &[f32; CABLES], limit: f32) -> Option<usize> {
        if !matches!(self.supervisor.state(), State::Enabled | State::Holding) {
            return None;
        }
        let setpoint = self.last_feasible?;
        // The setpoint solved, so its kinematics do: only a non-finite
        // length fails here, which is as bad as a large one.
        let errors = crate::feedback::length_errors(self.controller.robot(), &setpoint.pose, lengths)
            .unwrap_or([f32::INFINITY; CABLES]);
        let (worst, error) = errors
            .iter()
            .map(|e| if e.is_nan() { f32::INFINITY } else { libm::fabsf(*e) })
            .enumerate()
            .fold((0, 0.0f32), |best, (i, e)| if e > best.1 { (i, e) } else { best });
        if error > limit && self.supervisor.fault(self.cycle, Reason::Tracking) {
            self.counters.faults = self.counters.faults.wrapping_add(1);
            return Some(worst);
        }
        None
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
        if let Some(event) = self.link.receive(byte, self.cycle, &mut self.counters) {
            self.apply(event);
        }
    }

    /// Takes the bytes `next` yields, at most [`RECEIVE_BUDGET`] (the rest
    /// stays with the caller for the next cycle); returns how many it took.
    pub fn receive_bytes(&mut self, mut next: impl FnMut() -> Option<u8>) -> usize {
        for taken in 0..RECEIVE_BUDGET {
            match next() {
                Some(byte) => self.receive_byte(byte),
                None => return taken,
            }
        }
        RECEIVE_BUDGET
    }

    /// Reports the bytes the receiver dropped so far (its running total),
    /// shown as `Counters::dropped_bytes`.
    pub fn record_dropped(&mut self, total: u32) {
        self.counters.dropped_bytes = total;
    }

    /// Takes one decoded message (checked like a received frame).
    pub fn receive(&mut self, message: HostMessage) {
        if let Some(event) = self.link.accept(message, self.cycle, &mut self.counters) {
            self.apply(event);
        }
    }

    fn apply(&mut self, event: Event) {
        match event {
            Event::Setpoint(s) => self.newest = Newest::Good(s, self.cycle),
            Event::BadSetpoint => self.newest = Newest::Bad,
            Event::Enable => self.requests.enable = true,
            Event::Disable => self.requests.disable = true,
            Event::ClearFault => self.requests.clear_fault = true,
            Event::TelemetryPeriod(p) => self.telemetry_period = p,
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

    /// Records the measured cost of the last step (instructions or cycles),
    /// reported in the next telemetry.
    pub fn record_cost(&mut self, cost: u32) {
        self.last_cost = cost;
    }

    /// One control cycle. `extra` is an external wrench on the platform
    /// (base frame, about the platform origin) that the cables must balance
    /// on top of gravity and the setpoint's inertia, so the cables produce
    /// `-extra` more: pass the negative of a feedback wrench
    /// (`feedback::TaskPid::update`), zero for feed-forward only; `overrun`
    /// says whether the previous cycle missed its deadline; `clock` times
    /// the controller's phases.
    pub fn step<C: TickCounter, D: WinchDrives>(
        &mut self,
        clock: &C,
        drives: &mut D,
        extra: &Wrench,
        overrun: bool,
    ) -> StepReport {
        let now = self.cycle;
        let mut solved = None;
        let status = match self.newest {
            Newest::Nothing => SetpointStatus::Stale,
            Newest::Bad => SetpointStatus::Bad,
            Newest::Good(_, arrived) if now.wrapping_sub(arrived) > self.supervisor.limits().stale_cycles => {
                SetpointStatus::Stale
            }
            Newest::Good(setpoint, _) => {
                let cycle = self.controller.step(&setpoint, extra, clock);
                solved = Some(cycle);
                match cycle.result {
                    Ok(c) if c.torques.iter().all(|t| t.is_finite()) => {
                        self.last_feasible = Some(setpoint);
                        SetpointStatus::Feasible(c.torques)
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
        if overrun {
            self.counters.overruns = self.counters.overruns.wrapping_add(1);
        }

        let requests = core::mem::take(&mut self.requests);
        let (mut output, decisions) = self.supervisor.cycle(now, requests, &status, overrun);
        for _ in 0..decisions.refused {
            self.counters.reject(Rejection::State);
        }
        let mut faulted = decisions.faulted;
        if decisions.disabled {
            self.link.restart_sequence();
        }

        let written = drives.set_brakes(output.brakes).and_then(|()| drives.apply(&output.torques));
        if written.is_err() && self.supervisor.fault(now, Reason::Output) {
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

        let state = self.supervisor.state();
        let reason = self.supervisor.reason();
        // Setpoints drive the winches only in Enabled and Holding: only
        // then do the order and jump checks apply (`crate::link`).
        self.link.bind(matches!(state, State::Enabled | State::Holding));
        let telemetry = (self.telemetry_period != 0 && now.is_multiple_of(u32::from(self.telemetry_period)))
            .then(|| {
                let ok = solved.and_then(|c| c.result.ok());
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
                    step_cost: self.last_cost,
                    counters: self.counters,
                    method: self.controller.method().wire_id(),
                }
            });
        self.cycle = self.cycle.wrapping_add(1);
        StepReport {
            cycle: now,
            solved,
            state,
            reason,
            torques: output.torques,
            brakes: output.brakes,
            telemetry,
        }
    }
}
