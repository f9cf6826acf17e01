//! The LS7366R quadrature counter chip (LSI/CSI, 32-bit counter with an SPI
//! interface) as an [`EncoderCounter`]: the direct path's encoders for the
//! cables the microcontroller's own timers cannot count (an STM32F405 has
//! four timers left with an encoder interface, `firmware/README.md`).
//!
//! From the datasheet (LS7366R, LSI Computer Systems, "IR" and "MDR0/MDR1"
//! register descriptions): every transfer starts with `SS/` low and an
//! instruction byte, bits 7-6 the operation (`00` clear, `01` read, `10`
//! write, `11` load) and bits 5-3 the register (`001` MDR0, `010` MDR1,
//! `011` DTR, `100` CNTR, `101` OTR, `110` STR); data follow MSB first, SPI
//! mode 0. Reading CNTR copies it to OTR and shifts OTR out, so the count
//! is one snapshot.
//!
//! The chip is set up as the timers are: x4 quadrature, free-running, no
//! index, and a **2-byte counter**, so a read is three bytes and the count
//! is the 16-bit value [`crate::quadrature::Extender`] extends (at 1 kHz
//! the motor may turn 32 767 counts between reads). Set-up reads both mode
//! registers back: a chip that is absent, unpowered or miswired (MISO stuck
//! at 0x00 or 0xFF) fails there with [`Ls7366rError::NotConfigured`],
//! before the board can be enabled.

use crate::quadrature::EncoderCounter;
use embedded_hal::spi::{Operation, SpiDevice};

/// Instruction: write MDR0 (`10` `001` `xxx`).
pub const WRITE_MDR0: u8 = 0b1000_1000;
/// Instruction: write MDR1 (`10` `010` `xxx`).
pub const WRITE_MDR1: u8 = 0b1001_0000;
/// Instruction: read MDR0 (`01` `001` `xxx`).
pub const READ_MDR0: u8 = 0b0100_1000;
/// Instruction: read MDR1 (`01` `010` `xxx`).
pub const READ_MDR1: u8 = 0b0101_0000;
/// Instruction: clear CNTR (`00` `100` `xxx`).
pub const CLEAR_CNTR: u8 = 0b0010_0000;
/// Instruction: read CNTR (`01` `100` `xxx`): CNTR to OTR, then OTR out.
pub const READ_CNTR: u8 = 0b0110_0000;
/// Instruction: clear STR (`00` `110` `xxx`).
pub const CLEAR_STR: u8 = 0b0011_0000;

/// MDR0 as set up: x4 quadrature (bits 1-0 `11`), free-running count
/// (bits 3-2 `00`), index disabled (bits 5-4 `00`), asynchronous index
/// (bit 6), filter clock division 1 (bit 7).
pub const MDR0_X4_FREE_RUNNING: u8 = 0b0000_0011;
/// MDR1 as set up: 2-byte counter (bits 1-0 `10`), counting enabled
/// (bit 2 `0`), no flag on the DFLAG/LFLAG outputs (bits 7-4 `0000`).
pub const MDR1_TWO_BYTES: u8 = 0b0000_0010;

/// Why an LS7366R could not be set up or read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ls7366rError<E> {
    /// The SPI transfer failed.
    Spi(E),
    /// The mode registers read back differ from what was written: the
    /// chip is absent, unpowered or miswired (what was read, MDR0 and MDR1).
    NotConfigured {
        /// MDR0 as read back.
        mdr0: u8,
        /// MDR1 as read back.
        mdr1: u8,
    },
}

/// One LS7366R behind an embedded-hal 1.0 [`SpiDevice`] (its own chip
/// select; several chips may share one bus, e.g. through
/// `embedded-hal-bus`).
pub struct Ls7366r<D> {
    spi: D,
}

impl<D: SpiDevice> Ls7366r<D> {
    /// The chip on `spi`, not yet set up ([`Ls7366r::configure`]).
    pub fn new(spi: D) -> Self {
        Self { spi }
    }

