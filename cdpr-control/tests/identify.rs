//! `Identify` (tag 8): accepted in every state, counted, remembered until
//! the caller (which knows the robot it was built for) takes it, and it
//! changes nothing else.

use crate::common;

use cdpr_control::protocol::{encode, HostMessage, State, MAX_FRAME};
use cdpr_control::supervisor::SafetyLimits;
use cdpr_control::ControlLoop;
use tension_core::Method;

#[test]
fn identify_is_remembered_until_taken() {
    let mut control = ControlLoop::new(
        common::suspended8(),
        Method::Barycenter,
        common::setpoint_range(),
        SafetyLimits::DEFAULT,
    )
    .unwrap();
    assert!(!control.take_identify());
    let mut frame = [0u8; MAX_FRAME];
    let n = encode(&HostMessage::Identify, &mut frame).unwrap();
    // Two requests before the answer: one answer.
    for _ in 0..2 {
        for &b in &frame[..n] {
            control.receive_byte(b);
        }
    }
    assert_eq!(control.counters().accepted, 2);
    assert_eq!(control.counters().last_rejection.name(), "none");
    assert_eq!(control.supervisor().state(), State::Disabled);
    assert!(control.take_identify());
    assert!(!control.take_identify());
    control.receive(HostMessage::Identify);
    assert!(control.take_identify());
}
