//! Control loop of the suspended-8 cable robot on an STM32F405, as an RTIC 2
//! app that runs unchanged on the board and in QEMU's `netduinoplus2`.
//!
//! Every millisecond (absolute releases on TIM5: `next = previous + 1 ms`)
//! the `control` task drains the bytes USART1 received, lets
//! [`cdpr_control::ControlLoop`] act on the frames (setpoints, enable,
//! disable, clear fault, telemetry rate), solves the newest setpoint
//! (kinematics, wrench with the d'Alembert terms, warm-started barycenter,
//! motor torques), lets the safety state machine decide what reaches the
//! winches, writes the drives and queues telemetry. TIM2 times every step;
//! a late step counts as an overrun, which the state machine sees.
//!
//! Two builds of the same app:
//! * default: the product. Setpoints come over the serial link
//!   (`cdpr-protocol`), telemetry goes back; it runs until reset.
//! * `--features demo` (`cargo xtask run`): the setpoints come from a
//!   scripted trajectory ([`cdpr_demo::trajectory`]) and a scripted
//!   operator; after [`demo::CYCLES`] cycles the run prints its statistics,
//!   replays the poses through other methods for comparison and exits
//!   through semihosting with a verdict (see [`demo`]).
//!
//! The `board` feature adds what QEMU does not model (RCC/PLL clocks, the
//! IWDG, the USART pins) and logs over RTT instead of semihosting.

#![no_std]
#![no_main]

mod board;
#[cfg(feature = "demo")]
mod demo;
mod mono;
mod robot;
mod serial;
#[cfg(not(feature = "demo"))]
mod serve;

#[cfg(feature = "board")]
use defmt_rtt as _; // defmt over RTT (probe-rs)
#[cfg(not(feature = "board"))]
use defmt_semihosting as _; // defmt over semihosting (QEMU)

/// Exit code after a panic.
pub const EXIT_PANIC: i32 = 101;
/// Exit code after a HardFault.
pub const EXIT_HARDFAULT: i32 = 102;

#[rtic::app(device = stm32f4::stm32f405, dispatchers = [SPI1, SPI2, SPI3])]
mod app {
    use cdpr_control::supervisor::SafetyLimits;
    use cdpr_control::ControlLoop;
    use heapless::spsc::{Consumer, Producer, Queue};
    use tension_core::Method;

    use crate::board::{self, Drives, Tim2Counter};
    use crate::mono::Mono;
    use crate::serial::{self, Receiver, Transmitter, RX_QUEUE, TX_QUEUE};

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        control: ControlLoop,
        clock: Tim2Counter,
        drives: Drives,
        calibration_ticks: u32,
        rx: Consumer<'static, u8>,
        tx: Producer<'static, u8>,
        receiver: Receiver,
        transmitter: Transmitter,
    }

    #[init(local = [
        rx_queue: Queue<u8, RX_QUEUE> = Queue::new(),
        tx_queue: Queue<u8, TX_QUEUE> = Queue::new(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        board::paint_stack();
        let dp = cx.device;
        #[cfg(feature = "board")]
        board::configure_clocks(&dp.RCC, &dp.FLASH);

        let clock = Tim2Counter::start(dp.TIM2, &dp.RCC);
        let calibration_ticks = board::calibrate(&clock);
        Mono::start(dp.TIM5, &dp.RCC, board::TIMER_HZ as u32);

        let (rx_in, rx) = cx.local.rx_queue.split();
        let (tx, tx_out) = cx.local.tx_queue.split();
        serial::init(dp.USART1, &dp.RCC);

        let control = match crate::robot::robot().and_then(|robot| {
            let range = crate::robot::setpoint_range(&robot);
            ControlLoop::new(robot, Method::Barycenter, range, SafetyLimits::DEFAULT)
        }) {
            Ok(c) => c,
            Err(e) => panic!("robot description rejected: {}", e.status()),
        };
        #[cfg(feature = "board")]
        board::start_watchdog(&dp.IWDG);
        if control::spawn().is_err() {
            panic!("control task already spawned");
        }
        (
            Shared {},
            Local {
                control,
                clock,
                drives: Drives::new(),
                calibration_ticks,
                rx,
                tx,
                receiver: Receiver::new(rx_in),
                transmitter: Transmitter::new(tx_out),
            },
        )
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            // Sleep until the next interrupt; under `-icount ... sleep=off`
            // QEMU then jumps virtual time straight to the next timer event.
            cortex_m::asm::wfi();
        }
    }

    /// Every received byte into the queue (highest priority: a byte must
    /// be taken before the next arrives).
    #[task(binds = USART1, priority = 3, local = [receiver])]
    fn usart1(cx: usart1::Context) {
        cx.local.receiver.on_interrupt();
    }

    /// Writes queued telemetry to the line (lowest priority).
    #[task(priority = 1, local = [transmitter])]
    async fn transmit(cx: transmit::Context) {
        cx.local.transmitter.drain();
    }

    /// The 1 kHz control loop.
    #[task(
        priority = 2,
        local = [
            control,
            clock,
            drives,
            calibration_ticks,
            rx,
            tx,
        ]
    )]
    async fn control(cx: control::Context) {
        #[cfg(feature = "demo")]
        crate::demo::run(cx.local.control, cx.local.clock, cx.local.drives, *cx.local.calibration_ticks)
            .await;
        #[cfg(not(feature = "demo"))]
        crate::serve::run(
            cx.local.control,
            cx.local.clock,
            cx.local.drives,
            cx.local.rx,
            cx.local.tx,
            || {
                // Already running: it will find the new bytes.
                let _ = transmit::spawn();
            },
        )
        .await;
    }
}

/// Stops the motors, logs the panic and exits with [`EXIT_PANIC`].
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    board::emergency_stop();
    defmt::error!("panic: {}", defmt::Display2Format(info));
    report_stop();
    board::exit(EXIT_PANIC)
}

/// What the drives hold after the emergency stop (checked by the test
/// command's fault-injection runs).
fn report_stop() {
    let (torques, brakes) = board::drive_outputs();
    defmt::error!("drives after the emergency stop: torques {} N m, brakes engaged {=bool}", torques, brakes);
}

/// Stops the motors, logs the faulting address and exits with
/// [`EXIT_HARDFAULT`].
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    board::emergency_stop();
    defmt::error!("HardFault at pc {=u32:#010x}", frame.pc());
    report_stop();
    board::exit(EXIT_HARDFAULT)
}