    /// Sets the chip up (x4 quadrature, free-running, 2-byte counter,
    /// counting), clears its counter and status, and reads the mode
    /// registers back.
    pub fn configure(&mut self) -> Result<(), Ls7366rError<D::Error>> {
        for bytes in [[WRITE_MDR0, MDR0_X4_FREE_RUNNING], [WRITE_MDR1, MDR1_TWO_BYTES]] {
            self.spi.write(&bytes).map_err(Ls7366rError::Spi)?;
        }
        self.spi.write(&[CLEAR_CNTR]).map_err(Ls7366rError::Spi)?;
        self.spi.write(&[CLEAR_STR]).map_err(Ls7366rError::Spi)?;
        let mdr0 = self.read_register(READ_MDR0)?;
        let mdr1 = self.read_register(READ_MDR1)?;
        if (mdr0, mdr1) == (MDR0_X4_FREE_RUNNING, MDR1_TWO_BYTES) {
            Ok(())
        } else {
            Err(Ls7366rError::NotConfigured { mdr0, mdr1 })
        }
    }

    /// One byte register (MDR0, MDR1, STR) by its read instruction.
    fn read_register(&mut self, instruction: u8) -> Result<u8, Ls7366rError<D::Error>> {
        let mut value = [0u8; 1];
        self.spi
            .transaction(&mut [Operation::Write(&[instruction]), Operation::Read(&mut value)])
            .map_err(Ls7366rError::Spi)?;
        Ok(value[0])
    }

    /// The SPI device back.
    pub fn release(self) -> D {
        self.spi
    }
}

impl<D: SpiDevice> EncoderCounter for Ls7366r<D> {
    type Error = Ls7366rError<D::Error>;

    /// CNTR, 2 bytes MSB first: one transfer of three bytes.
    fn count(&mut self) -> Result<u16, Self::Error> {
        let mut value = [0u8; 2];
        self.spi
            .transaction(&mut [Operation::Write(&[READ_CNTR]), Operation::Read(&mut value)])
            .map_err(Ls7366rError::Spi)?;
        Ok(u16::from_be_bytes(value))
    }
}

#[cfg(test)]
mod tests {
    //! Against a model of the chip written from the datasheet's register
    //! description (not from the driver): it decodes each transfer's
    //! instruction byte and keeps MDR0, MDR1, CNTR (as wide as MDR1 says),
    //! OTR and STR.
    use super::*;
    use crate::drives::{PwmDrives, WinchDrives, WinchReading};
    use crate::quadrature::DirectDrives;
    use crate::CABLES;
    use core::convert::Infallible;
    use embedded_hal::digital::{ErrorType as PinErrorType, OutputPin};
    use embedded_hal::pwm::{ErrorType as PwmErrorType, SetDutyCycle};
    use embedded_hal::spi::{ErrorKind, ErrorType};
    use proptest::prelude::*;

    /// What the model's MISO does.
    #[derive(Clone, Copy, PartialEq, Debug)]
    enum Miso {
        /// A working chip.
        Chip,
        /// Nothing drives the line: it reads as this byte.
        Stuck(u8),
        /// The bus itself fails.
        BusError,
    }

    struct ChipModel {
        miso: Miso,
        mdr0: u8,
        mdr1: u8,
        /// The chip's count as a 32-bit register; only the low `bytes()`
        /// bytes exist.
        cntr: u32,
        otr: u32,
        str_: u8,
        transfers: usize,
    }

    impl ChipModel {
        fn new(miso: Miso) -> Self {
            Self { miso, mdr0: 0, mdr1: 0, cntr: 0, otr: 0, str_: 0xA5, transfers: 0 }
        }

        /// Counter width, bytes (MDR1 bits 1-0: 00 = 4, 01 = 3, 10 = 2, 11 = 1).
        fn bytes(&self) -> usize {
            4 - usize::from(self.mdr1 & 0b11)
        }

