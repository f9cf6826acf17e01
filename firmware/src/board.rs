//! The STM32F405 side: clocks, the TIM2 tick counter, the winch drives,
//! the independent watchdog, stack painting, the emergency stop and the
//! conversion of timer ticks to instructions (QEMU) or cycles (board).

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use cdpr_control::{TickCounter, WinchDrives, CABLES};
use stm32f4::stm32f405::{RCC, TIM2};

/// Core clock (SYSCLK, HCLK), Hz. QEMU's `netduinoplus2` models 168 MHz for
/// the core and SysTick; on the board the PLL set-up below provides it.
pub const SYSCLK_HZ: u32 = 168_000_000;

/// Input clock of the APB1 timers (TIM2, TIM5), Hz. QEMU's STM32 timer
/// model counts at a fixed 1 GHz of virtual time; on the board APB1 =
/// 42 MHz, so the timer clock is 84 MHz.
#[cfg(not(feature = "board"))]
pub const TIMER_HZ: u64 = 1_000_000_000;
#[cfg(feature = "board")]
pub const TIMER_HZ: u64 = 84_000_000;

/// Where this build runs.
#[cfg(not(feature = "board"))]
pub const TARGET: &str = "QEMU netduinoplus2, -icount shift=3: 1 instruction = 8 ns";
#[cfg(feature = "board")]
pub const TARGET: &str = "board build: HSE + PLL";

/// `-icount shift=N` of the QEMU runner (`.cargo/config.toml`); every
/// instruction advances virtual time by `2^N` ns.
#[cfg_attr(not(feature = "demo"), allow(dead_code))]
pub const ICOUNT_SHIFT: u32 = 3;

/// What one converted tick unit is: instructions under QEMU (exact, from
/// the icount relation), core clock cycles on the board.
#[cfg(not(feature = "board"))]
#[cfg_attr(not(feature = "demo"), allow(dead_code))]
pub const UNIT: &str = "instructions";
#[cfg(feature = "board")]
#[cfg_attr(not(feature = "demo"), allow(dead_code))]
pub const UNIT: &str = "cycles";

/// TIM2 ticks for one [`UNIT`], as a fraction `(numerator, denominator)`.
/// QEMU: `instructions = ticks x 1e9 / (f_timer x 2^shift)` (EMBEDDED-NOTES),
/// so one instruction is `f_timer 2^shift / 1e9` ticks (8 at 1 GHz, shift 3).
/// Board: one core cycle is `f_timer / f_core` ticks.
#[cfg(not(feature = "board"))]
const TICKS_PER_UNIT: (u64, u64) = (TIMER_HZ << ICOUNT_SHIFT, 1_000_000_000);
#[cfg(feature = "board")]
const TICKS_PER_UNIT: (u64, u64) = (TIMER_HZ, SYSCLK_HZ as u64);

