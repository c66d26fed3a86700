//! motet frames over a CAN bus node: a COBS-stuffed frame is split into
//! 64-byte CAN-FD payloads under the node's id (the last one padded with
//! 0x00 to a DLC length); the 0x00 delimiter ends the motet frame, so no
//! fragment header is needed, and the receiver collects fragments per
//! sender id, each frame stamped with its last fragment's end of frame.

use super::{CanNode, FD_CHUNK};
use crate::clock::Crystal;
use crate::slcan::fd_round_up;
use crate::{LinkStats, Stamp, StreamSplitter, Transport};
use std::collections::{BTreeMap, VecDeque};
use std::io;
use std::time::Duration;

/// Splits an encoded motet frame (delimiter added if missing) into CAN-FD
/// payloads of at most 64 bytes, the last one padded with 0x00 to a DLC
/// length.
pub fn fragment(frame: &[u8]) -> Vec<Vec<u8>> {
    let mut bytes = frame.to_vec();
    if bytes.last() != Some(&0) {
        bytes.push(0);
    }
    bytes
        .chunks(FD_CHUNK)
        .map(|c| {
            let mut c = c.to_vec();
            let n = fd_round_up(c.len()).unwrap_or(FD_CHUNK);
            c.resize(n, 0);
            c
        })
        .collect()
}

/// Bound on bus slots simulated per [`Transport::recv`].
const MAX_SLOTS_PER_RECV: usize = 1 << 16;

/// motet frames over a [`CanBus`](super::CanBus) node.
#[derive(Debug)]
pub struct CanTransport {
    name: String,
    node: CanNode,
    /// Only frames from this id are taken (all senders if `None`).
    peer: Option<u32>,
    splitters: BTreeMap<u32, StreamSplitter>,
    /// Frames reassembled, each with the stamp of its last fragment.
    ready: VecDeque<(Vec<u8>, Option<Stamp>)>,
    last_stamp: Option<Stamp>,
    /// The receiver's clock against the bus's, for stamps.
    crystal: Crystal,
    stats: LinkStats,
}

impl CanTransport {
    /// A transport sending under `node`'s identifier and taking only frames
    /// from `peer` (every sender's if `None`, each reassembled separately).
    /// Stamps read the bus's clock as it is.
    pub fn new(node: CanNode, peer: Option<u32>) -> CanTransport {
        CanTransport::with_clock(node, peer, Crystal::default())
    }

    /// [`CanTransport::new`] on a receiver whose clock reads `crystal`'s
    /// local time for the bus's: its stamps are in its own clock.
    pub fn with_clock(node: CanNode, peer: Option<u32>, crystal: Crystal) -> CanTransport {
        CanTransport {
            name: format!("can:{:#x}", node.id()),
            node,
            peer,
            splitters: BTreeMap::new(),
            ready: VecDeque::new(),
            last_stamp: None,
            crystal,
            stats: LinkStats::default(),
        }
    }

    /// The bus node it sends under.
    pub fn node(&self) -> &CanNode {
        &self.node
    }
}

