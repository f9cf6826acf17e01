//! CAN frames as the drive layer handles them: an 11-bit identifier and up
//! to 8 data bytes ([`RawFrame`]), the COB-IDs of CiA 301's predefined
//! connection set, and a frame's length on the wire.

use embedded_can::{Frame, Id, StandardId};

/// A classical CAN data frame with an 11-bit identifier (all CANopen uses
/// here). Extended and remote frames are not CANopen's predefined set:
/// [`RawFrame::from_frame`] refuses them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawFrame {
    /// The 11-bit identifier (COB-ID), `0..=0x7FF`.
    pub id: u16,
    /// Data length, `0..=8`.
    pub len: u8,
    /// The data bytes (`len` of them are the frame's).
    pub data: [u8; 8],
}

impl RawFrame {
    /// A frame with identifier `id` (masked to 11 bits) and `data` (at
    /// most 8 bytes are taken). Inlined: where `data` has a constant
    /// length (every frame the layer builds) the copy is a few stores.
    #[inline(always)]
    pub fn new(id: u16, data: &[u8]) -> Self {
        let (data, len) = padded(data);
        Self { id: id & 0x7FF, len, data }
    }

    /// The frame's data bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.data[..usize::from(self.len.min(8))]
    }

    /// An `embedded-can` frame of type `F` (`None` if `F` refuses it, which
    /// a standard data frame of at most 8 bytes never is for a conforming
    /// implementation).
    pub fn to_frame<F: Frame>(&self) -> Option<F> {
        F::new(StandardId::new(self.id)?, self.bytes())
    }

    /// The frame as CANopen sees it, or `None` for an extended-identifier
    /// or remote frame, or one longer than 8 bytes ([`standard_parts`]).
    #[inline]
    pub fn from_frame<F: Frame>(frame: &F) -> Option<Self> {
        standard_parts(frame).map(|(id, data)| Self::new(id, data))
    }

    /// Bits this frame takes on the bus at most: [`worst_case_bits`].
    pub fn worst_case_bits(&self) -> u32 {
        worst_case_bits(self.len)
    }
}

/// A frame's 11-bit identifier and data bytes, where they lie, or `None`
/// for what CANopen's predefined set does not use: an extended-identifier
/// or remote frame, or one longer than 8 bytes.
#[inline]
pub fn standard_parts<F: Frame>(frame: &F) -> Option<(u16, &[u8])> {
    let Id::Standard(id) = frame.id() else { return None };
    let data = frame.data();
    if frame.is_remote_frame() || data.len() > 8 {
        return None;
    }
    Some((id.as_raw(), data))
}

/// The first 8 bytes of `data` (at most), zero-padded, and how many were
/// taken. CANopen's frames are 0 (SYNC), 1 (heartbeat), 2, 4 or 8 bytes
/// long but for a few: those lengths are copied whole, the rest byte by
/// byte (a loop of at most 8; a general copy is a library call on the
/// Cortex-M4).
#[inline(always)]
pub fn padded(data: &[u8]) -> ([u8; 8], u8) {
    let mut d = [0u8; 8];
    match data.len() {
        0 => {}
        1 => d[0] = data[0],
        2 => d[..2].copy_from_slice(&data[..2]),
        4 => d[..4].copy_from_slice(&data[..4]),
        n if n >= 8 => d.copy_from_slice(&data[..8]),
        n => {
            for (i, byte) in d.iter_mut().enumerate() {
                if i < n {
                    *byte = data[i];
                }
            }
        }
    }
    (d, data.len().min(8) as u8)
}

/// NMT node control (CiA 301): `[command, node]`, node 0 for all.
pub const NMT: u16 = 0x000;
/// SYNC (no data bytes here: no counter).
pub const SYNC: u16 = 0x080;
/// EMCY of node `n`: `0x080 + n`.
pub const EMCY: u16 = 0x080;
/// TPDO1 of node `n` (drive to board: position actual 0x6064).
pub const TPDO1: u16 = 0x180;
/// RPDO1 of node `n` (board to drive: target torque 0x6071).
pub const RPDO1: u16 = 0x200;
/// TPDO2 of node `n` (drive to board: statusword 0x6041, on change).
pub const TPDO2: u16 = 0x280;
/// RPDO2 of node `n` (board to drive: controlword 0x6040, on change).
pub const RPDO2: u16 = 0x300;
/// SDO server to client (response) of node `n`.
pub const SDO_RESPONSE: u16 = 0x580;
/// SDO client to server (request) of node `n`.
pub const SDO_REQUEST: u16 = 0x600;
/// Heartbeat and boot-up of node `n`.
pub const HEARTBEAT: u16 = 0x700;

/// Bits a classical base-format data frame of `len` data bytes takes on
/// the bus at most, with the interframe space: 47 fixed bits (start of
/// frame, 11-bit identifier, RTR, IDE, r0, 4-bit DLC, 15-bit CRC, CRC
/// delimiter, ACK slot and delimiter, 7-bit end of frame, 3-bit
/// intermission) plus `8 len` data bits, plus the stuff bits: one after
/// every 4 bits at worst in the `34 + 8 len` bits from the start of frame
/// to the end of the CRC (ISO 11898-1; the bound of Davis et al., "Controller
/// Area Network (CAN) schedulability analysis: refuted, revisited and
/// revised", 2007, eq. 1): 55 bits for a SYNC, 79 + 16 = 95 for 4 bytes, 135
/// for 8.
pub const fn worst_case_bits(len: u8) -> u32 {
    let n = if len > 8 { 8 } else { len as u32 };
    47 + 8 * n + (34 + 8 * n - 1) / 4
}
