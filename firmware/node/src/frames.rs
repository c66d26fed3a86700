//! Frames out of a serial byte stream: COBS-stuffed frames end at 0x00
//! (docs/wire.md §1), so a receiver cuts the stream at each zero. A frame
//! longer than any valid one is dropped whole, up to its delimiter.

use motet_wire::frame::MAX_FRAME;

#[derive(Debug)]
pub struct FrameReader {
    buf: [u8; MAX_FRAME],
    len: usize,
    /// Skipping the rest of an overlong frame.
    overflow: bool,
    /// Frames dropped for their length.
    pub dropped: u32,
}

impl Default for FrameReader {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameReader {
    pub const fn new() -> Self {
        FrameReader {
            buf: [0; MAX_FRAME],
            len: 0,
            overflow: false,
            dropped: 0,
        }
    }

    /// Takes bytes from `input` up to and including the next delimiter;
    /// returns how many it took and the frame it completed, if any (without
    /// its delimiter). Call again with the rest.
    pub fn push<'s>(&'s mut self, input: &[u8]) -> (usize, Option<&'s [u8]>) {
        for (i, &b) in input.iter().enumerate() {
            if b == 0 {
                let done = !self.overflow && self.len > 0;
                let n = core::mem::replace(&mut self.len, 0);
                self.overflow = false;
                if done {
                    return (i + 1, Some(&self.buf[..n]));
                }
                continue;
            }
            if self.len == self.buf.len() {
                if !self.overflow {
                    self.dropped += 1;
                }
                self.overflow = true;
                continue;
            }
            self.buf[self.len] = b;
            self.len += 1;
        }
        (input.len(), None)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    fn frames(stream: &[u8], chunk: usize) -> (Vec<Vec<u8>>, u32) {
        let mut r = FrameReader::new();
        let mut out = Vec::new();
        for part in stream.chunks(chunk) {
            let mut rest = part;
            while !rest.is_empty() {
                let (n, f) = r.push(rest);
                if let Some(f) = f {
                    out.push(f.to_vec());
                }
                rest = &rest[n..];
            }
        }
        (out, r.dropped)
    }

    #[test]
    fn frames_are_cut_at_zeros_whatever_the_chunks() {
        let mut long = std::vec![7u8; MAX_FRAME + 3];
        long.push(0);
        let mut stream = std::vec![0, 1, 2, 0, 0, 3, 0];
        stream.extend(&long);
        stream.extend([4, 5, 0, 6]);
        for chunk in [1, 2, 5, 64, 1000] {
            let (f, dropped) = frames(&stream, chunk);
            assert_eq!(
                f,
                [std::vec![1, 2], std::vec![3], std::vec![4, 5]],
                "{chunk}"
            );
            assert_eq!(dropped, 1);
        }
    }
}
