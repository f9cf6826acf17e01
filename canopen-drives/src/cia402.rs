//! The CiA 402 device control state machine (IEC 61800-7-201, the "Power
//! Drive System" finite state automaton): the state a statusword (0x6041)
//! shows and the controlword (0x6040) command of each transition.

/// A drive's state as its statusword shows it (bits 0-3, 5 and 6:
/// ready to switch on, switched on, operation enabled, fault, quick stop,
/// switch on disabled).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DriveState {
    /// `xxxx xxxx x0xx 0000`: the drive initialises.
    NotReadyToSwitchOn,
    /// `x1xx 0000`: no high voltage switched, waiting for `Shutdown`.
    SwitchOnDisabled,
    /// `x01x 0001`: ready; `Switch on` next.
    ReadyToSwitchOn,
    /// `x01x 0011`: power stage on, no torque; the brake holds.
    SwitchedOn,
    /// `x01x 0111`: the drive follows its targets (here: the torque).
    OperationEnabled,
    /// `x00x 0111`: the quick stop function runs.
    QuickStopActive,
    /// `x0xx 1111`: the drive reacts to a fault.
    FaultReactionActive,
    /// `x0xx 1000`: faulted; power off, brake engaged.
    Fault,
}

impl DriveState {
    /// The state a statusword shows (CiA 402's masks 0x4F and 0x6F).
    pub const fn of_statusword(sw: u16) -> Self {
        match sw & 0x4F {
            0x00 => DriveState::NotReadyToSwitchOn,
            0x40 => DriveState::SwitchOnDisabled,
            0x0F => DriveState::FaultReactionActive,
            0x08 => DriveState::Fault,
            _ => match sw & 0x6F {
                0x21 => DriveState::ReadyToSwitchOn,
                0x23 => DriveState::SwitchedOn,
                0x27 => DriveState::OperationEnabled,
                0x07 => DriveState::QuickStopActive,
                // A combination CiA 402 does not define: a fault bit
                // pattern unclear is treated as faulted.
                _ => DriveState::Fault,
            },
        }
    }

    /// The statusword bits of this state (what a drive model reports;
    /// the other bits zero except "voltage enabled" (4) where power is on).
    pub const fn statusword(self) -> u16 {
        match self {
            DriveState::NotReadyToSwitchOn => 0x0000,
            DriveState::SwitchOnDisabled => 0x0040,
            DriveState::ReadyToSwitchOn => 0x0021,
            DriveState::SwitchedOn => 0x0033,
            DriveState::OperationEnabled => 0x0037,
            DriveState::QuickStopActive => 0x0017,
            DriveState::FaultReactionActive => 0x001F,
            DriveState::Fault => 0x0008,
        }
    }

    /// Whether the state is a fault (or the reaction to one).
    pub const fn is_fault(self) -> bool {
        matches!(self, DriveState::Fault | DriveState::FaultReactionActive)
    }
}

/// Controlword commands (the bits 0-3 and 7 CiA 402 defines for each).
pub mod controlword {
    /// Switch on disabled / ready to switch on -> ready to switch on
    /// (transitions 2, 6, 8).
    pub const SHUTDOWN: u16 = 0x0006;
    /// Ready to switch on -> switched on (3); operation enabled -> switched
    /// on ("disable operation", 5): the same bits.
    pub const SWITCH_ON: u16 = 0x0007;
    /// Operation enabled -> switched on (5).
    pub const DISABLE_OPERATION: u16 = 0x0007;
    /// Switched on -> operation enabled (4; 16 from quick stop active).
    pub const ENABLE_OPERATION: u16 = 0x000F;
    /// Any powered state -> switch on disabled (7, 9, 10, 12).
    pub const DISABLE_VOLTAGE: u16 = 0x0000;
    /// Ready, switched on -> switch on disabled; operation enabled -> quick
    /// stop active (11).
    pub const QUICK_STOP: u16 = 0x0002;
    /// Fault -> switch on disabled (15), on this bit's rising edge.
    pub const FAULT_RESET: u16 = 0x0080;
}

/// Where the board wants a drive: its brake engaged and no torque
/// (`SwitchedOn`, power stage on, ready to enable in one transition) or
/// following the torque (`OperationEnabled`, brake released).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// "Switched on": the brake holds, no torque.
    Hold,
    /// "Operation enabled": torque control, brake released.
    Operate,
}

/// The controlword that moves a drive from `state` towards `target`, and
/// the state it should then show; `None` where it is there (or in a fault,
/// which only a fault reset leaves; or initialising, which the drive
/// leaves by itself).
pub const fn step_towards(state: DriveState, target: Target) -> Option<(u16, DriveState)> {
    use controlword::*;
    match (state, target) {
        (DriveState::SwitchOnDisabled, _) => Some((SHUTDOWN, DriveState::ReadyToSwitchOn)),
        (DriveState::ReadyToSwitchOn, _) => Some((SWITCH_ON, DriveState::SwitchedOn)),
        (DriveState::SwitchedOn, Target::Operate) => Some((ENABLE_OPERATION, DriveState::OperationEnabled)),
        (DriveState::OperationEnabled, Target::Hold) => Some((DISABLE_OPERATION, DriveState::SwitchedOn)),
        (DriveState::QuickStopActive, _) => Some((DISABLE_VOLTAGE, DriveState::SwitchOnDisabled)),
        _ => None,
    }
}
