//! The direct path for small winches (`direct` feature, with `board`):
//! PWM amplifiers with a direction and a brake input, and quadrature
//! encoders, as `cdpr_control::quadrature::DirectDrives` on the STM32F405's
//! own timers, instead of the CiA 402 drives on CAN.
//!
//! Pins are for the 100-pin STM32F405VG (port E); every timer clock and
//! register value below is from RM0090 (the STM32F405 reference manual).
//!
//! | cable | PWM (20 kHz, PWM mode 1) | direction | encoder A / B |
//! | --- | --- | --- | --- |
//! | 1 | TIM9 CH1, PE5 (AF3) | PD0 | TIM1 CH1/CH2, PE9 / PE11 (AF1) |
//! | 2 | TIM9 CH2, PE6 (AF3) | PD1 | TIM3 CH1/CH2, PB4 / PB5 (AF2) |
//! | 3 | TIM10 CH1, PB8 (AF3) | PD2 | TIM4 CH1/CH2, PD12 / PD13 (AF2) |
//! | 4 | TIM11 CH1, PB9 (AF3) | PD3 | TIM8 CH1/CH2, PC6 / PC7 (AF3) |
//! | 5 | TIM12 CH1, PB14 (AF9) | PD4 | LS7366R, chip select PD8 |
//! | 6 | TIM12 CH2, PB15 (AF9) | PD5 | LS7366R, chip select PD9 |
//! | 7 | TIM13 CH1, PA6 (AF9) | PD6 | LS7366R, chip select PD10 |
//! | 8 | TIM14 CH1, PA7 (AF9) | PD7 | LS7366R, chip select PD11 |
//!
//! * **Brake:** PD14, high = engaged (give the brake driver a pull-up, so
//!   that the brakes hold while the pin floats during reset).
//! * **PWM:** TIM9-11 run from APB2's timer clock (168 MHz, `ARR` 8 399),
//!   TIM12-14 from APB1's (84 MHz, `ARR` 4 199): 20 kHz, above hearing; a
//!   duty of `ARR + 1` is full torque.
//! * **Encoders:** TIM1, TIM3, TIM4 and TIM8 in encoder mode 3 (both edges
//!   of both inputs: x4), input filter `fCK_INT`, N = 8. They are the
//!   STM32F405's timers with an encoder interface that are still free:
//!   TIM2 times the steps and TIM5 is the monotonic. Cables 5-8 are
//!   counted by LS7366R chips ([`cdpr_control::ls7366r`]) on SPI2 (SCK PB10,
//!   MISO PC2, MOSI PC3, AF5; mode 0, 42 MHz / 16 = 2.625 MHz; three bytes
//!   per read, about 9 us per chip, 37 us a cycle, inside the step).
//! * PB4 is JTAG's NJTRST after reset: debug the direct build over SWD.
//!
//! A chip that does not answer its set-up keeps failing its reads, so the
//! control loop names that cable in a `drive` fault and the board stays
//! out of Enabled. [`emergency_stop`] writes every PWM compare register to
//! zero and the brake pin high, straight to the registers.

use cdpr_control::drives::PwmDrives;
use cdpr_control::ls7366r::Ls7366r;
use cdpr_control::quadrature::{DirectDrives, EncoderCounter};
use cdpr_control::CABLES;
use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{ErrorType as PinErrorType, OutputPin};
use embedded_hal::pwm::{ErrorType as PwmErrorType, SetDutyCycle};
use embedded_hal::spi::{ErrorKind, ErrorType as SpiErrorType, SpiBus};
use embedded_hal_bus::spi::AtomicDevice;
use embedded_hal_bus::util::AtomicCell;
use stm32f4::stm32f405::{
    gpioi, GPIOA, GPIOB, GPIOC, GPIOD, GPIOE, RCC, SPI2, TIM1, TIM10, TIM11, TIM12, TIM13, TIM14, TIM3, TIM4,
    TIM8, TIM9,
};

