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

/// `torque * per_nm` within `+-max` (and within `+-i16::MAX`), rounded half
/// away from zero; 0 for a non-finite torque.
pub fn permille_of(torque: f32, per_nm: f32, max: f32) -> i16 {
    let t = torque * per_nm;
    if !t.is_finite() {
        return 0;
    }
    // The limit within i16 first (a NaN limit is the widest), so that the
    // result needs no saturating conversion: through i32, the FPU's one
    // `vcvt` (truncating, as rounding half away from zero wants).
    let max = if max < 32_767.0 { max } else { 32_767.0 };
    // Comparisons, not `f32::clamp` (its check of the bounds' order and
    // NaN handling cost a cycle's worth of instructions for eight drives).
    let t = if t > max {
        max
    } else if t < -max {
        -max
    } else {
        t
    };
    (t + if t >= 0.0 { 0.5 } else { -0.5 }) as i32 as i16
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
    /// Read the modes of operation display 0x6061 (i8) and compare it with
    /// the mode written (10, cyclic synchronous torque): the drive runs in
    /// the mode the board commands in (CiA 402), not only acknowledged it.
    CheckMode,
    /// Read the rated torque 0x6076 (u32, mN m) and compare it with the
    /// robot file's.
    CheckRatedTorque,
}

impl ConfigStep {
    /// The object it writes or reads: index and sub-index (the SDO's
    /// multiplexer, which the drive's answer repeats).
    pub fn object(self) -> (u16, u8) {
        match self {
            ConfigStep::Write { index, sub, .. } => (index, sub),
            ConfigStep::CheckMode => (0x6061, 0),
            ConfigStep::CheckRatedTorque => (0x6076, 0),
        }
    }
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

/// The mode of operation the configuration writes to 0x6060 and checks
/// in 0x6061: cyclic synchronous torque (CiA 402).
pub const TORQUE_MODE: u8 = 10;

/// Steps of [`configuration`].
pub const CONFIG_STEPS: usize = 32;

/// The objects of [`configuration`]'s steps, in order (they do not depend
/// on the drive): what a drive's answer names, looked up without building
/// the steps.
pub const CONFIG_OBJECTS: [(u16, u8); CONFIG_STEPS] = [
    (0x1017, 0),
    (0x6007, 0),
    (0x6060, 0),
    (0x6072, 0),
    (0x1400, 1),
    (0x1600, 0),
    (0x1600, 1),
    (0x1600, 0),
    (0x1400, 2),
    (0x1400, 5),
    (0x1400, 1),
    (0x1401, 1),
    (0x1601, 0),
    (0x1601, 1),
    (0x1601, 0),
    (0x1401, 2),
    (0x1401, 1),
    (0x1800, 1),
    (0x1A00, 0),
    (0x1A00, 1),
    (0x1A00, 0),
    (0x1800, 2),
    (0x1800, 1),
    (0x1801, 1),
    (0x1A01, 0),
    (0x1A01, 1),
    (0x1A01, 0),
    (0x1801, 2),
    (0x1801, 5),
    (0x1801, 1),
    (0x6061, 0),
    (0x6076, 0),
];

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
/// transmission type set and then made valid; and last the reads of the
/// mode the drive runs in, 0x6061, and of the rated torque 0x6076.
pub fn configuration(config: &DriveConfig, timing: &Timing) -> [ConfigStep; CONFIG_STEPS] {
    let n = u32::from(config.node);
    let cob = |base: u16| u32::from(base) + n;
    [
        w16(0x1017, 0, u32::from(timing.heartbeat_ms)),
        w16(0x6007, 0, 3),
        w8(0x6060, 0, TORQUE_MODE as u32),
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
        // Then the mode the drive runs in and the rated torque, compared.
        ConfigStep::CheckMode,
        ConfigStep::CheckRatedTorque,
    ]
}

/// The loop delay the buses add to a control step, in ns, against drives
/// read and written directly at the step: the step reads at the start of
/// the cycle (`1e9 / cycle_hz` ns long) the positions of the last SYNC
/// and queues its frames `step_ns` later; on each bus the
/// `drives_per_bus` target torques (RPDO1, 2 bytes) go first, then the
/// SYNC (no data), at `bit_rate` bit/s with worst-case stuffing
/// ([`crate::frame::worst_case_bits`]). So
///
/// ```text
/// position age  = period - (step + n b_rpdo + b_sync) / rate
/// torque delay  = step + b_rpdo (n + 1) / (2 rate)     (the mean of the n receipts)
/// ```
///
/// and the sum is returned: 545 + 287.5 = 832.5 us for the board (a
/// 0.1 ms step, 4 drives a bus, 1 Mbit/s, 1 kHz), which `hal-sim`'s
/// simulated buses measure (`README.md`, "One cycle's timing"). The
/// task-space PID predicts over it (`cdpr_control::feedback::Prediction`).
pub const fn added_loop_delay_ns(step_ns: u32, drives_per_bus: u32, bit_rate: u32, cycle_hz: u32) -> u32 {
    let bit_rate = if bit_rate == 0 { 1 } else { bit_rate } as u64;
    let cycle_hz = if cycle_hz == 0 { 1 } else { cycle_hz } as u64;
    let rpdo = crate::frame::worst_case_bits(2) as u64;
    let n = drives_per_bus as u64;
    let period = 1_000_000_000 / cycle_hz;
    let age = period.saturating_sub(sync_end_ns(step_ns, drives_per_bus, bit_rate));
    let torque = step_ns as u64 + rpdo * (n + 1) * 1_000_000_000 / (2 * bit_rate);
    let total = age + torque;
    if total > u32::MAX as u64 {
        u32::MAX
    } else {
        total as u32
    }
}

/// When, in ns from the cycle's start, the last position of the cycle
/// (TPDO1, 4 bytes) has arrived on a bus: the step's frames queued
/// `step_ns` in, the `drives_per_bus` RPDO1s and the SYNC as in
/// [`added_loop_delay_ns`], then, `response_ns` after the SYNC, the
/// drives' TPDO1s back to back. The next cycle's `read` (one period from
/// the start) has every position only if this is at most the period.
/// (Heartbeats, every 100 ms, push it later; the layer then extrapolates
/// that drive's position for the cycle: `Node::reading`.)
pub const fn last_position_ns(step_ns: u32, drives_per_bus: u32, bit_rate: u32, response_ns: u32) -> u64 {
    let bit_rate = if bit_rate == 0 { 1 } else { bit_rate } as u64;
    let tpdos = drives_per_bus as u64 * crate::frame::worst_case_bits(4) as u64;
    sync_end_ns(step_ns, drives_per_bus, bit_rate) + response_ns as u64 + tpdos * 1_000_000_000 / bit_rate
}

/// When, in ns from the cycle's start, a bus's SYNC has gone out: the
/// step's frames queued `step_ns` in, the `drives_per_bus` RPDO1s (2
/// bytes) first, then the SYNC, at `bit_rate` (at least 1) bit/s with
/// worst-case stuffing.
const fn sync_end_ns(step_ns: u32, drives_per_bus: u32, bit_rate: u64) -> u64 {
    let rpdo = crate::frame::worst_case_bits(2) as u64;
    let sync = crate::frame::worst_case_bits(0) as u64;
    step_ns as u64 + (drives_per_bus as u64 * rpdo + sync) * 1_000_000_000 / bit_rate
}

/// [`added_loop_delay_ns`] of the board: its step's frames queued 0.1 ms
/// into the cycle, four drives a bus (the default split of eight), 1
/// Mbit/s, [`Timing::DEFAULT`]'s cycle rate: 832.5 us.
pub const BOARD_LOOP_DELAY_NS: u32 = added_loop_delay_ns(100_000, 4, 1_000_000, Timing::DEFAULT.cycle_hz);

/// The most drives one bus serves in a cycle of `cycle_hz`: the largest
/// count whose cycle's last position arrives before the next cycle's read
/// ([`last_position_ns`] within the period), with the step's frames queued
/// `step_ns` in and the drives answering the SYNC within `response_ns`.
pub const fn drives_per_bus_max(step_ns: u32, bit_rate: u32, cycle_hz: u32, response_ns: u32) -> u32 {
    let cycle_hz = if cycle_hz == 0 { 1 } else { cycle_hz } as u64;
    let period = 1_000_000_000 / cycle_hz;
    let mut n = 0;
    // Bounded: a bus has 127 node ids.
    while n < 127 && last_position_ns(step_ns, n + 1, bit_rate, response_ns) <= period {
        n += 1;
    }
    n
}

/// The board's [`drives_per_bus_max`]: 1 Mbit/s, [`Timing::DEFAULT`]'s
/// 1 kHz, a step as long as the 20 000-instruction budget at two cycles
/// an instruction at 168 MHz (238 us) and 20 us for the drives' answers: 4.
/// (Five drives' positions would be back 1.16 ms after the cycle's start,
/// 1.03 ms with a 0.1 ms step; the README's "Bus load" has the frames.)
pub const BOARD_DRIVES_PER_BUS: u32 =
    drives_per_bus_max(238_095, 1_000_000, Timing::DEFAULT.cycle_hz, 20_000);

/// A drive layout the board's buses cannot serve ([`check_layout`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LayoutError {
    /// Bus `bus` (0 CAN1, 1 CAN2) has `drives` drives, more than
    /// [`BOARD_DRIVES_PER_BUS`].
    Crowded {
        /// The bus, 0-based.
        bus: u8,
        /// Its drives.
        drives: u32,
    },
    /// A drive on a bus the board does not have (0-based index).
    NoSuchBus {
        /// The drive (cable index).
        drive: u8,
        /// Its bus, 0-based.
        bus: u8,
    },
}

