//! [`FrameDecoder`]: frames reassembled from a byte stream, COBS undone as
//! the bytes arrive.
//!
//! The receive path is part of the board's 1 kHz control step, so it is
//! written for the Cortex-M4: [`FrameDecoder::take_bytes`] takes a cycle's
//! bytes in one loop with the decoder's state in registers, undoing COBS
//! and running the CRC-32 register on the way; at the delimiter only the
//! residue's comparison and the message's decoding remain
//! ([`crate::Message`]).
//! Decoding the whole frame again at its delimiter (the `cobs` crate's
//! `decode_in_place`, which [`crate::decode`] uses) cost the board more:
//! see BENCHMARKS.md.
//!
//! COBS (Cheshire and Baker, "Consistent Overhead Byte Stuffing", IEEE/ACM
//! Trans. Networking 7(2), 1999) cuts the data into blocks: a code byte
//! `c` (1 to 255) followed by `c - 1` data bytes, and a zero after the
//! block unless `c` is 255 or the block is the frame's last. A frame is
//! valid COBS exactly when its last block is complete at the delimiter
//! (the `cobs` crate's rule; `tests/frames.rs` checks that this receiver
//! and one built on the `cobs` crate agree on arbitrary bytes).

use crate::{crc32_update, FrameError, Message, CRC32_INIT, CRC32_RESIDUE, CRC_LEN, DELIMITER, MAX_FRAME};

/// Reassembles frames from a byte stream: feed every received byte to
/// [`FrameDecoder::push`] (or many at a time to
/// [`FrameDecoder::take_bytes`]); at each delimiter it returns the frame's
/// message or why the frame was rejected. Empty frames (two delimiters in a
/// row, which a sender may use to flush) are skipped silently. More than
/// [`MAX_FRAME`] bytes without a delimiter are dropped up to the next one
/// and rejected as [`FrameError::Oversize`].
#[derive(Debug, Clone)]
pub struct FrameDecoder {
    /// The frame's decoded bytes so far (never more than the bytes received).
    buf: [u8; MAX_FRAME],
    /// Decoded bytes in `buf`.
    len: usize,
    /// Bytes received since the last delimiter (saturating at
    /// `MAX_FRAME + 1`: oversize).
    received: usize,
    /// Data bytes still to come in the current COBS block (0: the next byte
    /// is a code byte).
    block_left: u8,
    /// Whether a zero comes before the next block's data (the current
    /// block's code is below 255).
    zero_next: bool,
    /// The CRC-32 register over the decoded bytes so far: a frame is
    /// intact when it ends at the residue ([`crate::CRC32_RESIDUE`]).
    crc: u32,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    /// An empty decoder.
    pub const fn new() -> Self {
        Self { buf: [0; MAX_FRAME], len: 0, received: 0, block_left: 0, zero_next: false, crc: CRC32_INIT }
    }

    /// Takes one byte; returns `Some` when it ended a frame.
    pub fn push<T: Message>(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if self.push_byte(byte) {
            self.finish()
        } else {
            None
        }
    }

    /// The per-byte half of [`FrameDecoder::push`]: takes one byte and
    /// returns whether it was a delimiter ending a non-empty frame, after
    /// which [`FrameDecoder::finish`] must be called (a delimiter after an
    /// empty frame changes nothing).
    #[inline(always)]
    pub fn push_byte(&mut self, byte: u8) -> bool {
        if byte == DELIMITER {
            return self.received != 0;
        }
        if self.received >= MAX_FRAME {
            // Oversize: dropped up to the delimiter (the count saturates).
            self.received = MAX_FRAME + 1;
            return false;
        }
        self.received += 1;
        if self.block_left == 0 {
            if self.zero_next {
                self.store(0);
            }
            self.zero_next = byte != 0xFF;
            self.block_left = byte - 1;
        } else {
            self.store(byte);
            self.block_left -= 1;
        }
        false
    }

    #[inline(always)]
    fn store(&mut self, byte: u8) {
        // In bounds: a frame's decoded bytes are fewer than its received
        // bytes, which are at most MAX_FRAME here.
        if let Some(slot) = self.buf.get_mut(self.len) {
            *slot = byte;
            self.len += 1;
            self.crc = crc32_update(self.crc, byte);
        }
    }

    /// Takes bytes from `next` until one ends a non-empty frame (returns
    /// `(taken, true)`: call [`FrameDecoder::finish`]), `next` has none
    /// left, or `limit` bytes are taken (`(taken, false)`): the same as
    /// [`FrameDecoder::push_byte`] byte by byte, with the decoder's state
    /// in registers (a byte at a time through `&mut self` costs the board
    /// the loads and stores of every field).
    #[inline]
    pub fn take_bytes(&mut self, next: &mut impl FnMut() -> Option<u8>, limit: usize) -> (usize, bool) {
        let (mut len, mut received, mut block_left, mut zero_next, mut crc) =
            (self.len, self.received, self.block_left, self.zero_next, self.crc);
        let mut taken = 0;
        let mut ended = false;
        while taken < limit {
            let Some(byte) = next() else { break };
            taken += 1;
            if byte == DELIMITER {
                if received != 0 {
                    ended = true;
                    break;
                }
                continue;
            }
            if received >= MAX_FRAME {
                received = MAX_FRAME + 1;
                continue;
            }
            received += 1;
            let data = if block_left == 0 {
                let implied_zero = zero_next;
                zero_next = byte != 0xFF;
                block_left = byte - 1;
                if !implied_zero {
                    continue;
                }
                0
            } else {
                block_left -= 1;
                byte
            };
            // In bounds: decoded bytes are fewer than received ones.
            if let Some(slot) = self.buf.get_mut(len) {
                *slot = data;
                len += 1;
                crc = crc32_update(crc, data);
            }
        }
        (self.len, self.received, self.block_left, self.zero_next, self.crc) =
            (len, received, block_left, zero_next, crc);
        (taken, ended)
    }

