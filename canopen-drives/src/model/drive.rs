//! A CiA 402 servo drive in cyclic synchronous torque mode, at frame
//! level, written from CiA 301 (NMT, heartbeat, SDO, PDO, SYNC, EMCY) and
//! CiA 402 (the device state machine, the objects 0x6040, 0x6041, 0x6060,
//! 0x6064, 0x6071, 0x6072, 0x6076, 0x6007): what the board's layer is
//! tested against. The motor is the simulator's: it sets the position
//! ([`SimDrive::set_position`]) and takes the torque
//! ([`SimDrive::torque_nm`]) and the brake ([`SimDrive::brake_engaged`]).

use super::FrameSink;
use crate::cia402::DriveState;
use crate::frame::RawFrame;

/// The NMT state (CiA 301 heartbeat values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Nmt {
    /// Not powered, or initialising.
    Initialising,
    /// SDO only.
    PreOperational,
    /// PDOs too.
    Operational,
    /// NMT and heartbeat only.
    Stopped,
}

impl Nmt {
    fn heartbeat(self) -> u8 {
        match self {
            Nmt::Initialising => 0x00,
            Nmt::PreOperational => 0x7F,
            Nmt::Operational => 0x05,
            Nmt::Stopped => 0x04,
        }
    }
}

/// Misbehaviour a test switches on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SimDriveFaults {
    /// Off the bus: receives and sends nothing (a cut cable, no power).
    pub silent: bool,
    /// Sends no TPDO (its process data stopped).
    pub no_tpdo: bool,
    /// Answers no SDO.
    pub ignore_sdo: bool,
    /// Sends no heartbeat.
    pub no_heartbeat: bool,
    /// Refuses mode of operation 10 (a drive without torque mode).
    pub no_torque_mode: bool,
    /// Acknowledges mode of operation 10 but stays in its mode (a drive
    /// whose firmware does not apply it).
    pub mode_unapplied: bool,
    /// Aborts every write to this object (index, sub-index) with 0x0609_0030
    /// (value range exceeded).
    pub refuse_write: Option<(u16, u8)>,
    /// Ignores the controlword (stays where it is).
    pub stuck_state: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Pdo {
    cob: u32,
    kind: u8,
    count: u8,
    map: [u32; 4],
    event_ms: u16,
}

impl Pdo {
    const INVALID: Self = Self { cob: 0x8000_0000, kind: 255, count: 0, map: [0; 4], event_ms: 0 };
    fn valid(&self) -> bool {
        self.cob & 0x8000_0000 == 0
    }
    fn bytes(&self) -> usize {
        self.map[..usize::from(self.count.min(4))].iter().map(|m| (m & 0xFF) as usize / 8).sum()
    }
}

/// One drive.
#[derive(Debug, Clone)]
pub struct SimDrive {
    /// Node id.
    pub node: u8,
    /// Rated torque 0x6076, mN m.
    pub rated_torque_mnm: u32,
    /// Misbehaviour switched on.
    pub faults: SimDriveFaults,
    nmt: Nmt,
    state: DriveState,
    heartbeat_ms: u16,
    abort_option: u16,
    mode: u8,
    max_torque: u16,
    rpdo: [Pdo; 2],
    tpdo: [Pdo; 2],
    controlword: u16,
    pending_torque: i16,
    target_torque: i16,
    position: i32,
    last_heartbeat_ns: u64,
    last_status_ns: u64,
    sent_status: Option<u16>,
    /// EMCY frames sent.
    pub emcy_sent: u32,
    /// RPDOs of the wrong length received (each answered by EMCY 0x8210).
    pub bad_pdo: u32,
    /// SYNCs seen while operational.
    pub syncs: u32,
    /// The time of the last SYNC, ns.
    pub last_sync_ns: u64,
    /// When RPDO1 last came while operational (its timeout is armed by the
    /// first), ns.
    last_rpdo_ns: Option<u64>,
    /// RPDO timeouts seen (each an EMCY 0x8250 and the 0x6007 reaction).
    pub rpdo_timeouts: u32,
    /// When it last left "operation enabled", ns.
    disabled_at: Option<u64>,
    was_enabled: bool,
    /// The time of the last frame or tick, ns.
    now_ns: u64,
}

impl SimDrive {
    /// How long the drive keeps the torque after leaving "operation
    /// enabled" (its brake's engagement time): 20 ms, the plant's.
    pub const BRAKE_DELAY_NS: u64 = 20_000_000;

