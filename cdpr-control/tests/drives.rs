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
