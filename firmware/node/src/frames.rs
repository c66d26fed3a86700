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

/// Reads the link dry: `read` fills `rx` with what arrived (0: nothing
/// now), and each complete frame goes to `deliver` with the clock's time
/// (`now`) read when it was taken. Returns the last such time (0 when no
/// frame came).
///
/// A time per frame, not one for the round: a clock request is answered
/// with it, and one that came while the loop was busy (or while the core
/// was away, as an emulated board's is on a loaded computer) must not be
/// dated before the host sent it, or the host's hard limits on the node's
/// rate stop holding.
pub fn take_frames(
    reader: &mut FrameReader,
    rx: &mut [u8],
    mut read: impl FnMut(&mut [u8]) -> usize,
    mut now: impl FnMut() -> u64,
    mut deliver: impl FnMut(&[u8], u64),
) -> u64 {
    let mut last = 0;
    loop {
        let n = read(rx);
        if n == 0 {
            return last;
        }
        let mut rest = &rx[..n];
        while !rest.is_empty() {
            let (used, frame) = reader.push(rest);
            if let Some(f) = frame {
                last = now();
                deliver(f, last);
            }
            rest = &rest[used..];
        }
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

    /// Each frame is dated when it was taken, not when the round began:
    /// a frame that came in a later read gets that read's time.
    #[test]
    fn each_frame_is_dated_when_it_is_taken() {
        use core::cell::Cell;
        // Reads as the link gives them: the third frame arrives 5 ms into
        // the round, split across two reads.
        let reads: [&[u8]; 4] = [&[1, 0, 2], &[0], &[3, 3], &[3, 0, 4, 0]];
        let t = Cell::new(1_000u64);
        let mut k = 0;
        let mut got = Vec::new();
        let mut rx = [0u8; 8];
        let last = take_frames(
            &mut FrameReader::new(),
            &mut rx,
            |buf| {
                let Some(r) = reads.get(k) else { return 0 };
                k += 1;
                // Each read comes 5 ms after the one before.
                t.set(t.get() + 5_000);
                buf[..r.len()].copy_from_slice(r);
                r.len()
            },
            || t.get(),
            |f, at| got.push((f.to_vec(), at)),
        );
        assert_eq!(
            got,
            [
                (std::vec![1], 6_000),
                (std::vec![2], 11_000),
                (std::vec![3, 3, 3], 21_000),
                (std::vec![4], 21_000),
            ]
        );
        assert_eq!(last, 21_000);
        let mut none = |_: &mut [u8]| 0;
        assert_eq!(
            take_frames(&mut FrameReader::new(), &mut rx, &mut none, || 7, |_, _| {}),
            0
        );
    }
}
