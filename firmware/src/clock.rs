//! TIM2 as the tick counter that times code, its calibration against a
//! loop of known length, and the conversion of ticks to the board's unit
//! (instructions under QEMU, core cycles on the board: see [`crate::bsp`]).

use cdpr_control::TickCounter;
use stm32f4::stm32f405::{RCC, TIM2};

use crate::bsp;

/// Converts TIM2 ticks to [`bsp::UNIT`]s (rounded to nearest).
pub fn ticks_to_units(ticks: u32) -> u32 {
    let (num, den) = bsp::TICKS_PER_UNIT;
    ((u64::from(ticks) * den + num / 2) / num) as u32
}

/// TIM2's count, for code that cannot hold the [`Tim2Counter`] (the
/// receive interrupt times itself with it); 0 before [`Tim2Counter::start`].
#[inline(always)]
pub fn ticks_now() -> u32 {
    // SAFETY: a read of TIM2's counter register, which has no side effect;
    // the one writer (`Tim2Counter::start`) runs in `init`, before any
    // interrupt is enabled.
    unsafe { (*TIM2::ptr()).cnt().read().bits() }
}

/// TIM2 as a free-running 32-bit up-counter, prescaler 0.
pub struct Tim2Counter {
    tim: TIM2,
}

impl Tim2Counter {
    /// Enables TIM2's clock and starts it counting from 0 over the full
    /// 32-bit range.
    pub fn start(tim: TIM2, rcc: &RCC) -> Self {
        rcc.apb1enr().modify(|_, w| w.tim2en().set_bit());
        // Read back: the clock must be on before TIM2 is touched (RM0090 errata).
        let _ = rcc.apb1enr().read();
        tim.cr1().reset();
        tim.psc().write(|w| w.psc().set(0));
        tim.arr().write(|w| w.arr().set(u32::MAX));
        tim.cnt().write(|w| w.cnt().set(0));
        // PSC = 0 is its reset value, so no UG is needed to load it.
        tim.cr1().modify(|_, w| w.cen().set_bit());
        Self { tim }
    }
}

impl TickCounter for Tim2Counter {
    #[inline(always)]
    fn ticks(&self) -> u32 {
        self.tim.cnt().read().bits()
    }
}

/// Runs `subs; bne` `n` times: exactly `2 n` instructions. Returns the ticks.
#[inline(never)]
fn timed_loop(clock: &impl TickCounter, n: u32) -> u32 {
    let start = clock.ticks();
    // SAFETY: only a register the asm owns is touched.
    unsafe {
        core::arch::asm!(
            "2:",
            "subs {n}, {n}, #1",
            "bne 2b",
            n = inout(reg) n => _,
            options(nomem, nostack),
        );
    }
    clock.since(start)
}

/// Instructions in the difference of the two calibration loops.
pub const CALIBRATION_INSTRUCTIONS: u32 = 2 * 10_000;

/// TIM2 ticks for exactly [`CALIBRATION_INSTRUCTIONS`] instructions: the
/// difference of a 11000- and a 1000-iteration loop, so that the overhead
/// of reading the timer cancels. Run with interrupts off.
pub fn calibrate(clock: &impl TickCounter) -> u32 {
    cortex_m::interrupt::free(|_| {
        let short = timed_loop(clock, 1_000);
        let long = timed_loop(clock, 11_000);
        long.wrapping_sub(short)
    })
}

/// The ticks [`calibrate`] should measure where one unit is one
/// instruction ([`bsp::EXACT_UNITS`]).
pub fn expected_calibration_ticks() -> u64 {
    let (num, den) = bsp::TICKS_PER_UNIT;
    u64::from(CALIBRATION_INSTRUCTIONS) * num / den
}