/// Converts TIM2 ticks to [`UNIT`]s (rounded to nearest).
pub fn ticks_to_units(ticks: u32) -> u32 {
    let (num, den) = TICKS_PER_UNIT;
    ((u64::from(ticks) * den + num / 2) / num) as u32
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
#[cfg_attr(not(feature = "demo"), allow(dead_code))]
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

/// Set once the emergency stop has run; the drives then refuse commands.
static STOPPED: AtomicBool = AtomicBool::new(false);
/// Bit pattern of every drive's last torque command (for the emergency
/// stop's report and the demo's printout).
static LAST_TORQUES: [AtomicU32; CABLES] = [const { AtomicU32::new(0) }; CABLES];
/// Whether the brakes were last commanded engaged.
static BRAKES: AtomicBool = AtomicBool::new(true);

/// The winch drives. The QEMU board has none, so the commands are kept (the
/// last one) and counted. A board port puts its PWM timers and pins behind
/// [`cdpr_control::drives::PwmDrives`] (embedded-hal 1.0) or a CAN driver
/// here, and makes [`emergency_stop`] write zero torque and drop the brake
/// pin directly.
pub struct Drives {
    writes: u32,
}

impl Drives {
    /// No command yet (torques zero, brakes engaged).
    pub const fn new() -> Self {
        Self { writes: 0 }
    }

    /// Commands written so far.
    pub fn writes(&self) -> u32 {
        self.writes
    }
}

/// Why a drive refused a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DrivesStopped;

impl WinchDrives for Drives {
    type Error = DrivesStopped;

    fn apply(&mut self, torques: &[f32; CABLES]) -> Result<(), DrivesStopped> {
        if STOPPED.load(Ordering::Relaxed) {
            return Err(DrivesStopped);
        }
        for (slot, t) in LAST_TORQUES.iter().zip(torques) {
            slot.store(t.to_bits(), Ordering::Relaxed);
        }
        self.writes = self.writes.wrapping_add(1);
        Ok(())
    }

    fn set_brakes(&mut self, engaged: bool) -> Result<(), DrivesStopped> {
        if STOPPED.load(Ordering::Relaxed) {
            return Err(DrivesStopped);
        }
        BRAKES.store(engaged, Ordering::Relaxed);
        Ok(())
    }
}

/// The torques and brake state last written to the drives.
pub fn drive_outputs() -> ([f32; CABLES], bool) {
    (
        LAST_TORQUES.each_ref().map(|t| f32::from_bits(t.load(Ordering::Relaxed))),
        BRAKES.load(Ordering::Relaxed),
    )
}

/// Stops the motors: zero torque on every drive and the brakes engaged,
/// written directly (no task, no lock: callable from the panic and
/// HardFault handlers), after which the drives refuse further commands.
pub fn emergency_stop() {
    STOPPED.store(true, Ordering::Relaxed);
    for slot in &LAST_TORQUES {
        slot.store(0.0f32.to_bits(), Ordering::Relaxed);
    }
    BRAKES.store(true, Ordering::Relaxed);
}

/// Ends the program: motors stopped first. Under QEMU the semihosting exit
/// code reaches the shell; on the board the core waits for the watchdog
/// (or a debugger).
pub fn exit(code: i32) -> ! {
    emergency_stop();
    #[cfg(not(feature = "board"))]
    semihosting::process::exit(code);
    #[cfg(feature = "board")]
    {
        let _ = code;
        loop {
            cortex_m::asm::wfi();
        }
    }
}

/// Independent watchdog timeout, ms: a little over 20 control periods, so
/// a stuck control task resets the chip (which comes up Disabled, brakes on).
#[cfg(feature = "board")]
pub const WATCHDOG_MS: u32 = 20;

/// Starts the IWDG (LSI 32 kHz / 32 = 1 kHz count, reload [`WATCHDOG_MS`]).
/// Board only: QEMU 7.2's `netduinoplus2` does not model the IWDG.
#[cfg(feature = "board")]
pub fn start_watchdog(iwdg: &stm32f4::stm32f405::IWDG) {
    iwdg.kr().write(|w| w.key().unlock());
    iwdg.pr().write(|w| w.pr().divide_by32());
    iwdg.rlr().write(|w| w.rl().set(WATCHDOG_MS as u16));
    iwdg.kr().write(|w| w.key().start());
}

/// Reloads the IWDG (board only; nothing under QEMU).
#[inline(always)]
pub fn feed_watchdog() {
    #[cfg(feature = "board")]
    {
        // SAFETY: a write of the reload key to IWDG_KR, which only this
        // function writes after start-up.
        let iwdg = unsafe { &*stm32f4::stm32f405::IWDG::ptr() };
        iwdg.kr().write(|w| w.key().feed());
    }
}

/// HSE crystal of the board, Hz (8 MHz assumed; adjust `PLLM` for others).
#[cfg(feature = "board")]
pub const HSE_HZ: u32 = 8_000_000;

/// Real hardware only: HSE -> PLL -> 168 MHz SYSCLK, AHB 168 MHz, APB1
/// 42 MHz (timers 84 MHz), APB2 84 MHz, 48 MHz for USB, 5 flash wait
/// states. QEMU does not model the RCC: the ready-bit waits would hang.
#[cfg(feature = "board")]
pub fn configure_clocks(rcc: &RCC, flash: &stm32f4::stm32f405::FLASH) {
    rcc.cr().modify(|_, w| w.hseon().set_bit());
    while rcc.cr().read().hserdy().bit_is_clear() {}
    // VCO in = HSE / M = 1 MHz, VCO out = x N = 336 MHz, SYSCLK = / P = 168 MHz,
    // USB = / Q = 48 MHz.
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

/// The stack's extent from the linker script: it grows down from
/// `_stack_start` (end of RAM) towards `_stack_end` (end of `.bss`/`.uninit`).
fn stack_bounds() -> (usize, usize) {
    extern "C" {
        static _stack_start: u32;
        static _stack_end: u32;
    }
    // Only the symbols' addresses are taken (safe since Rust 1.82).
    (core::ptr::addr_of!(_stack_end) as usize, core::ptr::addr_of!(_stack_start) as usize)
}

const PAINT: u32 = 0x5A5A_A5A5;

/// Fills the unused stack (from its limit up to 256 bytes below the current
/// stack pointer) with a pattern, for [`stack_high_water`]. Call once, early.
pub fn paint_stack() {
    let (bottom, _) = stack_bounds();
    let limit = cortex_m::register::msp::read() as usize - 256;
    let mut addr = bottom;
    while addr < limit {
        // SAFETY: the words between the stack's limit and well below the
        // live stack pointer belong to no one yet.
        unsafe { core::ptr::write_volatile(addr as *mut u32, PAINT) };
        addr += 4;
    }
}

/// `(used, size)` of the stack in bytes: the deepest word that no longer
/// holds the pattern of [`paint_stack`].
pub fn stack_high_water() -> (u32, u32) {
    let (bottom, top) = stack_bounds();
    let mut addr = bottom;
    // SAFETY: reads of RAM inside the stack region.
    while addr < top && unsafe { core::ptr::read_volatile(addr as *const u32) } == PAINT {
        addr += 4;
    }
    ((top - addr) as u32, (top - bottom) as u32)
}