/// PWM frequency, Hz.
pub const PWM_HZ: u32 = 20_000;
/// APB2 timer clock (TIM1, TIM8, TIM9-11), Hz.
const APB2_TIMER_HZ: u32 = 168_000_000;
/// APB1 timer clock (TIM3, TIM4, TIM12-14), Hz.
const APB1_TIMER_HZ: u32 = 84_000_000;
/// `ARR` of the APB2 PWM timers.
const ARR_APB2: u16 = (APB2_TIMER_HZ / PWM_HZ - 1) as u16;
/// `ARR` of the APB1 PWM timers.
const ARR_APB1: u16 = (APB1_TIMER_HZ / PWM_HZ - 1) as u16;
/// Reads a second (the control rate).
const READS_PER_SECOND: u32 = 1_000;
/// Status-register polls an SPI byte may take before it is an error (a
/// byte takes about 500 core cycles at 2.625 MHz; a poll is a few).
const SPI_POLLS: u32 = 20_000;

// RM0090 register bits used below.
/// `TIMx_CR1`: counter enable.
const CR1_CEN: u32 = 1 << 0;
/// `TIMx_CR1`: auto-reload preload.
const CR1_ARPE: u32 = 1 << 7;
/// `TIMx_EGR`: update generation (loads the preloaded registers).
const EGR_UG: u32 = 1 << 0;
/// `TIMx_CCMR1`, output: OC1M = 110 (PWM mode 1), OC1PE.
const CCMR1_PWM_CH1: u32 = (0b110 << 4) | (1 << 3);
/// `TIMx_CCMR1`, output: OC2M = 110 (PWM mode 1), OC2PE.
const CCMR1_PWM_CH2: u32 = (0b110 << 12) | (1 << 11);
/// `TIMx_CCER`: CC1E.
const CCER_CC1E: u32 = 1 << 0;
/// `TIMx_CCER`: CC2E.
const CCER_CC2E: u32 = 1 << 4;
/// `TIMx_CCMR1`, input: CC1S = 01 (IC1 on TI1), IC1F = 0011, CC2S = 01
/// (IC2 on TI2), IC2F = 0011 (`fCK_INT`, N = 8).
const CCMR1_ENCODER: u32 = 0b01 | (0b0011 << 4) | (0b01 << 8) | (0b0011 << 12);
/// `TIMx_SMCR`: SMS = 011, encoder mode 3 (counts on TI1 and TI2 edges).
const SMCR_ENCODER_MODE_3: u32 = 0b011;
/// `SPI_CR1`: master, baud rate fPCLK / 16 (BR = 011), mode 0, 8-bit,
/// MSB first, software slave select (SSM, SSI), enabled (SPE).
const SPI_CR1_MASTER: u16 = (1 << 2) | (0b011 << 3) | (1 << 6) | (1 << 8) | (1 << 9);
/// `SPI_SR`: RXNE.
const SPI_SR_RXNE: u16 = 1 << 0;
/// `SPI_SR`: TXE.
const SPI_SR_TXE: u16 = 1 << 1;
/// The brake pin, PD14.
const BRAKE_PIN: u8 = 14;

/// One of the eight PWM channels (cable order).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PwmChannel {
    /// TIM9 CH1 (cable 1).
    Tim9Ch1,
    /// TIM9 CH2 (cable 2).
    Tim9Ch2,
    /// TIM10 CH1 (cable 3).
    Tim10Ch1,
    /// TIM11 CH1 (cable 4).
    Tim11Ch1,
    /// TIM12 CH1 (cable 5).
    Tim12Ch1,
    /// TIM12 CH2 (cable 6).
    Tim12Ch2,
    /// TIM13 CH1 (cable 7).
    Tim13Ch1,
    /// TIM14 CH1 (cable 8).
    Tim14Ch1,
}

/// The channels in cable order.
pub const PWM_CHANNELS: [PwmChannel; CABLES] = [
    PwmChannel::Tim9Ch1,
    PwmChannel::Tim9Ch2,
    PwmChannel::Tim10Ch1,
    PwmChannel::Tim11Ch1,
    PwmChannel::Tim12Ch1,
    PwmChannel::Tim12Ch2,
    PwmChannel::Tim13Ch1,
    PwmChannel::Tim14Ch1,
];

