//! The safety state machine: what reaches the winches each cycle.
//!
//! ```text
//!                 Enable (fresh feasible setpoint,
//!                  ramp finished)
//!   +----------+ -----------------------------> +---------+
//!   | Disabled |                                | Enabled | <-----------+
//!   +----------+ <----------------------------- +---------+             |
//!     ^    ^         Disable (ramp to 0)            | setpoint          | feasible
//!     |    |                                        | infeasible, bad   | setpoint
//!     |    |         Disable (ramp to 0)            v or stale          |
//!     |    +------------------------------------ +---------+ -----------+
//!     |                                          | Holding |  last feasible
//!     | ClearFault (ramp finished)               +---------+  torques held
//!     |                                               | held hold_cycles
//!  +-------+ <----------------------------------------+
//!  | Fault | <---- overrun_limit overruns in a row, drive error (from Enabled or Holding)
//!  +-------+  torques ramp to 0 over ramp_cycles, brakes engaged; latched
//! ```
//!
//! * **Disabled**: brakes engaged; torques ramp from what was applied to
//!   zero over `ramp_cycles` (so the load passes to the brakes smoothly), then
//!   stay zero. `Enable` is granted only once the ramp has finished and the
//!   newest setpoint was solved feasibly in this very cycle; otherwise it
//!   is refused and counted (`rejected_state`).
//! * **Enabled**: brakes released; the torques of the newest setpoint.
//! * **Holding**: the newest setpoint is infeasible, bad (non-finite, out of
//!   range, solver failure) or stale (no setpoint for more than
//!   `stale_cycles`), or the pose estimator failed (`estimator`): the last
//!   feasible torques are held (a cycle whose task-space feedback alone
//!   made the setpoint infeasible gets them too, the state unchanged:
//!   `FeedbackInfeasible`). A feasible fresh
//!   setpoint returns to Enabled; after `hold_cycles` of holding, Fault.
//! * **Fault**: brakes engaged, torques ramp to zero like Disabled; the
//!   state is latched until `ClearFault` (granted once the ramp has
//!   finished), which leads to Disabled. Requests change the state at most
//!   once per cycle (precedence Disable, ClearFault, Enable): an `Enable`
//!   in the same cycle as a granted `ClearFault` or `Disable` is refused,
//!   so Disabled is always visible on the way back. Also entered from Enabled or
//!   Holding when `overrun_limit` cycles in a row miss their deadline (a
//!   loop that cannot keep up; one late cycle only holds the previous
//!   torques a millisecond longer), when the drives report an error
//!   (`drive-error`), when an encoder cannot be read (`encoder`) or when a
//!   cable length departs from the setpoint's (`tracking`).
//!
//! Time is counted in control cycles (1 ms each on the board).

use cdpr_protocol::{Reason, State};

use crate::CABLES;

/// The state machine's time limits, in control cycles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SafetyLimits {
    /// A setpoint older than this is stale.
    pub stale_cycles: u32,
    /// Holding longer than this faults.
    pub hold_cycles: u32,
    /// Torques ramp to zero over this many cycles when disabling or faulting.
    pub ramp_cycles: u32,
    /// This many deadline overruns in a row fault.
    pub overrun_limit: u32,
}

impl SafetyLimits {
    /// The firmware's limits at 1 kHz: stale after 50 ms, fault after
    /// holding 100 ms, 200 ms torque ramp, fault at the 5th overrun in a row.
    pub const DEFAULT: Self = Self { stale_cycles: 50, hold_cycles: 100, ramp_cycles: 200, overrun_limit: 5 };
}

