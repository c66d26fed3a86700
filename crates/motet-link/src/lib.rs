//! Transports that carry `motet-wire` frames between a host and its nodes.
//!
//! Every transport implements [`Transport`]: it sends one encoded frame (the
//! COBS-stuffed bytes, with or without the trailing 0x00) and hands received
//! frames back one at a time, without blocking or with a timeout. Datagram
//! transports (channels, UDP) keep frame boundaries themselves; stream
//! transports (serial, CAN-FD) find them at the 0x00 delimiter with a
//! [`StreamSplitter`] and queue them in an [`Inbox`], whose
//! [`Inbox::recv`] is the receive loop they share.
//!
//! Fault injection for tests and benchmarks is a wrapper ([`Faulty`]), not
//! part of the trait.

use std::io;
use std::time::Duration;

pub mod can;
pub mod clock;
pub mod fault;
pub mod inbox;
pub mod mem;
pub mod serial;
pub mod slcan;
pub mod slcan_port;
pub mod spec;
pub mod udp;
pub mod udp_group;
mod udp_stamp;

pub use can::{BusTiming, CanBus, CanNode, CanTransport, Received};
pub use clock::{Clock, Crystal, SimClock, WallClock};
pub use fault::{FaultClock, FaultConfig, FaultCounts, Faulty};
pub use inbox::Inbox;
pub use mem::{pair, MemTransport};
pub use serial::SerialTransport;
pub use slcan_port::{SlcanConfig, SlcanTransport};
pub use spec::{open, LinkSpec, OpenError, SpecError};
pub use udp::UdpTransport;
pub use udp_group::{GroupTally, UdpGroup};

/// Traffic counters of one transport: frames and bytes as they crossed it.
/// Link-level figures (CRC errors, retransmits, round-trip time) belong to
/// the `motet_wire::link::Link` that rides on the transport and are read
/// from it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Frames sent.
    pub frames_out: u64,
    /// Bytes sent, as this transport puts them on its medium (a delimiter
    /// it adds, CAN padding included).
    pub bytes_out: u64,
    /// Frames handed out by `recv`.
    pub frames_in: u64,
    /// Bytes of those frames as handed out.
    pub bytes_in: u64,
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
}

/// One end of a carrier of motet frames.
///
/// A transport moves whole encoded frames and nothing else: it does not
/// decode them, acknowledge them, retransmit them or read a clock. The
/// `motet_wire::link::Link` above it does all of that with the time its
/// caller passes in, so a transport that loses, corrupts, duplicates or
/// reorders frames is still correct, only slower.
///
/// # What each method must do
///
/// - [`name`](Transport::name): a short label for messages and logs, fixed
///   when the transport is made (`"udp:127.0.0.1:4000->127.0.0.1:5000"`).
/// - [`send`](Transport::send): hand one frame to the medium and return
///   without waiting for it to arrive. The frame is the COBS-stuffed bytes,
///   usually ending with the 0x00 delimiter. A datagram transport sends it as
///   one datagram, as given; a stream transport appends the delimiter if it
///   is missing, because the receiver finds frame boundaries only there.
///   Count it with [`LinkStats::sent`]. Return `Err` only when the medium is
///   gone (port closed, peer dropped, no route); a frame lost in transit is
///   not an error.
/// - [`recv`](Transport::recv): the next frame received, or `Ok(None)`.
///   `timeout` `None` must not block at all (the caller polls in its own
///   loop); `Some(d)` may block up to `d` of real time for the first frame,
///   and must return as soon as one frame is ready. Hand frames out one per
///   call, in arrival order, with their delimiter if the medium carried it.
///   Bytes that cannot be a frame are handed on anyway (the decoder counts
///   them as CRC errors); a run longer than `motet_wire::frame::MAX_FRAME`
///   without a delimiter is cut ([`StreamSplitter`] does both). Count each
///   frame handed out with [`LinkStats::received`].
/// - [`stats`](Transport::stats): the counters above.
///
/// # Timestamps
///
/// The transport owns none. The caller reads its clock before and after
/// `recv` and passes the time to the link; a transport simulated in
/// process (the CAN bus, [`Faulty`] on a [`SimClock`]) never waits for its
/// own notion of time inside `recv`.
///
/// # Framing help
///
/// A byte-stream medium keeps a [`StreamSplitter`] (one per sender if
/// several share the medium) that cuts the stream at 0x00, and an [`Inbox`]
/// of frames completed but not yet handed out; [`Inbox::recv`] then is the
/// whole of `recv`: the transport only says how to read its medium once.
///
/// # Example
///
/// A transport over any `Read + Write` byte stream, here an in-memory loop
/// that receives what it sent:
///
/// ```
/// use motet_link::{Inbox, LinkStats, StreamSplitter, Transport};
/// use std::io::{self, Read, Write};
/// use std::time::Duration;
///
/// struct StreamTransport<S> {
///     name: String,
///     stream: S,
///     splitter: StreamSplitter,
///     inbox: Inbox,
///     stats: LinkStats,
/// }
///
/// impl<S: Read + Write> Transport for StreamTransport<S> {
///     fn name(&self) -> &str {
///         &self.name
///     }
///
///     fn send(&mut self, frame: &[u8]) -> io::Result<()> {
///         self.stream.write_all(frame)?;
///         if frame.last() != Some(&0) {
///             self.stream.write_all(&[0])?;
///         }
///         self.stats.sent(frame.len());
///         Ok(())
///     }
///
///     fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>> {
///         // Read the medium once, waiting at most `_wait` (this stream
///         // never blocks), and say whether bytes arrived.
///         let (stream, splitter) = (&mut self.stream, &mut self.splitter);
///         self.inbox.recv(timeout, &mut self.stats, |inbox, _wait| {
///             let mut buf = [0u8; 256];
///             let n = stream.read(&mut buf)?;
///             inbox.take_stream(splitter, &buf[..n]);
///             Ok(n > 0)
///         })
///     }
///
///     fn stats(&self) -> &LinkStats {
///         &self.stats
///     }
/// }
///
/// /// Bytes written come back to be read.
/// #[derive(Default)]
/// struct Echo(std::collections::VecDeque<u8>);
/// impl Read for Echo {
///     fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
///         self.0.read(buf)
///     }
/// }
/// impl Write for Echo {
///     fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
///         self.0.extend(buf);
///         Ok(buf.len())
///     }
///     fn flush(&mut self) -> io::Result<()> {
///         Ok(())
///     }
/// }
///
/// let mut t = StreamTransport {
///     name: "echo".into(),
///     stream: Echo::default(),
///     splitter: StreamSplitter::default(),
///     inbox: Inbox::default(),
///     stats: LinkStats::default(),
/// };
/// t.send(&[1, 2, 3]).unwrap();
/// t.send(&[4, 0]).unwrap();
/// assert_eq!(t.recv(None).unwrap(), Some(vec![1, 2, 3, 0]));
/// assert_eq!(t.recv(Some(Duration::from_millis(1))).unwrap(), Some(vec![4, 0]));
/// assert_eq!(t.recv(None).unwrap(), None);
/// assert_eq!(t.stats().frames_in, 2);
/// ```
///
/// To make the transport reachable by a link specification
/// (`motet run --link …`), add its scheme to [`spec`].
pub trait Transport {
    /// A short human-readable name ("mem:a", "udp:127.0.0.1:4000", ...).
    fn name(&self) -> &str;