impl PwmChannel {
    /// Writes the compare register (duty in timer counts, `0..=ARR + 1`).
    fn write(self, duty: u16) {
        let duty = u32::from(duty);
        // SAFETY: the compare registers of TIM9-14 are written only here
        // and by `emergency_stop` (which then stops everything); `start`
        // took ownership of the timers.
        unsafe {
            match self {
                Self::Tim9Ch1 => (*TIM9::ptr()).ccr1().write(|w| w.bits(duty)),
                Self::Tim9Ch2 => (*TIM9::ptr()).ccr2().write(|w| w.bits(duty)),
                Self::Tim10Ch1 => (*TIM10::ptr()).ccr1().write(|w| w.bits(duty)),
                Self::Tim11Ch1 => (*TIM11::ptr()).ccr1().write(|w| w.bits(duty)),
                Self::Tim12Ch1 => (*TIM12::ptr()).ccr1().write(|w| w.bits(duty)),
                Self::Tim12Ch2 => (*TIM12::ptr()).ccr2().write(|w| w.bits(duty)),
                Self::Tim13Ch1 => (*TIM13::ptr()).ccr1().write(|w| w.bits(duty)),
                Self::Tim14Ch1 => (*TIM14::ptr()).ccr1().write(|w| w.bits(duty)),
            };
        }
    }
}

impl PwmErrorType for PwmChannel {
    type Error = core::convert::Infallible;
}

impl SetDutyCycle for PwmChannel {
    /// `ARR + 1`: the compare value of a permanently high output.
    fn max_duty_cycle(&self) -> u16 {
        match self {
            Self::Tim9Ch1 | Self::Tim9Ch2 | Self::Tim10Ch1 | Self::Tim11Ch1 => ARR_APB2 + 1,
            _ => ARR_APB1 + 1,
        }
    }

    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Self::Error> {
        self.write(duty.min(self.max_duty_cycle()));
        Ok(())
    }
}

/// A push-pull output on port D (the directions PD0-PD7, the chip
/// selects PD8-PD11, the brake PD14).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutputLine {
    pin: u8,
}

impl OutputLine {
    const fn d(pin: u8) -> Self {
        Self { pin }
    }

    fn port() -> &'static gpioi::RegisterBlock {
        // SAFETY: a shared reference to memory-mapped registers; the only
        // writes are atomic (BSRR) or made once in `start`.
        unsafe { &*GPIOD::ptr() }
    }

    /// Sets the pin high or low in one atomic BSRR write.
    fn set(&self, high: bool) {
        let bit = if high { 1u32 << self.pin } else { 1u32 << (self.pin + 16) };
        // SAFETY: BSRR writes touch only this pin.
        Self::port().bsrr().write(|w| unsafe { w.bits(bit) });
    }

    /// Makes the pin a push-pull output at `high`.
    fn configure(&self, high: bool) {
        self.set(high);
        let shift = 2 * u32::from(self.pin);
        // SAFETY: read-modify-write of this pin's MODER field (01 =
        // general-purpose output), at start-up before any task runs.
        Self::port()
            .moder()
            .modify(|r, w| unsafe { w.bits((r.bits() & !(0b11 << shift)) | (0b01 << shift)) });
    }
}

impl PinErrorType for OutputLine {
    type Error = core::convert::Infallible;
}

impl OutputPin for OutputLine {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        self.set(false);
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Self::Error> {
        self.set(true);
        Ok(())
    }
}

/// One of the four encoder timers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncoderTimer {
    /// TIM1 (cable 1).
    Tim1,
    /// TIM3 (cable 2).
    Tim3,
    /// TIM4 (cable 3).
    Tim4,
    /// TIM8 (cable 4).
    Tim8,
}

impl EncoderTimer {
    fn count(self) -> u16 {
        // SAFETY: reads of the counters, which `start` owns and set up.
        unsafe {
            match self {
                Self::Tim1 => (*TIM1::ptr()).cnt().read().bits() as u16,
                Self::Tim3 => (*TIM3::ptr()).cnt().read().bits() as u16,
                Self::Tim4 => (*TIM4::ptr()).cnt().read().bits() as u16,
                Self::Tim8 => (*TIM8::ptr()).cnt().read().bits() as u16,
            }
        }
    }
}

/// SPI2 as an embedded-hal bus (master, mode 0, 8-bit, polled).
pub struct Spi2Bus {
    _spi: SPI2,
}