impl Default for SafetyLimits {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What the newest setpoint gave this cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SetpointStatus {
    /// Fresh and feasible: these motor torques, N m.
    Feasible([f32; CABLES]),
    /// Fresh, but no tensions within the limits hold it.
    Infeasible,
    /// Unusable: non-finite or out of range, or the solver failed otherwise.
    Bad,
    /// No setpoint, or the newest is older than `stale_cycles`.
    Stale,
    /// The setpoint solved, but the pose estimator failed this cycle (the
    /// forward kinematics of the encoder lengths, or its residual): the
    /// closed loop cannot run (Holding with `Reason::Estimator`; Enable
    /// refused).
    Unobservable,
    /// The setpoint with the task-space feedback wrench had no feasible
    /// tensions (the setpoint alone may): the last feasible torques this
    /// cycle, the state unchanged (`ControlLoop` backs the feedback off).
    FeedbackInfeasible,
}

/// Commands waiting for the next cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Requests {
    /// `Enable` was received.
    pub enable: bool,
    /// `Disable` was received.
    pub disable: bool,
    /// `ClearFault` was received.
    pub clear_fault: bool,
}

/// What the supervisor commands this cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Output {
    /// Motor torques, N m.
    pub torques: [f32; CABLES],
    /// Whether the brakes are engaged.
    pub brakes: bool,
}

/// What happened to this cycle's requests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Decisions {
    /// Requests refused in the current state.
    pub refused: u32,
    /// Whether this cycle entered Fault.
    pub faulted: bool,
    /// Whether this cycle entered Disabled (the link restarts its sequence).
    pub disabled: bool,
}

/// The state machine.
#[derive(Debug, Clone)]
pub struct Supervisor {
    limits: SafetyLimits,
    state: State,
    reason: Reason,
    hold_reason: Reason,
    hold_start: u32,
    ramp_from: [f32; CABLES],
    ramp_start: u32,
    last_feasible: [f32; CABLES],
    overruns: u32,
    output: [f32; CABLES],
}

impl Supervisor {
    /// Disabled, torques zero, ramp finished.
    pub fn new(limits: SafetyLimits) -> Self {
        Self {
            limits,
            state: State::Disabled,
            reason: Reason::None,
            hold_reason: Reason::None,
            hold_start: 0,
            ramp_from: [0.0; CABLES],
            // As if a ramp had finished just before cycle 0.
            ramp_start: 0u32.wrapping_sub(limits.ramp_cycles),
            last_feasible: [0.0; CABLES],
            overruns: 0,
            output: [0.0; CABLES],
        }
    }

    /// The current state.
    pub fn state(&self) -> State {
        self.state
    }

    /// Why the state is Holding or Fault.
    pub fn reason(&self) -> Reason {
        self.reason
    }

    /// What started the hold of a `HoldTimeout` fault (or of the current hold).
    pub fn hold_reason(&self) -> Reason {
        self.hold_reason
    }

    /// The limits.
    pub fn limits(&self) -> &SafetyLimits {
        &self.limits
    }

    /// The torques commanded by the last cycle.
    pub fn torques(&self) -> &[f32; CABLES] {
        &self.output
    }

    fn ramp_done(&self, now: u32) -> bool {
        now.wrapping_sub(self.ramp_start) >= self.limits.ramp_cycles
    }

    /// `ramp_from` scaled by `1 - elapsed / ramp_cycles`, zero after the ramp.
    fn ramp(&self, now: u32) -> [f32; CABLES] {
        let elapsed = now.wrapping_sub(self.ramp_start);
        if elapsed >= self.limits.ramp_cycles {
            return [0.0; CABLES];
        }
        let scale = 1.0 - elapsed as f32 / self.limits.ramp_cycles as f32;
        self.ramp_from.map(|t| t * scale)
    }

    fn start_ramp(&mut self, now: u32) {
        // Only finite torques are ever stored in `output`, so the ramp is finite.
        self.ramp_from = self.output;
        self.ramp_start = now;
    }

    fn enter_fault(&mut self, now: u32, reason: Reason) {
        if reason != Reason::HoldTimeout {
            self.hold_reason = Reason::None;
        }
        self.state = State::Fault;
        self.reason = reason;
        self.start_ramp(now);
    }

    /// Enters Fault now (e.g. the drives reported an error). Already in
    /// Fault: nothing changes. Returns whether it entered.
    pub fn fault(&mut self, now: u32, reason: Reason) -> bool {
        if self.state == State::Fault {
            return false;
        }
        self.enter_fault(now, reason);
        self.output = self.ramp(now);
        true
    }

