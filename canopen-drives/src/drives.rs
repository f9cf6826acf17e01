//! [`CanDrives`]: the robot's winch drives on the board's two CAN buses as
//! `cdpr-control`'s [`WinchDrives`], and the emergency stop's frames.
//!
//! One control cycle on each bus (`read` at the step's start, `apply` at
//! its end; 1 ms, the step takes about 0.1 ms of it):
//!
//! 1. `read`: the frames received since the last cycle are taken from the
//!    port (at most [`RX_PER_CYCLE`]): the drives' positions sampled at the
//!    last SYNC (TPDO1), statuswords (TPDO2), heartbeats, EMCYs, SDO
//!    answers; each drive's checks and start-up frames follow;
//! 2. `set_brakes` + `apply`: per drive its RPDO2 when a CiA 402
//!    transition is due (controlword), its RPDO1 (target torque, applied on
//!    receipt), then one SYNC: the drives answer with their positions
//!    sampled at it.
//!
//! The ports must send in the order given (bxCAN: transmit FIFO priority,
//! `TXFP`): the SYNC after the RPDOs, or the torques would wait a cycle.

use cdpr_control::protocol::DriveFault;
use cdpr_control::{WinchDrives, WinchReading, CABLES};
use embedded_can::nb::Can;

use crate::cia402::{controlword, Target};
use crate::config::{DriveConfig, Timing};
use crate::frame::{standard_parts, RawFrame, EMCY, NMT, RPDO1, RPDO2, SYNC};
use crate::node::{Node, Outbox, Received, Stage};

/// Frames taken from a port per cycle at most (a bus carries at most 18
/// frames in 1 ms at 1 Mbit/s, 55 bits each at the least: the bound keeps
/// `read` bounded whatever the port holds).
pub const RX_PER_CYCLE: usize = 32;

/// Buses.
pub const BUSES: usize = 2;

/// Drives per bus sent "enable operation" in one cycle at most: the
/// others follow one a cycle, in cable order (four drives on a bus are
/// enabled within 4 ms, against the supervisor's 200 ms torque ramp), so
/// enabling adds at most one controlword frame to a bus's cycle and two
/// to the step. Transitions towards the brake and fault resets are not
/// paced.
pub const ENABLES_PER_CYCLE: u8 = 1;

/// A CAN controller as the layer needs it: `embedded-can`'s non-blocking
/// transmit and receive, and whether it is bus-off (which `embedded-can`
/// does not say).
pub trait CanPort: Can {
    /// Whether the controller has gone bus-off (too many transmit errors:
    /// it no longer takes part in the bus).
    fn is_bus_off(&mut self) -> bool;
}

/// Why [`CanDrives`] failed a read or a write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CanDrivesError {
    /// Drive `drive` (cable index) is still starting up: no reading yet.
    NotReady {
        /// The cable.
        drive: u8,
        /// Where its start-up is.
        stage: Stage,
    },
    /// A drive faulted.
    Fault(DriveFault),
    /// Bus `bus` (0 CAN1, 1 CAN2) did not take a frame (its transmit
    /// queue is full).
    Transmit {
        /// The bus.
        bus: u8,
    },
}

/// Counters of what the buses brought that was not used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BusCounters {
    /// Frames with an identifier of no drive or function here, an
    /// extended identifier or RTR.
    pub unknown: u32,
    /// Frames of a drive with the wrong length, or not expected (an SDO
    /// answer nobody asked for).
    pub garbage: u32,
    /// Receive errors the port reported (overruns).
    pub receive_errors: u32,
    /// Frames received.
    pub received: u32,
    /// Frames sent.
    pub sent: u32,
}

/// The winch drives: cable `i` is `configs[i]`, on the bus it names.
#[derive(Debug)]
pub struct CanDrives<P1, P2> {
    port1: P1,
    port2: P2,
    nodes: [Node; CABLES],
    outbox: [Outbox; BUSES],
    cycle: u32,
    started: bool,
    counters: BusCounters,
    /// Per bus and node id, the drive's cable index plus one (0: no drive
    /// here): a received frame finds its drive in one look-up.
    by_node: [[u8; 128]; BUSES],
}

impl<P1: CanPort, P2: CanPort> CanDrives<P1, P2> {
    /// The drives of `configs` on `port1` (CAN1) and `port2` (CAN2), with
    /// `timing`. Nothing is sent before the first `read`, which resets
    /// every drive's communication (NMT, all nodes) and starts them up.
    pub fn new(port1: P1, port2: P2, configs: [DriveConfig; CABLES], timing: Timing) -> Self {
        Self {
            port1,
            port2,
            nodes: configs.map(|c| Node::new(c, timing, 0)),
            outbox: [Outbox::new(), Outbox::new()],
            cycle: 0,
            started: false,
            counters: BusCounters::default(),
            by_node: node_table(&configs),
        }
    }

    /// Drive `i` (cable index).
    pub fn node(&self, i: usize) -> Option<&Node> {
        self.nodes.get(i)
    }

    /// What the buses brought that was not used.
    pub fn counters(&self) -> &BusCounters {
        &self.counters
    }