impl Spi2Bus {
    fn registers() -> &'static stm32f4::stm32f405::spi1::RegisterBlock {
        // SAFETY: `Spi2Bus` owns SPI2; one instance, used by one task.
        unsafe { &*SPI2::ptr() }
    }

    /// One byte out and one in, each wait bounded by [`SPI_POLLS`].
    fn exchange(&mut self, out: u8) -> Result<u8, ErrorKind> {
        let spi = Self::registers();
        let mut polls = 0;
        while spi.sr().read().bits() & SPI_SR_TXE == 0 {
            polls += 1;
            if polls > SPI_POLLS {
                return Err(ErrorKind::Other);
            }
        }
        // SAFETY: an 8-bit frame into the data register.
        spi.dr().write(|w| unsafe { w.bits(u16::from(out)) });
        polls = 0;
        while spi.sr().read().bits() & SPI_SR_RXNE == 0 {
            polls += 1;
            if polls > SPI_POLLS {
                return Err(ErrorKind::Other);
            }
        }
        Ok(spi.dr().read().bits() as u8)
    }
}

impl SpiErrorType for Spi2Bus {
    type Error = ErrorKind;
}

impl SpiBus<u8> for Spi2Bus {
    fn read(&mut self, words: &mut [u8]) -> Result<(), ErrorKind> {
        for w in words {
            *w = self.exchange(0)?;
        }
        Ok(())
    }

    fn write(&mut self, words: &[u8]) -> Result<(), ErrorKind> {
        for &w in words {
            self.exchange(w)?;
        }
        Ok(())
    }

    fn transfer(&mut self, read: &mut [u8], write: &[u8]) -> Result<(), ErrorKind> {
        for i in 0..read.len().max(write.len()) {
            let b = self.exchange(write.get(i).copied().unwrap_or(0))?;
            if let Some(r) = read.get_mut(i) {
                *r = b;
            }
        }
        Ok(())
    }

    fn transfer_in_place(&mut self, words: &mut [u8]) -> Result<(), ErrorKind> {
        for w in words {
            *w = self.exchange(*w)?;
        }
        Ok(())
    }

    /// Every byte has been received when `exchange` returns.
    fn flush(&mut self) -> Result<(), ErrorKind> {
        Ok(())
    }
}

/// Busy waits on the core clock (for `SpiDevice`'s delay operations,
/// which the LS7366R driver does not use).
pub struct CoreDelay;

impl DelayNs for CoreDelay {
    fn delay_ns(&mut self, ns: u32) {
        // 168 cycles a microsecond.
        cortex_m::asm::delay(ns.div_ceil(1000).saturating_mul(crate::bsp::SYSCLK_HZ / 1_000_000));
    }
}

/// One LS7366R on the shared SPI2.
pub type CounterChip = Ls7366r<AtomicDevice<'static, Spi2Bus, OutputLine, CoreDelay>>;

/// Why a cable's counter could not be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CounterError {
    /// The chip failed its set-up at start (it stays out of use).
    NotSetUp,
    /// The chip's transfer failed (the bus timed out, or was busy: only
    /// the control task uses it, so never).
    Transfer,
}

/// A cable's counter: a timer in encoder mode or an LS7366R.
pub enum Counter {
    /// A timer in encoder mode.
    Timer(EncoderTimer),
    /// An LS7366R and whether its set-up succeeded.
    Chip(CounterChip, bool),
}

impl EncoderCounter for Counter {
    type Error = CounterError;

    fn count(&mut self) -> Result<u16, CounterError> {
        match self {
            Self::Timer(t) => Ok(t.count()),
            Self::Chip(chip, true) => chip.count().map_err(|_| CounterError::Transfer),
            Self::Chip(_, false) => Err(CounterError::NotSetUp),
        }
    }
}

/// The direct path's drives.
pub type DirectBoardDrives = DirectDrives<PwmChannel, OutputLine, OutputLine, Counter>;

/// The peripherals the direct path takes.
pub struct DirectPeripherals {
    /// Encoder timers.
    pub tim1: TIM1,
    /// Encoder timer.
    pub tim3: TIM3,
    /// Encoder timer.
    pub tim4: TIM4,
    /// Encoder timer.
    pub tim8: TIM8,
    /// PWM timer.
    pub tim9: TIM9,
    /// PWM timer.
    pub tim10: TIM10,
    /// PWM timer.
    pub tim11: TIM11,
    /// PWM timer.
    pub tim12: TIM12,
    /// PWM timer.
    pub tim13: TIM13,
    /// PWM timer.
    pub tim14: TIM14,
    /// The counter chips' bus.
    pub spi2: SPI2,
}

