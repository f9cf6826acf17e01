//! The board's two CAN controllers (bxCAN) as the drive layer's ports
//! (`canopen_drives::CanPort`), and the emergency stop's frames written
//! straight into their mailboxes (`board` feature).
//!
//! * **Pins:** CAN1 on PB8 (RX) / PB9 (TX), CAN2 on PB12 (RX) / PB13 (TX),
//!   alternate function 9, each to a 3.3 V transceiver (e.g. SN65HVD230);
//! * **Bit timing:** 1 Mbit/s from APB1's 42 MHz: prescaler 3 (14 MHz time
//!   quanta), 1 + 11 + 2 quanta a bit, sample point 85.7 %, SJW 1 (CiA 301's
//!   recommendation is 87.5 %; 85.7 % is the nearest at 14 quanta);
//! * **Order:** transmit FIFO priority (`TXFP`): the mailboxes go out in
//!   the order they were filled, so the cycle's SYNC follows its RPDOs (and
//!   `bxcan` takes a frame into a mailbox only ahead of lower-priority
//!   ones, so a cycle's RPDOs go one mailbox at a time, each loaded by the
//!   previous one's transmit interrupt);
//!   automatic bus-off management off (a bus-off stays until `ClearFault`
//!   restarts the drives: the layer reports it as `bus-off`);
//! * **Queues:** the control task's frames go into a queue the CAN TX
//!   interrupt moves into the mailboxes ([`CanIrq::on_transmit`]); the RX
//!   interrupt moves received frames into a queue the control task reads
//!   ([`CanIrq::on_receive`]): a cycle's 4 positions, heartbeats and
//!   statuswords never wait on the 3-frame hardware FIFO.

use bxcan::{Fifo, Frame};
use canopen_drives::{CanPort, RawFrame};
use cortex_m::peripheral::NVIC;
use heapless::spsc::{Consumer, Producer};
use stm32f4::stm32f405::{can1::RegisterBlock, Interrupt, CAN1, CAN2, GPIOB, RCC};

/// Frames each queue holds.
pub const QUEUE: usize = 32;

/// CAN1 (owns the filter banks; CAN2's start at [`CAN2_FIRST_BANK`]).
pub struct Can1;
/// CAN2.
pub struct Can2;

/// The filter bank CAN2's filters start at.
pub const CAN2_FIRST_BANK: u8 = 14;

// SAFETY: `Can1` is created once, in `start`, from the owned `CAN1`
// peripheral; its registers are at `CAN1::ptr()`.
unsafe impl bxcan::Instance for Can1 {
    const REGISTERS: *mut bxcan::RegisterBlock = CAN1::ptr() as *mut _;
}
// SAFETY: CAN1 has the 28 filter banks of the STM32F405 (RM0090 32.7.4).
unsafe impl bxcan::FilterOwner for Can1 {
    const NUM_FILTER_BANKS: u8 = 28;
}
// SAFETY: CAN2 is CAN1's slave on this chip.
unsafe impl bxcan::MasterInstance for Can1 {}
// SAFETY: as for `Can1`, at `CAN2::ptr()`.
unsafe impl bxcan::Instance for Can2 {
    const REGISTERS: *mut bxcan::RegisterBlock = CAN2::ptr() as *mut _;
}

/// Which controller.
pub trait Controller: bxcan::Instance {
    /// Its registers (for what bxcan does not offer: bus-off, `TXFP`, the
    /// emergency stop's raw writes).
    fn registers() -> &'static RegisterBlock;
    /// Its transmit interrupt.
    const TX_INTERRUPT: Interrupt;
    /// Bus number in the drive layer (0 CAN1, 1 CAN2).
    const BUS: u8;
}

impl Controller for Can1 {
    fn registers() -> &'static RegisterBlock {
        // SAFETY: a shared reference to memory-mapped registers that live
        // for the program; reads and the writes below are single accesses.
        unsafe { &*CAN1::ptr() }
    }
    const TX_INTERRUPT: Interrupt = Interrupt::CAN1_TX;
    const BUS: u8 = 0;
}

impl Controller for Can2 {
    fn registers() -> &'static RegisterBlock {
        // SAFETY: as for CAN1.
        unsafe { &*CAN2::ptr() }
    }
    const TX_INTERRUPT: Interrupt = Interrupt::CAN2_TX;
    const BUS: u8 = 1;
}

/// `CAN_BTR` for 1 Mbit/s at 42 MHz: BRP 3, TS1 11, TS2 2, SJW 1.
pub const BTR_1MBIT: u32 = (1 << 20) | (10 << 16) | 2;

