//! The RTIC monotonic: TIM5 (32-bit, APB1) as a 1 kHz tick, its update
//! interrupt driving `rtic-time`'s timer queue.
//!
//! Why not rtic-monotonics' SysTick monotonic: under QEMU 7.2 with
//! `-icount shift=3,align=off,sleep=off` a SysTick expiry that falls while
//! the core sleeps in `wfi` is lost (measured: a loop released every 1 ms
//! by `delay_until` ran with 2.000 ms periods, each sleep swallowing one
//! tick; with a busy idle the periods were exact). QEMU's STM32 timer model
//! wakes the core on time, and on the board either timer would do.
//!
//! QEMU's timer model updates every `ARR` ticks instead of `ARR + 1`, so
//! its periods are 999 999 ns (1 ppm short); the board's are exact.
//!
//! The count only advances on update events (one per millisecond), so
//! `now()` has 1 ms resolution; the control loop's releases fall on these
//! ticks, so no timer interrupt lands inside a (sub-millisecond) step.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::NVIC;
use rtic_monotonics::fugit;
use rtic_monotonics::rtic_time::timer_queue::TimerQueue;
use rtic_monotonics::{TimerQueueBackend, TimerQueueBasedMonotonic};
use stm32f4::stm32f405::{interrupt, Interrupt, RCC, TIM5};

/// Ticks per second.
pub const TICK_HZ: u32 = 1_000;

static TICKS: AtomicU32 = AtomicU32::new(0);
static QUEUE: TimerQueue<Tim5Backend> = TimerQueue::new();

/// The timer-queue backend on TIM5.
pub struct Tim5Backend;

fn tim5() -> &'static stm32f4::stm32f405::tim5::RegisterBlock {
    // SAFETY: TIM5 is owned by this module after `Mono::start` (which
    // consumes the PAC's `TIM5`); only the status register is touched here.
    unsafe { &*TIM5::ptr() }
}

impl Tim5Backend {
    /// Counts a pending update event. Call with interrupts disabled.
    fn count_update() {
        let tim = tim5();
        if tim.sr().read().uif().bit_is_set() {
            tim.sr().write(|w| w.uif().clear_bit());
            TICKS.store(TICKS.load(Ordering::Relaxed).wrapping_add(1), Ordering::Relaxed);
        }
    }
}

impl TimerQueueBackend for Tim5Backend {
    type Ticks = u32;

    fn now() -> u32 {
        cortex_m::interrupt::free(|_| {
            Self::count_update();
            TICKS.load(Ordering::Relaxed)
        })
    }

    fn set_compare(_: u32) {
        // A tick interrupt comes every period anyway.
    }

    fn clear_compare_flag() {}

    fn pend_interrupt() {
        NVIC::pend(Interrupt::TIM5);
    }

    fn on_interrupt() {
        cortex_m::interrupt::free(|_| Self::count_update());
    }

    fn timer_queue() -> &'static TimerQueue<Self> {
        &QUEUE
    }
}

/// An instant of [`Mono`].
pub type Instant = fugit::MonotonicTimerInstantU32<{ TICK_HZ as u64 }>;

/// The monotonic the app's tasks use (`Mono::now()`, `Mono::delay_until()`).
pub struct Mono;

impl TimerQueueBasedMonotonic for Mono {
    type Backend = Tim5Backend;
    type Instant = Instant;
    type Duration = fugit::TimerDurationU32<{ TICK_HZ as u64 }>;
}

impl Mono {
    /// Starts TIM5 counting at `timer_hz / TICK_HZ` input clocks per tick
    /// and unmasks its interrupt at the highest priority (it touches no
    /// RTIC resource, only the timer queue, which takes critical sections).
    pub fn start(tim: TIM5, rcc: &RCC, timer_hz: u32) {
        rcc.apb1enr().modify(|_, w| w.tim5en().set_bit());
        let _ = rcc.apb1enr().read();
        tim.cr1().reset();
        tim.psc().write(|w| w.psc().set(0));
        tim.arr().write(|w| w.arr().set(timer_hz / TICK_HZ - 1));
        // PSC = 0 is also its reset value and ARPE = 0, so both apply at
        // once; no UG (QEMU's timer model mis-times the alarms after one).
        tim.sr().write(|w| w.uif().clear_bit());
        tim.dier().write(|w| w.uie().set_bit());
        QUEUE.initialize(Tim5Backend);
        tim.cr1().modify(|_, w| w.cen().set_bit());
        // SAFETY: the NVIC settings of TIM5 belong to this monotonic; RTIC
        // neither binds nor dispatches on TIM5.
        unsafe {
            let mut nvic: NVIC = core::mem::transmute(());
            nvic.set_priority(Interrupt::TIM5, 0);
            NVIC::unmask(Interrupt::TIM5);
        }
    }
}

#[interrupt]
fn TIM5() {
    // SAFETY: called only from the TIM5 interrupt.
    unsafe { QUEUE.on_monotonic_interrupt() };
}
