//! The serial protocol between a host and the cable-robot firmware.
//!
//! Both ends use this crate: the firmware (no_std, no allocation) and the
//! host tools and tests. A frame on the wire is
//!
//! ```text
//! COBS( postcard(message) ++ CRC-32(postcard(message)) as 4 bytes, little endian ) ++ 0x00
//! ```
//!
//! * **postcard** (serde, wire format 1.0): integers `u16`/`u32` as varints,
//!   `f32` as 4 bytes little endian, `bool` as one byte, enums as a varint
//!   tag followed by the variant's fields in declaration order.
//! * **CRC-32** is CRC-32/ISO-HDLC (the Ethernet / zlib CRC) over the
//!   postcard bytes.
//! * **COBS** (consistent overhead byte stuffing) removes every zero byte,
//!   so that a single `0x00` ends each frame and a receiver that joins a
//!   stream mid-frame resynchronises at the next zero.
//!
//! [`FrameDecoder`] takes bytes one at a time and yields each complete
//! frame's message or the reason it was rejected ([`FrameError`]): bad COBS,
//! too long, CRC mismatch, undecodable or with bytes left over. No input
//! makes it panic. It undoes COBS as the bytes arrive and decodes the
//! messages the firmware receives every cycle (setpoints, trajectory
//! points) without serde ([`Message`]): the receive path is part of the
//! board's 1 kHz control step. [`encode`] writes one frame; [`decode`] is
//! the general (serde) path for one whole frame.
//!
//! What a well-formed message *means* (sequence order, value ranges) is the
//! receiver's business: see `cdpr-control`'s link layer.
//!
//! Tags and fields are wire-stable: variants and fields are only appended.
//! The telemetry sample is the largest message: at most 198 bytes of
//! postcard (every counter at `u32::MAX`; `tests/frames.rs` pins it), so
//! at the firmware's 460 800 baud (46 bytes per ms) one sample every 5
//! control cycles or more is sustainable (the default 10 uses 43 % of the
//! line: the firmware README's link budget).

#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod frame_decoder;
mod message;
mod messages;

pub use frame_decoder::{FrameDecoder, LineFrame};
pub use message::Message;
pub use messages::*;

use serde::{de::DeserializeOwned, Serialize};

/// Largest postcard payload of any message, bytes (the telemetry message
/// is the largest: 198 bytes at most, with every counter at its largest; see
/// `tests/frames.rs`).
pub const MAX_PAYLOAD: usize = 200;

/// Length of the CRC appended to the payload, bytes.
pub const CRC_LEN: usize = 4;

/// Largest frame on the wire: COBS adds one byte per 254 and the leading
/// code byte, plus the trailing zero.
pub const MAX_FRAME: usize = MAX_PAYLOAD + CRC_LEN + (MAX_PAYLOAD + CRC_LEN) / 254 + 2;

/// The frame delimiter.
pub const DELIMITER: u8 = 0x00;

/// The CRC-32/ISO-HDLC of `bytes` (check value `0xCBF43926` for
/// `"123456789"`): reflected polynomial `0xEDB88320`, initial value and
/// final XOR `0xFFFFFFFF`. Computed four bytes a step with four tables
/// ("slicing-by-4": Kounavis and Berry, "A Systematic Approach to Building
/// High Performance Software-based CRC Generators", ISCC 2005), 4 KiB of
/// flash: on the board it is half the cost of the `crc` crate's one-table
/// loop for a setpoint frame (about 260 instead of 530 instructions for
/// 77 bytes; the crate's sixteen-table variant measured no faster there),
/// and the CRC is in every control step. `tests/frames.rs` checks it
/// against the `crc` crate on arbitrary bytes.
pub fn crc32(bytes: &[u8]) -> u32 {
    let t = &CRC32_TABLES;
    let mut crc = !0u32;
    let mut words = bytes.chunks_exact(4);
    for w in &mut words {
        crc ^= u32::from_le_bytes([w[0], w[1], w[2], w[3]]);
        crc = t[3][(crc & 0xFF) as usize]
            ^ t[2][((crc >> 8) & 0xFF) as usize]
            ^ t[1][((crc >> 16) & 0xFF) as usize]
            ^ t[0][(crc >> 24) as usize];
    }
    for &b in words.remainder() {
        crc = crc32_update(crc, b);
    }
    !crc
}

/// The CRC-32 register (before the final XOR) after one more byte: a
/// receiver runs it over a frame's bytes as they arrive.
#[inline(always)]
pub(crate) fn crc32_update(crc: u32, byte: u8) -> u32 {
    CRC32_TABLES[0][((crc ^ u32::from(byte)) & 0xFF) as usize] ^ (crc >> 8)
}

/// The CRC-32 register's start (`0xFFFFFFFF`).
pub(crate) const CRC32_INIT: u32 = !0;