    /// Sends one encoded frame without waiting for it to arrive.
    fn send(&mut self, frame: &[u8]) -> io::Result<()>;

    /// The next received frame, if any: `timeout` `None` does not block,
    /// `Some(d)` waits at most `d`. `Ok(None)` means nothing arrived.
    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>>;

    /// Counters so far.
    fn stats(&self) -> &LinkStats;

    /// When the frame the last [`Transport::recv`] returned arrived, as
    /// close to the wire as the transport can tell (a CAN controller's
    /// receive timestamp), in the receiver's clock; `None` when it cannot
    /// tell better than the caller's own clock.
    fn last_stamp(&self) -> Option<Stamp> {
        None
    }

    /// From now on, stamps each frame's arrival where it comes in (a
    /// socket's receive queue) on `clock`, the receiver's own, and gives it
    /// as [`Transport::last_stamp`]; `false` when this transport cannot
    /// (the default), and frames are then stamped when read.
    fn stamp_arrivals(&mut self, clock: WallClock) -> bool {
        let _ = clock;
        false
    }
}

/// When a received frame arrived, read at the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stamp {
    /// Its arrival (end of frame), µs of the receiver's clock.
    pub at_us: u64,
    /// The receiver sent it itself and heard it back: the instant every
    /// other receiver on the medium heard it too.
    pub own: bool,
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
    /// A splitter that cuts runs longer than `max` bytes without a delimiter.
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
    use motet_wire::link::{Config, Link, Stats};
    use std::time::Duration;

    /// What [`link_exchange`] delivered, and the two links' figures.
    pub struct Exchanged {
        pub got: Vec<u32>,
        pub host: Stats,
        pub node: Stats,
    }

    /// Drives an active host link and a passive node link over two
    /// transports until the node has received `count` payloads; returns them.
    /// Time is a simulated clock advanced by each round, so the result does
    /// not depend on wall-clock timing; the loop is bounded.
    pub fn link_exchange(
        a: &mut dyn Transport,
        b: &mut dyn Transport,
        count: u32,
        wait: Option<Duration>,
    ) -> Exchanged {
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
    ) -> Exchanged {
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
        Exchanged {
            got,
            host: *host.stats(),
            node: *node.stats(),
        }
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
