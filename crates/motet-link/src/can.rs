//! A simulated CAN-FD bus with bitwise arbitration, and a transport that
//! carries motet frames over it.
//!
//! Every node owns one identifier (the bus refuses a second node with the
//! same one, so replies never share an id). In each slot, of the frames
//! waiting at the heads of the nodes' queues the one with the lowest
//! arbitration key wins; the losers try again in the next slot. The winner
//! is delivered to every other node, in order.
//!
//! [`CanTransport`] splits the COBS-stuffed frame into 64-byte CAN-FD
//! payloads under its node's id (the last one padded with 0x00 to a DLC
//! length); the 0x00 delimiter ends the motet frame, so no fragment header
//! is needed, and the receiver collects fragments per sender id.

use crate::slcan::{fd_round_up, CanFrame, MAX_EXT_ID, MAX_STD_ID};
use crate::{Inbox, LinkStats, StreamSplitter, Transport};
use std::collections::{BTreeMap, VecDeque};
use std::fmt;
use std::io;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

/// CAN-FD payload per fragment.
pub const FD_CHUNK: usize = 64;

/// Why the simulated bus refused a node or a frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BusError {
    /// Another node already owns this identifier.
    DuplicateId(u32),
    /// An identifier beyond 11 bits (standard) or 29 bits (extended).
    IdOutOfRange(u32),
    /// A node may only send under its own identifier.
    WrongId {
        /// The node's identifier.
        own: u32,
        /// The identifier the frame carried.
        frame: u32,
    },
    /// Payload length that is not a CAN / CAN-FD length.
    BadLength(usize),
}

impl fmt::Display for BusError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "CAN bus: {self:?}")
    }
}

impl std::error::Error for BusError {}

#[derive(Debug, Default)]
struct NodeState {
    id: u32,
    extended: bool,
    tx: VecDeque<CanFrame>,
    rx: VecDeque<CanFrame>,
}

#[derive(Debug, Default)]
struct BusInner {
    nodes: Vec<NodeState>,
    slots: u64,
}

/// The shared bus. Cloning gives another handle to the same bus.
#[derive(Clone, Debug, Default)]
pub struct CanBus {
    inner: Arc<Mutex<BusInner>>,
}

fn lock(m: &Mutex<BusInner>) -> MutexGuard<'_, BusInner> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl CanBus {
    /// A bus with no node attached.
    pub fn new() -> CanBus {
        CanBus::default()
    }

    /// Attaches a node owning `id`.
    pub fn attach(&self, id: u32, extended: bool) -> Result<CanNode, BusError> {
        let max = if extended { MAX_EXT_ID } else { MAX_STD_ID };
        if id > max {
            return Err(BusError::IdOutOfRange(id));
        }
        let mut b = lock(&self.inner);
        if b.nodes.iter().any(|n| n.id == id && n.extended == extended) {
            return Err(BusError::DuplicateId(id));
        }
        b.nodes.push(NodeState {
            id,
            extended,
            ..NodeState::default()
        });
        Ok(CanNode {
            bus: self.clone(),
            index: b.nodes.len() - 1,
            id,
            extended,
        })
    }

    /// One arbitration slot: the winning frame (if any node has one
    /// waiting) is taken off its queue, delivered to all other nodes and
    /// returned.
    pub fn step(&self) -> Option<CanFrame> {
        let mut b = lock(&self.inner);
        let winner = b
            .nodes
            .iter()
            .enumerate()
            .filter_map(|(i, n)| n.tx.front().map(|f| (f.arbitration_key(), i)))
            .min()?
            .1;
        let f = b.nodes[winner].tx.pop_front()?;
        b.slots += 1;
        for (i, n) in b.nodes.iter_mut().enumerate() {
            if i != winner {
                n.rx.push_back(f.clone());
            }
        }
        Some(f)
    }

    /// Steps until no node has a frame waiting, at most `max_slots` slots.
    /// Returns the slots used.
    pub fn run(&self, max_slots: usize) -> usize {
        (0..max_slots).take_while(|_| self.step().is_some()).count()
    }

    /// Slots used so far (frames carried).
    pub fn slots(&self) -> u64 {
        lock(&self.inner).slots
    }
}

/// A node's handle on the bus.
#[derive(Clone, Debug)]
pub struct CanNode {
    bus: CanBus,
    index: usize,
    id: u32,
    extended: bool,
}

impl CanNode {
    /// The identifier this node sends under.
    pub fn id(&self) -> u32 {
        self.id
    }

    /// The bus it is attached to.
    pub fn bus(&self) -> &CanBus {
        &self.bus
    }

    /// Queues a CAN-FD frame under this node's id; `data` must have a
    /// CAN-FD length.
    pub fn transmit(&self, data: &[u8]) -> Result<(), BusError> {
        if fd_round_up(data.len()) != Some(data.len()) {
            return Err(BusError::BadLength(data.len()));
        }
        self.transmit_frame(CanFrame::fd(self.id, self.extended, data))
    }

    /// Queues any frame; its id must be this node's.
    pub fn transmit_frame(&self, frame: CanFrame) -> Result<(), BusError> {
        if frame.id != self.id || frame.extended != self.extended {
            return Err(BusError::WrongId {
                own: self.id,
                frame: frame.id,
            });
        }
        let max = if frame.fd { 64 } else { 8 };
        if frame.data.len() > max {
            return Err(BusError::BadLength(frame.data.len()));
        }
        lock(&self.bus.inner).nodes[self.index].tx.push_back(frame);
        Ok(())
    }

