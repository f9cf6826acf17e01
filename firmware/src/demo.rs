//! The demo and cycle-time run (the `demo` program, `cargo xtask run`):
//! the same control loop as the product, on the same periodic release,
//! fed by a scripted trajectory instead of the serial link, timed, and
//! judged.
//!
//! * Setpoints: [`cdpr_demo::trajectory::Params::script`] with the robot's
//!   derived parameters ([`crate::robot::DEMO`]): 300 cycles at rest at
//!   the centre of its workspace and 300 cycles jumping between poses
//!   (disabled), then one closed loop of 4000 cycles around the centre,
//!   feasible with a tension margin, with one excursion out of the
//!   workspace. They enter the loop as protocol messages, through the
//!   same checks as received frames.
//! * The winches' encoders are a stand-in ([`cdpr_demo::winches`]: each
//!   cable follows the tracked setpoint's inverse kinematics with a 5 ms
//!   lag, read as counts), advanced after each measured step; the loop
//!   reads them, estimates the pose and runs its feedback inside the
//!   step, at their real cost.
//! * A scripted operator: `Home` at the centre at cycle 0, `SelectFeedback`
//!   of the task-space PID once the stand-in has settled after the jumps
//!   (25 cycles before the loop); `Enable` at the loop's start (repeated
//!   until granted: the stand-in needs a few cycles to reach the loop's
//!   first pose after the jumps); after a fault, once the torque ramp has
//!   finished and the setpoint is feasible again, `ClearFault`, the
//!   joint-space PID and `Enable`. So the run shows Enabled -> Holding
//!   (the pose leaves the workspace) -> Fault (hold timeout, torques ramp
//!   down, brakes on) -> Disabled -> Enabled, with each feedback scheme in
//!   one of the Enabled stretches.
//! * TIM2 times every step from the setpoint to the drive writes.
//!
//! At the end it prints the statistics, times the barycenter's phases and
//! replays the poses through the other methods, logs its results as one
//! encoded [`Record::Finished`] and exits through semihosting:
//!
//! * [`exit::PASS`]: every step within [`BUDGET`] and no deadline overrun,
//!   and the expected states ([`cdpr_demo::EXPECTED_STATES`]) and statuses;
//! * [`exit::FAIL`]` | flags` (32..=63) otherwise, see [`exit::fail`].
//!
//! The `inject-*` programs run the same demo and fault at
//! [`cdpr_demo::INJECT_AT`] ([`Inject`]).

use cdpr_control::controller::{Controller, Wrench};
use cdpr_control::feedback::Scheme;
use cdpr_control::protocol::{encode, HostMessage, State};
use cdpr_control::stats::{Running, Samples, Summary};
use cdpr_control::{ControlLoop, Setpoint, StepReport, TickCounter, CABLES};
use cdpr_demo::exit::{self, fail};
use cdpr_demo::report::{Record, Report, Spread, MAX_STATES};
use cdpr_demo::{methods, trajectory, BUDGET, EXPECTED_STATES, INJECT_AT};
use tension_core::{Error, Method, WarmStart};

use crate::clock::{self, ticks_to_units as units, Tim2Counter};
use crate::loopback::{self, DemoDrives};
use crate::periodic::Releases;
use crate::robot::DEMO;
use crate::{bsp, drives, log_record, stack, Board};
use canopen_drives::model::LoopbackRig;

/// Cycles of the scripted run (the prelude and one loop of the trajectory).
pub const CYCLES: usize = trajectory::SCRIPT_CYCLES;

// The statistics live in fixed buffers of this many samples.
const _: () = assert!(CYCLES >= 2000);

/// A fault the `inject-*` programs provoke at [`INJECT_AT`], while the
/// drives command torques, to check that the handlers stop them first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Inject {
    /// `panic!`.
    Panic,
    /// An undefined instruction: a HardFault.
    HardFault,
}

impl Inject {
    /// Logs the drives' torques (readable and as a record), then faults.
    fn fire(self, cycle: u32) -> ! {
        let (torques, _) = drives::drive_outputs();
        let what = match self {
            Inject::Panic => "a panic",
            Inject::HardFault => "a HardFault",
        };
        defmt::println!("injecting {=str} at cycle {=u32}; drives command {} N m", what, cycle, torques);
        log_record(&Record::Injecting { cycle, torques });
        match self {
            Inject::Panic => panic!("injected at cycle {}", cycle),
            Inject::HardFault => {
                cortex_m::asm::udf();
            }
        }
    }
}

/// Counts per status of a run's cycles.
#[derive(Default)]
struct Outcomes {
    estimated: u32,
    unestimated: u32,
    residual_um: u32,
    ok: u32,
    infeasible: u32,
    no_convergence: u32,
    other: u32,
    warm_held: u32,
    warm_lost: u32,
    saturated: u32,
}

impl Outcomes {
    fn count<T>(&mut self, result: &Result<T, Error>) {
        match result {
            Ok(_) => self.ok += 1,
            Err(Error::Infeasible) => self.infeasible += 1,
            Err(Error::NoConvergence) => self.no_convergence += 1,
            Err(_) => self.other += 1,
        }
    }
}

/// Mean and max of each phase of the control step.
#[derive(Default)]
struct Breakdown {
    /// The worst step and its phases: total, setpoint, encoders,
    /// kinematics, estimator, feedback, solver, torques, the rest.
    worst: [u32; 9],
    setpoint: Running,
    kinematics: Running,
    solver: Running,
    torques: Running,
    read: Running,
    estimator: Running,
    feedback: Running,
    supervisor_and_drives: Running,
}

/// The states the run went through, in order (at most [`MAX_STATES`]
/// changes kept).
struct Transitions {
    states: [State; MAX_STATES],
    len: usize,
}

impl Transitions {
    fn push(&mut self, s: State) {
        if let Some(slot) = self.states.get_mut(self.len) {
            *slot = s;
            self.len += 1;
        }
    }

    fn as_slice(&self) -> &[State] {
        &self.states[..self.len]
    }
}