        fn mask(&self) -> u32 {
            match self.bytes() {
                4 => u32::MAX,
                n => (1u32 << (8 * n)) - 1,
            }
        }

        /// The encoder turned by `counts` edges (x4 quadrature).
        fn turn(&mut self, counts: i32) {
            if self.mdr1 & 0b100 == 0 {
                self.cntr = self.cntr.wrapping_add(counts as u32) & self.mask();
            }
        }

        /// One `SS/` low .. high: the instruction, then data bytes.
        fn transfer(&mut self, mosi: &[u8], miso: &mut [u8]) {
            let Some((&ir, data)) = mosi.split_first() else { return };
            let op = ir >> 6;
            let reg = (ir >> 3) & 0b111;
            match (op, reg) {
                (0b00, 0b001) => self.mdr0 = 0,
                (0b00, 0b010) => self.mdr1 = 0,
                (0b00, 0b100) => self.cntr = 0,
                (0b00, 0b110) => self.str_ = 0,
                (0b10, 0b001) => self.mdr0 = data.first().copied().unwrap_or(self.mdr0),
                (0b10, 0b010) => self.mdr1 = data.first().copied().unwrap_or(self.mdr1),
                (0b01, r) => {
                    let (value, n) = match r {
                        0b001 => (u32::from(self.mdr0), 1),
                        0b010 => (u32::from(self.mdr1), 1),
                        0b100 => {
                            self.otr = self.cntr;
                            (self.otr, self.bytes())
                        }
                        0b101 => (self.otr, self.bytes()),
                        0b110 => (u32::from(self.str_), 1),
                        _ => (0, 0),
                    };
                    // MSB first, after the instruction byte.
                    for (k, out) in miso.iter_mut().skip(1).take(n).enumerate() {
                        *out = (value >> (8 * (n - 1 - k))) as u8;
                    }
                }
                _ => {}
            }
        }
    }

