//! USART1, the host link: 460 800 baud 8N1 on the board (PA9 TX, PA10 RX);
//! QEMU's `netduinoplus2` connects it to its first `-serial` chardev and
//! ignores the baud rate.
//!
//! * Receive: the RXNE interrupt ([`Receiver::on_interrupt`]) moves each
//!   byte into a single-producer queue the control task drains, at most
//!   `cdpr_control::RECEIVE_BUDGET` bytes a cycle (so no input can make a
//!   step overrun). A byte that finds the queue full (or a hardware
//!   overrun) is dropped and counted ([`dropped`], reported in telemetry as
//!   `dropped_bytes`); the protocol's CRC and COBS framing then reject the
//!   frame it belonged to.
//! * Transmit: the control task queues whole telemetry frames; a
//!   low-priority task writes them byte by byte as TXE allows, so a slow
//!   line never delays the control loop.

use core::sync::atomic::{AtomicU32, Ordering};

use heapless::spsc::{Consumer, Producer};
use stm32f4::stm32f405::{usart1::RegisterBlock, RCC, USART1};

use crate::bsp;

/// Received bytes waiting for the control task.
pub const RX_QUEUE: usize = 1024;
/// Telemetry bytes waiting for the line.
pub const TX_QUEUE: usize = 2048;

/// Baud rate on the board: 460 800, which the common USB-serial bridges
/// (FTDI FT232R, Silicon Labs CP210x, WCH CH340) and the STM32's USART
/// (within 0.2 % at 84 MHz) both support; the link budget is in the
/// firmware README ("Link budget").
pub const BAUD: u32 = 460_800;

fn usart() -> &'static RegisterBlock {
    // SAFETY: USART1 is configured once in `init` and then used only through
    // this module: the receiver reads SR and DR (the receive data register),
    // the transmitter reads SR.TXE and writes DR (the transmit data
    // register); on the STM32 these are separate registers behind one
    // address, so the two sides do not interfere.
    unsafe { &*USART1::ptr() }
}

/// Enables USART1 (clock, pins on the board, 8N1, RX interrupt).
pub fn init(usart1: USART1, rcc: &RCC) {
    rcc.apb2enr().modify(|_, w| w.usart1en().set_bit());
    let _ = rcc.apb2enr().read();
    bsp::configure_usart_pins(rcc);
    // BRR = f_APB2 / baud with 4 fractional bits (oversampling by 16).
    let brr = ((bsp::APB2_HZ + BAUD / 2) / BAUD) as u16;
    // SAFETY: BRR takes any 16-bit divisor; this one is 182 (mantissa 11,
    // fraction 6: 461 538 baud at 84 MHz, 0.16 % fast).
    const _: () = assert!((bsp::APB2_HZ + BAUD / 2) / BAUD == 182);
    usart1.brr().write(|w| unsafe { w.bits(brr) });
    usart1.cr1().write(|w| w.ue().set_bit().te().set_bit().re().set_bit().rxneie().set_bit());
}

/// Received bytes dropped so far (queue full or hardware overrun); only
/// the USART1 interrupt adds to it.
static DROPPED: AtomicU32 = AtomicU32::new(0);

/// Received bytes dropped so far (wrapping).
pub fn dropped() -> u32 {
    DROPPED.load(Ordering::Relaxed)
}

fn count_dropped() {
    DROPPED.fetch_add(1, Ordering::Relaxed);
}

/// The receiving side, owned by the USART1 interrupt.
pub struct Receiver {
    queue: Producer<'static, u8>,
}

impl Receiver {
    /// Receives into `queue`.
    pub fn new(queue: Producer<'static, u8>) -> Self {
        Self { queue }
    }

    /// Moves every received byte into the queue.
    pub fn on_interrupt(&mut self) {
        let usart = usart();
        // Bounded: the data register holds one byte, so two passes suffice
        // to clear RXNE and a pending overrun.
        for _ in 0..2 {
            let sr = usart.sr().read();
            if sr.ore().is_overrun() {
                count_dropped();
            }
            if !(sr.rxne().is_data_ready() || sr.ore().is_overrun()) {
                break;
            }
            // Reading DR after SR clears RXNE and ORE.
            let byte = usart.dr().read().dr().bits() as u8;
            if self.queue.enqueue(byte).is_err() {
                count_dropped();
            }
        }
    }
}

/// The transmitting side: a queue of bytes and the line.
pub struct Transmitter {
    queue: Consumer<'static, u8>,
}

impl Transmitter {
    /// Transmits from `queue`.
    pub fn new(queue: Consumer<'static, u8>) -> Self {
        Self { queue }
    }

    /// Writes queued bytes while the line takes them; returns when the
    /// queue is empty.
    pub fn drain(&mut self) {
        let usart = usart();
        while let Some(byte) = self.queue.dequeue() {
            // The line takes a byte every 21.7 us at 460 800 baud; QEMU at once.
            while usart.sr().read().txe().bit_is_clear() {}
            usart.dr().write(|w| w.dr().set(u16::from(byte)));
        }
    }
}

/// Queues a whole frame for transmission, or nothing if it does not fit
/// (telemetry is best effort: a frame is dropped, never cut).
pub fn queue_frame(queue: &mut Producer<'static, u8>, frame: &[u8]) -> bool {
    if queue.capacity() - queue.len() < frame.len() {
        return false;
    }
    frame.iter().all(|&b| queue.enqueue(b).is_ok())
}