    /// A drive with node id `node` and rated torque `rated_torque_mnm`,
    /// not powered yet.
    pub fn new(node: u8, rated_torque_mnm: u32) -> Self {
        Self {
            node,
            rated_torque_mnm,
            faults: SimDriveFaults::default(),
            nmt: Nmt::Initialising,
            state: DriveState::NotReadyToSwitchOn,
            heartbeat_ms: 0,
            abort_option: 1,
            mode: 0,
            max_torque: 1000,
            rpdo: [Pdo::INVALID; 2],
            tpdo: [Pdo::INVALID; 2],
            controlword: 0,
            pending_torque: 0,
            target_torque: 0,
            position: 0,
            last_heartbeat_ns: 0,
            last_status_ns: 0,
            sent_status: None,
            emcy_sent: 0,
            bad_pdo: 0,
            syncs: 0,
            last_sync_ns: 0,
            last_rpdo_ns: None,
            rpdo_timeouts: 0,
            disabled_at: None,
            was_enabled: false,
            now_ns: 0,
        }
    }

    /// NMT state.
    pub fn nmt(&self) -> Nmt {
        self.nmt
    }

    /// CiA 402 state.
    pub fn state(&self) -> DriveState {
        self.state
    }

    /// The mode of operation 0x6060.
    pub fn mode(&self) -> u8 {
        self.mode
    }

    /// The heartbeat producer time 0x1017, ms.
    pub fn heartbeat_ms(&self) -> u16 {
        self.heartbeat_ms
    }

    /// The max torque 0x6072, thousandths of rated.
    pub fn max_torque(&self) -> u16 {
        self.max_torque
    }

    /// The target torque in effect (applied at the last SYNC),
    /// thousandths of rated.
    pub fn target_torque(&self) -> i16 {
        self.target_torque
    }

    /// The motor's position, counts (0x6064).
    pub fn set_position(&mut self, counts: i32) {
        self.position = counts;
    }

    /// The torque the motor makes at `now_ns`, N m: the target within the
    /// max torque in "operation enabled", and for [`SimDrive::BRAKE_DELAY_NS`]
    /// after leaving it other than by a fault (the drive holds the load
    /// while its brake engages, as servo drives with a brake output do);
    /// zero otherwise.
    pub fn torque_nm(&self, now_ns: u64) -> f64 {
        let holding = matches!(self.disabled_at, Some(t) if now_ns < t + Self::BRAKE_DELAY_NS);
        let held = holding && !self.state.is_fault();
        if self.state != DriveState::OperationEnabled && !held {
            return 0.0;
        }
        let m = i32::from(self.max_torque.min(i16::MAX as u16));
        let t = i32::from(self.target_torque).clamp(-m, m);
        f64::from(t) / 1000.0 * f64::from(self.rated_torque_mnm) / 1000.0
    }

    /// Whether its holding brake is engaged: everywhere but "operation
    /// enabled".
    pub fn brake_engaged(&self) -> bool {
        self.state != DriveState::OperationEnabled
    }

    /// Powers the drive at `now_ns`: its boot-up, then pre-operational.
    pub fn power_on(&mut self, now_ns: u64, out: &mut impl FrameSink) {
        self.reset_communication();
        self.state = DriveState::SwitchOnDisabled;
        self.boot(now_ns, out);
    }

    fn reset_communication(&mut self) {
        self.heartbeat_ms = 0;
        self.rpdo = [Pdo::INVALID; 2];
        self.tpdo = [Pdo::INVALID; 2];
        self.sent_status = None;
    }

    fn boot(&mut self, now_ns: u64, out: &mut impl FrameSink) {
        self.leave_operational();
        self.nmt = Nmt::PreOperational;
        self.last_heartbeat_ns = now_ns;
        if !self.faults.silent {
            out.push(RawFrame::new(0x700 + u16::from(self.node), &[0x00]));
        }
    }

    /// A fault of the drive (over-current, over-temperature, ...): the
    /// state machine to "fault", an EMCY with `code`, the statusword sent
    /// on change.
    pub fn fail(&mut self, code: u16, out: &mut impl FrameSink) {
        self.state = DriveState::Fault;
        self.emcy(code, out);
    }

    fn emcy(&mut self, code: u16, out: &mut impl FrameSink) {
        if self.faults.silent || matches!(self.nmt, Nmt::Initialising | Nmt::Stopped) {
            return;
        }
        let c = code.to_le_bytes();
        out.push(RawFrame::new(0x080 + u16::from(self.node), &[c[0], c[1], 0x01, 0, 0, 0, 0, 0]));
        self.emcy_sent += 1;
    }

