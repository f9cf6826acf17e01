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
//!   with no bus time;
//! * [`LoopbackRig`]: the board's layer on two loopback ports with a model
//!   per cable (the QEMU demo's drives).

mod drive;
mod rig;

pub use drive::{Nmt, SimDrive, SimDriveFaults};
pub use rig::{LoopbackDrives, LoopbackRig};

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
/// data or remote. Laid out in words (the raw identifier, then flags and
/// length, then the data): a frame is moved in and out of the port's queue
/// as four word copies, as a controller's mailbox registers are written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SimFrame {
    /// The identifier's raw value (11 or 29 bits).
    raw_id: u32,
    extended: bool,
    remote: bool,
    dlc: u8,
    data: [u8; 8],
}

/// `id` as its raw value and whether it is extended.
#[inline]
fn raw_of(id: Id) -> (u32, bool) {
    match id {
        Id::Standard(s) => (u32::from(s.as_raw()), false),
        Id::Extended(e) => (e.as_raw(), true),
    }
}

impl Frame for SimFrame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        if data.len() > 8 {
            return None;
        }
        let (raw_id, extended) = raw_of(id.into());
        let (d, dlc) = crate::frame::padded(data);
        Some(Self { raw_id, extended, remote: false, dlc, data: d })
    }
    fn new_remote(id: impl Into<Id>, dlc: usize) -> Option<Self> {
        let (raw_id, extended) = raw_of(id.into());
        (dlc <= 8).then_some(Self { raw_id, extended, remote: true, dlc: dlc as u8, data: [0; 8] })
    }
    fn is_extended(&self) -> bool {
        self.extended
    }
    fn is_remote_frame(&self) -> bool {
        self.remote
    }
    fn id(&self) -> Id {
        // Built by `new` from a valid identifier: both arms hold.
        if self.extended {
            ExtendedId::new(self.raw_id).map_or(Id::Extended(ExtendedId::ZERO), Id::Extended)
        } else {
            StandardId::new(self.raw_id as u16).map_or(Id::Standard(StandardId::ZERO), Id::Standard)
        }
    }
    fn dlc(&self) -> usize {
        usize::from(self.dlc)
    }
    fn data(&self) -> &[u8] {
        if self.remote {
            &[]
        } else {
            &self.data[..usize::from(self.dlc).min(8)]
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

/// A frame type a [`Ring`] can hold: copyable, with an empty value to fill
/// the slots with.
pub trait Slot: Copy {
    /// A placeholder frame.
    const EMPTY: Self;
}

impl Slot for RawFrame {
    const EMPTY: Self = RawFrame { id: 0, len: 0, data: [0; 8] };
}

impl Slot for SimFrame {
    const EMPTY: Self = SimFrame { raw_id: 0, extended: false, remote: false, dlc: 0, data: [0; 8] };
}

/// A bounded FIFO of frames (no allocation).
#[derive(Debug, Clone, Copy)]
pub struct Ring<F: Slot = RawFrame> {
    frames: [F; RING],
    head: usize,
    len: usize,
    /// Frames pushed while full (dropped).
    pub dropped: u32,
}

impl<F: Slot> Ring<F> {
    /// Empty.
    pub const fn new() -> Self {
        Self { frames: [F::EMPTY; RING], head: 0, len: 0, dropped: 0 }
    }

    /// The oldest frame.
    pub fn pop(&mut self) -> Option<F> {
        (self.len > 0).then(|| {
            let f = self.frames[self.head];
            self.head = (self.head + 1) % RING;
            self.len -= 1;
            f
        })
    }

    /// Appends `frame` (counted in `dropped` if full).
    pub fn push_frame(&mut self, frame: F) {
        if self.len == RING {
            self.dropped = self.dropped.wrapping_add(1);
            return;
        }
        self.frames[(self.head + self.len) % RING] = frame;
        self.len += 1;
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

impl<F: Slot> Default for Ring<F> {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameSink for Ring {
    fn push(&mut self, frame: RawFrame) {
        self.push_frame(frame);
    }
}

/// A port whose frames reach drive models in memory. The frames wait in
/// the port's own frame type, so that sending and receiving (in the
/// measured step) are a copy each, like a controller's mailbox; the
/// conversion to the models' frames happens in [`Self::deliver`].
#[derive(Debug, Clone, Copy, Default)]
pub struct LoopbackPort {
    /// What the board sent, not yet delivered.
    pub to_drives: Ring<SimFrame>,
    /// What the drives sent, not yet read.
    pub to_board: Ring<SimFrame>,
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
        let mut answers = Ring::<RawFrame>::new();
        while let Some(f) = self.to_drives.pop() {
            // An extended or remote frame is no CANopen frame: no drive
            // sees it.
            let Some(raw) = RawFrame::from_frame(&f) else { continue };
            for d in drives.iter_mut() {
                d.receive(&raw, now_ns, &mut answers);
            }
            self.forward(&mut answers);
        }
        for d in drives.iter_mut() {
            d.tick(now_ns, &mut answers);
        }
        self.forward(&mut answers);
    }

    /// The drives' answers into the board's queue.
    fn forward(&mut self, answers: &mut Ring<RawFrame>) {
        while let Some(raw) = answers.pop() {
            match raw.to_frame::<SimFrame>() {
                Some(f) => self.to_board.push_frame(f),
                None => self.to_board.dropped = self.to_board.dropped.wrapping_add(1),
            }
        }
        self.to_board.dropped = self.to_board.dropped.wrapping_add(answers.dropped);
        answers.dropped = 0;
    }
}

impl embedded_can::nb::Can for LoopbackPort {
    type Frame = SimFrame;
    type Error = SimPortError;

    fn transmit(&mut self, frame: &SimFrame) -> nb::Result<Option<SimFrame>, SimPortError> {
        if self.to_drives.len() == RING {
            return Err(nb::Error::WouldBlock);
        }
        self.to_drives.push_frame(*frame);
        Ok(None)
    }

    fn receive(&mut self) -> nb::Result<SimFrame, SimPortError> {
        self.to_board.pop().ok_or(nb::Error::WouldBlock)
    }
}

impl CanPort for LoopbackPort {
    fn is_bus_off(&mut self) -> bool {
        false
    }
}
