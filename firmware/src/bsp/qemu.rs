//! QEMU's `netduinoplus2` (STM32F405, Cortex-M4) under
//! `-icount shift=3,align=off,sleep=off`: every instruction advances
//! virtual time by 8 ns. QEMU models no RCC, IWDG or GPIO, so the bring-up
//! functions do nothing; defmt goes out over semihosting, and [`exit`]'s
//! code reaches the shell.

use stm32f4::stm32f405::{FLASH, IWDG, RCC};

use defmt_semihosting as _; // defmt over semihosting (qemu-run decodes it)

/// Core clock (SYSCLK, HCLK), Hz: what QEMU models for the core and SysTick.
pub const SYSCLK_HZ: u32 = 168_000_000;

/// Input clock of the APB1 timers (TIM2, TIM5), Hz: QEMU's STM32 timer
/// model counts at a fixed 1 GHz of virtual time.
pub const TIMER_HZ: u64 = 1_000_000_000;

/// USART1's clock (APB2), Hz: the board's figure; QEMU ignores the baud
/// rate, so the divisor written from it has no effect here.
pub const APB2_HZ: u32 = 84_000_000;

/// Where this build runs.
pub const TARGET: &str = "QEMU netduinoplus2 under -icount: instructions counted exactly";

/// What one converted tick unit is: instructions (exact, from the icount
/// relation).
pub const UNIT: &str = "instructions";

/// TIM2 ticks for one [`UNIT`], as a fraction `(numerator, denominator)`:
/// `instructions = ticks x 1e9 / (f_timer x 2^shift)` (EMBEDDED-NOTES), so
/// one instruction is `f_timer 2^shift / 1e9` ticks (8 at 1 GHz, shift 3).
pub const TICKS_PER_UNIT: (u64, u64) = (TIMER_HZ << cdpr_demo::qemu::ICOUNT_SHIFT, 1_000_000_000);

/// The icount relation is exact: a loop of known length must take exactly
/// its instructions' ticks (within 1 %).
pub const EXACT_UNITS: bool = true;

/// Nothing: QEMU does not model the RCC (waiting for the PLL's ready bit
/// would hang).
pub fn configure_clocks(_: &RCC, _: &FLASH) {}

/// Nothing: QEMU connects USART1 to its first `-serial` chardev without pins.
pub fn configure_usart_pins(_: &RCC) {}

/// Nothing: QEMU 7.2's `netduinoplus2` does not model the IWDG.
pub fn start_watchdog(_: &IWDG) {}

/// Nothing (no watchdog).
#[inline(always)]
pub fn feed_watchdog() {}

/// Runs `step` (the product's control step) with USART1's receive
/// interrupt held off, then lets it in. Nothing is lost: QEMU's USART
/// takes the next byte from its chardev only once the last one was read
/// (RXNE clear), so the bytes wait in the chardev. And the step's
/// instruction count is then its own: under `-icount` each byte interrupt
/// taken inside a timed span moved the task clock's figure
/// ([`crate::serial::TaskClock`]) by about -5 to +3 instructions, as
/// measured, depending on the code it interrupted (QEMU's asynchronous
/// delivery; a known loop came out short, the step long), and QEMU
/// delivers a backlog back to back: the product's first solve on IPAnema 1
/// met up to 1 518 of them in one step and reported 17 275 for 12 700 of
/// its own (issue 17, session 34).
#[inline(always)]
pub fn with_receive_held<R>(step: impl FnOnce() -> R) -> R {
    use cortex_m::peripheral::NVIC;
    use stm32f4::stm32f405::Interrupt;
    NVIC::mask(Interrupt::USART1);
    let result = step();
    // SAFETY: USART1's handler (the RTIC task bound to it) was unmasked
    // before this call and only takes bytes into its own queue; unmasking
    // restores that.
    unsafe { NVIC::unmask(Interrupt::USART1) };
    result
}

/// Ends QEMU with `code` as its exit status (semihosting).
pub fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}
