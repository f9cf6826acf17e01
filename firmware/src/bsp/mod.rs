//! Board support: one module per board with the same items, chosen here
//! and nowhere else (the `board` feature selects the real STM32F405, its
//! absence QEMU's `netduinoplus2`).
//!
//! Every board module provides:
//! * clock frequencies: [`SYSCLK_HZ`] (core), [`TIMER_HZ`] (the APB1 timers
//!   TIM2 and TIM5), [`APB2_HZ`] (USART1);
//! * what a converted TIM2 tick is: [`UNIT`], [`TICKS_PER_UNIT`], and
//!   whether the timer calibration must match it exactly ([`EXACT_UNITS`]);
//! * [`TARGET`], a line naming where the build runs;
//! * the bring-up the board needs: [`configure_clocks`],
//!   [`configure_usart_pins`], [`start_watchdog`], [`feed_watchdog`];
//! * [`with_receive_held`]: whether the product's step may hold the receive
//!   interrupt off (QEMU, whose USART waits for the byte to be read) or
//!   must let it run (the board);
//! * [`exit`], the end of a program, and the defmt global logger.

#[cfg(not(feature = "board"))]
mod qemu;
#[cfg(not(feature = "board"))]
pub use qemu::*;

#[cfg(feature = "board")]
mod stm32f405;
#[cfg(feature = "board")]
pub use stm32f405::*;