impl core::fmt::Display for LayoutError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            LayoutError::Crowded { bus, drives } => write!(
                f,
                "CAN{} has {drives} drives; a bus serves at most {BOARD_DRIVES_PER_BUS} at 1 Mbit/s and 1 kHz \
                 (every position back before the next cycle), so spread them over both buses",
                u32::from(bus) + 1
            ),
            LayoutError::NoSuchBus { drive, bus } => write!(
                f,
                "cable {}'s drive is on CAN{}; the board has CAN1 and CAN2",
                u32::from(drive) + 1,
                u32::from(bus) + 1
            ),
        }
    }
}

/// Whether the board's two buses serve drives on `buses` (one 0-based bus
/// per drive): at most [`BOARD_DRIVES_PER_BUS`] on each. A crowded bus
/// brings its positions back after the next cycle's read, every cycle.
pub fn check_layout(buses: &[u8]) -> Result<(), LayoutError> {
    let mut count = [0u32; crate::drives::BUSES];
    for (drive, &bus) in buses.iter().enumerate() {
        match count.get_mut(usize::from(bus)) {
            Some(c) => *c += 1,
            None => return Err(LayoutError::NoSuchBus { drive: drive.min(255) as u8, bus }),
        }
    }
    for (bus, &drives) in count.iter().enumerate() {
        if drives > BOARD_DRIVES_PER_BUS {
            return Err(LayoutError::Crowded { bus: bus as u8, drives });
        }
    }
    Ok(())
}

