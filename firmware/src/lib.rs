//! The firmware's library: what every program on the STM32F405 shares. The
//! programs are in `src/bin/`:
//!
//! * `firmware`, the product: setpoints and commands over USART1
//!   (`cdpr-protocol`), telemetry back, every millisecond until reset;
//! * `demo` (`cargo xtask run`): the same control loop fed by the scripted
//!   trajectory of `cdpr-demo`, timed, ending with an encoded report;
//! * `inject-panic`, `inject-hardfault`: the demo, faulting at cycle 1000,
//!   to check that the handlers stop the drives first (`cargo xtask test`).
//!
//! Each is a small RTIC 2 app; the pieces are here:
//!
//! * [`bsp`]: board support, one module per board (QEMU's
//!   `netduinoplus2`, a real STM32F405 with the `board` feature), chosen in
//!   one place;
//! * [`mono`]: the RTIC monotonic on TIM5; [`periodic`]: the 1 ms release
//!   every control loop runs on;
//! * [`clock`]: TIM2 as the tick counter that times the steps;
//! * [`drives`]: the winch drives and the emergency stop (on the board
//!   the CiA 402 drives on CAN1 and CAN2 through `can`, or with the
//!   `direct` feature PWM amplifiers and quadrature counters through
//!   `direct`); [`serial`]:
//!   USART1; [`stack`]: stack painting; [`state_log`]: the product's log
//!   of state changes, written by the idle loop; [`robot`]: the robot's
//!   constants, generated from its robot file;
//! * `demo`: the demo run (the `demo` and `inject-*` programs; not for a
//!   robot from which no demo trajectory derives), whose
//!   drives ([`loopback`]) put the CiA 402 layer, its frames looped back
//!   to drive models in memory, in front of the board's;
//! * the panic and HardFault handlers: the drives stop first, then the
//!   program exits with [`cdpr_demo::exit::PANIC`] or
//!   [`cdpr_demo::exit::HARDFAULT`].

#![no_std]

pub mod bsp;
#[cfg(all(feature = "board", not(feature = "direct")))]
pub mod can;
pub mod clock;
// Not for a robot with no demo trajectory (`build.rs` sets `no_demo`).
#[cfg(not(no_demo))]
pub mod demo;
#[cfg(feature = "direct")]
pub mod direct;
pub mod drives;
pub mod loopback;
pub mod mono;
pub mod periodic;
pub mod robot;
pub mod serial;
pub mod stack;
pub mod state_log;
pub mod stress;

use cdpr_control::feedback::{JointGains, TaskPid};
use cdpr_control::supervisor::SafetyLimits;
use cdpr_control::ControlLoop;
use stm32f4::stm32f405::{Peripherals, IWDG, RCC, USART1};

use crate::clock::Tim2Counter;
use crate::drives::Drives;
use crate::mono::Mono;

/// What every program's control task owns: the step timer and its
/// calibration, the drives and the control loop.
pub struct Board {
    /// TIM2, timing the steps.
    pub clock: Tim2Counter,
    /// TIM2 ticks of the calibration loop ([`clock::calibrate`]).
    pub calibration_ticks: u32,
    /// The winch drives.
    pub drives: Drives,
    /// The control loop for [`robot::robot`] (barycenter, default safety limits).
    pub control: ControlLoop,
}

/// The peripherals a program may still need after [`Board::start`].
pub struct Rest {
    /// Reset and clock control (enables the USART's clock).
    pub rcc: RCC,
    /// The host link.
    pub usart1: USART1,
    /// The independent watchdog ([`Board::start_watchdog`]).
    pub iwdg: IWDG,
    /// The CAN controllers' interrupt sides (nothing under QEMU): the
    /// product binds CAN1_TX, CAN1_RX0, CAN2_TX and CAN2_RX0 to them.
    pub can: (Can1Irq, Can2Irq),
}

/// What the CAN interrupts do: move frames between a controller and its
/// queues (board); nothing under QEMU, which models no bxCAN.
pub trait CanInterrupt {
    /// A transmit mailbox emptied, or frames were queued.
    fn on_transmit(&mut self) {}
    /// A frame arrived.
    fn on_receive(&mut self) {}
}

impl CanInterrupt for () {}

#[cfg(all(feature = "board", not(feature = "direct")))]
impl<C: can::Controller> CanInterrupt for can::CanIrq<C> {
    fn on_transmit(&mut self) {
        can::CanIrq::on_transmit(self);
    }
    fn on_receive(&mut self) {
        can::CanIrq::on_receive(self);
    }
}

