//! A streaming packet decoder: bytes in as they arrive, packets out. Noise
//! between packets is skipped, and a frame that fails its CRC or has an
//! impossible length gives up only its start byte: the bytes after it are
//! searched again, so a real packet hidden behind a false start is found.

use crate::crc8::crc8;
use crate::packet::{MAX_PAYLOAD, START};
use std::collections::VecDeque;

/// What the decoder found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Decoded {
    /// A whole packet with a good CRC: its payload.
    Packet(Vec<u8>),
    /// A frame whose CRC did not match (its bytes are searched again for
    /// another start).
    CrcMismatch {
        /// The CRC the frame carried.
        got: u8,
        /// The CRC of the payload as received.
        want: u8,
    },
}

/// Bytes in, [`Decoded`] out; keeps at most one frame's bytes.
#[derive(Debug, Default)]
pub struct Decoder {
    /// Bytes from a start byte on, not yet a whole frame.
    held: VecDeque<u8>,
    /// Bytes skipped that could not start a frame.
    pub skipped: u64,
    /// Frames refused for their CRC.
    pub crc_errors: u64,
}

impl Decoder {
    /// A decoder waiting for a start byte.
    pub fn new() -> Decoder {
        Decoder::default()
    }

    /// Whether part of a frame is held (a reply has begun).
    pub fn in_frame(&self) -> bool {
        !self.held.is_empty()
    }

    /// Forgets a partial frame (after a timeout).
    pub fn reset(&mut self) {
        self.skipped += self.held.len() as u64;
        self.held.clear();
    }

    /// Feeds bytes; whatever they complete is appended to `out`.
    pub fn push(&mut self, bytes: &[u8], out: &mut Vec<Decoded>) {
        for &b in bytes {
            self.held.push_back(b);
            self.scan(out);
        }
    }

    /// Decodes everything in `bytes` at once.
    pub fn decode_all(bytes: &[u8]) -> (Vec<Decoded>, Decoder) {
        let mut d = Decoder::new();
        let mut out = Vec::new();
        d.push(bytes, &mut out);
        (out, d)
    }

    /// Makes what progress the held bytes allow.
    fn scan(&mut self, out: &mut Vec<Decoded>) {
        loop {
            // Skip to a start byte.
            while let Some(&b) = self.held.front() {
                if b == START {
                    break;
                }
                self.held.pop_front();
                self.skipped += 1;
            }
            let Some(&len) = self.held.get(1) else {
                return;
            };
            let len = len as usize;
            if len == 0 || len > MAX_PAYLOAD {
                self.drop_start();
                continue;
            }
            if self.held.len() < len + 3 {
                return;
            }
            let payload: Vec<u8> = self.held.range(2..2 + len).copied().collect();
            let got = self.held[2 + len];
            let want = crc8(&payload);
            if got == want {
                self.held.drain(..len + 3);
                out.push(Decoded::Packet(payload));
            } else {
                self.crc_errors += 1;
                out.push(Decoded::CrcMismatch { got, want });
                self.drop_start();
            }
        }
    }

    /// Gives up the held start byte; the rest is searched again.
    fn drop_start(&mut self) {
        self.held.pop_front();
        self.skipped += 1;
    }
}