    /// The ports.
    pub fn ports(&mut self) -> (&mut P1, &mut P2) {
        (&mut self.port1, &mut self.port2)
    }

    /// Whether every drive is operational and readable.
    pub fn ready(&self) -> bool {
        self.nodes.iter().all(Node::ready)
    }

    fn receive_bus(&mut self, bus: usize) {
        let bus = bus.min(BUSES - 1);
        for _ in 0..RX_PER_CYCLE {
            let (nodes, table, now) = (&mut self.nodes, &self.by_node[bus], self.cycle);
            let taken = match bus {
                0 => take(&mut self.port1, nodes, table, now),
                _ => take(&mut self.port2, nodes, table, now),
            };
            let c = &mut self.counters;
            match taken {
                Taken::Empty => break,
                Taken::Error => c.receive_errors = c.receive_errors.wrapping_add(1),
                Taken::Used => c.received = c.received.wrapping_add(1),
                Taken::Garbage => {
                    c.received = c.received.wrapping_add(1);
                    c.garbage = c.garbage.wrapping_add(1);
                }
                Taken::Unknown => {
                    c.received = c.received.wrapping_add(1);
                    c.unknown = c.unknown.wrapping_add(1);
                }
            }
        }
    }

    fn bus_off(&mut self, bus: usize) -> bool {
        match bus {
            0 => self.port1.is_bus_off(),
            _ => self.port2.is_bus_off(),
        }
    }

    /// Sends bus `bus`'s outbox; an error if the port did not take a frame.
    fn flush(&mut self, bus: usize) -> Result<(), CanDrivesError> {
        let outbox = &mut self.outbox[bus];
        let mut result =
            if outbox.overflowed != 0 { Err(CanDrivesError::Transmit { bus: bus as u8 }) } else { Ok(()) };
        let mut sent = 0u32;
        for raw in outbox.frames() {
            let ok = match bus {
                0 => transmit(&mut self.port1, raw),
                _ => transmit(&mut self.port2, raw),
            };
            if ok {
                sent += 1;
            } else {
                result = Err(CanDrivesError::Transmit { bus: bus as u8 });
            }
        }
        outbox.clear();
        self.counters.sent = self.counters.sent.wrapping_add(sent);
        result
    }

    /// The first drive (cable order) with a fault, then the first not ready.
    fn status(&self) -> Result<(), CanDrivesError> {
        for (i, n) in self.nodes.iter().enumerate() {
            if let Some((cause, code)) = n.fault() {
                return Err(CanDrivesError::Fault(DriveFault { drive: i as u8, cause, code }));
            }
        }
        match self.nodes.iter().position(|n| !n.ready()) {
            Some(i) => Err(CanDrivesError::NotReady { drive: i as u8, stage: self.nodes[i].stage() }),
            None => Ok(()),
        }
    }
}

/// The look-up of [`CanDrives::by_node`]: the first cable (in cable
/// order) with each bus and node id, plus one.
fn node_table(configs: &[DriveConfig; CABLES]) -> [[u8; 128]; BUSES] {
    let mut table = [[0u8; 128]; BUSES];
    for (i, c) in configs.iter().enumerate().rev() {
        if let Some(slot) = table.get_mut(usize::from(c.bus)).and_then(|t| t.get_mut(usize::from(c.node))) {
            *slot = i as u8 + 1;
        }
    }
    table
}

/// What a port's receive gave.
enum Taken {
    /// A frame its drive used.
    Used,
    /// A frame of a drive with the wrong length or unexpected.
    Garbage,
    /// A frame of no drive or function here (or an extended id, an RTR).
    Unknown,
    /// Nothing waiting.
    Empty,
    /// A receive error (an overrun).
    Error,
}

/// Takes one frame from `port` and hands its data, where it lies, to the
/// drive its COB-ID names (`table`: the bus's node-id look-up).
fn take<P: CanPort>(port: &mut P, nodes: &mut [Node; CABLES], table: &[u8; 128], now: u32) -> Taken {
    let frame = match port.receive() {
        Ok(f) => f,
        Err(nb::Error::WouldBlock) => return Taken::Empty,
        Err(nb::Error::Other(_)) => return Taken::Error,
    };
    let Some((id, data)) = standard_parts(&frame) else { return Taken::Unknown };
    let (function, node) = (id & 0x780, (id & 0x7F) as u8);
    let node = match (function, node) {
        // NMT, SYNC and the board's own PDOs are not for the board.
        (NMT, _) | (EMCY, 0) | (RPDO1 | RPDO2, _) => None,
        _ => match table[usize::from(node)] {
            0 => None,
            i => nodes.get_mut(usize::from(i) - 1),
        },
    };
    match node.map(|n| n.on_frame(function, data, now)) {
        Some(Received::Used) => Taken::Used,
        Some(Received::Garbage) => Taken::Garbage,
        None => Taken::Unknown,
    }
}

