//! A winch drive's own fault (what `WinchDrives::drive_fault` reports):
//! Fault `drive` from any state, named in telemetry until a granted
//! `ClearFault`, which the drives are told of (`clear_faults`).

use crate::common;

use cdpr_control::protocol::{DriveFault, DriveFaultCause, HostMessage, Reason, Setpoint, State};
use cdpr_control::{NoClock, WinchDrives, WinchReading};

const POSE: [f32; 6] = [0.1, -0.2, 1.9, 0.02, -0.01, 0.05];

/// Ideal drives that report `read_fault` from `read` and `apply_fault`
/// from `apply` when set, and count `clear_faults`.
struct FaultyDrives {
    ideal: common::IdealDrives,
    read_fault: Option<DriveFault>,
    apply_fault: Option<DriveFault>,
    cleared: u32,
}

#[derive(Debug)]
enum Failure {
    Drive(DriveFault),
}

impl WinchDrives for FaultyDrives {
    type Error = Failure;
    fn apply(&mut self, torques: &[f32; 8]) -> Result<(), Failure> {
        let _ = self.ideal.apply(torques);
        self.apply_fault.map_or(Ok(()), |f| Err(Failure::Drive(f)))
    }
    fn set_brakes(&mut self, engaged: bool) -> Result<(), Failure> {
        let _ = self.ideal.set_brakes(engaged);
        Ok(())
    }
    fn read(&mut self, readings: &mut [WinchReading; 8]) -> Result<(), Failure> {
        let _ = self.ideal.read(readings);
        self.read_fault.map_or(Ok(()), |f| Err(Failure::Drive(f)))
    }
    fn failed_drive(&self, error: &Failure) -> Option<usize> {
        let Failure::Drive(f) = error;
        Some(usize::from(f.drive))
    }
    fn drive_fault(&self, error: &Failure) -> Option<DriveFault> {
        let Failure::Drive(f) = error;
        Some(*f)
    }
    fn clear_faults(&mut self) {
        self.cleared += 1;
        self.read_fault = None;
        self.apply_fault = None;
    }
}

const OVER_CURRENT: DriveFault = DriveFault { drive: 5, cause: DriveFaultCause::Emergency, code: 0x2310 };
const MISSING: DriveFault = DriveFault { drive: 2, cause: DriveFaultCause::MissingPdo, code: 3 };

fn setpoint(seq: u32) -> HostMessage {
    HostMessage::Setpoint(Setpoint { seq, pose: POSE, velocity: [0.0; 6], acceleration: [0.0; 6] })
}

fn rig() -> (cdpr_control::ControlLoop, FaultyDrives) {
    let mut control = common::control_loop();
    control.receive(HostMessage::TelemetryPeriod(1));
    let readings = common::readings_at(&control, POSE);
    let mut drives = FaultyDrives {
        ideal: common::IdealDrives { readings },
        read_fault: None,
        apply_fault: None,
        cleared: 0,
    };
    common::home(&mut control, &mut drives, POSE);
    (control, drives)
}

/// [`rig`], Enabled at `POSE` with setpoint 1.
fn enabled() -> (cdpr_control::ControlLoop, FaultyDrives) {
    let (mut control, mut drives) = rig();
    control.receive(setpoint(1));
    control.receive(HostMessage::Enable);
    assert_eq!(control.step(&NoClock, &mut drives, false).state, State::Enabled);
    (control, drives)
}

#[test]
fn a_drive_fault_while_enabled_faults_and_names_the_drive_until_cleared() {
    let (mut control, mut drives) = enabled();
    drives.read_fault = Some(OVER_CURRENT);
    control.receive(setpoint(2));
    let r = control.step(&NoClock, &mut drives, false);
    assert_eq!((r.state, r.reason), (State::Fault, Reason::Drive));
    assert!(r.brakes, "brakes engaged on the fault");
    let t = r.telemetry.expect("telemetry every cycle");
    assert_eq!(t.drive_fault, Some(OVER_CURRENT));
    assert_eq!(t.unreadable_drive, Some(5));
    // A second fault does not replace the first.
    drives.read_fault = Some(MISSING);
    let r = control.step(&NoClock, &mut drives, false);
    assert_eq!(r.drive_fault, Some(OVER_CURRENT));
    // ClearFault once the ramp is over: the drives are told, the fault forgotten.
    for _ in 0..cdpr_control::supervisor::SafetyLimits::DEFAULT.ramp_cycles + 1 {
        control.step(&NoClock, &mut drives, false);
    }
    assert_eq!(drives.cleared, 0);
    control.receive(HostMessage::ClearFault);
    let r = control.step(&NoClock, &mut drives, false);
    assert_eq!(r.state, State::Disabled);
    assert_eq!(drives.cleared, 1);
    assert_eq!(r.drive_fault, None);
    assert_eq!(r.telemetry.and_then(|t| t.drive_fault), None);
}

#[test]
fn a_drive_fault_while_disabled_is_a_fault_too() {
    let (mut control, mut drives) = rig();
    drives.read_fault = Some(MISSING);
    let r = control.step(&NoClock, &mut drives, false);
    assert_eq!((r.state, r.reason), (State::Fault, Reason::Drive));
    assert_eq!(r.drive_fault, Some(MISSING));
    assert!(!control.homed(), "the homing is forgotten with the drive");
}

#[test]
fn a_drive_fault_on_the_write_is_drive_not_output() {
    let (mut control, mut drives) = enabled();
    drives.apply_fault = Some(OVER_CURRENT);
    control.receive(setpoint(2));
    let r = control.step(&NoClock, &mut drives, false);
    assert_eq!((r.state, r.reason), (State::Fault, Reason::Drive));
    assert_eq!(r.drive_fault, Some(OVER_CURRENT));
}
