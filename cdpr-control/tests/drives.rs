//! The embedded-hal PWM adapter against mock channels and pins.

use std::cell::RefCell;
use std::rc::Rc;

use cdpr_control::drives::{duty_for, PwmDriveError, PwmDrives};
use cdpr_control::WinchDrives;
use embedded_hal::digital::{ErrorType as PinErrorType, OutputPin};
use embedded_hal::pwm::{ErrorType as PwmErrorType, SetDutyCycle};

#[derive(Clone, Default)]
struct Channel(Rc<RefCell<Option<u16>>>);

impl PwmErrorType for Channel {
    type Error = core::convert::Infallible;
}

impl SetDutyCycle for Channel {
    fn max_duty_cycle(&self) -> u16 {
        1000
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Self::Error> {
        *self.0.borrow_mut() = Some(duty);
        Ok(())
    }
}

#[derive(Clone, Default)]
struct Pin(Rc<RefCell<Option<bool>>>, bool);

impl PinErrorType for Pin {
    type Error = embedded_hal::digital::ErrorKind;
}

impl OutputPin for Pin {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        if self.1 {
            return Err(embedded_hal::digital::ErrorKind::Other);
        }
        *self.0.borrow_mut() = Some(false);
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Self::Error> {
        if self.1 {
            return Err(embedded_hal::digital::ErrorKind::Other);
        }
        *self.0.borrow_mut() = Some(true);
        Ok(())
    }
}

#[test]
fn duty_is_the_torque_fraction_of_full_scale() {
    assert_eq!(duty_for(1.25, 2.5, 1000), 500);
    assert_eq!(duty_for(-2.5, 2.5, 1000), 1000);
    assert_eq!(duty_for(0.001, 2.5, 1000), 0);
    assert_eq!(duty_for(0.0013, 2.5, 1000), 1); // 0.52 rounds up
    assert_eq!(duty_for(f32::NAN, 2.5, 1000), 0);
    assert_eq!(duty_for(1.0, 0.0, 1000), 0);
    assert_eq!(duty_for(9.0, 2.5, 1000), 1000, "never above full scale");
}

#[test]
fn torques_and_brake_reach_the_pins() {
    let channels: [Channel; 8] = Default::default();
    let directions: [Pin; 8] = Default::default();
    let brake = Pin::default();
    let mut drives = PwmDrives::new(channels.clone(), directions.clone(), brake.clone(), 2.5);
    let torques = [0.5, -0.5, 2.5, 0.0, 1.0, -2.0, 0.25, 2.4];
    drives.apply(&torques).unwrap();
    drives.set_brakes(true).unwrap();
    for i in 0..8 {
        let expected = (torques[i].abs() / 2.5 * 1000.0_f32).round() as u16;
        assert_eq!(*channels[i].0.borrow(), Some(expected), "channel {i}");
        assert_eq!(*directions[i].0.borrow(), Some(torques[i] < 0.0), "direction {i}");
    }
    assert_eq!(*brake.0.borrow(), Some(true));
    drives.set_brakes(false).unwrap();
    assert_eq!(*brake.0.borrow(), Some(false));
}

#[test]
fn pin_errors_are_reported() {
    let channels: [Channel; 8] = Default::default();
    let mut directions: [Pin; 8] = Default::default();
    directions[3].1 = true;
    let mut drives = PwmDrives::new(channels, directions, Pin(Default::default(), true), 2.5);
    assert_eq!(drives.apply(&[0.1; 8]), Err(PwmDriveError::Direction(3)));
    assert_eq!(drives.set_brakes(true), Err(PwmDriveError::Brake));
}

mod quadrature {
    use super::{Channel, Pin};
    use cdpr_control::drives::PwmDrives;
    use cdpr_control::quadrature::{DirectDriveError, DirectDrives, EncoderCounter, Extender};
    use cdpr_control::{WinchDrives, WinchReading};
    use std::cell::RefCell;
    use std::rc::Rc;

    /// A counter the test sets (`None`: unreadable).
    #[derive(Clone, Default)]
    struct Counter(Rc<RefCell<Option<u16>>>);

    impl EncoderCounter for Counter {
        type Error = ();
        fn count(&mut self) -> Result<u16, ()> {
            self.0.borrow().ok_or(())
        }
    }

    /// The extension against a 64-bit reference count, over random walks
    /// that wrap the 16-bit counter many times.
    #[test]
    fn the_extension_follows_a_wide_count_through_the_wraps() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut reached = 0;
        for walk in 0..200 {
            let mut truth: i64 = i64::from(walk * 997 % 65_536) - 32_768;
            let mut e = Extender::new();
            let first = e.update(truth as u16, 1000);
            let base = i64::from(first.counts) - truth;
            for _ in 0..500 {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                // Steps of up to +-30 000 counts a read (below the 32 767 limit).
                let step = (state % 60_001) as i64 - 30_000;
                truth += step;
                let r = e.update(truth as u16, 1000);
                assert_eq!(i64::from(r.counts), (truth + base) as i32 as i64, "walk {walk}");
                assert_eq!(i64::from(r.counts_per_second), step * 1000);
                reached += 1;
            }
        }
        assert_eq!(reached, 100_000);
    }

    #[test]
    fn direct_drives_read_every_counter_and_name_the_one_that_fails() {
        let channels: [Channel; 8] = Default::default();
        let directions: [Pin; 8] = Default::default();
        let counters: [Counter; 8] = Default::default();
        for (i, c) in counters.iter().enumerate() {
            *c.0.borrow_mut() = Some((65_530 + i as u32) as u16);
        }
        let pwm = PwmDrives::new(channels.clone(), directions, Pin::default(), 2.5);
        let mut drives = DirectDrives::new(pwm, counters.clone(), 1000);
        let mut r = [WinchReading::default(); 8];
        drives.read(&mut r).unwrap();
        assert_eq!(r[0].counts, -6);
        // Counter 3 passes 0xFFFF: +20 counts, no jump.
        *counters[3].0.borrow_mut() = Some(((65_530u32 + 3 + 20) % 65_536) as u16);
        drives.read(&mut r).unwrap();
        assert_eq!((r[3].counts, r[3].counts_per_second), (-3 + 20, 20_000));
        // An unreadable counter is named; the others are still read.
        *counters[5].0.borrow_mut() = None;
        *counters[6].0.borrow_mut() = Some(65_540u32 as u16);
        assert_eq!(drives.read(&mut r), Err(DirectDriveError::Counter(5)));
        assert_eq!(drives.failed_drive(&DirectDriveError::Counter(5)), Some(5));
        assert_eq!(r[6].counts, 4, "counter 6 read: from 0 (65 536) to 4");
        // Torques reach the PWM.
        drives.apply(&[1.25; 8]).unwrap();
        assert_eq!(*channels[0].0.borrow(), Some(500));
    }
}