/// The control task's side of one controller.
pub struct BoardPort<C: Controller> {
    tx: Producer<'static, Frame>,
    rx: Consumer<'static, Frame>,
    _controller: core::marker::PhantomData<C>,
}

/// The interrupts' side of one controller.
pub struct CanIrq<C: Controller> {
    can: bxcan::Can<C>,
    tx: Consumer<'static, Frame>,
    rx: Producer<'static, Frame>,
    /// Frames lost: the hardware FIFO overran, or the queue was full.
    pub lost: u32,
}

/// Why the port failed (only receive overruns are reported).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PortError;

impl embedded_can::Error for PortError {
    fn kind(&self) -> embedded_can::ErrorKind {
        embedded_can::ErrorKind::Overrun
    }
}

impl<C: Controller> embedded_can::nb::Can for BoardPort<C> {
    type Frame = Frame;
    type Error = PortError;

    /// Queues `frame` and lets the transmit interrupt load it.
    fn transmit(&mut self, frame: &Frame) -> nb::Result<Option<Frame>, PortError> {
        self.tx.enqueue(frame.clone()).map_err(|_| nb::Error::WouldBlock)?;
        NVIC::pend(C::TX_INTERRUPT);
        Ok(None)
    }

    fn receive(&mut self) -> nb::Result<Frame, PortError> {
        self.rx.dequeue().ok_or(nb::Error::WouldBlock)
    }
}

impl<C: Controller> CanPort for BoardPort<C> {
    fn is_bus_off(&mut self) -> bool {
        C::registers().esr().read().boff().bit_is_set()
    }
}

impl<C: Controller> CanIrq<C> {
    /// The transmit interrupt (a mailbox emptied, or the control task
    /// queued frames): loads the queue's frames into free mailboxes, in
    /// order. `bxcan` refuses a frame whose identifier is not below every
    /// pending one's (it keeps priority order for controllers without
    /// `TXFP`): such a frame stays at the queue's head until the mailbox
    /// ahead of it has gone out (the next interrupt), so nothing is lost and
    /// the order holds.
    pub fn on_transmit(&mut self) {
        self.can.clear_tx_interrupt();
        // At most the three mailboxes per call: bounded.
        for _ in 0..3 {
            let Some(frame) = self.tx.peek() else { break };
            match self.can.transmit(frame) {
                Ok(_) => {
                    let _ = self.tx.dequeue();
                }
                Err(nb::Error::WouldBlock) => break,
                Err(nb::Error::Other(never)) => match never {},
            }
        }
    }

    /// The receive interrupt: every waiting frame into the queue (a FIFO
    /// holds 3: bounded).
    pub fn on_receive(&mut self) {
        for _ in 0..3 {
            match self.can.receive() {
                Ok(frame) => {
                    if self.rx.enqueue(frame).is_err() {
                        self.lost = self.lost.wrapping_add(1);
                    }
                }
                Err(nb::Error::Other(_)) => self.lost = self.lost.wrapping_add(1),
                Err(nb::Error::WouldBlock) => break,
            }
        }
    }
}

/// Both controllers' queues (statics the caller owns, as RTIC's `init`
/// locals).
pub struct Queues {
    /// CAN1 transmit.
    pub tx1: &'static mut heapless::spsc::Queue<Frame, QUEUE>,
    /// CAN1 receive.
    pub rx1: &'static mut heapless::spsc::Queue<Frame, QUEUE>,
    /// CAN2 transmit.
    pub tx2: &'static mut heapless::spsc::Queue<Frame, QUEUE>,
    /// CAN2 receive.
    pub rx2: &'static mut heapless::spsc::Queue<Frame, QUEUE>,
}

/// The two ports and their interrupt sides.
pub type Started = ((BoardPort<Can1>, BoardPort<Can2>), (CanIrq<Can1>, CanIrq<Can2>));