/// CAN1's interrupt side.
#[cfg(all(feature = "board", not(feature = "direct")))]
pub type Can1Irq = can::CanIrq<can::Can1>;
/// CAN2's interrupt side.
#[cfg(all(feature = "board", not(feature = "direct")))]
pub type Can2Irq = can::CanIrq<can::Can2>;
/// No CAN under QEMU or on the direct path.
#[cfg(any(not(feature = "board"), feature = "direct"))]
pub type Can1Irq = ();
/// No CAN under QEMU or on the direct path.
#[cfg(any(not(feature = "board"), feature = "direct"))]
pub type Can2Irq = ();

/// The feedback for the robot file: its bandwidth (`[control]
/// bandwidth`), then its bounds scaled to the platform's weight. Out of
/// line: inlined into [`Board::start`] it grew that frame (12 928 ->
/// 15 232 bytes, past the stack limit).
#[inline(never)]
fn configure_feedback(control: &mut ControlLoop) {
    if let Err(e) = control.set_bandwidth(robot::BANDWIDTH_HZ) {
        panic!("feedback bandwidth rejected: {}", e.status());
    }
    let gains = *control.task_pid().gains();
    match TaskPid::new(gains, robot::feedback_limits()) {
        Ok(pid) => control.set_task_pid(pid),
        Err(e) => panic!("feedback limits rejected: {}", e.status()),
    }
    let joint = control
        .joint_pid()
        .map(|pid| JointGains { integral_max: robot::joint_integral_max(), ..*pid.gains() });
    if let Err(e) = control.set_joint_gains(joint) {
        panic!("joint-space integral bound rejected: {}", e.status());
    }
}

impl Board {
    /// [`Self::start`] into `slot` (a static of the program's `init`): the
    /// board (about 6 KB with the control loop and the solver's room) is
    /// moved through this function's frame, which is gone before `init`
    /// goes on (e.g. to build the demo's drive models), so the two never
    /// sit on the stack together.
    ///
    /// The feedback's settings ([`configure_feedback`]) come after
    /// `start`'s frame (12 928 bytes) is gone: under it they took the
    /// product's stack 13 856 -> 14 336 bytes.
    #[inline(never)]
    pub fn start_in(slot: &'static mut Option<Board>, dp: Peripherals) -> (&'static mut Board, Rest) {
        let (board, rest) = Self::start_in_slot(slot, dp);
        configure_feedback(&mut board.control);
        (board, rest)
    }

    /// [`Self::start`] into `slot`, in a frame of its own.
    #[inline(never)]
    fn start_in_slot(slot: &'static mut Option<Board>, dp: Peripherals) -> (&'static mut Board, Rest) {
        let (board, rest) = Self::start(dp);
        (slot.insert(board), rest)
    }

    /// Brings the board up: stack painting, the board's clocks, TIM2 and
    /// its calibration, the monotonic on TIM5 and the control loop, its
    /// feedback at the loop's defaults ([`Self::start_in`] then sets the
    /// robot file's; the stress program, which runs no feedback, keeps
    /// them). Panics if the robot's constants do not form a valid robot.
    pub fn start(dp: Peripherals) -> (Self, Rest) {
        stack::paint_stack();
        bsp::configure_clocks(&dp.RCC, &dp.FLASH);
        let clock = Tim2Counter::start(dp.TIM2, &dp.RCC);
        let calibration_ticks = clock::calibrate(&clock);
        Mono::start(dp.TIM5, &dp.RCC, bsp::TIMER_HZ as u32);
        let mut control = match robot::robot().and_then(|robot| {
            let range = robot::setpoint_range(&robot);
            ControlLoop::new(robot, cdpr_demo::methods::LOOP_METHOD, range, SafetyLimits::DEFAULT)
        }) {
            Ok(c) => c,
            Err(e) => panic!("robot description rejected: {}", e.status()),
        };
        // Only the methods whose worst case fits the step budget.
        control.offer_only(cdpr_demo::methods::offered());
        // `build.rs` refuses a robot file whose encoders these refuse.
        if let Err(e) = robot::encoder_scale().and_then(|scale| control.set_encoder(scale)) {
            panic!("robot file's encoders rejected: {:?}", e);
        }
        // On the CAN buses the task-space PID predicts over the delay they
        // add (the step's frames queued about 0.1 ms in, 4 drives a bus at
        // 1 Mbit/s: 0.83 ms) and its D-term takes the estimator's speed
        // through a 10 Hz filter (`EstimatorSettings::FIELD_BUS`;
        // `hal-sim/README.md`, "On the CAN buses"). The direct path reads
        // and writes its winches in the step: no delay added.
        #[cfg(all(feature = "board", not(feature = "direct")))]
        {
            control.set_loop_delay(canopen_drives::BOARD_LOOP_DELAY_NS as f32 * 1e-9);
            control.set_estimator(cdpr_control::estimator::EstimatorSettings::FIELD_BUS);
        }
        #[cfg(not(feature = "board"))]
        let drives = Drives::new();
        #[cfg(feature = "direct")]
        let (drives, can) = {
            let peripherals = direct::DirectPeripherals {
                tim1: dp.TIM1,
                tim3: dp.TIM3,
                tim4: dp.TIM4,
                tim8: dp.TIM8,
                tim9: dp.TIM9,
                tim10: dp.TIM10,
                tim11: dp.TIM11,
                tim12: dp.TIM12,
                tim13: dp.TIM13,
                tim14: dp.TIM14,
                spi2: dp.SPI2,
            };
            (Drives::on_board(direct::start(peripherals, &dp.RCC, robot::TORQUE_MAX)), ((), ()))
        };
        #[cfg(all(feature = "board", not(feature = "direct")))]
        let (drives, can) = {
            use heapless::spsc::Queue;
            let queues = match (
                cortex_m::singleton!(: Queue<bxcan::Frame, { can::QUEUE }> = Queue::new()),
                cortex_m::singleton!(: Queue<bxcan::Frame, { can::QUEUE }> = Queue::new()),
                cortex_m::singleton!(: Queue<bxcan::Frame, { can::QUEUE }> = Queue::new()),
                cortex_m::singleton!(: Queue<bxcan::Frame, { can::QUEUE }> = Queue::new()),
            ) {
                (Some(tx1), Some(rx1), Some(tx2), Some(rx2)) => can::Queues { tx1, rx1, tx2, rx2 },
                _ => panic!("the CAN queues were taken twice"),
            };
            let ((port1, port2), irq) = can::start(dp.CAN1, dp.CAN2, &dp.RCC, queues);
            let bus = canopen_drives::CanDrives::new(
                port1,
                port2,
                robot::drive_configs(),
                canopen_drives::Timing::DEFAULT,
            );
            (Drives::on_board(bus), irq)
        };
        let board = Self { clock, calibration_ticks, drives, control };
        #[cfg(not(feature = "board"))]
        let can = ((), ());
        let rest = Rest { rcc: dp.RCC, usart1: dp.USART1, iwdg: dp.IWDG, can };
        (board, rest)
    }