    fn leave_operational(&mut self) {
        self.last_rpdo_ns = None;
        // Abort connection option 0x6007: 3 = quick stop, 2 = disable
        // voltage, 1 = fault; the drive leaves "operation enabled".
        if self.nmt == Nmt::Operational && self.state == DriveState::OperationEnabled {
            self.state = match self.abort_option {
                1 => DriveState::Fault,
                _ => DriveState::SwitchOnDisabled,
            };
        }
    }

    /// Timed frames at `now_ns`: the heartbeat every producer time, the
    /// statusword TPDO by its event timer.
    pub fn tick(&mut self, now_ns: u64, out: &mut impl FrameSink) {
        self.now_ns = now_ns;
        self.note_state();
        if self.nmt == Nmt::Initialising {
            return;
        }
        // RPDO1's timeout (CiA 301's RPDO event timer): no target torque for
        // that long is a lost connection.
        let timeout = u64::from(self.rpdo[0].event_ms) * 1_000_000;
        if let Some(last) = self.last_rpdo_ns {
            if self.nmt == Nmt::Operational && timeout > 0 && now_ns > last + timeout {
                self.last_rpdo_ns = None;
                self.rpdo_timeouts += 1;
                self.emcy(0x8250, out);
                self.leave_operational();
            }
        }
        self.note_state();
        // Off the bus, a drive still times out (above) but sends nothing.
        if self.faults.silent {
            return;
        }
        let hb = u64::from(self.heartbeat_ms) * 1_000_000;
        if hb > 0 && now_ns >= self.last_heartbeat_ns + hb {
            self.last_heartbeat_ns = now_ns;
            if !self.faults.no_heartbeat {
                out.push(RawFrame::new(0x700 + u16::from(self.node), &[self.nmt.heartbeat()]));
            }
        }
        let status = self.state.statusword();
        let t = self.tpdo[1];
        if self.nmt == Nmt::Operational && t.valid() && t.kind >= 254 {
            let timer = u64::from(t.event_ms) * 1_000_000;
            if self.sent_status != Some(status) || (timer > 0 && now_ns >= self.last_status_ns + timer) {
                self.send_tpdo(1, now_ns, out);
            }
        }
    }

    fn note_state(&mut self) {
        if self.state == DriveState::OperationEnabled {
            self.disabled_at = None;
        } else if self.disabled_at.is_none() && self.was_enabled {
            self.disabled_at = Some(self.now_ns);
        }
        self.was_enabled = self.state == DriveState::OperationEnabled;
    }

    /// A frame on the bus, delivered at `now_ns`; answers into `out`.
    pub fn receive(&mut self, frame: &RawFrame, now_ns: u64, out: &mut impl FrameSink) {
        self.now_ns = now_ns;
        if self.faults.silent || self.nmt == Nmt::Initialising {
            return;
        }
        let n = u16::from(self.node);
        let data = frame.bytes();
        if frame.id == 0x000 {
            if data.len() == 2 && (data[1] == 0 || data[1] == self.node) {
                self.nmt_command(data[0], now_ns, out);
            }
            return;
        }
        if frame.id == 0x080 && self.nmt == Nmt::Operational {
            self.sync(now_ns, out);
            return;
        }
        if frame.id == 0x600 + n && data.len() == 8 && self.nmt != Nmt::Stopped {
            if !self.faults.ignore_sdo {
                let answer = self.sdo(data);
                out.push(RawFrame::new(0x580 + n, &answer));
            }
            return;
        }
        if self.nmt == Nmt::Operational {
            for k in 0..2 {
                let p = self.rpdo[k];
                if p.valid() && u32::from(frame.id) == p.cob & 0x7FF {
                    if k == 0 {
                        self.last_rpdo_ns = Some(now_ns);
                    }
                    if data.len() != p.bytes() {
                        self.bad_pdo += 1;
                        // PDO not processed due to length error.
                        self.emcy(0x8210, out);
                        return;
                    }
                    self.rpdo_data(k, data, out);
                }
            }
        }
        self.tick(now_ns, out);
    }