/// Sets pin `pin` of a port to alternate function `af` (MODER 10, AFR).
macro_rules! alternate {
    ($port:expr, $pin:expr, $af:expr) => {{
        let (port, pin, af): (_, u32, u32) = ($port, $pin, $af);
        let shift = 2 * pin;
        // SAFETY: read-modify-writes of this pin's MODER and AFR fields at
        // start-up, before any task runs.
        port.moder().modify(|r, w| unsafe { w.bits((r.bits() & !(0b11 << shift)) | (0b10 << shift)) });
        if pin < 8 {
            let s = 4 * pin;
            port.afrl().modify(|r, w| unsafe { w.bits((r.bits() & !(0xF << s)) | (af << s)) });
        } else {
            let s = 4 * (pin - 8);
            port.afrh().modify(|r, w| unsafe { w.bits((r.bits() & !(0xF << s)) | (af << s)) });
        }
    }};
}

/// Sets up a PWM timer (`arr`, both channels' modes in `ccmr1`, their
/// outputs in `ccer`), starting at zero duty.
macro_rules! pwm_timer {
    ($tim:expr, $arr:expr, $ccmr1:expr, $ccer:expr) => {{
        let t = $tim;
        // SAFETY: whole-register writes of documented values (RM0090,
        // general-purpose timers TIM9-14) to a timer `start` owns.
        unsafe {
            t.psc().write(|w| w.bits(0));
            t.arr().write(|w| w.bits(u32::from($arr)));
            t.ccr1().write(|w| w.bits(0));
            t.ccmr1_output().write(|w| w.bits($ccmr1));
            t.ccer().write(|w| w.bits($ccer));
            t.egr().write(|w| w.bits(EGR_UG));
            t.cr1().write(|w| w.bits(CR1_ARPE | CR1_CEN));
        }
    }};
}

/// Sets up an encoder timer: encoder mode 3, filtered inputs, full 16-bit range.
macro_rules! encoder_timer {
    ($tim:expr) => {{
        let t = $tim;
        // SAFETY: whole-register writes of documented values (RM0090,
        // encoder interface mode) to a timer `start` owns.
        unsafe {
            t.arr().write(|w| w.bits(0xFFFF));
            t.ccmr1_input().write(|w| w.bits(CCMR1_ENCODER));
            t.ccer().write(|w| w.bits(0));
            t.smcr().write(|w| w.bits(SMCR_ENCODER_MODE_3));
            t.cnt().write(|w| w.bits(0));
            t.cr1().write(|w| w.bits(CR1_CEN));
        }
    }};
}

