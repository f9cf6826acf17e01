//! Control loop of the suspended-8 cable robot on an STM32F405, as an RTIC 2
//! app that runs unchanged on the board and in QEMU's `netduinoplus2`
//! (`cargo xtask run`, or `cargo run -p firmware --release --target
//! thumbv7em-none-eabihf` with the runner of `.cargo/config.toml`).
//!
//! A 1 kHz task with absolute release times (`next = previous + 1 ms`)
//! follows a scripted trajectory ([`control::trajectory`]) for
//! [`CYCLES`] cycles: setpoint -> wrench matrix -> required wrench ->
//! barycenter tensions (warm-started) -> motor torques. TIM2 counts the
//! instructions of every cycle. At the end the task prints the statistics,
//! replays the same poses through the analytic-centre and barycenter-brute
//! solvers for comparison, and exits through semihosting:
//!
//! * 0: every cycle within [`BUDGET`] instructions and no deadline overrun;
//! * `EXIT_FAIL | flags` (32..=47) otherwise, see [`fail`];
//! * [`EXIT_PANIC`] on a panic, [`EXIT_HARDFAULT`] on a HardFault.

#![no_std]
#![no_main]

mod board;
mod control;
mod mono;

use defmt_semihosting as _; // defmt global logger over semihosting

use control::trajectory::CYCLES;

/// Instruction budget of one control cycle (QEMU; cycles on the board).
pub const BUDGET: u32 = 20_000;

/// Exit code base for a failed run; the low bits say why ([`fail`]).
pub const EXIT_FAIL: i32 = 32;
/// Exit code after a panic.
pub const EXIT_PANIC: i32 = 101;
/// Exit code after a HardFault.
pub const EXIT_HARDFAULT: i32 = 102;

/// Failure flags, or-ed into [`EXIT_FAIL`].
pub mod fail {
    /// Some cycle took more than [`crate::BUDGET`].
    pub const BUDGET: i32 = 1;
    /// Some cycle missed its deadline.
    pub const OVERRUN: i32 = 2;
    /// The timer calibration disagrees with the icount relation.
    pub const CALIBRATION: i32 = 4;
    /// The trajectory never left the workspace, or a cycle failed with
    /// something other than `infeasible`.
    pub const STATUS: i32 = 8;
}

#[rtic::app(device = stm32f4::stm32f405, dispatchers = [SPI1, SPI2])]
mod app {
    use rtic_monotonics::fugit::ExtU32;
    use rtic_monotonics::Timebase;
    use tension_core::{Error, Method, WarmStart};

    use crate::board::{self, Drives, Tim2Counter};
    use crate::control::controller::{Controller, Cycle};
    use crate::control::stats::{Running, Samples, Summary};
    use crate::control::trajectory::{self, Setpoint, CYCLES};
    use crate::control::{TickCounter, TorqueOutput};
    use crate::mono::Mono;
    use crate::{fail, BUDGET, EXIT_FAIL};

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        controller: Controller,
        clock: Tim2Counter,
        drives: Drives,
        calibration_ticks: u32,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        board::paint_stack();
        let dp = cx.device;
        #[cfg(feature = "board")]
        board::configure_clocks(&dp.RCC, &dp.FLASH);

        let clock = Tim2Counter::start(dp.TIM2, &dp.RCC);
        let calibration_ticks = board::calibrate(&clock);
        Mono::start(dp.TIM5, &dp.RCC, board::TIMER_HZ as u32);

