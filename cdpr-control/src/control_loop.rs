//! One call per control cycle: the link's events, the controller and the
//! supervisor together. The firmware and `hal-sim` both drive a
//! [`ControlLoop`]:
//!
//! 1. every received byte goes to [`ControlLoop::receive_byte`] (or a
//!    decoded message to [`ControlLoop::receive`]);
//! 2. once per period [`ControlLoop::step`] solves the newest setpoint,
//!    lets the supervisor decide, writes the drives and returns the
//!    telemetry due this cycle;
//! 3. the caller reports the step's measured cost with
//!    [`ControlLoop::record_cost`] (it appears in the next telemetry).

use cdpr_protocol::{Counters, HostMessage, Reason, State, Telemetry};
use tension_core::{Error, Method};

use crate::controller::{Controller, Cycle, Wrench};
use crate::drives::WinchDrives;
use crate::link::{Event, Link, SetpointRange};
use crate::robot::ControlRobot;
use crate::setpoint::Setpoint;
use crate::supervisor::{Requests, SafetyLimits, SetpointStatus, Supervisor};
use crate::{TickCounter, CABLES};

/// Telemetry period at start-up, cycles.
pub const DEFAULT_TELEMETRY_PERIOD: u16 = 10;

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

    /// Takes one byte from the serial link.
    pub fn receive_byte(&mut self, byte: u8) {
        if let Some(event) = self.link.receive(byte, &mut self.counters) {
            self.apply(event);
        }
    }

    /// Takes one decoded message (checked like a received frame).
    pub fn receive(&mut self, message: HostMessage) {
        if let Some(event) = self.link.accept(message, &mut self.counters) {
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
            // Only while disabled: a switch in motion would jump the tensions.
            Event::SelectMethod(method) => {
                let allowed = self.supervisor.state() == State::Disabled;
                if !(allowed && self.controller.set_method(method).is_ok()) {
                    self.counters.rejected_state = self.counters.rejected_state.wrapping_add(1);
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
        self.counters.rejected_state = self.counters.rejected_state.wrapping_add(decisions.refused);
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