/// Brings the direct path up: clocks, pins, PWM at zero duty with the
/// brake engaged, the encoder timers counting, SPI2 and the four counter
/// chips set up (a chip that fails is reported by every read of its cable).
/// `torque_max` is the torque at full duty (N m).
pub fn start(p: DirectPeripherals, rcc: &RCC, torque_max: f32) -> DirectBoardDrives {
    rcc.ahb1enr().modify(|_, w| {
        w.gpioaen().set_bit();
        w.gpioben().set_bit();
        w.gpiocen().set_bit();
        w.gpioden().set_bit();
        w.gpioeen().set_bit()
    });
    rcc.apb2enr().modify(|_, w| {
        w.tim1en().set_bit();
        w.tim8en().set_bit();
        w.tim9en().set_bit();
        w.tim10en().set_bit();
        w.tim11en().set_bit()
    });
    rcc.apb1enr().modify(|_, w| {
        w.tim3en().set_bit();
        w.tim4en().set_bit();
        w.tim12en().set_bit();
        w.tim13en().set_bit();
        w.tim14en().set_bit();
        w.spi2en().set_bit()
    });
    let _ = rcc.apb1enr().read();

    // The brake first: engaged before anything can move.
    let brake = OutputLine::d(BRAKE_PIN);
    brake.configure(true);
    let directions: [OutputLine; CABLES] = core::array::from_fn(|i| OutputLine::d(i as u8));
    for d in &directions {
        d.configure(false);
    }
    let selects: [OutputLine; 4] = core::array::from_fn(|i| OutputLine::d(8 + i as u8));
    for s in &selects {
        s.configure(true);
    }

    pwm_timer!(&*p.tim9, ARR_APB2, CCMR1_PWM_CH1 | CCMR1_PWM_CH2, CCER_CC1E | CCER_CC2E);
    pwm_timer!(&*p.tim10, ARR_APB2, CCMR1_PWM_CH1, CCER_CC1E);
    pwm_timer!(&*p.tim11, ARR_APB2, CCMR1_PWM_CH1, CCER_CC1E);
    pwm_timer!(&*p.tim12, ARR_APB1, CCMR1_PWM_CH1 | CCMR1_PWM_CH2, CCER_CC1E | CCER_CC2E);
    pwm_timer!(&*p.tim13, ARR_APB1, CCMR1_PWM_CH1, CCER_CC1E);
    pwm_timer!(&*p.tim14, ARR_APB1, CCMR1_PWM_CH1, CCER_CC1E);
    // SAFETY: TIM9's and TIM12's second compare registers, zero duty.
    unsafe {
        p.tim9.ccr2().write(|w| w.bits(0));
        p.tim12.ccr2().write(|w| w.bits(0));
    }
    encoder_timer!(&*p.tim1);
    encoder_timer!(&*p.tim3);
    encoder_timer!(&*p.tim4);
    encoder_timer!(&*p.tim8);

    // SAFETY: references to memory-mapped GPIO registers, configured here
    // once before any task runs.
    let (gpioa, gpiob, gpioc, gpiod, gpioe) =
        unsafe { (&*GPIOA::ptr(), &*GPIOB::ptr(), &*GPIOC::ptr(), &*GPIOD::ptr(), &*GPIOE::ptr()) };
    // PWM outputs.
    alternate!(gpioe, 5, 3);
    alternate!(gpioe, 6, 3);
    alternate!(gpiob, 8, 3);
    alternate!(gpiob, 9, 3);
    alternate!(gpiob, 14, 9);
    alternate!(gpiob, 15, 9);
    alternate!(gpioa, 6, 9);
    alternate!(gpioa, 7, 9);
    // Encoder inputs.
    alternate!(gpioe, 9, 1);
    alternate!(gpioe, 11, 1);
    alternate!(gpiob, 4, 2);
    alternate!(gpiob, 5, 2);
    alternate!(gpiod, 12, 2);
    alternate!(gpiod, 13, 2);
    alternate!(gpioc, 6, 3);
    alternate!(gpioc, 7, 3);
    // SPI2.
    alternate!(gpiob, 10, 5);
    alternate!(gpioc, 2, 5);
    alternate!(gpioc, 3, 5);

    // SAFETY: SPI2's control register, documented value.
    unsafe { p.spi2.cr1().write(|w| w.bits(SPI_CR1_MASTER)) };
    let bus: &'static AtomicCell<Spi2Bus> = match cortex_m::singleton!(: AtomicCell<Spi2Bus> = AtomicCell::new(Spi2Bus { _spi: p.spi2 }))
    {
        Some(b) => b,
        None => panic!("the direct path was started twice"),
    };
    let [c5, c6, c7, c8] = selects.map(|cs| {
        // Setting an `OutputLine` cannot fail.
        let Ok(device) = AtomicDevice::new(bus, cs, CoreDelay);
        let mut chip = Ls7366r::new(device);
        let ready = chip.configure().is_ok();
        Counter::Chip(chip, ready)
    });
    let counters = [
        Counter::Timer(EncoderTimer::Tim1),
        Counter::Timer(EncoderTimer::Tim3),
        Counter::Timer(EncoderTimer::Tim4),
        Counter::Timer(EncoderTimer::Tim8),
        c5,
        c6,
        c7,
        c8,
    ];
    let pwm = PwmDrives::new(PWM_CHANNELS, directions, brake, torque_max);
    DirectDrives::new(pwm, counters, READS_PER_SECOND)
}

/// Zero duty on every channel and the brake engaged, written straight to
/// the registers (callable from the panic and HardFault handlers).
pub fn emergency_stop() {
    for channel in PWM_CHANNELS {
        channel.write(0);
    }
    OutputLine::d(BRAKE_PIN).set(true);
}