    /// The per-frame half of [`FrameDecoder::push`], after a delimiter:
    /// the frame's message or why it was rejected, `None` for an empty
    /// frame; the decoder is ready for the next frame.
    pub fn finish<T: Message>(&mut self) -> Option<Result<T, FrameError>> {
        let outcome = self
            .line_outcome()
            .map(|raw| raw.and_then(|(raw, intact)| payload(raw, intact)).and_then(T::from_payload));
        self.reset();
        outcome
    }

    /// After a delimiter, as the receive interrupt hands frames on: the
    /// frame as the line delivered it (COBS undone, or why it could not
    /// be), `None` for an empty frame; the decoder is ready for the next
    /// frame. [`LineFrame::message`] does the rest of [`FrameDecoder::finish`].
    pub fn finish_line(&mut self) -> Option<LineFrame> {
        let frame = match self.line_outcome()? {
            Ok((raw, intact)) => LineFrame::checked(raw, intact),
            Err(e) => LineFrame::rejected(e),
        };
        self.reset();
        Some(frame)
    }

    /// The frame ended by a delimiter: its COBS-decoded bytes and whether
    /// their CRC-32 holds, or oversize, or framing (its last block
    /// incomplete); `None` if empty.
    fn line_outcome(&self) -> Option<Result<(&[u8], bool), FrameError>> {
        if self.received > MAX_FRAME {
            return Some(Err(FrameError::Oversize));
        }
        if self.received == 0 {
            return None;
        }
        if self.block_left != 0 {
            return Some(Err(FrameError::Framing));
        }
        self.buf.get(..self.len).map(|raw| Ok((raw, self.crc == CRC32_RESIDUE)))
    }

    /// Drops a partly received frame (e.g. after a link reset).
    pub fn reset(&mut self) {
        self.len = 0;
        self.received = 0;
        self.block_left = 0;
        self.zero_next = false;
        self.crc = CRC32_INIT;
    }

    /// Bytes of the frame received so far.
    pub fn pending(&self) -> usize {
        self.received
    }
}

/// A frame as the line delivered it: its COBS-decoded bytes (the payload
/// and its CRC, not yet checked), or why it is not a frame (oversize,
/// framing). The board's receive interrupt reassembles frames as the bytes
/// arrive and queues these; the control step checks and decodes them
/// ([`LineFrame::message`]).
// Word-aligned: a frame is moved whole (the interrupt's queue, the step's
// dequeue), and the Cortex-M4 copies aligned words four times faster
// than bytes.
#[derive(Debug, Clone)]
#[repr(C, align(4))]
pub struct LineFrame {
    bytes: [u8; MAX_FRAME],
    len: u8,
    /// Whether the bytes' CRC-32 holds (run as they arrived).
    intact: bool,
    rejected: Option<FrameError>,
}

// A frame's decoded length is below MAX_FRAME, so it fits the `u8`.
const _: () = assert!(MAX_FRAME <= u8::MAX as usize);

impl LineFrame {
    /// The frame whose COBS-decoded bytes are `raw` (at most [`MAX_FRAME`];
    /// longer is oversize).
    pub fn of(raw: &[u8]) -> Self {
        let intact = raw.iter().fold(CRC32_INIT, |crc, &b| crc32_update(crc, b)) == CRC32_RESIDUE;
        Self::checked(raw, intact)
    }

    /// `raw` with its CRC's verdict already known.
    fn checked(raw: &[u8], intact: bool) -> Self {
        let mut bytes = [0u8; MAX_FRAME];
        match bytes.get_mut(..raw.len()) {
            Some(dest) => {
                dest.copy_from_slice(raw);
                Self { bytes, len: raw.len() as u8, intact, rejected: None }
            }
            None => Self::rejected(FrameError::Oversize),
        }
    }

    /// A frame rejected while it was received.
    pub const fn rejected(why: FrameError) -> Self {
        Self { bytes: [0; MAX_FRAME], len: 0, intact: false, rejected: Some(why) }
    }

    /// Its message (CRC checked, decoded: the same outcome as
    /// [`FrameDecoder::push`] for the same bytes).
    pub fn message<T: Message>(&self) -> Result<T, FrameError> {
        if let Some(why) = self.rejected {
            return Err(why);
        }
        let raw = self.bytes.get(..usize::from(self.len)).ok_or(FrameError::Framing)?;
        payload(raw, self.intact).and_then(T::from_payload)
    }
}

/// The payload of a frame's decoded bytes whose CRC-32 verdict is
/// `intact` ([`FrameError::Crc`] if it is not, or if the frame is too
/// short to hold a CRC: the same as [`crate::checked_payload`]).
fn payload(raw: &[u8], intact: bool) -> Result<&[u8], FrameError> {
    if raw.len() < CRC_LEN + 1 || !intact {
        return Err(FrameError::Crc);
    }
    Ok(&raw[..raw.len() - CRC_LEN])
}
