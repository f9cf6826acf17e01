//! The product's log of the safety state machine's changes, written in the
//! time the control loop leaves.
//!
//! A change's line (the states, the reason, what the drives hold, the
//! counters, the stack's high-water mark) costs far more than the step:
//! the high-water scan reads every painted word of the stack (about 27 000
//! words, some 130 000 instructions: longer than a control period), and
//! the logger formats and writes the line. Written from the control task,
//! each line made the next release late, and the supervisor counted a
//! deadline overrun for every state change (five in a row fault).
//!
//! So the control task only copies what changed into a queue
//! ([`Recorder::record`], a few dozen instructions), and the idle loop
//! ([`ChangeLog::write_pending`], below every interrupt and task) writes
//! the lines. A change that finds the queue full is not written and is
//! counted; the next line says how many were left out.

use cdpr_control::protocol::{Counters, Reason, State};
use cdpr_control::{StepReport, CABLES};
use heapless::spsc::{Consumer, Producer, Queue};

use crate::{drives, stack};

/// Changes queued before the idle loop has written them. The idle loop
/// runs every millisecond, so a full queue takes eight changes within
/// one line's writing.
pub const QUEUE: usize = 8;

/// The queue's storage, in a static slot of `init`.
pub type ChangeQueue = Queue<StateChange, QUEUE>;

/// One change of the safety state machine, as the control task saw it.
#[derive(Debug, Clone, Copy)]
pub struct StateChange {
    /// The control cycle of the change.
    pub cycle: u32,
    /// The state before.
    pub from: State,
    /// The state after.
    pub to: State,
    /// Why.
    pub reason: Reason,
    /// The drives' torques after the cycle, N m.
    pub torques: [f32; CABLES],
    /// The brakes after the cycle.
    pub brakes: bool,
    /// The link's and the loop's counters after the cycle.
    pub counters: Counters,
    /// Changes before this one that found the queue full: not written.
    pub left_out: u32,
}

/// The control task's side: watches the state, queues its changes.
pub struct Recorder {
    queue: Producer<'static, StateChange>,
    last: State,
    left_out: u32,
}

impl Recorder {
    /// Watches the state from `initial` on.
    pub fn new(queue: Producer<'static, StateChange>, initial: State) -> Self {
        Self { queue, last: initial, left_out: 0 }
    }

    /// Queues the cycle's change of state, if there is one, with what the
    /// drives hold and the counters. Returns whether a change was queued.
    pub fn record(&mut self, report: &StepReport, counters: &Counters) -> bool {
        if report.state == self.last {
            return false;
        }
        let (torques, brakes) = drives::drive_outputs();
        let change = StateChange {
            cycle: report.cycle,
            from: self.last,
            to: report.state,
            reason: report.reason,
            torques,
            brakes,
            counters: *counters,
            left_out: self.left_out,
        };
        self.last = report.state;
        if self.queue.enqueue(change).is_ok() {
            self.left_out = 0;
            true
        } else {
            self.left_out = self.left_out.saturating_add(1);
            false
        }
    }
}

/// The idle loop's side: writes the queued changes.
pub struct ChangeLog {
    queue: Consumer<'static, StateChange>,
}

impl ChangeLog {
    /// Writes from `queue`.
    pub fn new(queue: Consumer<'static, StateChange>) -> Self {
        Self { queue }
    }

    /// Writes every queued change, one line each (at most [`QUEUE`] and
    /// those queued meanwhile: the control task queues at most one a
    /// cycle).
    pub fn write_pending(&mut self) {
        while let Some(change) = self.queue.dequeue() {
            write(&change);
        }
    }
}

/// One change's line; the stack's high-water mark is read now.
fn write(change: &StateChange) {
    if change.left_out > 0 {
        defmt::println!(
            "{=u32} state changes before the next were not logged (the log's queue was full)",
            change.left_out
        );
    }
    let (stack, _) = stack::stack_high_water();
    defmt::println!(
        "cycle {=u32}: {} -> {} ({}); drives {} N m, brakes {=bool}; counters {}; stack high-water mark {=u32} bytes",
        change.cycle,
        change.from,
        change.to,
        change.reason,
        change.torques,
        change.brakes,
        change.counters,
        stack
    );
}