impl Transport for CanTransport {
    fn name(&self) -> &str {
        &self.name
    }

    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        let parts = fragment(frame);
        let n: usize = parts.iter().map(Vec::len).sum();
        for p in parts {
            self.node
                .transmit(&p)
                .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
        }
        self.stats.sent(n);
        Ok(())
    }

    /// The simulated bus is synchronous: this runs it until idle and never
    /// waits, whatever `timeout` says.
    fn recv(&mut self, _timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>> {
        if self.ready.is_empty() {
            self.node.bus().run(MAX_SLOTS_PER_RECV);
            while let Some(r) = self.node.receive_stamped() {
                let f = &r.frame;
                if self.peer.is_some_and(|p| p != f.id) || !f.fd {
                    continue;
                }
                let stamp = r.at_us.map(|t| Stamp {
                    at_us: self.crystal.local(t),
                    own: r.own,
                });
                let ready = &mut self.ready;
                self.splitters
                    .entry(f.id)
                    .or_default()
                    .push(&f.data, &mut |bytes| ready.push_back((bytes, stamp)));
            }
        }
        let Some((f, stamp)) = self.ready.pop_front() else {
            return Ok(None);
        };
        self.last_stamp = stamp;
        self.stats.received(f.len());
        Ok(Some(f))
    }

    fn last_stamp(&self) -> Option<Stamp> {
        self.last_stamp
    }

    fn stats(&self) -> &LinkStats {
        &self.stats
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::can::{BusTiming, CanBus};
    use crate::clock::SimClock;
    use crate::slcan::CanFrame;
    use crate::testutil::link_exchange;
    use motet_wire::frame::{decode, encode, Flags, Header, MAX_FRAME};
    use std::sync::Arc;

    /// A transport stamps what it receives in its own clock: the bus's end
    /// of frame read through its crystal.
    #[test]
    fn transport_stamps_in_its_own_clock() {
        let clock = SimClock::new();
        let bus = CanBus::timed(BusTiming::FD_1M_5M, Arc::new(clock.clone()));
        let crystal = Crystal {
            ppm: 100.0,
            offset_us: 5_000_000,
        };
        let mut a = CanTransport::new(bus.attach_hearing_own(0x10, false).unwrap(), None);
        let mut b = CanTransport::with_clock(bus.attach(0x20, false).unwrap(), None, crystal);
        clock.set(1_000_000);
        a.send(&frame(1, 100)).unwrap();
        clock.set(2_000_000);
        let f = b.recv(None).unwrap().unwrap();
        assert_eq!(decode(&f, &mut [0u8; MAX_FRAME]).unwrap().header.seq, 1);
        let end = 1_000_000.0
            + fragment(&frame(1, 100))
                .iter()
                .map(|p| BusTiming::FD_1M_5M.frame_us(&CanFrame::fd(0x10, false, p)))
                .sum::<f64>();
        assert_eq!(
            b.last_stamp(),
            Some(Stamp {
                at_us: crystal.local(end),
                own: false
            })
        );
        assert!(a.recv(None).unwrap().is_some());
        assert_eq!(
            a.last_stamp(),
            Some(Stamp {
                at_us: end as u64,
                own: true
            })
        );
    }

    fn frame(seq: u16, len: usize) -> Vec<u8> {
        let h = Header {
            dst: 2,
            src: 1,
            port: 10,
            flags: Flags::DATA,
            seq,
            ack: 0,
        };
        let p: Vec<u8> = (0..len).map(|i| i as u8 ^ 0x5A).collect();
        let mut out = [0u8; MAX_FRAME];
        let n = encode(&h, &p, &mut out).unwrap();
        out[..n].to_vec()
    }

    #[test]
    fn fragment_sizes() {
        // (payload length, CAN-FD payload lengths on the bus)
        let cases: &[(usize, &[usize])] = &[
            (0, &[16]),
            (14, &[32]),
            (48, &[64]),
            (50, &[64, 2]),
            (60, &[64, 12]),
            (192, &[64, 64, 64, 16]),
        ];
        for &(len, want) in cases {
            let f = frame(1, len);
            let parts = fragment(&f);
            let sizes: Vec<usize> = parts.iter().map(Vec::len).collect();
            assert_eq!(sizes, want, "payload {len}");
            let joined: Vec<u8> = parts.concat();
            assert_eq!(&joined[..f.len()], &f[..]);
            assert!(joined[f.len()..].iter().all(|&b| b == 0));
        }
    }

    #[test]
    fn transport_frames_and_lost_fragment() {
        let bus = CanBus::new();
        let mut a = CanTransport::new(bus.attach(0x20, false).unwrap(), Some(0x21));
        let mut b = CanTransport::new(bus.attach(0x21, false).unwrap(), Some(0x20));
        let stranger = bus.attach(0x01, false).unwrap();
        stranger.transmit(&[1, 2, 3, 0]).unwrap();
        for (i, len) in [0usize, 30, 100, 192].iter().enumerate() {
            a.send(&frame(i as u16, *len)).unwrap();
        }
        let mut raw = [0u8; MAX_FRAME];
        for (i, len) in [0usize, 30, 100, 192].iter().enumerate() {
            let f = b.recv(None).unwrap().unwrap();
            let d = decode(&f, &mut raw).unwrap();
            assert_eq!((d.header.seq, d.payload.len()), (i as u16, *len));
        }
        assert_eq!(b.recv(None).unwrap(), None);
        // A lost fragment spoils one frame; the next decodes.
        let parts = fragment(&frame(7, 150));
        for (i, p) in parts.iter().enumerate() {
            if i != 1 {
                a.node().transmit(p).unwrap();
            }
        }
        a.send(&frame(8, 20)).unwrap();
        let bad = b.recv(None).unwrap().unwrap();
        assert!(decode(&bad, &mut raw).is_err());
        let good = b.recv(None).unwrap().unwrap();
        assert_eq!(decode(&good, &mut raw).unwrap().header.seq, 8);
    }

    #[test]
    fn link_over_can_delivers_1000_in_order() {
        let bus = CanBus::new();
        let mut a = CanTransport::new(bus.attach(0x10, false).unwrap(), Some(0x11));
        let mut b = CanTransport::new(bus.attach(0x11, false).unwrap(), Some(0x10));
        let x = link_exchange(&mut a, &mut b, 1000, None);
        assert_eq!(x.got, (0..1000).collect::<Vec<u32>>());
        assert_eq!(x.host.retransmits, 0);
    }
}