    fn nmt_command(&mut self, command: u8, now_ns: u64, out: &mut impl FrameSink) {
        match command {
            0x01 => self.nmt = Nmt::Operational,
            0x02 => {
                self.leave_operational();
                self.nmt = Nmt::Stopped;
            }
            0x80 => {
                self.leave_operational();
                self.nmt = Nmt::PreOperational;
            }
            0x81 => {
                // Reset node: the application too.
                self.leave_operational();
                self.reset_communication();
                self.mode = 0;
                self.max_torque = 1000;
                self.abort_option = 1;
                if !self.state.is_fault() {
                    self.state = DriveState::SwitchOnDisabled;
                }
                self.boot(now_ns, out);
            }
            0x82 => {
                self.reset_communication();
                self.boot(now_ns, out);
            }
            _ => {}
        }
    }

    fn sync(&mut self, now_ns: u64, out: &mut impl FrameSink) {
        self.syncs += 1;
        self.last_sync_ns = now_ns;
        for k in 0..2 {
            if self.rpdo[k].valid() && self.rpdo[k].kind <= 240 && self.rpdo[k].map[0] >> 16 == 0x6071 {
                self.target_torque = self.pending_torque;
            }
        }
        for k in 0..2 {
            let t = self.tpdo[k];
            if t.valid() && (1..=240).contains(&t.kind) && !self.faults.no_tpdo {
                self.send_tpdo(k, now_ns, out);
            }
        }
    }

    fn send_tpdo(&mut self, k: usize, now_ns: u64, out: &mut impl FrameSink) {
        let t = self.tpdo[k];
        let mut data = [0u8; 8];
        let mut len = 0;
        for m in &t.map[..usize::from(t.count.min(4))] {
            let bytes: &[u8] = match m >> 8 {
                0x60_6400 => &self.position.to_le_bytes(),
                0x60_4100 => &self.state.statusword().to_le_bytes(),
                _ => &[],
            };
            let end = (len + bytes.len()).min(8);
            data[len..end].copy_from_slice(&bytes[..end - len]);
            len = end;
        }
        if k == 1 {
            self.sent_status = Some(self.state.statusword());
            self.last_status_ns = now_ns;
        }
        if self.faults.no_tpdo && k == 0 {
            return;
        }
        out.push(RawFrame::new((t.cob & 0x7FF) as u16, &data[..len]));
    }

    fn rpdo_data(&mut self, k: usize, data: &[u8], out: &mut impl FrameSink) {
        let p = self.rpdo[k];
        let mut at = 0;
        for m in &p.map[..usize::from(p.count.min(4))] {
            let size = (m & 0xFF) as usize / 8;
            let Some(bytes) = data.get(at..at + size) else { return };
            at += size;
            match (m >> 16, size) {
                (0x6071, 2) => {
                    let t = i16::from_le_bytes([bytes[0], bytes[1]]);
                    if p.kind <= 240 {
                        self.pending_torque = t;
                    } else {
                        self.target_torque = t;
                    }
                }
                (0x6040, 2) => self.control(u16::from_le_bytes([bytes[0], bytes[1]]), out),
                _ => {}
            }
        }
    }

    /// The device state machine on a controlword (CiA 402 transitions 2-16).
    fn control(&mut self, cw: u16, _out: &mut impl FrameSink) {
        let previous = self.controlword;
        self.controlword = cw;
        if self.faults.stuck_state {
            return;
        }
        use DriveState::*;
        let shutdown = cw & 0x87 == 0x06;
        let switch_on = cw & 0x8F == 0x07;
        let enable = cw & 0x8F == 0x0F;
        let disable_voltage = cw & 0x82 == 0x00;
        let quick_stop = cw & 0x86 == 0x02;
        self.state = match self.state {
            Fault if cw & 0x80 != 0 && previous & 0x80 == 0 => SwitchOnDisabled,
            SwitchOnDisabled if shutdown => ReadyToSwitchOn,
            ReadyToSwitchOn if switch_on => SwitchedOn,
            ReadyToSwitchOn | SwitchedOn if disable_voltage || quick_stop => SwitchOnDisabled,
            SwitchedOn if enable => OperationEnabled,
            SwitchedOn | OperationEnabled if shutdown => ReadyToSwitchOn,
            OperationEnabled if switch_on => SwitchedOn,
            OperationEnabled if disable_voltage => SwitchOnDisabled,
            // Quick stop: torque to zero, then switch on disabled (quick
            // stop option 2).
            OperationEnabled if quick_stop => SwitchOnDisabled,
            QuickStopActive if disable_voltage => SwitchOnDisabled,
            s => s,
        };
    }

