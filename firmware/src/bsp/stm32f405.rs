//! A real STM32F405 board: HSE 8 MHz -> PLL -> 168 MHz, the IWDG, USART1
//! on PA9/PA10, defmt over RTT (probe-rs).

use stm32f4::stm32f405::{FLASH, GPIOA, IWDG, RCC};

use defmt_rtt as _; // defmt over RTT (probe-rs)

/// Core clock (SYSCLK, HCLK), Hz, as [`configure_clocks`] sets it.
pub const SYSCLK_HZ: u32 = 168_000_000;

/// Input clock of the APB1 timers (TIM2, TIM5), Hz: APB1 = 42 MHz, and the
/// timers run at twice a divided APB clock.
pub const TIMER_HZ: u64 = 84_000_000;

/// USART1's clock (APB2 = SYSCLK / 2), Hz.
pub const APB2_HZ: u32 = 84_000_000;

/// HSE crystal of the board, Hz (8 MHz assumed; `PLLM` follows it).
pub const HSE_HZ: u32 = 8_000_000;

/// Independent watchdog timeout, ms: a little over 20 control periods, so
/// a stuck control task resets the chip (which comes up Disabled, brakes on).
pub const WATCHDOG_MS: u32 = 20;

/// Where this build runs.
pub const TARGET: &str = "board build: HSE + PLL";

/// What one converted tick unit is: core clock cycles.
pub const UNIT: &str = "cycles";

/// TIM2 ticks for one core cycle: `f_timer / f_core`.
pub const TICKS_PER_UNIT: (u64, u64) = (TIMER_HZ, SYSCLK_HZ as u64);

/// Cycles per instruction vary (flash wait states, branches): the timer
/// calibration is reported, not checked.
pub const EXACT_UNITS: bool = false;

/// HSE -> PLL -> 168 MHz SYSCLK, AHB 168 MHz, APB1 42 MHz (timers 84 MHz),
/// APB2 84 MHz, 48 MHz for USB, 5 flash wait states.
pub fn configure_clocks(rcc: &RCC, flash: &FLASH) {
    rcc.cr().modify(|_, w| w.hseon().set_bit());
    while rcc.cr().read().hserdy().bit_is_clear() {}
    // VCO in = HSE / M = 1 MHz, VCO out = x N = 336 MHz, SYSCLK = / P = 168 MHz,
    // USB = / Q = 48 MHz.
    // SAFETY: `bits` writes raw field values; M = 8, N = 336 and Q = 7 are
    // within the ranges RM0090 allows (M 2..=63, N 50..=432, Q 2..=15).
    rcc.pllcfgr().write(|w| unsafe {
        w.pllsrc().hse();
        w.pllm().bits((HSE_HZ / 1_000_000) as u8);
        w.plln().bits(336);
        w.pllp().div2();
        w.pllq().bits(7)
    });
    rcc.cr().modify(|_, w| w.pllon().set_bit());
    flash.acr().modify(|_, w| {
        w.latency().ws5();
        w.prften().set_bit();
        w.icen().set_bit();
        w.dcen().set_bit()
    });
    while flash.acr().read().latency().bits() != 5 {}
    rcc.cfgr().modify(|_, w| {
        w.hpre().div1();
        w.ppre1().div4();
        w.ppre2().div2()
    });
    while rcc.cr().read().pllrdy().bit_is_clear() {}
    rcc.cfgr().modify(|_, w| w.sw().pll());
    while !rcc.cfgr().read().sws().is_pll() {}
}

/// PA9 (TX) and PA10 (RX) in alternate function 7 (USART1).
pub fn configure_usart_pins(rcc: &RCC) {
    rcc.ahb1enr().modify(|_, w| w.gpioaen().set_bit());
    let _ = rcc.ahb1enr().read();
    // SAFETY: only PA9/PA10's fields are modified; no other code uses GPIOA.
    let gpioa = unsafe { &*GPIOA::ptr() };
    gpioa.moder().modify(|_, w| w.moder9().alternate().moder10().alternate());
    gpioa.afrh().modify(|_, w| w.afrh9().af7().afrh10().af7());
}

/// Starts the IWDG (LSI 32 kHz / 32 = 1 kHz count, reload [`WATCHDOG_MS`]).
pub fn start_watchdog(iwdg: &IWDG) {
    iwdg.kr().write(|w| w.key().unlock());
    iwdg.pr().write(|w| w.pr().divide_by32());
    iwdg.rlr().write(|w| w.rl().set(WATCHDOG_MS as u16));
    iwdg.kr().write(|w| w.key().start());
}

/// Reloads the IWDG.
#[inline(always)]
pub fn feed_watchdog() {
    // SAFETY: a write of the reload key to IWDG_KR, which only this
    // function writes after start-up.
    let iwdg = unsafe { &*IWDG::ptr() };
    iwdg.kr().write(|w| w.key().feed());
}

/// Runs `step` (the product's control step) as it is: the receive
/// interrupt must run during it (a byte every 21.7 us at 460 800 baud into
/// a one-byte data register, and a step of about 80 us), so nothing is
/// held off; the task clock takes the interrupts' time out of the step's
/// figure ([`crate::serial::TaskClock`]).
#[inline(always)]
pub fn with_receive_held<R>(step: impl FnOnce() -> R) -> R {
    step()
}

/// Waits for the watchdog (or a debugger): a board has no one to return
/// an exit code to. The caller has stopped the motors.
pub fn exit(_code: i32) -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}