/// Clocks, pins, bit timing, filters (everything into FIFO 0) and
/// interrupts of CAN1 and CAN2; both controllers on the bus.
pub fn start(_can1: CAN1, _can2: CAN2, rcc: &RCC, queues: Queues) -> Started {
    rcc.apb1enr().modify(|_, w| w.can1en().set_bit().can2en().set_bit());
    rcc.ahb1enr().modify(|_, w| w.gpioben().set_bit());
    let _ = rcc.apb1enr().read();
    // SAFETY: only PB8, PB9, PB12 and PB13's fields are modified; no other
    // code uses GPIOB.
    let gpiob = unsafe { &*GPIOB::ptr() };
    gpiob.moder().modify(|_, w| {
        w.moder8().alternate().moder9().alternate().moder12().alternate().moder13().alternate()
    });
    gpiob.afrh().modify(|_, w| w.afrh8().af9().afrh9().af9().afrh12().af9().afrh13().af9());

    let mut can1 =
        bxcan::Can::builder(Can1).set_bit_timing(BTR_1MBIT).set_automatic_retransmit(true).leave_disabled();
    {
        let mut filters = can1.modify_filters();
        filters.set_split(CAN2_FIRST_BANK);
        filters.enable_bank(0, Fifo::Fifo0, bxcan::filter::Mask32::accept_all());
        filters.slave_filters().enable_bank(
            CAN2_FIRST_BANK,
            Fifo::Fifo0,
            bxcan::filter::Mask32::accept_all(),
        );
    }
    let mut can2 =
        bxcan::Can::builder(Can2).set_bit_timing(BTR_1MBIT).set_automatic_retransmit(true).leave_disabled();
    for regs in [Can1::registers(), Can2::registers()] {
        // Mailboxes in request order; no automatic bus-off recovery.
        regs.mcr().modify(|_, w| w.txfp().set_bit().abom().clear_bit());
    }
    can1.enable_interrupts(
        bxcan::Interrupts::TRANSMIT_MAILBOX_EMPTY | bxcan::Interrupts::FIFO0_MESSAGE_PENDING,
    );
    can2.enable_interrupts(
        bxcan::Interrupts::TRANSMIT_MAILBOX_EMPTY | bxcan::Interrupts::FIFO0_MESSAGE_PENDING,
    );
    let _ = can1.enable_non_blocking();
    let _ = can2.enable_non_blocking();

    let (tx1p, tx1c) = queues.tx1.split();
    let (rx1p, rx1c) = queues.rx1.split();
    let (tx2p, tx2c) = queues.tx2.split();
    let (rx2p, rx2c) = queues.rx2.split();
    (
        (
            BoardPort { tx: tx1p, rx: rx1c, _controller: core::marker::PhantomData },
            BoardPort { tx: tx2p, rx: rx2c, _controller: core::marker::PhantomData },
        ),
        (
            CanIrq { can: can1, tx: tx1c, rx: rx1p, lost: 0 },
            CanIrq { can: can2, tx: tx2c, rx: rx2p, lost: 0 },
        ),
    )
}

/// The emergency stop on both buses, best effort (from the panic and
/// HardFault handlers: no lock, no queue): aborts what the mailboxes hold,
/// then writes `canopen_drives::emergency_frames` (quick stop and zero
/// torque per drive, SYNC, NMT pre-operational to all) into the mailboxes,
/// waiting at most [`STOP_SPIN`] polls for each to free.
pub fn emergency_stop(configs: &[canopen_drives::DriveConfig]) {
    for (bus, regs) in [(0u8, Can1::registers()), (1u8, Can2::registers())] {
        regs.tsr().write(|w| w.abrq0().set_bit().abrq1().set_bit().abrq2().set_bit());
        let mut frames = [RawFrame::new(0, &[]); 16];
        let n = canopen_drives::emergency_frames(configs, bus, &mut frames);
        for f in &frames[..n] {
            write_mailbox(regs, f);
        }
    }
}

/// Polls for a free mailbox per frame, at most this many (about 1 ms at
/// 168 MHz: a 2-byte frame takes 75 us at 1 Mbit/s).
pub const STOP_SPIN: u32 = 40_000;

fn write_mailbox(regs: &RegisterBlock, f: &RawFrame) {
    for _ in 0..STOP_SPIN {
        let tsr = regs.tsr().read();
        let free = [tsr.tme0().bit_is_set(), tsr.tme1().bit_is_set(), tsr.tme2().bit_is_set()];
        if let Some(m) = free.iter().position(|&e| e) {
            let mb = regs.tx(m);
            let d = f.data;
            // SAFETY: raw values of the mailbox registers (RM0090 32.9.3):
            // DLC 0..=8, the data bytes, the 11-bit id at STID with TXRQ.
            unsafe {
                mb.tdtr().write(|w| w.bits(u32::from(f.len.min(8))));
                mb.tdlr().write(|w| w.bits(u32::from_le_bytes([d[0], d[1], d[2], d[3]])));
                mb.tdhr().write(|w| w.bits(u32::from_le_bytes([d[4], d[5], d[6], d[7]])));
                mb.tir().write(|w| w.bits((u32::from(f.id) << 21) | 1));
            }
            return;
        }
    }
}