/// The scripted operator: re-enables once a fault's ramp is over and the
/// setpoint is feasible again.
struct Operator {
    enable: bool,
    /// A scheme to select at the next Disabled cycle.
    scheme: Option<Scheme>,
    fault_since: Option<u32>,
    ramp_cycles: u32,
}

impl Operator {
    /// After cycle `k`'s step: what to ask for next.
    fn after(&mut self, k: u32, report: &StepReport, ok: bool, control: &mut ControlLoop) {
        self.enable = false;
        if report.state == State::Fault && self.fault_since.is_none() {
            self.fault_since = Some(k);
        }
        match report.state {
            State::Fault if ok && self.fault_since.is_some_and(|f| k >= f + self.ramp_cycles) => {
                control.receive(HostMessage::ClearFault);
                // The second Enabled stretch runs the joint-space scheme
                // (granted in Disabled only: after this ClearFault's cycle).
                self.scheme = Some(Scheme::JointSpace);
                self.fault_since = None;
            }
            State::Disabled if self.scheme.is_some() => {
                if let Some(scheme) = self.scheme.take() {
                    control.receive(HostMessage::SelectFeedback(scheme.wire_id()));
                }
            }
            State::Disabled if ok && k + 1 >= trajectory::PRELUDE_CYCLES => self.enable = true,
            _ => {}
        }
    }
}

/// What the real-time loop measured.
struct LoopResults<'a> {
    steps: Samples<'a>,
    solver: Samples<'a>,
    /// The estimator's cost in every cycle it ran.
    estimator: Samples<'a>,
    breakdown: Breakdown,
    outcomes: Outcomes,
    transitions: Transitions,
    overruns: u32,
    first_failure: Option<u32>,
    recovered: Option<u32>,
    period_ticks: u64,
    /// The step less its solve, worst over the cycles
    /// ([`Report::rest_worst`]).
    rest_worst: u32,
}

/// The scripted run; never returns (exits through semihosting). `rig`: the
/// CiA 402 layer and its drive models for the measured step
/// ([`loopback::LAYER_IN_STEP`]; the program's `init` builds it in static
/// memory), `None` for the board's drives alone. `inject`: the fault the
/// `inject-*` programs provoke.
pub async fn run(board: &mut Board, rig: Option<&mut LoopbackRig>, inject: Option<Inject>) -> ! {
    let mut flags = announce(board);
    board.place_stand_in(DEMO.script(0).pose.into());
    let mut results = realtime_loop(board, rig, inject).await;
    // Where the worst step and solve were (the samples are in cycle order
    // until sorted; the solver's only for cycles that solved).
    let worst =
        |s: &[u32]| s.iter().enumerate().fold((0, 0), |w, (k, &c)| if c > w.1 { (k, c) } else { w }).0;
    let worst_cycle = worst(results.steps.as_slice());
    let worst_solve = worst(results.solver.as_slice());
    let step = results.steps.summary();
    let barycenter = results.solver.summary();
    let estimator = results.estimator.summary();
    print_loop_results(board, &results, &step, &barycenter, &estimator);
    defmt::println!(
        "worst control step at cycle {=u32}; worst solve at the {=u32}th solved cycle",
        worst_cycle as u32,
        worst_solve as u32
    );
    barycenter_phases(&board.clock);
    let method_worst = replay_other_methods(&board.clock, &mut results.solver, barycenter.max);
    let forward = replay_forward_kinematics(&board.clock, &mut results.solver);
    replay_drive_layer(&board.clock, &mut results.solver, step.max);

    let (torques, brakes) = drives::drive_outputs();
    defmt::println!(
        "drives at the end: torques N m = {}, brakes engaged {=bool}",
        rounded::<CABLES>(&torques, 3),
        brakes
    );
    let (receive_worst, framing_worst) = receive_flood(board);
    let (used, size) = stack::stack_high_water();
    defmt::println!("stack high-water mark: {=u32} of {=u32} bytes", used, size);

    flags |= verdict_flags(&results, &step);
    let code = if flags == 0 { exit::PASS } else { exit::FAIL | flags };
    print_verdict(code, flags, step.max);
    let report = Report {
        method_worst,
        receive_worst,
        framing_worst,
        forward,
        ..summarise(board, &results, &step, &barycenter, &estimator, code)
    };
    log_record(&Record::Finished(report));
    crate::exit(code)
}

/// The banner, the timer check (its failure flag), the libm reference
/// costs and the loop's settings.
fn announce(board: &Board) -> i32 {
    let mut flags = 0;
    defmt::println!(
        "{=str} cable robot: RTIC 2 on an STM32F405 at {=u32} MHz ({=str})",
        crate::robot::NAME,
        bsp::SYSCLK_HZ / 1_000_000,
        bsp::TARGET,
    );
    let calibration = board.calibration_ticks;
    let expected = clock::expected_calibration_ticks();
    defmt::println!(
        "timer check: a {=u32}-instruction loop took {=u32} TIM2 ticks = {=u32} {=str} (icount shift={=u32}, {=u64} Hz timer: {=u64} ticks expected)",
        clock::CALIBRATION_INSTRUCTIONS,
        calibration,
        units(calibration),
        bsp::UNIT,
        cdpr_demo::qemu::ICOUNT_SHIFT,
        bsp::TIMER_HZ,
        expected,
    );
    if bsp::EXACT_UNITS && u64::from(calibration).abs_diff(expected) * 100 > expected {
        defmt::println!("timer check FAILED: ticks do not convert to instructions as assumed");
        flags |= fail::CALIBRATION;
    }
    cost_reference(&board.clock);

    let limits = *board.control.supervisor().limits();
    defmt::println!(
        "control loop: barycenter (warm-started), {=u32} cycles at {=u32} Hz, budget {=u32} {=str} per step; safety: stale after {=u32} ms, fault after holding {=u32} ms, {=u32} ms torque ramp",
        CYCLES as u32,
        crate::mono::TICK_HZ,
        BUDGET,
        bsp::UNIT,
        limits.stale_cycles,
        limits.hold_cycles,
        limits.ramp_cycles,
    );
    flags
}