    /// An SpiDevice over one model: each transaction is one `SS/` cycle,
    /// its operations one byte stream.
    struct ModelDevice<'a>(&'a mut ChipModel);

    impl ErrorType for ModelDevice<'_> {
        type Error = ErrorKind;
    }

    impl SpiDevice for ModelDevice<'_> {
        fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
            let chip = &mut *self.0;
            chip.transfers += 1;
            if chip.miso == Miso::BusError {
                return Err(ErrorKind::Overrun);
            }
            let mut mosi = [0u8; 8];
            let mut n = 0;
            for op in operations.iter() {
                let len = match op {
                    Operation::Write(w) => {
                        mosi[n..n + w.len()].copy_from_slice(w);
                        w.len()
                    }
                    Operation::Read(r) => r.len(),
                    _ => 0,
                };
                n += len;
            }
            let mut miso = [0u8; 8];
            chip.transfer(&mosi[..n], &mut miso[..n]);
            if let Miso::Stuck(level) = chip.miso {
                miso = [level; 8];
            }
            let mut at = 0;
            for op in operations.iter_mut() {
                match op {
                    Operation::Write(w) => at += w.len(),
                    Operation::Read(r) => {
                        let len = r.len();
                        r.copy_from_slice(&miso[at..at + len]);
                        at += len;
                    }
                    _ => {}
                }
            }
            Ok(())
        }
    }

    #[test]
    fn set_up_writes_x4_free_running_two_bytes_and_clears_the_count() {
        let mut chip = ChipModel::new(Miso::Chip);
        chip.cntr = 0xDEAD_BEEF;
        Ls7366r::new(ModelDevice(&mut chip)).configure().expect("a working chip");
        assert_eq!((chip.mdr0, chip.mdr1), (0b11, 0b10), "x4 quadrature; 2-byte counter, counting");
        assert_eq!((chip.cntr, chip.str_), (0, 0));
        assert_eq!(chip.bytes(), 2);
    }

    #[test]
    fn an_absent_or_miswired_chip_fails_its_set_up() {
        for level in [0x00, 0xFF] {
            let mut chip = ChipModel::new(Miso::Stuck(level));
            let error = Ls7366r::new(ModelDevice(&mut chip)).configure();
            assert_eq!(error, Err(Ls7366rError::NotConfigured { mdr0: level, mdr1: level }));
        }
        let mut chip = ChipModel::new(Miso::BusError);
        let error = Ls7366r::new(ModelDevice(&mut chip)).configure();
        assert_eq!(error, Err(Ls7366rError::Spi(ErrorKind::Overrun)));
        assert_eq!(chip.transfers, 1, "stops at the first failed transfer");
    }

    #[test]
    fn a_count_is_the_counters_low_sixteen_bits_msb_first() {
        let mut chip = ChipModel::new(Miso::Chip);
        let mut counter = Ls7366r::new(ModelDevice(&mut chip));
        counter.configure().unwrap();
        let chip = counter.release().0;
        for (turn, expected) in [(0x1234, 0x1234u16), (-0x1235, 0xFFFF), (2, 1), (-2, 0xFFFF)] {
            chip.turn(turn);
            let mut counter = Ls7366r::new(ModelDevice(&mut *chip));
            assert_eq!(counter.count(), Ok(expected));
        }
    }

    struct Duty;
    impl PwmErrorType for Duty {
        type Error = Infallible;
    }
    impl SetDutyCycle for Duty {
        fn max_duty_cycle(&self) -> u16 {
            1000
        }
        fn set_duty_cycle(&mut self, _: u16) -> Result<(), Infallible> {
            Ok(())
        }
    }
    struct Pin;
    impl PinErrorType for Pin {
        type Error = Infallible;
    }
    impl OutputPin for Pin {
        fn set_low(&mut self) -> Result<(), Infallible> {
            Ok(())
        }
        fn set_high(&mut self) -> Result<(), Infallible> {
            Ok(())
        }
    }

    proptest! {
        /// Eight chips behind `DirectDrives`: after any motion (each step
        /// under the 32 767 counts the extension allows) every cable's
        /// reading is its true 64-bit count modulo 2^32, and its speed the
        /// last step times the read rate; the 16-bit counters wrap many
        /// times on the way.
        #[test]
        fn eight_chips_read_through_direct_drives_follow_the_true_counts(
            steps in proptest::collection::vec(proptest::array::uniform8(-32_000i32..32_000), 1..200),
        ) {
            let mut chips: [ChipModel; CABLES] = core::array::from_fn(|_| ChipModel::new(Miso::Chip));
            let mut truth = [0i64; CABLES];
            let mut reached = 0usize;
            let devices = chips.each_mut().map(|c| {
                let mut counter = Ls7366r::new(ModelDevice(c));
                counter.configure().unwrap();
                counter
            });
            let pwm = PwmDrives::new(core::array::from_fn(|_| Duty), core::array::from_fn(|_| Pin), Pin, 1.0);
            let mut drives = DirectDrives::new(pwm, devices, 1000);
            let mut readings = [WinchReading::default(); CABLES];
            drives.read(&mut readings).unwrap();
            for step in &steps {
                // The model is behind the drives' devices: turn it through them.
                for (counter, &d) in drives.counters_mut().iter_mut().zip(step) {
                    counter.spi.0.turn(d);
                }
                for (t, &d) in truth.iter_mut().zip(step) {
                    *t += i64::from(d);
                }
                drives.read(&mut readings).unwrap();
                for i in 0..CABLES {
                    prop_assert_eq!(readings[i].counts, truth[i] as i32);
                    prop_assert_eq!(readings[i].counts_per_second, step[i] * 1000);
                    reached += 1;
                }
            }
            prop_assert_eq!(reached, steps.len() * CABLES);
        }
    }
}