    /// One control cycle at time `now` (cycles): applies the pending
    /// `requests`, the newest setpoint's `status` and whether the previous
    /// cycle overran its deadline, and returns the command for the drives.
    pub fn cycle(
        &mut self,
        now: u32,
        requests: Requests,
        status: &SetpointStatus,
        overrun: bool,
    ) -> (Output, Decisions) {
        let mut decisions = Decisions::default();
        let before = self.state;

        // Requests, most protective first; at most one of them changes the
        // state per cycle, so every transition is an edge of the diagram
        // and each state it passes through is seen (ClearFault and Enable
        // in one burst: Disabled this cycle, and the Enable is refused).
        let mut changed = false;
        if requests.disable {
            match self.state {
                State::Enabled | State::Holding => {
                    self.state = State::Disabled;
                    self.reason = Reason::None;
                    self.hold_reason = Reason::None;
                    self.start_ramp(now);
                    changed = true;
                }
                // Already disabled, or latched in fault: nothing to do.
                State::Disabled | State::Fault => {}
            }
        }
        if requests.clear_fault {
            if self.state == State::Fault && self.ramp_done(now) && !changed {
                self.state = State::Disabled;
                self.reason = Reason::None;
                self.hold_reason = Reason::None;
                changed = true;
            } else {
                decisions.refused += 1;
            }
        }
        if requests.enable {
            match (self.state, status) {
                (State::Disabled, SetpointStatus::Feasible(_))
                    if self.ramp_done(now) && !requests.disable && !changed =>
                {
                    self.state = State::Enabled;
                }
                _ => decisions.refused += 1,
            }
        }

        self.overruns = if overrun { self.overruns.saturating_add(1) } else { 0 };
        if matches!(self.state, State::Enabled | State::Holding) && self.overruns >= self.limits.overrun_limit
        {
            self.enter_fault(now, Reason::Overruns);
        }

        match self.state {
            State::Disabled | State::Fault => self.output = self.ramp(now),
            State::Enabled | State::Holding => {
                match status {
                    SetpointStatus::Feasible(torques) => {
                        self.state = State::Enabled;
                        self.reason = Reason::None;
                        self.hold_reason = Reason::None;
                        self.last_feasible = *torques;
                        self.output = self.last_feasible;
                    }
                    // Neither a problem nor a fresh solution: one cycle
                    // more of the last feasible torques; a hold goes on.
                    SetpointStatus::FeedbackInfeasible => self.hold_last_feasible(now),
                    SetpointStatus::Infeasible => self.hold(now, Reason::Infeasible),
                    SetpointStatus::Bad => self.hold(now, Reason::BadSetpoint),
                    SetpointStatus::Stale => self.hold(now, Reason::Stale),
                    SetpointStatus::Unobservable => self.hold(now, Reason::Estimator),
                }
            }
        }

        self.finish_cycle(before, decisions)
    }

    /// Holding for `reason` (entered now from Enabled, its hold reason
    /// kept from the hold's start), the last feasible torques held.
    fn hold(&mut self, now: u32, reason: Reason) {
        if self.state == State::Enabled {
            self.state = State::Holding;
            self.hold_start = now;
            self.hold_reason = reason;
        }
        self.reason = reason;
        self.hold_last_feasible(now);
    }

    /// The last feasible torques; in Holding, Fault (`HoldTimeout`) once
    /// the hold has lasted `hold_cycles`.
    fn hold_last_feasible(&mut self, now: u32) {
        self.output = self.last_feasible;
        if self.state == State::Holding && now.wrapping_sub(self.hold_start) >= self.limits.hold_cycles {
            self.enter_fault(now, Reason::HoldTimeout);
            self.output = self.ramp(now);
        }
    }

    /// The cycle's output and what it decided, from the state before it.
    fn finish_cycle(&self, before: State, mut decisions: Decisions) -> (Output, Decisions) {
        decisions.faulted = self.state == State::Fault && before != State::Fault;
        decisions.disabled = self.state == State::Disabled && before != State::Disabled;
        let brakes = matches!(self.state, State::Disabled | State::Fault);
        (Output { torques: self.output, brakes }, decisions)
    }
}