/// The real-time loop over the trajectory, on the product's periodic
/// release.
async fn realtime_loop(
    board: &mut Board,
    rig: Option<&mut LoopbackRig>,
    inject: Option<Inject>,
) -> LoopResults<'static> {
    let Board { clock, drives: board_drives, control, .. } = board;
    // The CiA 402 layer in front of the board's drives when the build asks
    // for it (`loopback::LAYER_IN_STEP`), started (untimed) before the run.
    let mut drives = DemoDrives { board: board_drives, rig };
    if !drives.start() {
        defmt::println!("drive layer: the drives did not start (rated torque in the robot file?)");
    }
    if loopback::LAYER_IN_STEP {
        defmt::println!("the measured step runs the CiA 402 drive layer (CDPR_DEMO_CAN_LAYER), frames looped back in memory to 8 drive models");
    }
    let drives = &mut drives;
    let steps_buf = cortex_m::singleton!(: [u32; CYCLES] = [0; CYCLES]);
    let solver_buf = cortex_m::singleton!(: [u32; CYCLES] = [0; CYCLES]);
    let estimator_buf = cortex_m::singleton!(: [u32; CYCLES] = [0; CYCLES]);
    let (Some(steps_buf), Some(solver_buf), Some(estimator_buf)) = (steps_buf, solver_buf, estimator_buf)
    else {
        panic!("statistics buffers taken twice");
    };
    let mut r = LoopResults {
        steps: Samples::new(steps_buf),
        solver: Samples::new(solver_buf),
        estimator: Samples::new(estimator_buf),
        breakdown: Breakdown::default(),
        outcomes: Outcomes::default(),
        transitions: Transitions { states: [State::Disabled; MAX_STATES], len: 0 },
        overruns: 0,
        first_failure: None,
        recovered: None,
        period_ticks: 0,
        rest_worst: 0,
    };
    r.transitions.push(control.supervisor().state());
    let ramp_cycles = control.supervisor().limits().ramp_cycles;
    let mut operator =
        Operator { enable: trajectory::PRELUDE_CYCLES == 0, scheme: None, fault_since: None, ramp_cycles };
    // The platform (the encoders' stand-in) rests at the script's first
    // pose: home there. The task-space scheme for the first stretch is
    // selected once the stand-in has settled after the jumps (halfway
    // through the prelude's settling cycles): selected earlier, it would
    // start from the jumps' error, saturated, and push the pose out of
    // the workspace for a cycle.
    let home = DEMO.script(0).pose;
    control.receive(HostMessage::Home(home.into()));
    let select_at = trajectory::PRELUDE_CYCLES - trajectory::SETTLE_CYCLES / 2;
    let mut overrun = false;
    let mut previous_ok = true;
    let mut frame = [0u8; cdpr_control::protocol::MAX_FRAME];
    let mut decoder = cdpr_control::protocol::FrameDecoder::new();
    // Written in place by every step, as the product's.
    let mut report = StepReport::default();

    let mut releases = Releases::start().await;
    let mut last_start = clock.ticks();
    for k in 0..CYCLES as u32 {
        if k == select_at {
            control.receive(HostMessage::SelectFeedback(Scheme::TaskSpace.wire_id()));
        }
        // The script's setpoint: what a host computes and sends (the
        // product receives it), so not part of the measured step.
        let setpoint = DEMO.script(k);
        let message = HostMessage::Setpoint(setpoint.to_wire());
        // The USART1 interrupt's work as the bytes arrive (the product
        // does it in the interrupt, outside the step; `receive_flood`
        // measures it).
        let frame_len = encode(&message, &mut frame).unwrap_or(0);
        let mut line = None;
        for &b in &frame[..frame_len] {
            if decoder.push_byte(b) {
                line = decoder.finish_line();
            }
        }
        let mut queued = cdpr_control::SliceFrames::new(line.as_slice());
        let start = clock.ticks();
        bsp::feed_watchdog();
        r.period_ticks += u64::from(start.wrapping_sub(last_start));
        last_start = start;

        // The measured control step, as the product runs it: the setpoint
        // frame taken from the interrupt's queue (CRC-32, decoding, the
        // link's checks) -> encoders -> kinematics -> estimator ->
        // feedback -> solve -> supervisor -> drives.
        control.receive_frames(&mut queued);
        if operator.enable {
            control.receive(HostMessage::Enable);
        }
        let t_setpoint = clock.ticks();
        control.step_into(clock, drives, overrun, &mut report);
        let end = clock.ticks();
        let ticks = end.wrapping_sub(start);
        control.record_cost(units(ticks));
        // The encoders' stand-in, outside the measured step.
        drives.advance(control.last_feasible_lengths());

        r.record_step(&report, start, t_setpoint, end);
        if k == INJECT_AT {
            if let Some(fault) = inject {
                fault.fire(k);
            }
        }
        let ok = report.solved.is_some_and(|c| c.result.is_ok());
        operator.after(k, &report, ok, control);
        r.record_state(k, &report, ok, previous_ok);
        if k % 500 == 0 || ok != previous_ok || k == CYCLES as u32 - 1 {
            show(k, &setpoint, &report, units(ticks));
        }
        previous_ok = ok;

        overrun = releases.next().await;
        if overrun {
            r.overruns += 1;
        }
    }
    r
}

