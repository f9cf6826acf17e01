//! [`FrameDecoder`]: frames reassembled from a byte stream, COBS undone as
//! the bytes arrive.
//!
//! The receive path is part of the board's 1 kHz control step, so it is
//! written for the Cortex-M4: [`FrameDecoder::take_bytes`] takes a cycle's
//! bytes in one loop with the decoder's state in registers, undoing COBS
//! on the way; at the delimiter
//! only the CRC-32 and the message's decoding remain ([`crate::Message`]).
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

use crate::{checked_payload, FrameError, Message, DELIMITER, MAX_FRAME};

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
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    /// An empty decoder.
    pub const fn new() -> Self {
        Self { buf: [0; MAX_FRAME], len: 0, received: 0, block_left: 0, zero_next: false }
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
        let (mut len, mut received, mut block_left, mut zero_next) =
            (self.len, self.received, self.block_left, self.zero_next);
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
            }
        }
        (self.len, self.received, self.block_left, self.zero_next) = (len, received, block_left, zero_next);
        (taken, ended)
    }

    /// The per-frame half of [`FrameDecoder::push`], after a delimiter:
    /// the frame's message or why it was rejected, `None` for an empty
    /// frame; the decoder is ready for the next frame.
    pub fn finish<T: Message>(&mut self) -> Option<Result<T, FrameError>> {
        let (len, received, complete) = (self.len, self.received, self.block_left == 0);
        self.reset();
        if received > MAX_FRAME {
            return Some(Err(FrameError::Oversize));
        }
        if received == 0 {
            return None;
        }
        if !complete {
            return Some(Err(FrameError::Framing));
        }
        let raw = self.buf.get(..len)?;
        Some(checked_payload(raw).and_then(T::from_payload))
    }

    /// Drops a partly received frame (e.g. after a link reset).
    pub fn reset(&mut self) {
        self.len = 0;
        self.received = 0;
        self.block_left = 0;
        self.zero_next = false;
    }

    /// Bytes of the frame received so far.
    pub fn pending(&self) -> usize {
        self.received
    }
}