    /// Puts the encoders' stand-in (QEMU) at rest at `pose`: where the
    /// host's `Home` says the platform is.
    pub fn place_stand_in(&mut self, pose: [f32; 6]) {
        let pose = cdpr_control::setpoint::Pose6::from(pose);
        if !self.drives.place_stand_in(self.control.controller().robot(), &pose) && !cfg!(feature = "board") {
            panic!("the encoders' stand-in has no kinematics at its start pose");
        }
    }

    /// Starts the watchdog (board only); the control loop feeds it every
    /// cycle from now on. Call last in `init`.
    pub fn start_watchdog(iwdg: &IWDG) {
        bsp::start_watchdog(iwdg);
    }
}

/// The idle loop: sleep until the next interrupt; under `-icount ...
/// sleep=off` QEMU then jumps virtual time straight to the next timer event.
pub fn idle() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

/// Ends the program: motors stopped first. Under QEMU the exit code
/// reaches the shell; on the board the core waits for the watchdog (or a
/// debugger).
pub fn exit(code: i32) -> ! {
    drives::emergency_stop();
    bsp::exit(code)
}

/// Logs `record` on a line of its own, encoded (see [`cdpr_demo::report`]).
pub fn log_record(record: &cdpr_demo::report::Record) {
    let mut text = [0u8; cdpr_demo::report::MAX_TEXT];
    match cdpr_demo::report::encode(record, &mut text) {
        Ok(line) => defmt::println!("{=str}", line),
        Err(_) => defmt::println!("a record did not fit its buffer"),
    }
}

/// What the drives hold after the emergency stop, as a readable line and
/// as the encoded record the test command decodes.
fn report_stop() {
    let (torques, brakes) = drives::drive_outputs();
    defmt::error!("drives after the emergency stop: torques {} N m, brakes engaged {=bool}", torques, brakes);
    log_record(&cdpr_demo::report::Record::Stopped { torques, brakes });
}

/// Stops the motors, logs the panic and exits with [`cdpr_demo::exit::PANIC`].
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    drives::emergency_stop();
    defmt::error!("panic: {}", defmt::Display2Format(info));
    report_stop();
    exit(cdpr_demo::exit::PANIC)
}

/// Stops the motors, logs the faulting address and exits with
/// [`cdpr_demo::exit::HARDFAULT`].
///
/// `unsafe fn` because cortex-m-rt requires it of a HardFault handler; the
/// runtime calls it only on a HardFault, with the stacked frame.
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    drives::emergency_stop();
    defmt::error!("HardFault at pc {=u32:#010x}", frame.pc());
    report_stop();
    exit(cdpr_demo::exit::HARDFAULT)
}
