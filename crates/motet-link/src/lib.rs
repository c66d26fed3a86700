//! Transports that carry `motet-wire` frames between a host and its nodes.
//!
//! Every transport implements [`Transport`]: it sends one encoded frame (the
//! COBS-stuffed bytes, with or without the trailing 0x00) and hands received
//! frames back one at a time, without blocking or with a timeout. Datagram
//! transports (channels, UDP) keep frame boundaries themselves; stream
//! transports (serial, CAN-FD) find them at the 0x00 delimiter.

use std::io;
use std::time::Duration;

pub mod can;
pub mod fault;
pub mod mem;
pub mod serial;
pub mod slcan;
pub mod slcan_port;
pub mod spec;
pub mod udp;

pub use can::{CanBus, CanNode, CanTransport};
pub use fault::{FaultClock, FaultConfig, FaultCounts, Faulty, SimClock};
pub use mem::{pair, MemTransport};
pub use serial::SerialTransport;
pub use slcan_port::{SlcanConfig, SlcanTransport};
pub use spec::{open, LinkSpec, OpenError, SpecError};
pub use udp::UdpTransport;

/// Traffic counters of one transport. Frames and bytes are counted by the
/// transport; CRC errors, retransmits and the RTT estimate come from the
/// `motet_wire::link::Link` that rides on it ([`LinkStats::absorb`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkStats {
    pub frames_out: u64,
    pub bytes_out: u64,
    pub frames_in: u64,
    pub bytes_in: u64,
    pub crc_errors: u64,
    pub retransmits: u64,
    /// Smoothed round-trip time in µs (0 before any sample).
    pub rtt_us: u64,
}

impl LinkStats {
    /// Counts one frame sent.
    pub fn sent(&mut self, bytes: usize) {
        self.frames_out += 1;
        self.bytes_out += bytes as u64;
    }

    /// Counts one frame received.
    pub fn received(&mut self, bytes: usize) {
        self.frames_in += 1;
        self.bytes_in += bytes as u64;
    }

    /// Copies the link-level figures from a `Link`'s statistics.
    pub fn absorb(&mut self, link: &motet_wire::link::Stats) {
        self.crc_errors = link.crc_errors;
        self.retransmits = link.retransmits;
        self.rtt_us = link.srtt_us;
    }
}

/// One end of a carrier of motet frames.
pub trait Transport {
    /// A short human-readable name ("mem:a", "udp:127.0.0.1:4000", ...).
    fn name(&self) -> &str;

    /// Sends one encoded frame.
    fn send(&mut self, frame: &[u8]) -> io::Result<()>;

    /// The next received frame, if any: `timeout` `None` does not block,
    /// `Some(d)` waits at most `d`. `Ok(None)` means nothing arrived.
    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>>;

    /// Counters so far.
    fn stats(&self) -> &LinkStats;

    /// Counters, for the caller to fill in link-level figures.
    fn stats_mut(&mut self) -> &mut LinkStats;
}

/// Collects a byte stream into frames ending at 0x00. Empty frames (repeated
/// delimiters) are skipped; a run longer than `max` without a delimiter is
/// cut and handed on, so the decoder reports it.
#[derive(Clone, Debug)]
pub struct StreamSplitter {
    buf: Vec<u8>,
    max: usize,
}

impl Default for StreamSplitter {
    fn default() -> Self {
        StreamSplitter::new(motet_wire::frame::MAX_FRAME)
    }
}

impl StreamSplitter {
    pub fn new(max: usize) -> StreamSplitter {
        StreamSplitter {
            buf: Vec::new(),
            max,
        }
    }

    /// Feeds bytes; every complete frame (with its 0x00) goes to `out`.
    pub fn push(&mut self, bytes: &[u8], out: &mut impl FnMut(Vec<u8>)) {
        for &b in bytes {
            if b == 0 {
                if !self.buf.is_empty() {
                    self.buf.push(0);
                    out(std::mem::take(&mut self.buf));
                }
                continue;
            }
            if self.buf.len() >= self.max {
                out(std::mem::take(&mut self.buf));
            }
            self.buf.push(b);
        }
    }

