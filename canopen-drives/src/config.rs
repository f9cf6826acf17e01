//! What each drive is set to at start-up, and the layer's timing.

use crate::frame::{RPDO1, RPDO2, TPDO1, TPDO2};

/// One winch drive: where it is and what it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveConfig {
    /// Bus: 0 (CAN1) or 1 (CAN2).
    pub bus: u8,
    /// CANopen node id, 1..=127.
    pub node: u8,
    /// The motor's rated torque, N m (the drive's 0x6076, in mN m there):
    /// the target torque 0x6071 is written in thousandths of it.
    pub rated_torque: f32,
    /// The largest torque the control loop commands, N m (the robot file's
    /// `torque_max`): written to the drive's max torque 0x6072, so the drive
    /// limits it too.
    pub torque_max: f32,
}

impl DriveConfig {
    /// `torque` (N m) as a target torque in thousandths of the rated
    /// torque, rounded half away from zero, within
    /// `+-max_torque_permille`; 0 for a non-finite torque.
    pub fn permille(&self, torque: f32) -> i16 {
        permille_of(torque, self.permille_per_nm(), f32::from(self.max_torque_permille()))
    }

    /// Thousandths of the rated torque per N m (0 for a rated torque that
    /// is not positive and finite).
    pub fn permille_per_nm(&self) -> f32 {
        let k = 1000.0 / self.rated_torque;
        if k.is_finite() && k > 0.0 {
            k
        } else {
            0.0
        }
    }

    /// The drive's max torque 0x6072: `torque_max` in thousandths of the
    /// rated torque, rounded up (at most `i16::MAX`, which the robot file's
    /// check keeps it under).
    pub fn max_torque_permille(&self) -> u16 {
        let m = libm::ceilf(self.torque_max * 1000.0 / self.rated_torque);
        if m.is_finite() && m > 0.0 {
            m.min(f32::from(i16::MAX as u16)) as u16
        } else {
            0
        }
    }
}

/// `torque * per_nm` within `+-max`, rounded half away from zero (the
/// `as` cast truncates and saturates); 0 for a non-finite torque.
pub fn permille_of(torque: f32, per_nm: f32, max: f32) -> i16 {
    let t = torque * per_nm;
    if !t.is_finite() {
        return 0;
    }
    // Comparisons, not `f32::clamp` (its check of the bounds' order and
    // NaN handling cost a cycle's worth of instructions for eight drives).
    let t = if t > max {
        max
    } else if t < -max {
        -max
    } else {
        t
    };
    (t + if t >= 0.0 { 0.5 } else { -0.5 }) as i16
}

/// The layer's timing, in control cycles (one `WinchDrives::read` each,
/// 1 ms on the board) and in the drives' milliseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// A drive's boot-up must be seen this many cycles after the board's
    /// NMT reset (a drive powered after the board has this long too).
    pub boot_cycles: u32,
    /// An SDO response must arrive within this many cycles.
    pub sdo_cycles: u32,
    /// NMT start to the first heartbeat "operational" or position.
    pub start_cycles: u32,
    /// A CiA 402 transition asked for must show in the statusword within
    /// this many cycles.
    pub transition_cycles: u32,
    /// A drive that sends no position (TPDO1) for this many SYNCs in a row
    /// has dropped out.
    pub missing_pdo_cycles: u32,
    /// The drives' heartbeat producer time 0x1017, ms.
    pub heartbeat_ms: u16,
    /// No heartbeat for this many cycles is a heartbeat timeout (a
    /// consumer time of 2.5 producer periods).
    pub heartbeat_timeout_cycles: u32,
    /// The statusword TPDO's event timer (it is also sent on every
    /// change), ms.
    pub status_refresh_ms: u16,
    /// The drives' RPDO1 timeout (the RPDO's event timer 0x1400:05,
    /// CiA 301): a drive that receives no target torque for this long
    /// reacts as to a lost connection (0x6007 = 3: quick stop, brake), ms.
    /// The board then faults it too (a missing PDO or heartbeat).
    pub rpdo_timeout_ms: u16,
    /// Control cycles (SYNCs) per second: the speed from two positions is
    /// their difference times this over the cycles between them.
    pub cycle_hz: u32,
}

impl Timing {
    /// The board's timing: boot-up within 2 s, SDO answers within 20 ms,
    /// operational within 200 ms, transitions within 50 ms, 3 SYNCs without
    /// a position, heartbeats every 100 ms (timeout 250 ms), the statusword
    /// at least every 50 ms, the drives' RPDO timeout 5 ms, 1 kHz.
    pub const DEFAULT: Self = Self {
        boot_cycles: 2000,
        sdo_cycles: 20,
        start_cycles: 200,
        transition_cycles: 50,
        missing_pdo_cycles: 3,
        heartbeat_ms: 100,
        heartbeat_timeout_cycles: 250,
        status_refresh_ms: 50,
        rpdo_timeout_ms: 5,
        cycle_hz: 1000,
    };
}