impl LoopResults<'_> {
    /// The step's cost, its phases and its outcome.
    fn record_step(&mut self, report: &StepReport, start: u32, t_setpoint: u32, end: u32) {
        self.steps.push(units(end.wrapping_sub(start)));
        self.breakdown.setpoint.push(units(t_setpoint.wrapping_sub(start)));
        let mut phases = 0;
        if let Some(cycle) = &report.solved {
            self.breakdown.read.push(units(cycle.ticks.read));
            self.breakdown.estimator.push(units(cycle.ticks.estimator));
            self.breakdown.feedback.push(units(cycle.ticks.feedback));
            if let Some(estimate) = &report.estimate {
                self.estimator.push(units(cycle.ticks.estimator));
                match estimate {
                    Ok(e) => {
                        self.outcomes.estimated += 1;
                        self.outcomes.residual_um = self.outcomes.residual_um.max((e.residual * 1e6) as u32);
                    }
                    Err(_) => self.outcomes.unestimated += 1,
                }
            }
            self.solver.push(units(cycle.ticks.solver));
            self.breakdown.kinematics.push(units(cycle.ticks.kinematics));
            self.breakdown.solver.push(units(cycle.ticks.solver));
            self.breakdown.torques.push(units(cycle.ticks.torques));
            phases = cycle.ticks.kinematics
                + cycle.ticks.solver
                + cycle.ticks.torques
                + cycle.ticks.read
                + cycle.ticks.estimator
                + cycle.ticks.feedback;
            self.outcomes.count(&cycle.result);
            if let Ok(command) = &cycle.result {
                match command.warm_start {
                    WarmStart::Held => self.outcomes.warm_held += 1,
                    WarmStart::Lost => self.outcomes.warm_lost += 1,
                    WarmStart::NotGiven => {}
                }
                if command.saturated.any() {
                    self.outcomes.saturated += 1;
                }
            }
        }
        let rest = units(end.wrapping_sub(t_setpoint).saturating_sub(phases));
        self.breakdown.supervisor_and_drives.push(rest);
        let total = units(end.wrapping_sub(start));
        let solve = report.solved.as_ref().map_or(0, |c| units(c.ticks.solver));
        self.rest_worst = self.rest_worst.max(total.saturating_sub(solve));
        if total > self.breakdown.worst[0] {
            let c = report.solved.as_ref().map(|c| c.ticks).unwrap_or_default();
            self.breakdown.worst = [
                total,
                units(t_setpoint.wrapping_sub(start)),
                units(c.read),
                units(c.kinematics),
                units(c.estimator),
                units(c.feedback),
                units(c.solver),
                units(c.torques),
                rest,
            ];
        }
    }

    /// State changes, and where the poses left and re-entered the workspace.
    fn record_state(&mut self, k: u32, report: &StepReport, ok: bool, previous_ok: bool) {
        if self.transitions.as_slice().last() != Some(&report.state) {
            self.transitions.push(report.state);
            defmt::println!(
                "cycle {=u32}: state -> {=str} ({=str})",
                k,
                report.state.name(),
                report.reason.name()
            );
        }
        if !ok && self.first_failure.is_none() {
            self.first_failure = Some(k);
        }
        if ok && ok != previous_ok && self.recovered.is_none() {
            self.recovered = Some(k);
        }
    }
}

/// The real-time loop's statistics, readable.
fn print_loop_results(board: &Board, r: &LoopResults, step: &Summary, barycenter: &Summary, e: &Summary) {
    defmt::println!(
        "control-step {=str}: min {=u32} median {=u32} max {=u32} over {=u32} cycles, overruns {=u32}",
        bsp::UNIT,
        step.min,
        step.median,
        step.max,
        step.count,
        r.overruns,
    );
    let share = per_mille_of_period(step.max);
    defmt::println!(
        "worst control step = {=u32}.{=u32} % of the 1 ms period at 168 MHz, assuming 1.5 cycles per instruction",
        share / 10,
        share % 10
    );
    summary_line("barycenter", "warm-started, solver only, same cycles", barycenter);
    defmt::println!(
        "forward kinematics (the estimator's Gauss-Newton step, in the loop) {=str}: min {=u32} median {=u32} max {=u32} over {=u32} cycles; estimates ok {=u32}, failed {=u32} (largest residual {=u32} um)",
        bsp::UNIT,
        e.min,
        e.median,
        e.max,
        e.count,
        r.outcomes.estimated,
        r.outcomes.unestimated,
        r.outcomes.residual_um,
    );
    let b = &r.breakdown;
    defmt::println!(
        "step breakdown, mean/max {=str}: setpoint and checks {=u32}/{=u32}, encoders {=u32}/{=u32}, kinematics (lengths, W and f with motion) {=u32}/{=u32}, estimator {=u32}/{=u32}, feedback {=u32}/{=u32}, solver {=u32}/{=u32}, torques {=u32}/{=u32}, supervisor and drives {=u32}/{=u32}",
        bsp::UNIT,
        b.setpoint.mean(),
        b.setpoint.max(),
        b.read.mean(),
        b.read.max(),
        b.kinematics.mean(),
        b.kinematics.max(),
        b.estimator.mean(),
        b.estimator.max(),
        b.feedback.mean(),
        b.feedback.max(),
        b.solver.mean(),
        b.solver.max(),
        b.torques.mean(),
        b.torques.max(),
        b.supervisor_and_drives.mean(),
        b.supervisor_and_drives.max(),
    );
    let w = &b.worst;
    defmt::println!(
        "worst step {=u32} {=str}: setpoint and checks {=u32}, encoders {=u32}, kinematics {=u32}, estimator {=u32}, feedback {=u32}, solver {=u32}, torques {=u32}, supervisor and drives {=u32}",
        w[0],
        bsp::UNIT,
        w[1],
        w[2],
        w[3],
        w[4],
        w[5],
        w[6],
        w[7],
        w[8],
    );
    defmt::println!(
        "the step without its solve: worst {=u32} {=str} (stated {=u32}: a method is offered when its stated worst solve plus this fits the budget)",
        r.rest_worst,
        bsp::UNIT,
        methods::STEP_REST,
    );
    let o = &r.outcomes;
    defmt::println!(
        "cycles: {=u32} ok, infeasible {=u32} (torques held, then fault), other errors {=u32}; warm start held {=u32}, lost {=u32}; torque-saturated {=u32}; drive writes {=u32}",
        o.ok,
        o.infeasible,
        o.no_convergence + o.other,
        o.warm_held,
        o.warm_lost,
        o.saturated,
        board.drives.writes(),
    );
    if let (Some(a), Some(b)) = (r.first_failure, r.recovered) {
        defmt::println!(
            "left the wrench-feasible workspace at cycle {=u32} (t = {=u32} ms), back in at cycle {=u32} (t = {=u32} ms)",
            a,
            a,
            b,
            b,
        );
    }
    let counters = board.control.counters();
    defmt::println!(
        "states: {=[?]}; faults {=u32}, refused requests {=u32}, rejected setpoints {=u32}",
        r.transitions.as_slice(),
        counters.faults,
        counters.rejected_state,
        counters.rejected_range + counters.rejected_order,
    );
    defmt::println!(
        "period check: {=u32} periods took {=u64} us of TIM2 time ({=u64} us nominal)",
        CYCLES as u32,
        r.period_ticks * 1_000_000 / bsp::TIMER_HZ,
        CYCLES as u64 * 1_000_000 / u64::from(crate::mono::TICK_HZ),
    );
}