    /// The SDO server: an expedited request's answer.
    fn sdo(&mut self, req: &[u8]) -> [u8; 8] {
        let index = u16::from_le_bytes([req[1], req[2]]);
        let sub = req[3];
        let abort = |code: u32| {
            let c = code.to_le_bytes();
            [0x80, req[1], req[2], sub, c[0], c[1], c[2], c[3]]
        };
        let cs = req[0];
        if cs == 0x40 {
            return match self.read(index, sub) {
                Ok((value, size)) => {
                    let v = value.to_le_bytes();
                    let command = match size {
                        1 => 0x4F,
                        2 => 0x4B,
                        _ => 0x43,
                    };
                    [command, req[1], req[2], sub, v[0], v[1], v[2], v[3]]
                }
                Err(code) => abort(code),
            };
        }
        // Expedited download with the size indicated: 0x2F, 0x2B, 0x27, 0x23.
        if cs & 0xE3 == 0x23 {
            let size = 4 - usize::from((cs >> 2) & 3);
            let mut v = [0u8; 4];
            v[..size].copy_from_slice(&req[4..4 + size]);
            return match self.write(index, sub, u32::from_le_bytes(v), size) {
                Ok(()) => [0x60, req[1], req[2], sub, 0, 0, 0, 0],
                Err(code) => abort(code),
            };
        }
        // Command specifier not valid or unknown.
        abort(0x0504_0001)
    }

    fn read(&self, index: u16, sub: u8) -> Result<(u32, usize), u32> {
        match (index, sub) {
            (0x6076, 0) => Ok((self.rated_torque_mnm, 4)),
            (0x6041, 0) => Ok((u32::from(self.state.statusword()), 2)),
            (0x6060 | 0x6061, 0) => Ok((u32::from(self.mode), 1)),
            (0x6064, 0) => Ok((self.position as u32, 4)),
            (0x1017, 0) => Ok((u32::from(self.heartbeat_ms), 2)),
            (0x6072, 0) => Ok((u32::from(self.max_torque), 2)),
            _ => Err(0x0602_0000),
        }
    }

    fn write(&mut self, index: u16, sub: u8, value: u32, size: usize) -> Result<(), u32> {
        let need = |s: usize| if size == s { Ok(()) } else { Err(0x0607_0010) };
        if self.faults.refuse_write == Some((index, sub)) {
            return Err(0x0609_0030);
        }
        match (index, sub) {
            (0x1017, 0) => need(2).map(|()| self.heartbeat_ms = value as u16),
            (0x6007, 0) => need(2).map(|()| self.abort_option = value as u16),
            (0x6060, 0) => {
                need(1)?;
                if value != 10 || self.faults.no_torque_mode {
                    return Err(0x0609_0030);
                }
                if !self.faults.mode_unapplied {
                    self.mode = value as u8;
                }
                Ok(())
            }
            (0x6072, 0) => need(2).map(|()| self.max_torque = value as u16),
            (0x6076, 0) | (0x6041, 0) | (0x6064, 0) => Err(0x0601_0002),
            (0x1400..=0x1401, _) | (0x1800..=0x1801, _) => {
                let rx = index < 0x1800;
                let k = usize::from(index & 1);
                let p = if rx { &mut self.rpdo[k] } else { &mut self.tpdo[k] };
                match sub {
                    1 => need(4).map(|()| p.cob = value),
                    2 => need(1).map(|()| p.kind = value as u8),
                    // A TPDO's event timer; an RPDO's is its timeout.
                    5 => need(2).map(|()| p.event_ms = value as u16),
                    _ => Err(0x0609_0011),
                }
            }
            (0x1600..=0x1601, _) | (0x1A00..=0x1A01, _) => {
                let rx = index < 0x1A00;
                let k = usize::from(index & 1);
                let p = if rx { &mut self.rpdo[k] } else { &mut self.tpdo[k] };
                if p.valid() {
                    // The mapping changes only while the PDO is invalid.
                    return Err(0x0800_0022);
                }
                match sub {
                    0 => {
                        need(1)?;
                        if value > 4 {
                            return Err(0x0609_0031);
                        }
                        p.count = value as u8;
                        Ok(())
                    }
                    1..=4 => {
                        need(4)?;
                        let mappable = if rx {
                            matches!(value, 0x6071_0010 | 0x6040_0010)
                        } else {
                            matches!(value, 0x6064_0020 | 0x6041_0010)
                        };
                        if !mappable {
                            return Err(0x0604_0041);
                        }
                        p.map[usize::from(sub - 1)] = value;
                        Ok(())
                    }
                    _ => Err(0x0609_0011),
                }
            }
            _ => Err(0x0602_0000),
        }
    }
}
