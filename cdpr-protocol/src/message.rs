//! [`Message`]: how a frame's payload becomes a message, and the direct
//! decoding of the messages the firmware receives every cycle.
//!
//! Serde's path ([`crate::decode_payload_serde`]: postcard's decoder, then
//! the message encoded again and compared with the payload, which is what
//! rejects non-canonical encodings) cost about 40 instructions a byte on
//! the board, half of the whole receive path. A [`HostMessage::Setpoint`]
//! (tag 0) and a [`HostMessage::Point`] (tag 9) are a varint and 4-byte
//! little-endian `f32`s (postcard wire format 1.0: varints are LEB128, an
//! `f32` its IEEE 754 bits), so they are read directly here: the varint is
//! canonical when it is as short as its value allows, and every `f32` bit
//! pattern is canonical. The other messages are rare and go through serde.
//! `tests/frames.rs` checks that both paths give the same message or the
//! same error on arbitrary payloads.

use serde::{de::DeserializeOwned, Serialize};

use crate::{decode_payload_serde, DeviceMessage, FrameError, HostMessage, Setpoint, TrajectoryPoint, DOF};

/// A message the frames carry.
pub trait Message: DeserializeOwned + Serialize {
    /// Decodes one frame's payload (the postcard bytes, CRC checked and
    /// removed), canonical encodings only. The default is serde's path.
    fn from_payload(payload: &[u8]) -> Result<Self, FrameError> {
        decode_payload_serde(payload)
    }
}

impl Message for DeviceMessage {}

impl Message for HostMessage {
    fn from_payload(payload: &[u8]) -> Result<Self, FrameError> {
        match payload.split_first() {
            Some((&SETPOINT_TAG, body)) => {
                let (seq, body) = varint_u32(body)?;
                let [pose, velocity, acceleration] = f32_arrays::<3>(body)?;
                canonical(
                    seq,
                    HostMessage::Setpoint(Setpoint { seq: seq.value, pose, velocity, acceleration }),
                )
            }
            Some((&POINT_TAG, body)) => {
                let (time_ms, body) = varint_u32(body)?;
                let [pose, velocity] = f32_arrays::<2>(body)?;
                canonical(
                    time_ms,
                    HostMessage::Point(TrajectoryPoint { time_ms: time_ms.value, pose, velocity }),
                )
            }
            _ => decode_payload_serde(payload),
        }
    }
}

/// `message` if its varint was canonical, [`FrameError::Decode`] if not
/// (checked last, as serde's path checks the re-encoding last).
#[inline(always)]
fn canonical(varint: Varint, message: HostMessage) -> Result<HostMessage, FrameError> {
    if varint.overlong {
        Err(FrameError::Decode)
    } else {
        Ok(message)
    }
}

/// Postcard's tag of [`HostMessage::Setpoint`] (a one-byte varint).
const SETPOINT_TAG: u8 = 0;
/// Postcard's tag of [`HostMessage::Point`].
const POINT_TAG: u8 = 9;

/// A LEB128 `u32` as postcard reads it, and whether it was longer than
/// its value needs.
#[derive(Clone, Copy)]
struct Varint {
    value: u32,
    overlong: bool,
}

/// The LEB128 `u32` at the start of `bytes` and the bytes after it:
/// at most 5 bytes, the last without the continuation bit and, if it is
/// the fifth, with no bits beyond 32 ([`FrameError::Decode`] otherwise,
/// postcard's rule). It is overlong (not the canonical encoding) when a
/// byte after the first is its last and is zero.
#[inline(always)]
fn varint_u32(bytes: &[u8]) -> Result<(Varint, &[u8]), FrameError> {
    let mut value = 0u32;
    for (i, &b) in bytes.iter().take(5).enumerate() {
        value |= u32::from(b & 0x7F) << (7 * i);
        if b & 0x80 == 0 {
            if i == 4 && b > 0x0F {
                return Err(FrameError::Decode);
            }
            let overlong = i > 0 && b == 0;
            return Ok((Varint { value, overlong }, &bytes[i + 1..]));
        }
    }
    Err(FrameError::Decode)
}

/// `K` arrays of [`DOF`] little-endian `f32`s making up all of `bytes`:
/// [`FrameError::Decode`] if there are fewer bytes, [`FrameError::TrailingBytes`]
/// if more (as serde's path).
#[inline(always)]
fn f32_arrays<const K: usize>(bytes: &[u8]) -> Result<[[f32; DOF]; K], FrameError> {
    let need = K * DOF * 4;
    if bytes.len() < need {
        return Err(FrameError::Decode);
    }
    if bytes.len() > need {
        return Err(FrameError::TrailingBytes);
    }
    let mut out = [[0.0f32; DOF]; K];
    for (value, b) in out.iter_mut().flatten().zip(bytes.chunks_exact(4)) {
        *value = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    }
    Ok(out)
}
