//! The product: the 1 kHz control loop of the cable robot, setpoints and
//! commands over USART1 (`cdpr-protocol`), telemetry back, until reset.
//!
//! Every millisecond ([`firmware::periodic::Releases`]) the `control` task
//! takes up to `cdpr_control::FRAME_BUDGET` of the frames the USART1 interrupt reassembled, lets [`cdpr_control::ControlLoop`]
//! act on the frames (setpoints, enable, disable, clear fault, telemetry
//! rate, method, home, feedback scheme, identify), reads the winch encoders, solves
//! the newest setpoint (kinematics, wrench with the d'Alembert terms, the
//! pose estimate and the selected feedback, warm-started barycenter, motor
//! torques), lets the
//! safety state machine decide what reaches the winches, writes the drives
//! and queues telemetry (and, after an `Identify`, the robot's identity
//! `firmware::robot::IDENTITY`), which a low-priority task writes to the line.
//! TIM2 times every step; a late cycle counts as an overrun, which the
//! state machine sees. The idle loop logs the state machine's changes
//! (`firmware::state_log`).

#![no_std]
#![no_main]

#[rtic::app(device = stm32f4::stm32f405, dispatchers = [SPI1, SPI2])]
mod app {
    use cdpr_control::TickCounter;
    use cdpr_protocol::{encode, DeviceMessage, LineFrame, MAX_FRAME};
    use firmware::periodic::Releases;
    use firmware::serial::{self, FrameQueue, Receiver, Transmitter, RX_QUEUE, TX_QUEUE};
    use firmware::state_log::{ChangeLog, ChangeQueue, Recorder};
    use firmware::{bsp, clock, robot, Board, CanInterrupt};
    use heapless::spsc::{Producer, Queue};

    #[shared]
    struct Shared {
        can1: firmware::Can1Irq,
        can2: firmware::Can2Irq,
    }

    #[local]
    struct Local {
        /// In `init`'s static slot: the board (about 5 KB with the control
        /// loop) is not moved through `init`'s return on the stack.
        board: &'static mut Board,
        rx: FrameQueue,
        tx: Producer<'static, u8>,
        receiver: Receiver,
        transmitter: Transmitter,
        /// The state changes the control task saw, for the idle loop.
        changes: Recorder,
        /// The idle loop's end of `changes`.
        change_log: ChangeLog,
    }

    #[init(local = [
        rx_queue: Queue<LineFrame, RX_QUEUE> = Queue::new(),
        tx_queue: Queue<u8, TX_QUEUE> = Queue::new(),
        board_slot: Option<Board> = None,
        change_queue: ChangeQueue = ChangeQueue::new(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let (board, rest) = Board::start_in(cx.local.board_slot, cx.device);
        // QEMU: the encoders' stand-in rests where the demo trajectory
        // starts (the pose the end-to-end test homes with), or at the
        // static workspace's centre for a robot with no demo.
        board.place_stand_in(firmware::robot::HOME);
        let (rx_in, rx) = cx.local.rx_queue.split();
        let (tx, tx_out) = cx.local.tx_queue.split();
        let (changes, change_log) = cx.local.change_queue.split();
        let changes = Recorder::new(changes, board.control.supervisor().state());
        serial::init(rest.usart1, &rest.rcc);
        Board::start_watchdog(&rest.iwdg);
        if control::spawn().is_err() {
            panic!("control task already spawned");
        }
        let (can1, can2) = rest.can;
        let local = Local {
            board,
            rx: FrameQueue(rx),
            tx,
            receiver: Receiver::new(rx_in),
            transmitter: Transmitter::new(tx_out),
            changes,
            change_log: ChangeLog::new(change_log),
        };
        (Shared { can1, can2 }, local)
    }

    /// The state changes' log lines (`firmware::state_log`), below every
    /// task: written in the control loop they cost it its deadline.
    #[idle(local = [change_log])]
    fn idle(cx: idle::Context) -> ! {
        loop {
            cx.local.change_log.write_pending();
            // A change queued after the check waits for the next interrupt
            // (the control release, at most 1 ms).
            cortex_m::asm::wfi();
        }
    }

    /// Every received byte into the queue (highest priority: a byte must
    /// be taken before the next arrives).
    #[task(binds = USART1, priority = 3, local = [receiver])]
    fn usart1(cx: usart1::Context) {
        cx.local.receiver.on_interrupt();
    }

    /// CAN1's mailboxes from its queue (board; QEMU has no bxCAN and never
    /// raises it): above the control task, so a cycle's RPDOs and SYNC go
    /// out as soon as they are queued.
    #[task(binds = CAN1_TX, priority = 3, shared = [can1])]
    fn can1_tx(mut cx: can1_tx::Context) {
        cx.shared.can1.lock(CanInterrupt::on_transmit);
    }

