//! USART1, the host link: 460 800 baud 8N1 on the board (PA9 TX, PA10 RX);
//! QEMU's `netduinoplus2` connects it to its first `-serial` chardev and
//! ignores the baud rate.
//!
//! * Receive: the RXNE interrupt ([`Receiver::on_interrupt`]) takes each
//!   byte into a [`FrameDecoder`] (COBS undone as the bytes arrive) and at
//!   each delimiter queues the [`LineFrame`] for the control task, which
//!   checks and decodes at most `cdpr_control::FRAME_BUDGET` frames a
//!   cycle (so no input can make a step overrun, and the byte-by-byte work
//!   happens as the bytes arrive, not in the control step). A frame that
//!   finds the queue full is dropped with its bytes counted, as is a
//!   hardware overrun ([`dropped`], reported in telemetry as
//!   `dropped_bytes`); the protocol's CRC and COBS framing then reject the
//!   frame a lost byte belonged to.
//! * Transmit: the control task queues whole telemetry frames; a
//!   low-priority task writes them byte by byte as TXE allows, so a slow
//!   line never delays the control loop.

use core::sync::atomic::{AtomicU32, Ordering};

use cdpr_protocol::{FrameDecoder, LineFrame};
use heapless::spsc::{Consumer, Producer};
use stm32f4::stm32f405::{usart1::RegisterBlock, RCC, USART1};

use crate::bsp;

/// Reassembled frames waiting for the control task: `LineFrame`s of
/// 212 bytes each, so the queue takes about 13 KiB of RAM.
pub const RX_QUEUE: usize = 64;
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

/// TIM2 ticks spent in the USART1 interrupt's body so far (wrapping):
/// [`TaskClock`] takes them out of the control task's time, so that the
/// step's reported cost is its own work (the interrupt's is bounded
/// apart: the demo's receive flood measures its worst byte).
static INTERRUPT_TICKS: AtomicU32 = AtomicU32::new(0);

/// USART1 interrupts taken so far (wrapping): each also costs its entry
/// and exit outside the body's ticks ([`calibrate_entry_exit`]).
static INTERRUPTS: AtomicU32 = AtomicU32::new(0);

/// The interrupt's running totals and TIM2's count, read together with
/// interrupts masked (a few instructions), so that no interrupt falls
/// between the reads.
#[derive(Debug, Clone, Copy)]
struct Snapshot {
    now: u32,
    body: u32,
    count: u32,
}

impl Snapshot {
    fn take() -> Self {
        cortex_m::interrupt::free(|_| Self {
            now: crate::clock::ticks_now(),
            body: INTERRUPT_TICKS.load(Ordering::Relaxed),
            count: INTERRUPTS.load(Ordering::Relaxed),
        })
    }
}

/// TIM2 with the receive interrupt's time taken out: the control task's
/// own ticks, for its step (the product does not time the step's phases).
/// Each reading is TIM2's
/// count less the interrupt's bodies so far and `entry_exit` ticks per
/// interrupt (the hardware's entry and exit and the handler's code around
/// the measured body, [`calibrate_entry_exit`]); the difference of two
/// readings is the task's work between them, whatever the interrupt did.
///
/// The three counts are read in one critical section ([`Snapshot`]).
/// Read one after the other, as the step's timing did before (issue 17,
/// session 27), a burst of received bytes landing between the reads
/// counted on one side of the subtraction only: QEMU delivers a backlog
/// of bytes back to back, so one such gap held up to hundreds of
/// interrupts, and the product's streamed step reported up to 20 418
/// instructions for 10 500 of its own (a telemetry `step_cost` that
/// depended on how the host's frames bunched). Under QEMU the product's
/// step now holds the interrupt off altogether ([`crate::bsp::with_receive_held`]):
/// there each interrupt taken inside a timed span still moved the result
/// by about -5 to +3 instructions (QEMU's asynchronous delivery under
/// `-icount`, whatever this clock subtracts), which a backlog of bytes made
/// thousands. On the board, where the interrupt must run, this clock takes
/// its time out.
#[derive(Debug, Clone, Copy)]
pub struct TaskClock {
    entry_exit: u32,
}

impl TaskClock {
    /// The task's clock, with `entry_exit` from [`calibrate_entry_exit`].
    pub fn new(entry_exit: u32) -> Self {
        Self { entry_exit }
    }
}

impl cdpr_control::TickCounter for TaskClock {
    fn ticks(&self) -> u32 {
        let Snapshot { now, body, count } = Snapshot::take();
        now.wrapping_sub(body).wrapping_sub(count.wrapping_mul(self.entry_exit))
    }
}