/// The other methods over the same poses (not real time); returns every
/// method's worst solve (`barycenter`: the loop's), in `Method::ALL` order,
/// after checking each against the board's table (`cdpr_demo::methods`).
fn replay_other_methods(clock: &Tim2Counter, solver: &mut Samples, barycenter: u32) -> [u32; 10] {
    let mut worst = [0u32; 10];
    for (slot, method) in worst.iter_mut().zip(Method::ALL) {
        if method == Method::Barycenter {
            *slot = barycenter;
            continue;
        }
        solver.clear();
        let counts = replay(method, clock, solver);
        let summary = solver.summary();
        *slot = summary.max;
        summary_line(method.name(), "solver only, same poses, replayed after the loop", &summary);
        defmt::println!(
            "  {=str}: {=u32} ok, infeasible {=u32}, no-convergence {=u32}, other errors {=u32}",
            method.name(),
            counts.ok,
            counts.infeasible,
            counts.no_convergence,
            counts.other,
        );
    }
    for (&measured, method) in worst.iter().zip(Method::ALL) {
        defmt::println!(
            "method table: {=str} worst {=u32} measured, {=u32} stated: {=str}, {=str}",
            method.name(),
            measured,
            methods::stated_worst(method),
            if methods::exceeded(method, measured) { "EXCEEDS the table" } else { "within" },
            if methods::is_offered(method) { "offered" } else { "not offered (over the step budget)" },
        );
    }
    worst
}

/// `tension_core`'s forward kinematics (`Robot::forward_kinematics`, its
/// default settings: warm run, chord steps, the bounded cold start when
/// the warm run fails) over the lengths of the encoders' stand-in as it
/// follows the script (not real time, after the loop; interrupts off for
/// each call), each call warm-started from the previous answer. The
/// in-loop estimator is its one-step special case about the setpoint; this
/// is the full solver's own cost on the board. Returns min, median, max.
fn replay_forward_kinematics(clock: &Tim2Counter, samples: &mut Samples) -> Spread {
    use cdpr_control::setpoint::Pose6;
    use tension_core::forward_kinematics::ForwardSettings;
    samples.clear();
    let controller = controller(Method::Barycenter);
    let robot = controller.robot();
    let settings = ForwardSettings::for_robot(robot);
    let Ok(scale) = crate::robot::encoder_scale() else { return Spread::default() };
    let start = DEMO.script(0).pose;
    let Some(mut winches) = cdpr_demo::winches::LagWinches::at_pose(robot, scale, &start) else {
        return Spread::default();
    };
    let mut warm: Option<Pose6> = Some(start);
    let (mut ok, mut failed, mut cold, mut iterations, mut worst_residual) = (0u32, 0u32, 0u32, 0u32, 0.0f32);
    let (mut worst_warm, mut worst_cold) = (0u32, 0u32);
    for k in 0..CYCLES as u32 {
        let target = robot.cables(&DEMO.script(k).pose).ok().map(|c| {
            let mut l = [0.0; CABLES];
            l.copy_from_slice(c.lengths.as_slice());
            l
        });
        winches.follow(target.as_ref(), 0.001);
        let lengths = tension_core::nalgebra::SVector::<f32, CABLES>::from(*winches.lengths());
        let (ticks, result) = cortex_m::interrupt::free(|_| {
            let t = clock.ticks();
            let result = robot.forward_kinematics(&lengths, warm.as_ref(), &settings);
            (clock.since(t), result)
        });
        let cost = units(ticks);
        samples.push(cost);
        match result {
            Ok(solution) => {
                ok += 1;
                warm = Some(solution.pose);
                iterations = iterations.max(solution.iterations);
                if solution.worst > worst_residual {
                    worst_residual = solution.worst;
                }
                if solution.cold_started {
                    cold += 1;
                    worst_cold = worst_cold.max(cost);
                } else {
                    worst_warm = worst_warm.max(cost);
                }
            }
            Err(_) => failed += 1,
        }
    }
    let s = samples.summary();
    defmt::println!(
        "forward kinematics (tension-core, warm from the previous answer, replayed over the stand-in's lengths) {=str}: min {=u32} median {=u32} max {=u32} over {=u32} calls; worst warm {=u32}, worst with a cold start {=u32} ({=u32} cold starts); {=u32} ok, {=u32} failed; most iterations {=u32}, worst residual {=u32} um",
        bsp::UNIT,
        s.min,
        s.median,
        s.max,
        s.count,
        worst_warm,
        worst_cold,
        cold,
        ok,
        failed,
        iterations,
        (worst_residual * 1e6) as u32,
    );
    Spread { min: s.min, median: s.median, max: s.max }
}

