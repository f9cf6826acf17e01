//! A CiA 402 drive model and an in-memory loopback port, `no_std` (feature
//! `model`): what the tests, `hal-sim` (through [`crate::sim`]) and the
//! QEMU demo's measurement of the layer's cost run the board's layer
//! against.
//!
//! * [`SimDrive`]: a CiA 402 servo drive at frame level, written from CiA
//!   301 and CiA 402 (not from this crate's board side): NMT, heartbeat
//!   and boot-up, an SDO server (expedited) over its object dictionary,
//!   PDO mapping and transmission types, SYNC, the device state machine,
//!   EMCY, the RPDO timeout, and faults a test injects;
//! * [`LoopbackPort`]: a `CanPort` whose frames go to drive models in
//!   memory, delivered when the caller says ([`LoopbackPort::deliver`]),
//!   with no bus time.

mod drive;

pub use drive::{Nmt, SimDrive, SimDriveFaults};

use embedded_can::{ErrorKind, ExtendedId, Frame, Id, StandardId};

use crate::frame::RawFrame;
use crate::CanPort;

/// Where a drive model puts the frames it sends.
pub trait FrameSink {
    /// Appends `frame` (a sink that is full drops it).
    fn push(&mut self, frame: RawFrame);
}

#[cfg(feature = "sim")]
impl FrameSink for std::vec::Vec<RawFrame> {
    fn push(&mut self, frame: RawFrame) {
        std::vec::Vec::push(self, frame);
    }
}

/// A frame of the simulated controllers (`embedded-can`), any identifier,
/// data or remote.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SimFrame {
    id: Id,
    remote: bool,
    dlc: usize,
    data: [u8; 8],
}

impl Frame for SimFrame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        if data.len() > 8 {
            return None;
        }
        let mut d = [0u8; 8];
        for (o, b) in d.iter_mut().zip(data) {
            *o = *b;
        }
        Some(Self { id: id.into(), remote: false, dlc: data.len(), data: d })
    }
    fn new_remote(id: impl Into<Id>, dlc: usize) -> Option<Self> {
        (dlc <= 8).then(|| Self { id: id.into(), remote: true, dlc, data: [0; 8] })
    }
    fn is_extended(&self) -> bool {
        matches!(self.id, Id::Extended(_))
    }
    fn is_remote_frame(&self) -> bool {
        self.remote
    }
    fn id(&self) -> Id {
        self.id
    }
    fn dlc(&self) -> usize {
        self.dlc
    }
    fn data(&self) -> &[u8] {
        if self.remote {
            &[]
        } else {
            &self.data[..self.dlc]
        }
    }
}

impl SimFrame {
    /// An extended-identifier data frame (not CANopen's: for tests).
    pub fn extended(id: u32, data: &[u8]) -> Option<Self> {
        Self::new(ExtendedId::new(id)?, data)
    }

    /// A standard data frame.
    pub fn standard(id: u16, data: &[u8]) -> Option<Self> {
        Self::new(StandardId::new(id)?, data)
    }
}

/// The simulated controllers' error: a receive overrun.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SimPortError;

impl embedded_can::Error for SimPortError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Overrun
    }
}

/// Frames a [`Ring`] holds.
pub const RING: usize = 32;

/// A bounded FIFO of frames (no allocation).
#[derive(Debug, Clone, Copy)]
pub struct Ring {
    frames: [RawFrame; RING],
    head: usize,
    len: usize,
    /// Frames pushed while full (dropped).
    pub dropped: u32,
}

impl Ring {
    /// Empty.
    pub const fn new() -> Self {
        Self { frames: [RawFrame { id: 0, len: 0, data: [0; 8] }; RING], head: 0, len: 0, dropped: 0 }
    }

    /// The oldest frame.
    pub fn pop(&mut self) -> Option<RawFrame> {
        (self.len > 0).then(|| {
            let f = self.frames[self.head];
            self.head = (self.head + 1) % RING;
            self.len -= 1;
            f
        })
    }

    /// Frames waiting.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether none wait.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl Default for Ring {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameSink for Ring {
    fn push(&mut self, frame: RawFrame) {
        if self.len == RING {
            self.dropped = self.dropped.wrapping_add(1);
            return;
        }
        self.frames[(self.head + self.len) % RING] = frame;
        self.len += 1;
    }
}

/// A port whose frames reach drive models in memory.
#[derive(Debug, Clone, Copy, Default)]
pub struct LoopbackPort {
    /// What the board sent, not yet delivered.
    pub to_drives: Ring,
    /// What the drives sent, not yet read.
    pub to_board: Ring,
}

impl LoopbackPort {
    /// Empty queues.
    pub const fn new() -> Self {
        Self { to_drives: Ring::new(), to_board: Ring::new() }
    }

    /// Delivers everything the board sent to every drive of `drives` at
    /// `now_ns` (and their answers to the board), then lets each drive's
    /// timers run.
    pub fn deliver(&mut self, drives: &mut [SimDrive], now_ns: u64) {
        while let Some(f) = self.to_drives.pop() {
            for d in drives.iter_mut() {
                d.receive(&f, now_ns, &mut self.to_board);
            }
        }
        for d in drives.iter_mut() {
            d.tick(now_ns, &mut self.to_board);
        }
    }
}

impl embedded_can::nb::Can for LoopbackPort {
    type Frame = SimFrame;
    type Error = SimPortError;

    fn transmit(&mut self, frame: &SimFrame) -> nb::Result<Option<SimFrame>, SimPortError> {
        if self.to_drives.len() == RING {
            return Err(nb::Error::WouldBlock);
        }
        if let Some(raw) = RawFrame::from_frame(frame) {
            self.to_drives.push(raw);
        }
        Ok(None)
    }

    fn receive(&mut self) -> nb::Result<SimFrame, SimPortError> {
        match self.to_board.pop() {
            Some(raw) => raw.to_frame::<SimFrame>().ok_or(nb::Error::WouldBlock),
            None => Err(nb::Error::WouldBlock),
        }
    }
}

impl CanPort for LoopbackPort {
    fn is_bus_off(&mut self) -> bool {
        false
    }
}