    /// Bytes of a frame not yet ended.
    pub fn pending(&self) -> usize {
        self.buf.len()
    }
}

#[cfg(test)]
pub(crate) mod testutil {
    use super::Transport;
    use motet_wire::frame::MAX_FRAME;
    use motet_wire::link::{Config, Link};
    use std::time::Duration;

    /// Drives an active host link and a passive node link over two
    /// transports until the node has received `count` payloads; returns them.
    /// Time is a simulated clock advanced by each round, so the result does
    /// not depend on wall-clock timing; the loop is bounded.
    pub fn link_exchange(
        a: &mut dyn Transport,
        b: &mut dyn Transport,
        count: u32,
        wait: Option<Duration>,
    ) -> Vec<u32> {
        let mut now = 0u64;
        link_exchange_clocked(a, b, count, wait, &mut || {
            now += 50;
            now
        })
    }

    /// Like [`link_exchange`] with the links' time taken from `clock` once
    /// per round.
    pub fn link_exchange_clocked(
        a: &mut dyn Transport,
        b: &mut dyn Transport,
        count: u32,
        wait: Option<Duration>,
        clock: &mut dyn FnMut() -> u64,
    ) -> Vec<u32> {
        let mut host = Link::new(Config {
            isn: 1000,
            ..Config::new(1, 2, true)
        });
        let mut node = Link::new(Config {
            isn: 7,
            ..Config::new(2, 1, false)
        });
        let mut got = Vec::new();
        let mut next = 0u32;
        let mut out = [0u8; MAX_FRAME];
        for _round in 0..1_000_000 {
            if got.len() as u32 == count {
                break;
            }
            let now = clock();
            while next < count && host.send(&next.to_le_bytes(), now).is_ok() {
                next += 1;
            }
            while let Some(f) = host.poll(now, &mut out) {
                a.send(f).unwrap();
            }
            // Drain the node side.
            let mut first = true;
            while let Some(f) = b.recv(if first { wait } else { None }).unwrap() {
                first = false;
                let mut d = node.on_frame(&f, now).map(|d| d.payload.to_vec());
                while let Some(p) = d {
                    got.push(u32::from_le_bytes(p[..4].try_into().unwrap()));
                    d = node.recv().map(|d| d.payload.to_vec());
                }
            }
            while let Some(f) = node.poll(now, &mut out) {
                b.send(f).unwrap();
            }
            let mut first = true;
            while let Some(f) = a.recv(if first { wait } else { None }).unwrap() {
                first = false;
                let _ = host.on_frame(&f, now);
            }
        }
        a.stats_mut().absorb(host.stats());
        b.stats_mut().absorb(node.stats());
        got
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitter_cases() {
        // (input chunks, expected frames)
        type Case<'a> = (&'a [&'a [u8]], &'a [&'a [u8]]);
        let cases: &[Case] = &[
            (&[&[1, 2, 0]], &[&[1, 2, 0]]),
            (&[&[0, 0, 1, 0, 0, 2, 3, 0]], &[&[1, 0], &[2, 3, 0]]),
            (&[&[1], &[2], &[3, 0, 4], &[0]], &[&[1, 2, 3, 0], &[4, 0]]),
            (&[&[5, 6]], &[]),
        ];
        for (chunks, want) in cases {
            let mut s = StreamSplitter::default();
            let mut got = Vec::new();
            for c in *chunks {
                s.push(c, &mut |f| got.push(f));
            }
            let want: Vec<Vec<u8>> = want.iter().map(|f| f.to_vec()).collect();
            assert_eq!(got, want, "chunks {chunks:?}");
        }
    }

    #[test]
    fn splitter_cuts_runaway() {
        let mut s = StreamSplitter::new(4);
        let mut got = Vec::new();
        s.push(&[1, 2, 3, 4, 5, 6, 0], &mut |f| got.push(f));
        assert_eq!(got, vec![vec![1, 2, 3, 4], vec![5, 6, 0]]);
    }
}