/// The CiA 402 drive layer's cost per control cycle alone (`canopen-drives`,
/// the board's drives on CAN1 and CAN2), with its frames looped back in
/// memory to eight CiA 402 drive models ([`LoopbackRig`]): the start-up
/// untimed, then [`CYCLES`] cycles of `read` + `set_brakes` + `apply` timed
/// with interrupts off (the models answer between cycles, outside the
/// measurement) with the brakes released, the winches following the demo
/// trajectory's cable lengths. The measured step runs the same layer
/// ([`DemoDrives`]) when built with `CDPR_DEMO_CAN_LAYER`; otherwise the
/// line states what the step's worst plus the layer's worst come to.
fn replay_drive_layer(clock: &Tim2Counter, samples: &mut Samples, step_max: u32) {
    use cdpr_control::{WinchDrives, WinchReading};
    if loopback::LAYER_IN_STEP {
        // A second rig would not fit the stack limit beside the first.
        defmt::println!("the drive layer ran inside the measured step above (not replayed alone)");
        return;
    }
    samples.clear();
    // In static memory: 6.4 KB on the stack took the demo's high-water
    // mark from 9 to 15 KB (the limit is 16 KB).
    let Some(rig) = cortex_m::singleton!(: LoopbackRig = loopback::rig()) else { return };
    let mut readings = [WinchReading::default(); CABLES];
    let (Ok(robot), Ok(scale)) = (crate::robot::robot(), crate::robot::encoder_scale()) else { return };
    if !rig.start(loopback::START_CYCLES, 1_000_000) {
        defmt::println!("drive layer: the drive models did not start (rated torque in the robot file?)");
        return;
    }
    let mut errors = 0u32;
    for k in 0..CYCLES as u32 {
        let setpoint = DEMO.script(k);
        let torques = match robot.cables(&setpoint.pose) {
            Ok(c) => {
                let counts: [i32; CABLES] =
                    core::array::from_fn(|i| scale.counts_of(i, c.lengths[i], 0).unwrap_or(0));
                rig.set_positions(&counts);
                [0.3; CABLES]
            }
            Err(_) => [0.2; CABLES],
        };
        let layer = &mut rig.layer;
        let (ticks, ok) = cortex_m::interrupt::free(|_| {
            let start = clock.ticks();
            let r = layer.read(&mut readings);
            let b = layer.set_brakes(false);
            let a = layer.apply(&torques);
            (clock.since(start), r.is_ok() && b.is_ok() && a.is_ok())
        });
        errors += u32::from(!ok);
        samples.push(units(ticks));
        rig.deliver(1_000_000);
    }
    let s = samples.summary();
    defmt::println!(
        "drive layer alone (CiA 402 on CAN1 + CAN2, frames looped back in memory to 8 drive models, brakes released) {=str}: min {=u32} median {=u32} max {=u32} per cycle over {=u32} cycles, {=u32} cycles in error",
        bsp::UNIT,
        s.min,
        s.median,
        s.max,
        s.count,
        errors,
    );
    defmt::println!(
        "the demo's worst step {=u32} + the layer's worst = {=u32} (budget {=u32}; the step with the layer inside: CDPR_DEMO_CAN_LAYER=1 cargo xtask run)",
        step_max,
        step_max + s.max,
        cdpr_demo::BUDGET,
    );
}

/// Cycles of each kind of flood [`receive_flood`] times.
const FLOOD_CYCLES: u32 = 16;

/// Bytes of each kind of flood the receive interrupt's framing is timed on.
const FLOOD_BYTES: usize = 256;

/// A flood's byte number `at` of kind `kind`: a 0x00 storm, 0xFF runs
/// (oversize frames), pseudo-random bytes (xorshift state `x`), or
/// back-to-back valid setpoint frames (`frame`).
fn flood_byte(kind: usize, at: usize, x: &mut u32, frame: &[u8]) -> u8 {
    match kind {
        0 => 0x00,
        1 => 0xFF,
        2 => {
            *x ^= *x << 13;
            *x ^= *x >> 17;
            *x ^= *x << 5;
            *x as u8
        }
        _ => frame.get(at % frame.len().max(1)).copied().unwrap_or(0),
    }
}

const FLOOD_NAMES: [&str; 4] =
    ["0x00 storm", "0xFF (oversize frames)", "pseudo-random bytes", "back-to-back setpoints"];

/// The receive work under a flood, on the board, in its two halves:
///
/// * the USART1 interrupt's framing ([`crate::serial::Receiver::take`]:
///   a byte into the frame decoder and, at a delimiter, the frame out),
///   timed byte by byte over [`FLOOD_BYTES`] of each kind; returns the
///   worst byte;
/// * the control step's share: the control loop (disabled first, so that
///   every valid frame is accepted and acted on) takes a cycle's
///   [`cdpr_control::FRAME_BUDGET`] of the flood's frames, timed with
///   interrupts off; returns the worst cycle.
fn receive_flood(board: &mut Board) -> (u32, u32) {
    use cdpr_control::protocol::{encode, FrameDecoder, LineFrame, MAX_FRAME};
    let Board { clock, drives, control, .. } = board;
    control.receive(HostMessage::Disable);
    control.step(&*clock, drives, false);
    let mut frame = [0u8; MAX_FRAME];
    let setpoint = HostMessage::Setpoint(DEMO.setpoint(0).to_wire());
    let frame_len = encode(&setpoint, &mut frame).unwrap_or(0);
    let frame = &frame[..frame_len];
    let (mut framing_worst, mut step_worst) = (0, 0);
    for (kind, name) in FLOOD_NAMES.iter().enumerate() {
        // The interrupt's half, byte by byte.
        let mut decoder = FrameDecoder::new();
        let mut x = 0x2545_f491u32;
        let mut byte_worst = 0;
        let mut frames = 0u32;
        for at in 0..FLOOD_BYTES {
            let byte = flood_byte(kind, at, &mut x, frame);
            let ticks = cortex_m::interrupt::free(|_| {
                let start = clock.ticks();
                if decoder.push_byte(core::hint::black_box(byte)) {
                    let line = decoder.finish_line();
                    frames += u32::from(line.is_some());
                    core::hint::black_box(line);
                }
                clock.since(start)
            });
            byte_worst = byte_worst.max(units(ticks));
        }
        // The step's half: the frames of an endless flood of this kind,
        // FRAME_BUDGET a cycle.
        let mut decoder = FrameDecoder::new();
        let mut x = 0x2545_f491u32;
        let mut at = 0usize;
        let mut next_frame = || -> LineFrame {
            // Bounded: a frame ends within MAX_FRAME + 2 bytes of any kind
            // but 0xFF runs, which this cuts (oversize) after 4 frames' worth.
            for _ in 0..4 * (MAX_FRAME + 2) {
                let byte = flood_byte(kind, at, &mut x, frame);
                at += 1;
                if decoder.push_byte(byte) {
                    if let Some(line) = decoder.finish_line() {
                        return line;
                    }
                }
            }
            LineFrame::rejected(cdpr_control::protocol::FrameError::Oversize)
        };
        let mut kind_worst = 0;
        for _ in 0..FLOOD_CYCLES {
            let cycle: [LineFrame; cdpr_control::FRAME_BUDGET] = core::array::from_fn(|_| next_frame());
            let mut queued = cdpr_control::SliceFrames::new(&cycle);
            let ticks = cortex_m::interrupt::free(|_| {
                let start = clock.ticks();
                core::hint::black_box(control.receive_frames(&mut queued));
                clock.since(start)
            });
            kind_worst = kind_worst.max(units(ticks));
        }
        defmt::println!(
            "receive flood, {=str}: the interrupt's framing at most {=u32} {=str} a byte ({=u32} frames in {=u32} bytes); the step's {=u32} frames at most {=u32} {=str} a cycle",
            name,
            byte_worst,
            bsp::UNIT,
            frames,
            FLOOD_BYTES as u32,
            cdpr_control::FRAME_BUDGET as u32,
            kind_worst,
            bsp::UNIT,
        );
        framing_worst = framing_worst.max(byte_worst);
        step_worst = step_worst.max(kind_worst);
    }
    let counters = control.counters();
    defmt::println!(
        "receive flood: worst {=u32} {=str} a cycle in the step, {=u32} {=str} a byte in the interrupt; accepted {=u32}, rejected framing {=u32}, crc {=u32}, decode {=u32}",
        step_worst,
        bsp::UNIT,
        framing_worst,
        bsp::UNIT,
        counters.accepted,
        counters.rejected_framing,
        counters.rejected_crc,
        counters.rejected_decode,
    );
    (step_worst, framing_worst)
}