/// The register after a payload followed by its own CRC-32 (little
/// endian), whatever the payload: the CRC's residue (`0xDEBB20E3` for
/// CRC-32/ISO-HDLC), so a receiver that runs the register over the whole
/// frame checks it with one comparison.
pub(crate) const CRC32_RESIDUE: u32 = 0xDEBB_20E3;

/// `CRC32_TABLES[0][b]` is the CRC register after shifting the byte `b`
/// through it; `CRC32_TABLES[k][b]` the same followed by `k` zero bytes.
static CRC32_TABLES: [[u32; 256]; 4] = crc32_tables();

const fn crc32_tables() -> [[u32; 256]; 4] {
    let mut t = [[0u32; 256]; 4];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
            k += 1;
        }
        t[0][i] = c;
        i += 1;
    }
    let mut k = 1;
    while k < 4 {
        let mut i = 0;
        while i < 256 {
            let prev = t[k - 1][i];
            t[k][i] = (prev >> 8) ^ t[0][(prev & 0xFF) as usize];
            i += 1;
        }
        k += 1;
    }
    t
}

/// Why a frame was rejected (or could not be written).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The bytes between two delimiters are not valid COBS (or are empty).
    Framing,
    /// More than [`MAX_FRAME`] bytes arrived without a delimiter; they are
    /// dropped up to the next delimiter.
    Oversize,
    /// Too short to hold a CRC, or the CRC does not match.
    Crc,
    /// The CRC matches but the payload is not a message of the expected
    /// type, or not its canonical encoding (e.g. an overlong varint).
    Decode,
    /// The payload holds a message followed by extra bytes.
    TrailingBytes,
    /// (Encoding) the output buffer is too small for the frame.
    BufferTooSmall,
}

/// Writes `message` as one frame (COBS with the trailing delimiter) into
/// `out` and returns the frame's length. `out` of [`MAX_FRAME`] bytes always
/// suffices for this crate's messages.
pub fn encode<T: Serialize>(message: &T, out: &mut [u8]) -> Result<usize, FrameError> {
    let mut raw = [0u8; MAX_PAYLOAD + CRC_LEN];
    let payload_len =
        postcard::to_slice(message, &mut raw[..MAX_PAYLOAD]).map_err(|_| FrameError::BufferTooSmall)?.len();
    let crc = crc32(&raw[..payload_len]).to_le_bytes();
    raw[payload_len..payload_len + CRC_LEN].copy_from_slice(&crc);
    let raw = &raw[..payload_len + CRC_LEN];
    let body = cobs::try_encode(raw, out).map_err(|_| FrameError::BufferTooSmall)?;
    let end = out.get_mut(body).ok_or(FrameError::BufferTooSmall)?;
    *end = DELIMITER;
    Ok(body + 1)
}

/// Decodes one frame's bytes (COBS, without the delimiter) in place and
/// returns the message. Only the canonical encoding is accepted: the
/// message must re-encode to exactly the payload (postcard's decoder also
/// takes overlong varints, e.g. the tag `1` as `81 00`, so one message would
/// otherwise have many encodings); anything else is [`FrameError::Decode`].
/// This is the general path (serde's, for any message type); the firmware's
/// receiver, [`FrameDecoder`], decodes COBS as the bytes arrive and its
/// messages through [`Message::from_payload`].
pub fn decode<T: DeserializeOwned + Serialize>(frame: &mut [u8]) -> Result<T, FrameError> {
    if frame.is_empty() {
        return Err(FrameError::Framing);
    }
    let len = cobs::decode_in_place(frame).map_err(|_| FrameError::Framing)?;
    let raw = frame.get(..len).ok_or(FrameError::Framing)?;
    decode_payload_serde(checked_payload(raw)?)
}

/// The payload of a frame's COBS-decoded bytes (`payload ++ CRC-32`), if it
/// is long enough and its CRC matches ([`FrameError::Crc`] otherwise).
pub fn checked_payload(raw: &[u8]) -> Result<&[u8], FrameError> {
    if raw.len() < CRC_LEN + 1 {
        return Err(FrameError::Crc);
    }
    let (payload, crc) = raw.split_at(raw.len() - CRC_LEN);
    let expected = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
    if crc32(payload) != expected {
        return Err(FrameError::Crc);
    }
    Ok(payload)
}

/// Decodes a payload (postcard bytes, the CRC already checked and removed)
/// through serde, canonical encodings only: [`FrameError::Decode`] if it is
/// not a `T` or not the encoding `T` re-encodes to, [`FrameError::TrailingBytes`]
/// if bytes follow the message.
pub fn decode_payload_serde<T: DeserializeOwned + Serialize>(payload: &[u8]) -> Result<T, FrameError> {
    let (message, rest) = postcard::take_from_bytes::<T>(payload).map_err(|_| FrameError::Decode)?;
    if !rest.is_empty() {
        return Err(FrameError::TrailingBytes);
    }
    let mut canonical = [0u8; MAX_PAYLOAD];
    match postcard::to_slice(&message, &mut canonical) {
        Ok(bytes) if *bytes == *payload => Ok(message),
        _ => Err(FrameError::Decode),
    }
}
