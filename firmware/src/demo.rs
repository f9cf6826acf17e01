//! The demo and cycle-time run (`--features demo`, `cargo xtask run`):
//! the same control loop as the product, fed by a scripted trajectory
//! instead of the serial link, timed, and judged.
//!
//! * Setpoints: [`cdpr_demo::trajectory`], one closed loop of 4000
//!   cycles that crosses the workspace of suspended-8 and leaves it once
//!   (near the top). They enter the loop as protocol messages, through the
//!   same checks as received frames.
//! * A scripted operator: `Enable` at the start; after a fault, once the
//!   torque ramp has finished and the setpoint is feasible again,
//!   `ClearFault` and `Enable`. So the run shows Enabled -> Holding (the
//!   pose leaves the workspace) -> Fault (hold timeout, torques ramp down,
//!   brakes on) -> Disabled -> Enabled.
//! * TIM2 times every step from the setpoint to the drive writes.
//!
//! At the end it prints the statistics, times the barycenter's phases and
//! replays the poses through `analytic-centre` and `barycenter-brute`, and
//! exits through semihosting:
//!
//! * 0: every step within [`BUDGET`] and no deadline overrun, and the
//!   expected states and statuses;
//! * [`EXIT_FAIL`]` | flags` (32..=63) otherwise, see [`fail`].

use cdpr_control::controller::{Controller, Wrench};
use cdpr_control::protocol::{HostMessage, State};
use cdpr_control::stats::{Running, Samples, Summary};
use cdpr_control::{ControlLoop, Setpoint, StepReport, TickCounter};
use cdpr_demo::trajectory;
use rtic_monotonics::fugit::ExtU32;
use rtic_monotonics::Timebase;
use tension_core::{Error, Method, WarmStart};

use crate::board::{self, Drives, Tim2Counter};
use crate::mono::Mono;

/// Cycles of the scripted run (one loop of the trajectory).
pub const CYCLES: usize = trajectory::CYCLES;

/// Instruction budget of one control step (QEMU; cycles on the board).
pub const BUDGET: u32 = 20_000;

/// The cycle at which the `inject-panic` / `inject-hardfault` builds fault
/// (enabled and moving at that point).
const INJECT_AT: u32 = 1000;

/// Exit code base for a failed run; the low bits say why ([`fail`]).
pub const EXIT_FAIL: i32 = 32;

/// Failure flags, or-ed into [`EXIT_FAIL`].
pub mod fail {
    /// Some step took more than [`super::BUDGET`].
    pub const BUDGET: i32 = 1;
    /// Some step missed its deadline.
    pub const OVERRUN: i32 = 2;
    /// The timer calibration disagrees with the icount relation.
    pub const CALIBRATION: i32 = 4;
    /// The trajectory never left the workspace, or a cycle failed with
    /// something other than `infeasible`.
    pub const STATUS: i32 = 8;
    /// The state machine did not go Enabled -> Holding -> Fault -> Disabled
    /// -> Enabled as scripted.
    pub const STATES: i32 = 16;
}

// The statistics live in fixed buffers of this many samples.
const _: () = assert!(CYCLES >= 2000);

/// Counts per status of a run's cycles.
#[derive(Default)]
struct Outcomes {
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
    setpoint: Running,
    kinematics: Running,
    solver: Running,
    torques: Running,
    supervisor_and_drives: Running,
}