#[cfg(test)]
mod object_tests {
    use super::*;

    #[test]
    fn the_object_table_is_the_configurations() {
        for config in [
            DriveConfig { bus: 0, node: 1, rated_torque: 0.64, torque_max: 2.5 },
            DriveConfig { bus: 1, node: 127, rated_torque: 3.0, torque_max: 0.1 },
        ] {
            let objects = configuration(&config, &Timing::DEFAULT).map(ConfigStep::object);
            assert_eq!(objects, CONFIG_OBJECTS);
        }
    }
}

#[cfg(test)]
mod delay_tests {
    use super::*;

    #[test]
    fn the_board_serves_four_drives_a_bus() {
        assert_eq!(BOARD_DRIVES_PER_BUS, 4);
        // By hand: 4 drives, a 238 us step: SYNC out at 238 + 4 x 75 + 55
        // = 593 us, positions back at 593 + 20 + 4 x 95 = 993 us; a fifth
        // drive: 238 + 430 + 20 + 475 = 1 163 us.
        assert_eq!(last_position_ns(238_095, 4, 1_000_000, 20_000), 993_095);
        assert_eq!(last_position_ns(238_095, 5, 1_000_000, 20_000), 1_163_095);
        // Slower buses and cycles: fewer and more.
        assert_eq!(drives_per_bus_max(238_095, 500_000, 1000, 20_000), 1);
        assert_eq!(drives_per_bus_max(100_000, 1_000_000, 500, 20_000), 10);
        assert_eq!(drives_per_bus_max(2_000_000, 1_000_000, 1000, 20_000), 0);
        assert_eq!(drives_per_bus_max(0, u32::MAX, 1, 0), 127);
    }

    #[test]
    fn layouts_the_buses_cannot_serve_are_refused_and_said() {
        assert_eq!(check_layout(&[0, 0, 0, 0, 1, 1, 1, 1]), Ok(()));
        assert_eq!(check_layout(&[1, 0, 1, 0, 1, 0, 1, 0]), Ok(()));
        assert_eq!(check_layout(&[0; 4]), Ok(()));
        assert_eq!(check_layout(&[]), Ok(()));
        assert_eq!(check_layout(&[0; 8]), Err(LayoutError::Crowded { bus: 0, drives: 8 }));
        assert_eq!(check_layout(&[0, 1, 1, 1, 1, 1, 0, 0]), Err(LayoutError::Crowded { bus: 1, drives: 5 }));
        assert_eq!(check_layout(&[0, 1, 2]), Err(LayoutError::NoSuchBus { drive: 2, bus: 2 }));
        let text = LayoutError::Crowded { bus: 0, drives: 8 }.to_string();
        assert!(text.starts_with("CAN1 has 8 drives; a bus serves at most 4"), "{text}");
        let text = LayoutError::NoSuchBus { drive: 2, bus: 2 }.to_string();
        assert_eq!(text, "cable 3's drive is on CAN3; the board has CAN1 and CAN2");
    }

