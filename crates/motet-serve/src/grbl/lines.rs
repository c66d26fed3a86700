//! The receive buffer a character-counting sender fills: 128 bytes, lines
//! of at most 80 characters, each taken out whole when the protocol
//! accepts it (a line the machine cannot take yet stays, and its bytes
//! stay counted, so the sender waits).

use std::collections::VecDeque;

/// Bytes a sender may have in flight (grbl's serial receive buffer).
pub const RX_BUFFER: usize = 128;
/// Longest line, characters (its end not counted); longer → `error:11`.
pub const MAX_LINE: usize = 80;
/// Most bytes kept, complete lines waiting included: past this the port
/// stops reading (the sender's writes wait) rather than drop anything.
pub const MAX_KEPT: usize = 4096;

/// A complete line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Line {
    /// Its text, without its end.
    Text(String),
    /// Longer than [`MAX_LINE`]: refused whole.
    TooLong,
}

/// Line bytes received, in order.
#[derive(Debug, Default)]
pub struct RxBuffer {
    bytes: VecDeque<u8>,
    /// A `\r` ended the last line: a `\n` right after it ends nothing.
    after_cr: bool,
    /// Bytes of the line not yet ended.
    open_len: usize,
}

impl RxBuffer {
    /// Appends line bytes (real-time bytes already taken out). Bytes past
    /// the 128 are kept too, not dropped as a UART would: a sender that
    /// does not count characters only waits longer.
    pub fn push(&mut self, b: u8) {
        if b == b'\n' && self.after_cr {
            self.after_cr = false;
            return;
        }
        self.after_cr = b == b'\r';
        // Control bytes other than line ends are dropped, as grbl does.
        if b < 0x20 && b != b'\n' && b != b'\r' && b != b'\t' {
            return;
        }
        if b == b'\n' || b == b'\r' {
            self.open_len = 0;
        } else if self.open_len > MAX_LINE {
            // Already too long: it will be refused whole; the rest of it
            // need not be kept (grbl drops it too).
            return;
        } else {
            self.open_len += 1;
        }
        self.bytes.push_back(b);
    }

    /// Whether more bytes may be taken ([`MAX_KEPT`]).
    pub fn has_room(&self) -> bool {
        self.bytes.len() < MAX_KEPT
    }

    /// Room left of [`RX_BUFFER`], bytes.
    pub fn free(&self) -> usize {
        RX_BUFFER.saturating_sub(self.bytes.len())
    }

    /// The first complete line, left in the buffer.
    pub fn peek(&self) -> Option<Line> {
        let end = self.bytes.iter().position(|&b| b == b'\n' || b == b'\r')?;
        if end > MAX_LINE {
            return Some(Line::TooLong);
        }
        let text: Vec<u8> = self.bytes.range(..end).copied().collect();
        Some(Line::Text(String::from_utf8_lossy(&text).into_owned()))
    }

    /// Removes the first complete line (after [`RxBuffer::peek`]).
    pub fn pop(&mut self) {
        if let Some(end) = self.bytes.iter().position(|&b| b == b'\n' || b == b'\r') {
            self.bytes.drain(..=end);
        }
    }

    /// Forgets everything (a soft reset).
    pub fn clear(&mut self) {
        self.bytes.clear();
        self.after_cr = false;
        self.open_len = 0;
    }
}