/// One configuration step at start-up: an SDO write (expedited: 1, 2 or 4
/// bytes) or the read of the rated torque to compare.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConfigStep {
    /// Write `value` (`size` bytes, little endian) to `index:sub`.
    Write {
        /// Object index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// Bytes: 1, 2 or 4.
        size: u8,
        /// The value (its low `size` bytes).
        value: u32,
    },
    /// Read the rated torque 0x6076 (u32, mN m) and compare it with the
    /// robot file's.
    CheckRatedTorque,
}

const fn w8(index: u16, sub: u8, value: u32) -> ConfigStep {
    ConfigStep::Write { index, sub, size: 1, value }
}
const fn w16(index: u16, sub: u8, value: u32) -> ConfigStep {
    ConfigStep::Write { index, sub, size: 2, value }
}
const fn w32(index: u16, sub: u8, value: u32) -> ConfigStep {
    ConfigStep::Write { index, sub, size: 4, value }
}

/// Steps of [`configuration`].
pub const CONFIG_STEPS: usize = 31;

/// A PDO COB-ID with bit 31 set: the PDO is invalid while it is mapped
/// (CiA 301: the mapping may only change while it is).
const INVALID: u32 = 0x8000_0000;

/// What the board writes to drive `config` at start-up, in order (CiA 301
/// and CiA 402 objects):
/// 1. heartbeat producer time 0x1017 = `timing.heartbeat_ms`;
/// 2. abort connection option 0x6007 = 3 (a lost connection, e.g. an NMT
///    state change, quick stops the drive);
/// 3. mode of operation 0x6060 = 10 (cyclic synchronous torque);
/// 4. max torque 0x6072 (thousandths of the rated torque);
/// 5. RPDO1 = target torque 0x6071 (16 bits), asynchronous (type 255:
///    applied on receipt, 0.1-0.4 ms into the cycle; type 1 would hold it
///    to the SYNC, 0.45 ms, and the loop has no delay to spare: see the
///    crate's README), with its timeout `timing.rpdo_timeout_ms` (a drive
///    that hears no board quick stops by itself);
/// 6. RPDO2 = controlword 0x6040 (16 bits), asynchronous (type 255:
///    applied on receipt);
/// 7. TPDO1 = position actual 0x6064 (32 bits), sent after every SYNC
///    (type 1);
/// 8. TPDO2 = statusword 0x6041 (16 bits), on change (type 255) and by
///    the event timer `timing.status_refresh_ms`;
///
/// each PDO made invalid, its mapping cleared, written and counted, its
/// transmission type set and then made valid; and last the read of the
/// rated torque 0x6076.
pub fn configuration(config: &DriveConfig, timing: &Timing) -> [ConfigStep; CONFIG_STEPS] {
    let n = u32::from(config.node);
    let cob = |base: u16| u32::from(base) + n;
    [
        w16(0x1017, 0, u32::from(timing.heartbeat_ms)),
        w16(0x6007, 0, 3),
        w8(0x6060, 0, 10),
        w16(0x6072, 0, u32::from(config.max_torque_permille())),
        // RPDO1: target torque.
        w32(0x1400, 1, INVALID | cob(RPDO1)),
        w8(0x1600, 0, 0),
        w32(0x1600, 1, 0x6071_0010),
        w8(0x1600, 0, 1),
        w8(0x1400, 2, 255),
        w16(0x1400, 5, u32::from(timing.rpdo_timeout_ms)),
        w32(0x1400, 1, cob(RPDO1)),
        // RPDO2: controlword.
        w32(0x1401, 1, INVALID | cob(RPDO2)),
        w8(0x1601, 0, 0),
        w32(0x1601, 1, 0x6040_0010),
        w8(0x1601, 0, 1),
        w8(0x1401, 2, 255),
        w32(0x1401, 1, cob(RPDO2)),
        // TPDO1: position actual.
        w32(0x1800, 1, INVALID | cob(TPDO1)),
        w8(0x1A00, 0, 0),
        w32(0x1A00, 1, 0x6064_0020),
        w8(0x1A00, 0, 1),
        w8(0x1800, 2, 1),
        w32(0x1800, 1, cob(TPDO1)),
        // TPDO2: statusword.
        w32(0x1801, 1, INVALID | cob(TPDO2)),
        w8(0x1A01, 0, 0),
        w32(0x1A01, 1, 0x6041_0010),
        w8(0x1A01, 0, 1),
        w8(0x1801, 2, 255),
        w16(0x1801, 5, u32::from(timing.status_refresh_ms)),
        w32(0x1801, 1, cob(TPDO2)),
        // Then the rated torque, compared.
        ConfigStep::CheckRatedTorque,
    ]
}