    /// CAN1's received frames into its queue (board).
    #[task(binds = CAN1_RX0, priority = 3, shared = [can1])]
    fn can1_rx(mut cx: can1_rx::Context) {
        cx.shared.can1.lock(CanInterrupt::on_receive);
    }

    /// CAN2's mailboxes from its queue (board).
    #[task(binds = CAN2_TX, priority = 3, shared = [can2])]
    fn can2_tx(mut cx: can2_tx::Context) {
        cx.shared.can2.lock(CanInterrupt::on_transmit);
    }

    /// CAN2's received frames into its queue (board).
    #[task(binds = CAN2_RX0, priority = 3, shared = [can2])]
    fn can2_rx(mut cx: can2_rx::Context) {
        cx.shared.can2.lock(CanInterrupt::on_receive);
    }

    /// Writes queued telemetry to the line (lowest priority).
    #[task(priority = 1, local = [transmitter])]
    async fn transmit(cx: transmit::Context) {
        cx.local.transmitter.drain();
    }

    /// The 1 kHz control loop.
    #[task(priority = 2, local = [board, rx, tx, changes])]
    async fn control(cx: control::Context) {
        let Board { drives, control, .. } = &mut **cx.local.board;
        let (rx, tx) = (cx.local.rx, cx.local.tx);
        defmt::println!(
            "{=str} cable robot: RTIC 2 on an STM32F405 at {=u32} MHz ({=str}); serial link on USART1, disabled until Enable",
            firmware::robot::NAME,
            bsp::SYSCLK_HZ / 1_000_000,
            bsp::TARGET,
        );
        let mut frame = [0u8; MAX_FRAME];
        let mut overrun = false;
        let mut identify = false;
        // What one receive interrupt costs outside its measured body.
        let entry_exit = serial::calibrate_entry_exit();
        defmt::println!(
            "the receive interrupt's entry and exit: {=u32} instructions (taken out of each step with its body)",
            clock::ticks_to_units(entry_exit)
        );
        // The step is timed on the task's own clock: TIM2 less the receive
        // interrupt's time.
        let task_clock = serial::TaskClock::new(entry_exit);
        // Written in place by every step (484 bytes: not copied out).
        let mut report = cdpr_control::StepReport::default();
        let mut releases = Releases::start().await;
        loop {
            // The step's own work: the receive interrupt's time within it
            // (bodies, entries and exits) is left out (bounded apart, see
            // `serial`); under QEMU the interrupt waits until the step is
            // done (`bsp::with_receive_held`).
            let cost = bsp::with_receive_held(|| {
                let start = task_clock.ticks();
                bsp::feed_watchdog();
                // At most FRAME_BUDGET frames (reassembled by the USART1
                // interrupt), whatever arrives; the rest waits.
                control.receive_frames(rx);
                control.record_dropped(serial::dropped());
                // QEMU has no platform: the stand-in's cables are where the
                // host says at homing (nothing on the board).
                // A Home is carried out only in Disabled.
                if let Some(pose) = control.pending_home().copied() {
                    if control.supervisor().state() == cdpr_control::protocol::State::Disabled {
                        let _ = drives.place_stand_in(control.controller().robot(), &pose);
                    }
                }
                // The phases are not timed here (nothing in the product
                // reads them: telemetry carries the whole step's cost); the
                // demo times them.
                control.step_into(&cdpr_control::NoClock, drives, overrun, &mut report);
                clock::ticks_to_units(task_clock.since(start))
            });
            control.record_cost(cost);
            // The encoders' stand-in (QEMU), outside the measured step.
            drives.advance(control.last_feasible_lengths());
            // The answer to `Identify` (kept until it fits the transmit
            // queue), then the cycle's telemetry (best effort).
            identify |= control.take_identify();
            let mut queued = false;
            if identify {
                if let Ok(n) = encode(&DeviceMessage::Identity(robot::IDENTITY), &mut frame) {
                    identify = !serial::queue_frame(tx, &frame[..n]);
                    queued |= !identify;
                }
            }
            if let Some(telemetry) = &report.telemetry {
                if let Ok(n) = encode(&DeviceMessage::Telemetry(*telemetry), &mut frame) {
                    queued |= serial::queue_frame(tx, &frame[..n]);
                }
            }
            if queued {
                // Already running: it will find the new bytes.
                let _ = transmit::spawn();
            }
            // Logged by the idle loop.
            cx.local.changes.record(&report, control.counters());
            overrun = releases.next().await;
        }
    }
}