        let controller = match Controller::new(Method::Barycenter) {
            Ok(c) => c,
            Err(e) => panic!("robot description rejected: {}", e.status()),
        };
        if control::spawn().is_err() {
            panic!("control task already spawned");
        }
        (Shared {}, Local { controller, clock, drives: Drives::new(), calibration_ticks })
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            // Sleep until the next interrupt; under `-icount ... sleep=off`
            // QEMU then jumps virtual time straight to the next timer event.
            cortex_m::asm::wfi();
        }
    }

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

    /// Mean and max of each phase of the control step, instructions.
    #[derive(Default)]
    struct Breakdown {
        setpoint: Running,
        kinematics: Running,
        solver: Running,
        torques: Running,
        drives: Running,
    }

    #[task(
        priority = 1,
        local = [
            controller,
            clock,
            drives,
            calibration_ticks,
            step_buf: [u32; CYCLES] = [0; CYCLES],
            solver_buf: [u32; CYCLES] = [0; CYCLES],
        ]
    )]
    async fn control(cx: control::Context) {
        let controller = cx.local.controller;
        let clock = &*cx.local.clock;
        let drives = cx.local.drives;
        let mut flags = 0;
        let units = board::ticks_to_units;

        defmt::println!(
            "suspended-8 cable robot: RTIC 2 on an STM32F405 at {=u32} MHz ({=str})",
            board::SYSCLK_HZ / 1_000_000,
            board::TARGET,
        );

        // --- Timer check: the icount relation against a known loop.
        let expected = u64::from(board::CALIBRATION_INSTRUCTIONS) * (board::TIMER_HZ << board::ICOUNT_SHIFT)
            / 1_000_000_000;
        let measured = *cx.local.calibration_ticks;
        defmt::println!(
            "timer check: a {=u32}-instruction loop took {=u32} TIM2 ticks = {=u32} {=str} (icount shift={=u32}, {=u64} Hz timer: {=u64} ticks expected)",
            board::CALIBRATION_INSTRUCTIONS,
            measured,
            units(measured),
            board::UNIT,
            board::ICOUNT_SHIFT,
            board::TIMER_HZ,
            expected,
        );
        if cfg!(not(feature = "board")) && u64::from(measured).abs_diff(expected) * 100 > expected {
            defmt::println!("timer check FAILED: ticks do not convert to instructions as assumed");
            flags |= fail::CALIBRATION;
        }
        cost_reference(clock);

        defmt::println!(
            "control loop: barycenter (warm-started), {=u32} cycles at {=u32} Hz, budget {=u32} {=str} per step",
            CYCLES as u32,
            crate::mono::TICK_HZ,
            BUDGET,
            board::UNIT,
        );

        // --- The real-time loop.
        let mut steps = Samples::new(cx.local.step_buf);
        let mut solver = Samples::new(cx.local.solver_buf);
        let mut breakdown = Breakdown::default();
        let mut outcomes = Outcomes::default();
        let mut overruns = 0u32;
        let mut first_failure: Option<u32> = None;
        let mut recovered: Option<u32> = None;
        let mut previous_ok = true;
        let mut period_ticks = 0u64;

        // Start on a tick, so that the first cycle has a whole period.
        let mut release = Mono::now() + 1.millis();
        Mono::delay_until(release).await;
        let mut last_start = clock.ticks();

        for k in 0..CYCLES as u32 {
            let start = clock.ticks();
            period_ticks += u64::from(start.wrapping_sub(last_start));
            last_start = start;

            // The measured control step: setpoint -> torques -> drives.
            let setpoint = trajectory::setpoint(k);
            let t_setpoint = clock.ticks();
            let cycle = controller.step(&setpoint, clock);
            let t_step = clock.ticks();
            drives.apply(controller.applied());
            let end = clock.ticks();

            // Absolute deadlines: this cycle's ends where the next begins.
            let deadline = release + 1.millis();
            if Mono::now() >= deadline {
                overruns += 1;
            }

            let ticks = end.wrapping_sub(start);
            steps.push(units(ticks));
            solver.push(units(cycle.ticks.solver));
            breakdown.setpoint.push(units(t_setpoint.wrapping_sub(start)));
            breakdown.kinematics.push(units(cycle.ticks.kinematics));
            breakdown.solver.push(units(cycle.ticks.solver));
            breakdown.torques.push(units(cycle.ticks.torques));
            breakdown.drives.push(units(end.wrapping_sub(t_step)));
            outcomes.count(&cycle.result);
            if let Ok(command) = &cycle.result {
                match command.warm_start {
                    WarmStart::Held => outcomes.warm_held += 1,
                    WarmStart::Lost => outcomes.warm_lost += 1,
                    WarmStart::NotGiven => {}
                }
                if command.saturated != 0 {
                    outcomes.saturated += 1;
                }
            }

            // A few cycles shown readably (after the deadline check; the
            // printing eats into the slack before the next release).
            let ok = cycle.result.is_ok();
            let transition = ok != previous_ok;
            if !ok && first_failure.is_none() {
                first_failure = Some(k);
            }
            if ok && transition && recovered.is_none() {
                recovered = Some(k);
            }
            if k % 500 == 0 || transition || k == CYCLES as u32 - 1 {
                show(k, &setpoint, &cycle, controller.applied(), units(ticks));
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
        summary_line("barycenter", "warm-started, solver only, same cycles", &solver.summary());
        defmt::println!(
            "step breakdown, mean/max {=str}: setpoint {=u32}/{=u32}, kinematics (W and f with motion) {=u32}/{=u32}, solver {=u32}/{=u32}, torques {=u32}/{=u32}, drives {=u32}/{=u32}",
            board::UNIT,
            breakdown.setpoint.mean(),
            breakdown.setpoint.max(),
            breakdown.kinematics.mean(),
            breakdown.kinematics.max(),
            breakdown.solver.mean(),
            breakdown.solver.max(),
            breakdown.torques.mean(),
            breakdown.torques.max(),
            breakdown.drives.mean(),
            breakdown.drives.max(),
        );
        defmt::println!(
            "cycles: {=u32} ok, infeasible {=u32} (torques held), other errors {=u32}; warm start held {=u32}, lost {=u32}; torque-saturated {=u32}; drive writes {=u32}",
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
        defmt::println!(
            "period check: {=u32} periods took {=u64} us of TIM2 time ({=u32} us nominal)",
            CYCLES as u32,
            loop_us,
            CYCLES as u32 * 1_000_000 / crate::mono::TICK_HZ,
        );

        barycenter_phases(clock);

        // --- The other methods over the same poses (not real time).
        for method in [Method::AnalyticCentre, Method::BarycenterBrute] {
            solver.clear();
            let counts = replay(method, clock, &mut solver);
            summary_line(
                method.name(),
                "solver only, same poses, replayed after the loop",
                &solver.summary(),
            );
            defmt::println!(
                "  {=str}: {=u32} ok, infeasible {=u32}, no-convergence {=u32}, other errors {=u32}",
                method.name(),
                counts.ok,
                counts.infeasible,
                counts.no_convergence,
                counts.other,
            );
        }

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
                "FAIL (exit code {=i32}): over budget {=bool}, overruns {=bool}, timer check failed {=bool}, unexpected statuses {=bool}",
                code,
                flags & fail::BUDGET != 0,
                flags & fail::OVERRUN != 0,
                flags & fail::CALIBRATION != 0,
                flags & fail::STATUS != 0,
            );
        }
        semihosting::process::exit(code);
    }

    /// One `<method> solver instructions: ...` line.
    fn summary_line(method: &str, note: &str, s: &Summary) {
        defmt::println!(
            "{=str} solver {=str}: min {=u32} median {=u32} max {=u32} over {=u32} cycles ({=str})",
            method,
            board::UNIT,
            s.min,
            s.median,
            s.max,
            s.count,
            note,
        );
    }

    /// Runs `method` (warm-started like the loop's solver) over the loop's
    /// poses and times the solver alone, interrupts off for each call.
    /// The barycenter's phases over the same poses: factorisation of `W`,
    /// the polygon's half-planes, the warm-started walk and centroid.
    fn barycenter_phases(clock: &Tim2Counter) {
        use tension_core::barycenter::TensionPolygon;
        use tension_core::linalg::WrenchFactorization;
        use tension_core::polygon::VertexList;
        let controller = match Controller::new(Method::Barycenter) {
            Ok(c) => c,
            Err(e) => panic!("robot description rejected: {}", e.status()),
        };
        let limits = *controller.robot().limits();
        let (mut fact_t, mut poly_t, mut walk_t) =
            (Running::default(), Running::default(), Running::default());
        let mut pair = None;
        // Interrupts off: the timings must not include the monotonic's tick.
        cortex_m::interrupt::free(|_| {
            for k in 0..CYCLES as u32 {
                let Ok((w, f)) = controller.wrench(&trajectory::setpoint(k)) else { continue };
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

    fn replay(method: Method, clock: &Tim2Counter, samples: &mut Samples) -> Outcomes {
        let mut counts = Outcomes::default();
        let mut controller = match Controller::new(method) {
            Ok(c) => c,
            Err(e) => panic!("robot description rejected: {}", e.status()),
        };
        for k in 0..CYCLES as u32 {
            let (w, f) = match controller.wrench(&trajectory::setpoint(k)) {
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

    /// Prints what the libm primitives the control step leans on cost.
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
    fn show(k: u32, setpoint: &Setpoint, cycle: &Cycle, applied: &[f32; 8], cost: u32) {
        let pose: [f32; 6] = rounded(setpoint.pose.as_slice(), 3);
        defmt::println!(
            "cycle {=u32} (t = {=u32} ms, {=u32} {=str}): pose [x y z rx ry rz] = {}",
            k,
            k,
            cost,
            board::UNIT,
            pose,
        );
        match &cycle.result {
            Ok(c) => {
                let tensions: [f32; 8] = rounded(&c.tensions, 1);
                let torques: [f32; 8] = rounded(&c.torques, 3);
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
            Err(e) => {
                let held: [f32; 8] = rounded(applied, 3);
                defmt::println!("  status {=str}: torques held at N m = {}", e.status(), held);
            }
        }
    }
}

/// Logs the panic and exits with [`EXIT_PANIC`].
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    semihosting::process::exit(EXIT_PANIC)
}

/// Logs the faulting address and exits with [`EXIT_HARDFAULT`].
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::error!("HardFault at pc {=u32:#010x}", frame.pc());
    semihosting::process::exit(EXIT_HARDFAULT)
}

// The loop's statistics live in fixed buffers of this many samples.
const _: () = assert!(CYCLES >= 2000);
