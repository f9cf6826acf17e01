//! The product's control loop (default build): setpoints and commands from
//! the serial link, telemetry back, every millisecond until reset.

use cdpr_control::controller::Wrench;
use cdpr_control::{ControlLoop, TickCounter};
use cdpr_protocol::{encode, DeviceMessage, MAX_FRAME};
use heapless::spsc::{Consumer, Producer};
use rtic_monotonics::fugit::ExtU32;
use rtic_monotonics::Timebase;

use crate::board::{self, Drives, Tim2Counter};
use crate::mono::Mono;
use crate::serial::{self, RX_QUEUE};

/// Runs the loop; `wake_transmitter` is called after telemetry was queued.
pub async fn run(
    control: &mut ControlLoop,
    clock: &Tim2Counter,
    drives: &mut Drives,
    rx: &mut Consumer<'static, u8>,
    tx: &mut Producer<'static, u8>,
    wake_transmitter: impl Fn(),
) -> ! {
    defmt::println!(
        "{=str} cable robot: RTIC 2 on an STM32F405 at {=u32} MHz ({=str}); serial link on USART1, disabled until Enable",
        crate::robot::NAME,
        board::SYSCLK_HZ / 1_000_000,
        board::TARGET,
    );
    let mut frame = [0u8; MAX_FRAME];
    let mut overrun = false;
    let mut last_state = control.supervisor().state();
    let mut release = Mono::now() + 1.millis();
    Mono::delay_until(release).await;
    loop {
        let start = clock.ticks();
        board::feed_watchdog();
        // Bounded: the queue holds at most RX_QUEUE bytes.
        for _ in 0..RX_QUEUE {
            match rx.dequeue() {
                Some(byte) => control.receive_byte(byte),
                None => break,
            }
        }
        let report = control.step(clock, drives, &Wrench::zeros(), overrun);
        control.record_cost(board::ticks_to_units(clock.since(start)));
        if let Some(telemetry) = report.telemetry {
            if let Ok(n) = encode(&DeviceMessage::Telemetry(telemetry), &mut frame) {
                if serial::queue_frame(tx, &frame[..n]) {
                    wake_transmitter();
                }
            }
        }
        if report.state != last_state {
            let (stack, _) = board::stack_high_water();
            let (torques, brakes) = board::drive_outputs();
            defmt::println!(
                "cycle {=u32}: {} -> {} ({}); drives {} N m, brakes {=bool}; counters {}; stack high-water mark {=u32} bytes",
                report.cycle,
                last_state,
                report.state,
                report.reason,
                torques,
                brakes,
                control.counters(),
                stack
            );
            last_state = report.state;
        }
        let deadline = release + 1.millis();
        overrun = Mono::now() >= deadline;
        // After an overrun the next release is a whole period from now.
        release = if overrun { Mono::now() + 1.millis() } else { deadline };
        Mono::delay_until(release).await;
    }
}