/// The states the run went through, in order (at most 16 changes kept).
struct Transitions {
    states: [State; 16],
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

/// The scripted run; never returns (exits through semihosting).
pub async fn run(control: &mut ControlLoop, clock: &Tim2Counter, drives: &mut Drives, calibration: u32) -> ! {
    let units = board::ticks_to_units;
    let mut flags = 0;
    defmt::println!(
        "{=str} cable robot: RTIC 2 on an STM32F405 at {=u32} MHz ({=str})",
        crate::robot::NAME,
        board::SYSCLK_HZ / 1_000_000,
        board::TARGET,
    );

    // --- Timer check: the icount relation against a known loop.
    let expected =
        u64::from(board::CALIBRATION_INSTRUCTIONS) * (board::TIMER_HZ << board::ICOUNT_SHIFT) / 1_000_000_000;
    defmt::println!(
        "timer check: a {=u32}-instruction loop took {=u32} TIM2 ticks = {=u32} {=str} (icount shift={=u32}, {=u64} Hz timer: {=u64} ticks expected)",
        board::CALIBRATION_INSTRUCTIONS,
        calibration,
        units(calibration),
        board::UNIT,
        board::ICOUNT_SHIFT,
        board::TIMER_HZ,
        expected,
    );
    if cfg!(not(feature = "board")) && u64::from(calibration).abs_diff(expected) * 100 > expected {
        defmt::println!("timer check FAILED: ticks do not convert to instructions as assumed");
        flags |= fail::CALIBRATION;
    }
    cost_reference(clock);

    let limits = *control.supervisor().limits();
    defmt::println!(
        "control loop: barycenter (warm-started), {=u32} cycles at {=u32} Hz, budget {=u32} {=str} per step; safety: stale after {=u32} ms, fault after holding {=u32} ms, {=u32} ms torque ramp",
        CYCLES as u32,
        crate::mono::TICK_HZ,
        BUDGET,
        board::UNIT,
        limits.stale_cycles,
        limits.hold_cycles,
        limits.ramp_cycles,
    );

    // --- The real-time loop.
    let steps_buf = cortex_m::singleton!(: [u32; CYCLES] = [0; CYCLES]);
    let solver_buf = cortex_m::singleton!(: [u32; CYCLES] = [0; CYCLES]);
    let (Some(steps_buf), Some(solver_buf)) = (steps_buf, solver_buf) else {
        panic!("statistics buffers taken twice");
    };
    let mut steps = Samples::new(steps_buf);
    let mut solver = Samples::new(solver_buf);
    let mut breakdown = Breakdown::default();
    let mut outcomes = Outcomes::default();
    let mut transitions = Transitions { states: [State::Disabled; 16], len: 0 };
    transitions.push(control.supervisor().state());
    let mut overruns = 0u32;
    let mut overrun = false;
    let mut first_failure: Option<u32> = None;
    let mut recovered: Option<u32> = None;
    let mut previous_ok = true;
    let mut period_ticks = 0u64;
    let mut operator_enable = true;
    let mut fault_since: Option<u32> = None;

    // Start on a tick, so that the first cycle has a whole period.
    let mut release = Mono::now() + 1.millis();
    Mono::delay_until(release).await;
    let mut last_start = clock.ticks();

    for k in 0..CYCLES as u32 {
        let start = clock.ticks();
        board::feed_watchdog();
        period_ticks += u64::from(start.wrapping_sub(last_start));
        last_start = start;

        // The measured control step: setpoint -> checks -> solve ->
        // supervisor -> drives.
        let setpoint = trajectory::setpoint(k);
        control.receive(HostMessage::Setpoint(setpoint.to_wire()));
        if operator_enable {
            control.receive(HostMessage::Enable);
        }
        let t_setpoint = clock.ticks();
        let report = control.step(clock, drives, &Wrench::zeros(), overrun);
        let end = clock.ticks();
        let ticks = end.wrapping_sub(start);
        control.record_cost(units(ticks));

        // Absolute deadlines: this cycle's ends where the next begins.
        let deadline = release + 1.millis();
        overrun = Mono::now() >= deadline;
        if overrun {
            overruns += 1;
        }

        steps.push(units(ticks));
        breakdown.setpoint.push(units(t_setpoint.wrapping_sub(start)));
        let mut phases = 0;
        if let Some(cycle) = &report.solved {
            solver.push(units(cycle.ticks.solver));
            breakdown.kinematics.push(units(cycle.ticks.kinematics));
            breakdown.solver.push(units(cycle.ticks.solver));
            breakdown.torques.push(units(cycle.ticks.torques));
            phases = cycle.ticks.kinematics + cycle.ticks.solver + cycle.ticks.torques;
            outcomes.count(&cycle.result);
            if let Ok(command) = &cycle.result {
                match command.warm_start {
                    WarmStart::Held => outcomes.warm_held += 1,
                    WarmStart::Lost => outcomes.warm_lost += 1,
                    WarmStart::NotGiven => {}
                }
                if command.saturated.any() {
                    outcomes.saturated += 1;
                }
            }
        }
        breakdown.supervisor_and_drives.push(units(end.wrapping_sub(t_setpoint).saturating_sub(phases)));

        // Fault injection (test builds only): the handlers must stop the
        // drives, which are commanding torques at this point.
        if k == INJECT_AT {
            let (torques, _) = board::drive_outputs();
            #[cfg(feature = "inject-panic")]
            {
                defmt::println!("injecting a panic at cycle {=u32}; drives command {} N m", k, torques);
                panic!("injected at cycle {}", k);
            }
            #[cfg(feature = "inject-hardfault")]
            {
                defmt::println!("injecting a HardFault at cycle {=u32}; drives command {} N m", k, torques);
                cortex_m::asm::udf();
            }
            #[cfg(not(any(feature = "inject-panic", feature = "inject-hardfault")))]
            let _ = torques;
        }

        // The scripted operator: re-enable once the fault's ramp is over
        // and the setpoint is feasible again.
        let ok = report.solved.is_some_and(|c| c.result.is_ok());
        operator_enable = false;
        if report.state == State::Fault && fault_since.is_none() {
            fault_since = Some(k);
        }
        match report.state {
            State::Fault if ok && fault_since.is_some_and(|f| k >= f + limits.ramp_cycles) => {
                control.receive(HostMessage::ClearFault);
                fault_since = None;
            }
            State::Disabled if ok => operator_enable = true,
            _ => {}
        }

        let changed = transitions.as_slice().last() != Some(&report.state);
        if changed {
            transitions.push(report.state);
            defmt::println!(
                "cycle {=u32}: state -> {=str} ({=str})",
                k,
                report.state.name(),
                report.reason.name()
            );
        }
        let transition = ok != previous_ok;
        if !ok && first_failure.is_none() {
            first_failure = Some(k);
        }
        if ok && transition && recovered.is_none() {
            recovered = Some(k);
        }
        if k % 500 == 0 || transition || k == CYCLES as u32 - 1 {
            show(k, &setpoint, &report, units(ticks));
        }
        previous_ok = ok;

        release = deadline;
        Mono::delay_until(release).await;
    }
    let loop_us = period_ticks * 1_000_000 / board::TIMER_HZ;

    // --- Results of the real-time loop.
    let step = steps.summary();
    defmt::println!(
        "control-step {=str}: min {=u32} median {=u32} max {=u32} over {=u32} cycles, overruns {=u32}",
        board::UNIT,
        step.min,
        step.median,
        step.max,
        step.count,
        overruns,
    );
    let share = per_mille_of_period(step.max);
    defmt::println!(
        "worst control step = {=u32}.{=u32} % of the 1 ms period at 168 MHz, assuming 1.5 cycles per instruction",
        share / 10,
        share % 10
    );
    summary_line("barycenter", "warm-started, solver only, same cycles", &solver.summary());
    defmt::println!(
        "step breakdown, mean/max {=str}: setpoint and checks {=u32}/{=u32}, kinematics (W and f with motion) {=u32}/{=u32}, solver {=u32}/{=u32}, torques {=u32}/{=u32}, supervisor and drives {=u32}/{=u32}",
        board::UNIT,
        breakdown.setpoint.mean(),
        breakdown.setpoint.max(),
        breakdown.kinematics.mean(),
        breakdown.kinematics.max(),
        breakdown.solver.mean(),
        breakdown.solver.max(),
        breakdown.torques.mean(),
        breakdown.torques.max(),
        breakdown.supervisor_and_drives.mean(),
        breakdown.supervisor_and_drives.max(),
    );
    defmt::println!(
        "cycles: {=u32} ok, infeasible {=u32} (torques held, then fault), other errors {=u32}; warm start held {=u32}, lost {=u32}; torque-saturated {=u32}; drive writes {=u32}",
        outcomes.ok,
        outcomes.infeasible,
        outcomes.no_convergence + outcomes.other,
        outcomes.warm_held,
        outcomes.warm_lost,
        outcomes.saturated,
        drives.writes(),
    );
    if let (Some(a), Some(b)) = (first_failure, recovered) {
        defmt::println!(
            "left the wrench-feasible workspace at cycle {=u32} (t = {=u32} ms), back in at cycle {=u32} (t = {=u32} ms)",
            a,
            a,
            b,
            b,
        );
    }
    let counters = control.counters();
    defmt::println!(
        "states: {=[?]}; faults {=u32}, refused requests {=u32}, rejected setpoints {=u32}",
        transitions.as_slice(),
        counters.faults,
        counters.rejected_state,
        counters.rejected_range + counters.rejected_order,
    );
    defmt::println!(
        "period check: {=u32} periods took {=u64} us of TIM2 time ({=u32} us nominal)",
        CYCLES as u32,
        loop_us,
        CYCLES as u32 * 1_000_000 / crate::mono::TICK_HZ,
    );

    barycenter_phases(clock);

    // --- The other methods over the same poses (not real time).
    for method in Method::ALL.into_iter().filter(|&m| m != Method::Barycenter) {
        solver.clear();
        let counts = replay(method, clock, &mut solver);
        summary_line(method.name(), "solver only, same poses, replayed after the loop", &solver.summary());
        defmt::println!(
            "  {=str}: {=u32} ok, infeasible {=u32}, no-convergence {=u32}, other errors {=u32}",
            method.name(),
            counts.ok,
            counts.infeasible,
            counts.no_convergence,
            counts.other,
        );
    }

    let (torques, brakes) = board::drive_outputs();
    defmt::println!(
        "drives at the end: torques N m = {}, brakes engaged {=bool}",
        rounded::<8>(&torques, 3),
        brakes
    );
    let (used, size) = board::stack_high_water();
    defmt::println!("stack high-water mark: {=u32} of {=u32} bytes", used, size);

    // --- Verdict.
    if step.max > BUDGET {
        flags |= fail::BUDGET;
    }
    if overruns > 0 {
        flags |= fail::OVERRUN;
    }
    if outcomes.infeasible == 0 || outcomes.no_convergence + outcomes.other > 0 {
        flags |= fail::STATUS;
    }
    let expected_states =
        [State::Disabled, State::Enabled, State::Holding, State::Fault, State::Disabled, State::Enabled];
    if transitions.as_slice() != expected_states {
        flags |= fail::STATES;
    }
    let code = if flags == 0 { 0 } else { EXIT_FAIL | flags };
    if code == 0 {
        defmt::println!(
            "PASS: max {=u32} <= {=u32} {=str} per step, 0 overruns",
            step.max,
            BUDGET,
            board::UNIT
        );
    } else {
        defmt::println!(
            "FAIL (exit code {=i32}): over budget {=bool}, overruns {=bool}, timer check failed {=bool}, unexpected statuses {=bool}, unexpected states {=bool}",
            code,
            flags & fail::BUDGET != 0,
            flags & fail::OVERRUN != 0,
            flags & fail::CALIBRATION != 0,
            flags & fail::STATUS != 0,
            flags & fail::STATES != 0,
        );
    }
    board::exit(code)
}

/// Cycles per instruction assumed to turn QEMU's instruction counts into a
/// share of the board's 1 ms period: the Cortex-M4 retires most
/// instructions in one cycle, loads, stores and branches take two, and
/// flash wait states are mostly hidden by the ART accelerator at 168 MHz;
/// 1.5 is a deliberately pessimistic average.
pub const ASSUMED_CPI: (u32, u32) = (3, 2);

/// Per mille of the 1 ms period at [`board::SYSCLK_HZ`] that `instructions`
/// take at [`ASSUMED_CPI`].
fn per_mille_of_period(instructions: u32) -> u32 {
    let cycles = u64::from(instructions) * u64::from(ASSUMED_CPI.0) / u64::from(ASSUMED_CPI.1);
    (cycles * 1000 * 1000 / u64::from(board::SYSCLK_HZ)) as u32
}

/// One `<method> solver instructions: ...` line.
fn summary_line(method: &str, note: &str, s: &Summary) {
    let share = per_mille_of_period(s.max);
    defmt::println!(
        "{=str} solver {=str}: min {=u32} median {=u32} max {=u32} over {=u32} cycles ({=str}); worst = {=u32}.{=u32} % of the 1 ms period at 168 MHz and 1.5 cycles per instruction",
        method,
        board::UNIT,
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
    use tension_core::barycenter::TensionPolygon;
    use tension_core::linalg::WrenchFactorization;
    use tension_core::polygon::VertexList;
    let controller = controller(Method::Barycenter);
    let limits = *controller.robot().limits();
    let (mut fact_t, mut poly_t, mut walk_t) = (Running::default(), Running::default(), Running::default());
    let mut pair = None;
    // Interrupts off: the timings must not include the monotonic's tick.
    cortex_m::interrupt::free(|_| {
        for k in 0..CYCLES as u32 {
            let Ok((w, f)) = controller.wrench(&trajectory::setpoint(k), &Wrench::zeros()) else { continue };
            // Filled in place, as `TensionSolver::solve` does.
            let t0 = clock.ticks();
            let mut fact = WrenchFactorization::zeroed();
            let Ok(()) = fact.factor(&w, &[true; 8], 2) else { continue };
            let t1 = clock.ticks();
            let mut poly = TensionPolygon::zeroed();
            let Ok(()) = poly.set(&fact, &f, &limits) else { continue };
            let t2 = clock.ticks();
            let mut vertices = VertexList::new();
            let found = poly.polygon.walk_into(pair, &mut vertices);
            let t3 = clock.ticks();
            if let Ok(found) = found {
                pair = Some(found.robust_pair);
                fact_t.push(board::ticks_to_units(t1.wrapping_sub(t0)));
                poly_t.push(board::ticks_to_units(t2.wrapping_sub(t1)));
                walk_t.push(board::ticks_to_units(t3.wrapping_sub(t2)));
            }
        }
    });
    defmt::println!(
        "barycenter phases, mean/max {=str}: factorisation {=u32}/{=u32}, polygon {=u32}/{=u32}, walk and centroid {=u32}/{=u32}",
        board::UNIT,
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
        let (w, f) = match controller.wrench(&trajectory::setpoint(k), &Wrench::zeros()) {
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
        samples.push(board::ticks_to_units(ticks));
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
            board::ticks_to_units(clock.since(start))
        })
    };
    let empty = time(&|| black_box(0.5));
    let sin = time(&|| libm::sinf(black_box(0.5)));
    let cos = time(&|| libm::cosf(black_box(0.5)));
    let sqrt = time(&|| libm::sqrtf(black_box(0.5)));
    defmt::println!(
        "cost reference, {=str} per call: libm sinf {=u32}, cosf {=u32} (both compute in f64, soft-float on the M4F), sqrtf {=u32}",
        board::UNIT,
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
        board::UNIT,
        report.state.name(),
        pose,
    );
    let torques: [f32; 8] = rounded(&report.torques, 3);
    match report.solved.map(|c| c.result) {
        Some(Ok(c)) => {
            let tensions: [f32; 8] = rounded(&c.tensions, 1);
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