/// The failure flags of the real-time loop's results.
fn verdict_flags(r: &LoopResults, step: &Summary) -> i32 {
    let mut flags = 0;
    if step.max > BUDGET {
        flags |= fail::BUDGET;
    }
    if r.overruns > 0 {
        flags |= fail::OVERRUN;
    }
    if r.outcomes.infeasible == 0 || r.outcomes.no_convergence + r.outcomes.other > 0 {
        flags |= fail::STATUS;
    }
    if r.transitions.as_slice() != EXPECTED_STATES {
        flags |= fail::STATES;
    }
    flags
}

/// The verdict, readable.
fn print_verdict(code: i32, flags: i32, max: u32) {
    if code == exit::PASS {
        defmt::println!("PASS: max {=u32} <= {=u32} {=str} per step, 0 overruns", max, BUDGET, bsp::UNIT);
    } else {
        defmt::println!(
            "FAIL (exit code {=i32}): over budget {=bool}, overruns {=bool}, timer check failed {=bool}, unexpected statuses {=bool}, unexpected state sequence {=bool}",
            code,
            flags & fail::BUDGET != 0,
            flags & fail::OVERRUN != 0,
            flags & fail::CALIBRATION != 0,
            flags & fail::STATUS != 0,
            flags & fail::STATES != 0,
        );
    }
}

/// The report `cargo xtask` decodes.
fn summarise(
    board: &Board,
    r: &LoopResults,
    step: &Summary,
    barycenter: &Summary,
    estimator: &Summary,
    exit_code: i32,
) -> Report {
    let spread = |s: &Summary| Spread { min: s.min, median: s.median, max: s.max };
    let (stack_used, stack_size) = stack::stack_high_water();
    Report {
        instructions: bsp::EXACT_UNITS,
        cycles: step.count,
        step: spread(step),
        solver: spread(barycenter),
        estimator: spread(estimator),
        overruns: r.overruns,
        calibration_ticks: board.calibration_ticks,
        calibration_expected: clock::expected_calibration_ticks() as u32,
        calibration_exact: bsp::EXACT_UNITS,
        ok: r.outcomes.ok,
        infeasible: r.outcomes.infeasible,
        other_errors: r.outcomes.no_convergence + r.outcomes.other,
        states: r.transitions.states,
        state_count: r.transitions.len as u8,
        stack_used,
        stack_size,
        exit_code,
        method_worst: [0; 10],
        receive_worst: 0,
        framing_worst: 0,
        forward: Spread::default(),
        rest_worst: r.rest_worst,
    }
}

/// Cycles per instruction assumed to turn QEMU's instruction counts into a
/// share of the board's 1 ms period: the Cortex-M4 retires most
/// instructions in one cycle, loads, stores and branches take two, and
/// flash wait states are mostly hidden by the ART accelerator at 168 MHz;
/// 1.5 is a deliberately pessimistic average.
pub const ASSUMED_CPI: (u32, u32) = (3, 2);

/// Per mille of the 1 ms period at [`bsp::SYSCLK_HZ`] that `instructions`
/// take at [`ASSUMED_CPI`].
fn per_mille_of_period(instructions: u32) -> u32 {
    let cycles = u64::from(instructions) * u64::from(ASSUMED_CPI.0) / u64::from(ASSUMED_CPI.1);
    (cycles * 1000 * 1000 / u64::from(bsp::SYSCLK_HZ)) as u32
}

/// One `<method> solver instructions: ...` line.
fn summary_line(method: &str, note: &str, s: &Summary) {
    let share = per_mille_of_period(s.max);
    defmt::println!(
        "{=str} solver {=str}: min {=u32} median {=u32} max {=u32} over {=u32} cycles ({=str}); worst = {=u32}.{=u32} % of the 1 ms period at 168 MHz and 1.5 cycles per instruction",
        method,
        bsp::UNIT,
        s.min,
        s.median,
        s.max,
        s.count,
        note,
        share / 10,
        share % 10,
    );
}