    /// The next frame received from the bus.
    pub fn receive(&self) -> Option<CanFrame> {
        lock(&self.bus.inner).nodes[self.index].rx.pop_front()
    }

    /// Frames waiting to be sent.
    pub fn pending(&self) -> usize {
        lock(&self.bus.inner).nodes[self.index].tx.len()
    }
}

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

/// motet frames over a [`CanBus`] node.
#[derive(Debug)]
pub struct CanTransport {
    name: String,
    node: CanNode,
    /// Only frames from this id are taken (all senders if `None`).
    peer: Option<u32>,
    splitters: BTreeMap<u32, StreamSplitter>,
    inbox: Inbox,
    stats: LinkStats,
}

impl CanTransport {
    /// A transport sending under `node`'s identifier and taking only frames
    /// from `peer` (every sender's if `None`, each reassembled separately).
    pub fn new(node: CanNode, peer: Option<u32>) -> CanTransport {
        CanTransport {
            name: format!("can:{:#x}", node.id()),
            node,
            peer,
            splitters: BTreeMap::new(),
            inbox: Inbox::new(),
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
        if self.inbox.is_empty() {
            self.node.bus().run(MAX_SLOTS_PER_RECV);
            while let Some(f) = self.node.receive() {
                if self.peer.is_some_and(|p| p != f.id) || !f.fd {
                    continue;
                }
                self.inbox.take_from(&mut self.splitters, f.id, &f.data);
            }
        }
        Ok(self.inbox.pop(&mut self.stats))
    }

    fn stats(&self) -> &LinkStats {
        &self.stats
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::link_exchange;
    use motet_wire::frame::{decode, encode, Flags, Header, MAX_FRAME};

    fn tagged(node: &CanNode, tag: u8) {
        node.transmit(&[tag]).unwrap();
    }

    #[test]
    fn three_nodes_same_slot_in_id_order_none_lost() {
        let bus = CanBus::new();
        let ids = [0x300, 0x100, 0x200];
        let nodes: Vec<CanNode> = ids
            .iter()
            .map(|&id| bus.attach(id, false).unwrap())
            .collect();
        let listener = bus.attach(0x7FF, false).unwrap();
        for round in 0..5u8 {
            for n in &nodes {
                tagged(n, round);
            }
        }
        assert_eq!(bus.run(1000), 15);
        let mut got = Vec::new();
        while let Some(f) = listener.receive() {
            got.push((f.id, f.data[0]));
        }
        let mut want = Vec::new();
        for id in [0x100, 0x200, 0x300] {
            for round in 0..5u8 {
                want.push((id, round));
            }
        }
        assert_eq!(got, want);
        // Each sender hears the other two, never itself.
        for n in &nodes {
            let mut heard = 0;
            while let Some(f) = n.receive() {
                assert_ne!(f.id, n.id());
                heard += 1;
            }
            assert_eq!(heard, 10);
        }
        assert_eq!(bus.slots(), 15);
    }

    #[test]
    fn arbitration_scenario() {
        // (slot, id, tag) injections before each slot; expected winners.
        let events: &[(usize, u32, u8)] = &[
            (0, 0x300, b'a'),
            (0, 0x100, b'b'),
            (0, 0x200, b'c'),
            (1, 0x050, b'd'),
            (3, 0x100, b'e'),
        ];
        let want = b"bdcea";
        let bus = CanBus::new();
        let mut nodes = BTreeMap::new();
        for &(_, id, _) in events {
            if let std::collections::btree_map::Entry::Vacant(e) = nodes.entry(id) {
                e.insert(bus.attach(id, false).unwrap());
            }
        }
        let mut got = Vec::new();
        for slot in 0..10 {
            for &(s, id, tag) in events {
                if s == slot {
                    tagged(&nodes[&id], tag);
                }
            }
            if let Some(f) = bus.step() {
                got.push(f.data[0]);
            }
        }
        assert_eq!(got, want);
    }

    #[test]
    fn arbitration_keys() {
        let std_ = |id| CanFrame::standard(id, &[]);
        let ext = |id| CanFrame {
            extended: true,
            ..CanFrame::standard(id, &[])
        };
        let rtr = |f: CanFrame| CanFrame { rtr: true, ..f };
        // (winner, loser)
        let cases = [
            (std_(0x100), std_(0x101)),
            (std_(0x100), rtr(std_(0x100))),
            (std_(0x100), ext(0x100 << 18)),
            (ext(0x0FF << 18 | 0x3FFFF), std_(0x100)),
            (ext(5), ext(6)),
            (ext(5), rtr(ext(5))),
            (rtr(std_(0x100)), ext(0x100 << 18)),
        ];
        for (w, l) in cases {
            assert!(w.arbitration_key() < l.arbitration_key(), "{w:?} vs {l:?}");
        }
    }

    #[test]
    fn ids_are_owned() {
        let bus = CanBus::new();
        let a = bus.attach(0x10, false).unwrap();
        assert_eq!(
            bus.attach(0x10, false).unwrap_err(),
            BusError::DuplicateId(0x10)
        );
        assert!(bus.attach(0x10, true).is_ok());
        assert_eq!(
            bus.attach(0x800, false).unwrap_err(),
            BusError::IdOutOfRange(0x800)
        );
        assert_eq!(
            a.transmit_frame(CanFrame::standard(0x11, &[])),
            Err(BusError::WrongId {
                own: 0x10,
                frame: 0x11
            })
        );
        assert_eq!(a.transmit(&[0; 13]), Err(BusError::BadLength(13)));
        assert_eq!(a.pending(), 0);
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