/// The TIM2 ticks one USART1 interrupt costs outside its measured body
/// (exception entry and exit, the handler's prologue and epilogue, the
/// body's own bookkeeping), measured: the smallest over a few trials of
/// the span around a pended interrupt, less the body's ticks, less the
/// same span around a pended interrupt that is masked (so never taken,
/// the same instructions otherwise). A trial a received byte interrupts
/// is discarded; 0 if every trial was (the step then reports a little
/// more than its own work, never less).
///
/// Call from a context the USART1 interrupt preempts (the control task),
/// after it is unmasked.
pub fn calibrate_entry_exit() -> u32 {
    use cortex_m::peripheral::NVIC;
    use stm32f4::stm32f405::Interrupt;
    // An interrupt the firmware never unmasks: pending it runs nothing.
    const IDLE: Interrupt = Interrupt::UART4;
    let span = |irq: Interrupt| {
        let before = Snapshot::take();
        NVIC::pend(irq);
        cortex_m::asm::dsb();
        cortex_m::asm::isb();
        let after = Snapshot::take();
        NVIC::unpend(IDLE);
        (
            after.now.wrapping_sub(before.now),
            after.count.wrapping_sub(before.count),
            after.body.wrapping_sub(before.body),
        )
    };
    let mut idle = u32::MAX;
    let mut taken = u32::MAX;
    for _ in 0..4 {
        let (ticks, count, _) = span(IDLE);
        if count == 0 {
            idle = idle.min(ticks);
        }
        let (ticks, count, body) = span(Interrupt::USART1);
        if count == 1 {
            taken = taken.min(ticks.saturating_sub(body));
        }
    }
    if idle == u32::MAX || taken == u32::MAX {
        return 0;
    }
    taken.saturating_sub(idle)
}

/// Received bytes dropped so far (queue full or hardware overrun); only
/// the USART1 interrupt adds to it.
static DROPPED: AtomicU32 = AtomicU32::new(0);

/// Received bytes dropped so far (wrapping).
pub fn dropped() -> u32 {
    DROPPED.load(Ordering::Relaxed)
}

fn count_dropped(bytes: usize) {
    DROPPED.fetch_add(bytes as u32, Ordering::Relaxed);
}

/// The receiving side, owned by the USART1 interrupt.
pub struct Receiver {
    decoder: FrameDecoder,
    queue: Producer<'static, LineFrame>,
}

impl Receiver {
    /// Receives into `queue`.
    pub fn new(queue: Producer<'static, LineFrame>) -> Self {
        Self { decoder: FrameDecoder::new(), queue }
    }

    /// Takes every received byte; queues the frame a delimiter ends.
    pub fn on_interrupt(&mut self) {
        let start = crate::clock::ticks_now();
        self.receive();
        INTERRUPTS.fetch_add(1, Ordering::Relaxed);
        let spent = crate::clock::ticks_now().wrapping_sub(start);
        INTERRUPT_TICKS.fetch_add(spent, Ordering::Relaxed);
    }

    fn receive(&mut self) {
        let usart = usart();
        // Bounded: the data register holds one byte, so two passes suffice
        // to clear RXNE and a pending overrun.
        for _ in 0..2 {
            let sr = usart.sr().read();
            if sr.ore().is_overrun() {
                count_dropped(1);
            }
            if !(sr.rxne().is_data_ready() || sr.ore().is_overrun()) {
                break;
            }
            // Reading DR after SR clears RXNE and ORE.
            let byte = usart.dr().read().dr().bits() as u8;
            self.take(byte);
        }
    }

    /// One byte into the decoder; at a delimiter, the frame into the queue.
    pub fn take(&mut self, byte: u8) {
        if !self.decoder.push_byte(byte) {
            return;
        }
        let bytes = self.decoder.pending() + 1;
        if let Some(frame) = self.decoder.finish_line() {
            if self.queue.enqueue(frame).is_err() {
                count_dropped(bytes);
            }
        }
    }
}

/// The control task's end of the receive queue, as the control loop's
/// [`cdpr_control::FrameSource`]: frames are read in the queue and then
/// dropped (no copy of a 212-byte frame).
pub struct FrameQueue(pub Consumer<'static, LineFrame>);

impl cdpr_control::FrameSource for FrameQueue {
    fn peek(&mut self) -> Option<&LineFrame> {
        self.0.peek()
    }

    fn pop(&mut self) {
        let _ = self.0.dequeue();
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