    #[test]
    fn the_boards_added_loop_delay() {
        // SYNC ends 100 + 4 x 75 + 55 = 455 us in: positions 545 us old;
        // torques received at 175, 250, 325, 400 us: mean 287.5 us.
        assert_eq!(added_loop_delay_ns(100_000, 4, 1_000_000, 1000), 832_500);
        assert_eq!(BOARD_LOOP_DELAY_NS, 832_500);
    }

    /// The board's step is not 0.1 ms long: with the CiA 402 layer inside
    /// it takes 13 747 instructions (median) to 18 112 (worst) under QEMU
    /// (`CDPR_DEMO_CAN_LAYER=1 cargo xtask run --robot
    /// robots/ipanema1.toml`), 0.12-0.16 ms at 1.5 cycles an instruction
    /// at 168 MHz. What the positions lose in age the torques gain in
    /// delay, so the added loop delay the PID predicts over is the same;
    /// and the last position still arrives before the next read for any
    /// step within the 20 000-instruction budget at up to 2 cycles an
    /// instruction.
    #[test]
    fn a_longer_step_moves_the_schedule_not_the_delay() {
        for step_ns in [0, 100_000, 161_714, 238_095, 300_000] {
            assert_eq!(added_loop_delay_ns(step_ns, 4, 1_000_000, 1000), 832_500, "{step_ns}");
        }
        // The simulated bus's schedule (README, "One cycle's timing"):
        // SYNC over 0.455 ms in, 20 us of response, 4 x 95 us of TPDO1.
        assert_eq!(last_position_ns(100_000, 4, 1_000_000, 20_000), 855_000);
        // A step's length in ns at 168 MHz, from instructions and half
        // cycles an instruction.
        let ns = |instructions: u64, half_cycles: u64| {
            (instructions * half_cycles * 1_000_000_000 / 336_000_000) as u32
        };
        assert_eq!(ns(18_112, 3), 161_714);
        assert_eq!(last_position_ns(ns(18_112, 3), 4, 1_000_000, 20_000), 916_714);
        assert!(last_position_ns(ns(20_000, 4), 4, 1_000_000, 20_000) <= 1_000_000);
        // The margin: a step longer than 0.245 ms loses a position a cycle.
        assert!(last_position_ns(245_001, 4, 1_000_000, 20_000) > 1_000_000);
        assert!(last_position_ns(245_000, 4, 1_000_000, 20_000) <= 1_000_000);
    }
}

#[cfg(test)]
mod tests {
    use super::permille_of;
    use proptest::prelude::*;

    /// The f64 reference for a limit `max >= 0` or NaN: clamp to
    /// `+-min(max, 32767)` (a NaN limit: 32767), round half away from zero;
    /// 0 when `torque * per_nm` is not finite in f32.
    fn reference(torque: f32, per_nm: f32, max: f32) -> i16 {
        let t32 = torque * per_nm;
        if !t32.is_finite() {
            return 0;
        }
        let limit = if max.is_nan() { 32_767.0 } else { f64::from(max).min(32_767.0) };
        let t = f64::from(t32).clamp(-limit, limit);
        (t.signum() * (t.abs() + 0.5).floor()) as i16
    }

    proptest! {
        #[test]
        fn permille_is_the_clamped_product_rounded_half_away_from_zero(
            torque in prop_oneof![-200.0f32..200.0, any::<f32>()],
            per_nm in prop_oneof![0.0f32..5000.0, any::<f32>()],
            max in prop_oneof![0.0f32..40_000.0, Just(f32::NAN), Just(f32::INFINITY), Just(1e30f32)],
        ) {
            prop_assert_eq!(permille_of(torque, per_nm, max), reference(torque, per_nm, max));
        }
    }

    #[test]
    fn permille_rounds_half_away_from_zero_and_saturates() {
        assert_eq!(permille_of(1.5, 1.0, 100.0), 2);
        assert_eq!(permille_of(-1.5, 1.0, 100.0), -2);
        assert_eq!(permille_of(1.49, 1.0, 100.0), 1);
        assert_eq!(permille_of(1e6, 1.0, 1e9), i16::MAX);
        assert_eq!(permille_of(-1e6, 1.0, f32::NAN), -i16::MAX);
        assert_eq!(permille_of(f32::NAN, 1.0, 100.0), 0);
    }
}