fn controller(method: Method) -> Controller {
    match crate::robot::robot().and_then(|robot| Controller::new(robot, method)) {
        Ok(c) => c,
        Err(e) => panic!("robot description rejected: {}", e.status()),
    }
}

/// The barycenter's phases over the loop's poses: factorisation of `W`,
/// the polygon's half-planes, the warm-started walk and centroid.
fn barycenter_phases(clock: &Tim2Counter) {
    use tension_core::linalg::WrenchFactorization;
    use tension_core::polygon::VertexList;
    use tension_core::tension_polygon::TensionPolygon;
    let controller = controller(Method::Barycenter);
    let limits = *controller.robot().limits();
    let (mut fact_t, mut poly_t, mut walk_t) = (Running::default(), Running::default(), Running::default());
    let mut pair = None;
    let mut vertices = VertexList::new();
    // Interrupts off: the timings must not include the monotonic's tick.
    cortex_m::interrupt::free(|_| {
        for k in 0..CYCLES as u32 {
            let Ok((w, f)) = controller.wrench(&DEMO.script(k), &Wrench::zeros()) else { continue };
            // Filled in place, as `TensionSolver::solve` does.
            let t0 = clock.ticks();
            let mut fact = WrenchFactorization::zeroed();
            let Ok(()) = fact.factor(&w, &[true; CABLES], 2) else { continue };
            let t1 = clock.ticks();
            let mut poly = TensionPolygon::zeroed();
            let Ok(()) = poly.set(&fact, &f, &limits) else { continue };
            let t2 = clock.ticks();
            // Kept from cycle to cycle, as the solver's workspace keeps it:
            // the last polygon's lines are the walk's hints.
            let found = poly.polygon.walk_into(pair, &mut vertices);
            let t3 = clock.ticks();
            if let Ok(found) = found {
                pair = Some(found.robust_pair);
                fact_t.push(units(t1.wrapping_sub(t0)));
                poly_t.push(units(t2.wrapping_sub(t1)));
                walk_t.push(units(t3.wrapping_sub(t2)));
            }
        }
    });
    defmt::println!(
        "barycenter phases, mean/max {=str}: factorisation {=u32}/{=u32}, polygon {=u32}/{=u32}, walk and centroid {=u32}/{=u32}",
        bsp::UNIT,
        fact_t.mean(),
        fact_t.max(),
        poly_t.mean(),
        poly_t.max(),
        walk_t.mean(),
        walk_t.max(),
    );
}

/// Runs `method` (warm-started like the loop's solver) over the loop's
/// poses and times the solver alone, interrupts off for each call.
fn replay(method: Method, clock: &Tim2Counter, samples: &mut Samples) -> Outcomes {
    let mut counts = Outcomes::default();
    let mut controller = controller(method);
    for k in 0..CYCLES as u32 {
        let (w, f) = match controller.wrench(&DEMO.script(k), &Wrench::zeros()) {
            Ok(wf) => wf,
            Err(e) => {
                counts.count::<()>(&Err(e));
                continue;
            }
        };
        let (ticks, result) = cortex_m::interrupt::free(|_| {
            let start = clock.ticks();
            let result = controller.solve(&w, &f);
            (clock.since(start), result)
        });
        samples.push(units(ticks));
        counts.count(&result);
    }
    counts
}

/// Prints what the libm primitives the control step avoids cost.
fn cost_reference(clock: &Tim2Counter) {
    use core::hint::black_box;
    let time = |f: &dyn Fn() -> f32| {
        cortex_m::interrupt::free(|_| {
            let start = clock.ticks();
            black_box(f());
            units(clock.since(start))
        })
    };
    let empty = time(&|| black_box(0.5));
    let sin = time(&|| libm::sinf(black_box(0.5)));
    let cos = time(&|| libm::cosf(black_box(0.5)));
    let sqrt = time(&|| libm::sqrtf(black_box(0.5)));
    defmt::println!(
        "cost reference, {=str} per call: libm sinf {=u32}, cosf {=u32} (both compute in f64, soft-float on the M4F), sqrtf {=u32}",
        bsp::UNIT,
        sin.saturating_sub(empty),
        cos.saturating_sub(empty),
        sqrt.saturating_sub(empty),
    );
}

fn round(x: f32, decimals: i32) -> f32 {
    let scale = libm::powf(10.0, decimals as f32);
    libm::roundf(x * scale) / scale
}

fn rounded<const K: usize>(v: &[f32], decimals: i32) -> [f32; K] {
    core::array::from_fn(|i| round(v[i], decimals))
}

/// Prints one cycle: pose, then tensions and torques or the status.
fn show(k: u32, setpoint: &Setpoint, report: &StepReport, cost: u32) {
    let pose: [f32; 6] = rounded(setpoint.pose.as_slice(), 3);
    defmt::println!(
        "cycle {=u32} (t = {=u32} ms, {=u32} {=str}, {=str}): pose [x y z rx ry rz] = {}",
        k,
        k,
        cost,
        bsp::UNIT,
        report.state.name(),
        pose,
    );
    let torques: [f32; CABLES] = rounded(&report.torques, 3);
    match report.solved.map(|c| c.result) {
        Some(Ok(c)) => {
            let tensions: [f32; CABLES] = rounded(&c.tensions, 1);
            defmt::println!("  tensions N   = {}", tensions);
            defmt::println!(
                "  torques N m  = {} (robustness {=f32} N, {=u8} polygon vertices, warm start {=str})",
                torques,
                round(c.robustness, 2),
                c.vertices,
                match c.warm_start {
                    WarmStart::Held => "held",
                    WarmStart::Lost => "lost",
                    WarmStart::NotGiven => "none",
                },
            );
        }
        Some(Err(e)) => {
            defmt::println!(
                "  status {=str}: torques N m = {} (brakes {=bool})",
                e.status(),
                torques,
                report.brakes
            );
        }
        None => {
            defmt::println!("  no setpoint solved: torques N m = {} (brakes {=bool})", torques, report.brakes)
        }
    }
}