/// Sends `raw` on `port`: whether it was queued (a frame the port pushed
/// out of its queue for it counts as not sent).
fn transmit<P: CanPort>(port: &mut P, raw: &RawFrame) -> bool {
    match raw.to_frame::<P::Frame>() {
        Some(f) => matches!(port.transmit(&f), Ok(None)),
        None => false,
    }
}

impl<P1: CanPort, P2: CanPort> WinchDrives for CanDrives<P1, P2> {
    type Error = CanDrivesError;

    /// This cycle's frames in, the drives' checks and start-up frames out;
    /// the positions (counts, 0x6064) and speeds (from two positions) of
    /// every drive, or the first fault, or the first drive not ready.
    fn read(&mut self, readings: &mut [WinchReading; CABLES]) -> Result<(), CanDrivesError> {
        self.cycle = self.cycle.wrapping_add(1);
        let now = self.cycle;
        if !self.started {
            self.started = true;
            for bus in 0..BUSES {
                // Every drive restarts its communication and sends its boot-up.
                self.outbox[bus].push(RawFrame::new(NMT, &[0x82, 0]));
            }
            for n in &mut self.nodes {
                *n = Node::new(*n.config(), *n.timing(), now);
            }
        }
        for bus in 0..BUSES {
            if self.bus_off(bus) {
                self.nodes.iter_mut().filter(|n| usize::from(n.config().bus) == bus).for_each(Node::bus_off);
            }
            self.receive_bus(bus);
        }
        for n in &mut self.nodes {
            let bus = usize::from(n.config().bus).min(BUSES - 1);
            n.poll(now, &mut self.outbox[bus]);
        }
        let sent = (0..BUSES).try_for_each(|bus| self.flush(bus));
        for (r, n) in readings.iter_mut().zip(&self.nodes) {
            if let Some((counts, counts_per_second)) = n.reading() {
                *r = WinchReading { counts, counts_per_second };
            }
        }
        self.status().and(sent)
    }

    fn failed_drive(&self, error: &CanDrivesError) -> Option<usize> {
        match *error {
            CanDrivesError::NotReady { drive, .. } => Some(usize::from(drive)),
            CanDrivesError::Fault(f) => Some(usize::from(f.drive)),
            CanDrivesError::Transmit { .. } => None,
        }
    }

    fn drive_fault(&self, error: &CanDrivesError) -> Option<DriveFault> {
        match *error {
            CanDrivesError::Fault(f) => Some(f),
            _ => None,
        }
    }

    /// Released: every drive to "operation enabled"; engaged: to
    /// "switched on", where the drive engages its holding brake (the
    /// brakes are the drives' brake outputs).
    fn set_brakes(&mut self, engaged: bool) -> Result<(), CanDrivesError> {
        let target = if engaged { Target::Hold } else { Target::Operate };
        self.nodes.iter_mut().for_each(|n| n.set_target(target));
        Ok(())
    }

    /// Per drive its target torque (and controlword when due), then the
    /// SYNC, on each bus.
    fn apply(&mut self, torques: &[f32; CABLES]) -> Result<(), CanDrivesError> {
        let now = self.cycle;
        let mut sync = [false; BUSES];
        let mut enables = [ENABLES_PER_CYCLE; BUSES];
        for (n, &t) in self.nodes.iter_mut().zip(torques) {
            let bus = usize::from(n.config().bus).min(BUSES - 1);
            sync[bus] |= n.cyclic(t, now, &mut self.outbox[bus], &mut enables[bus]);
        }
        let mut result = Ok(());
        for (bus, &s) in sync.iter().enumerate() {
            if s {
                self.outbox[bus].push(RawFrame::new(SYNC, &[]));
            }
            result = result.and(self.flush(bus));
        }
        result
    }

    fn clear_faults(&mut self) {
        let now = self.cycle;
        for n in &mut self.nodes {
            let bus = usize::from(n.config().bus).min(BUSES - 1);
            n.clear_fault(now, &mut self.outbox[bus]);
        }
    }
}

/// The emergency stop's frames for the drives of `configs` on bus `bus`,
/// into `out` (returns how many; 10 for four drives): per drive a quick
/// stop controlword (RPDO2, applied on receipt) and a zero target torque
/// (RPDO1), a SYNC that applies the zero, then NMT "enter
/// pre-operational" to all, which quick stops a drive that missed its
/// controlword (abort connection option 0x6007 = 3). A CiA 402 drive
/// engages its holding brake on leaving "operation enabled".
pub fn emergency_frames(configs: &[DriveConfig], bus: u8, out: &mut [RawFrame]) -> usize {
    let mut len = 0;
    let mut push = |f: RawFrame| {
        if let Some(slot) = out.get_mut(len) {
            *slot = f;
            len += 1;
        }
    };
    for c in configs.iter().filter(|c| c.bus == bus) {
        push(RawFrame::new(RPDO2 + u16::from(c.node), &controlword::QUICK_STOP.to_le_bytes()));
        push(RawFrame::new(RPDO1 + u16::from(c.node), &0i16.to_le_bytes()));
    }
    push(RawFrame::new(SYNC, &[]));
    push(RawFrame::new(NMT, &[0x80, 0]));
    len
}
