//! A simulated CAN-FD bus with bitwise arbitration, and a transport that
//! carries motet frames over it.
//!
//! Every node owns one identifier (the bus refuses a second node with the
//! same one, so replies never share an id). In each slot, of the frames
//! waiting at the heads of the nodes' queues the one with the lowest
//! arbitration key wins; the losers try again in the next slot. The winner
//! is delivered to every other node, in order.
//!
//! [`CanTransport`] (`transport.rs`) carries motet frames over a bus node.
//!
//! A bus made with [`CanBus::timed`] also takes time: a frame occupies the
//! bus for its bits at the nominal and data rates ([`BusTiming`]), the next
//! arbitration starts when it ends, and every receiver gets it at its end
//! of frame, stamped with that instant as its own clock reads it (the
//! receive timestamp a CAN controller takes). The sender can hear its own
//! frames back, stamped the same way ([`CanBus::attach_hearing_own`], as
//! SocketCAN's `CAN_RAW_RECV_OWN_MSGS`): a frame every node hears at one
//! instant is a shared reference for their clocks.

mod timing;
mod transport;

pub use timing::BusTiming;
pub use transport::{fragment, CanTransport};

use crate::clock::Clock;
use crate::slcan::{fd_round_up, CanFrame, MAX_EXT_ID, MAX_STD_ID};
use std::collections::VecDeque;
use std::fmt;
use std::sync::{Arc, Mutex, MutexGuard};

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

/// A frame as a node receives it: when its end of frame passed (bus µs, on
/// a timed bus) and whether the node sent it itself.
#[derive(Clone, Debug)]
pub struct Received {
    /// The frame.
    pub frame: CanFrame,
    /// Its end of frame, µs of the bus's clock (timed bus only).
    pub at_us: Option<f64>,
    /// The node's own frame, heard back.
    pub own: bool,
}

#[derive(Debug, Default)]
struct NodeState {
    id: u32,
    extended: bool,
    hears_own: bool,
    /// Frames waiting, with when they were queued (bus µs; 0 untimed).
    tx: VecDeque<(CanFrame, f64)>,
    rx: VecDeque<Received>,
}

/// The time of a timed bus.
struct Timed {
    timing: BusTiming,
    clock: Arc<dyn Clock + Send + Sync>,
    /// The frame on the wire: its sender, the frame, its end, bus µs.
    on_wire: Option<(usize, CanFrame, f64)>,
    /// When the bus was last free, bus µs.
    free_at: f64,
}

impl fmt::Debug for Timed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Timed")
            .field("timing", &self.timing)
            .field("free_at", &self.free_at)
            .finish_non_exhaustive()
    }
}

#[derive(Debug, Default)]
struct BusInner {
    nodes: Vec<NodeState>,
    slots: u64,
    timed: Option<Timed>,
}

impl BusInner {
    /// Among the frames at the heads of the queues that were waiting at
    /// `at`, the node whose frame wins arbitration.
    fn winner(&self, at: f64) -> Option<usize> {
        self.nodes
            .iter()
            .enumerate()
            .filter_map(|(i, n)| {
                n.tx.front()
                    .filter(|f| f.1 <= at)
                    .map(|f| (f.0.arbitration_key(), i))
            })
            .min()
            .map(|w| w.1)
    }

    /// Hands `f` (sent by `from`) to every node that hears it.
    fn deliver(&mut self, from: usize, f: &CanFrame, at_us: Option<f64>) {
        self.slots += 1;
        for (i, n) in self.nodes.iter_mut().enumerate() {
            let own = i == from;
            if !own || n.hears_own {
                n.rx.push_back(Received {
                    frame: f.clone(),
                    at_us,
                    own,
                });
            }
        }
    }

    /// Runs a timed bus up to its clock's now: frames whose end of frame
    /// passed are delivered, at most `max` of them. Returns how many.
    fn advance(&mut self, max: usize) -> usize {
        let mut n = 0;
        while n < max {
            let Some(t) = self.timed.as_mut() else {
                return n;
            };
            let now = t.clock.now_us() as f64;
            if let Some((from, f, end)) = t.on_wire.take() {
                if end > now {
                    t.on_wire = Some((from, f, end));
                    return n;
                }
                t.free_at = end;
                self.deliver(from, &f, Some(end));
                n += 1;
                continue;
            }
            let free_at = t.free_at;
            let Some(first) = self
                .nodes
                .iter()
                .filter_map(|n| n.tx.front().map(|f| f.1))
                .reduce(f64::min)
            else {
                return n;
            };
            let start = free_at.max(first);
            if start > now {
                return n;
            }
            let Some(w) = self.winner(start) else {
                return n;
            };
            let Some((f, _)) = self.nodes[w].tx.pop_front() else {
                return n;
            };
            if let Some(t) = self.timed.as_mut() {
                let end = start + t.timing.frame_us(&f);
                t.on_wire = Some((w, f, end));
            }
        }
        n
    }

    /// When something next happens on a timed bus: the frame on the wire
    /// ends, or one waiting can start, bus µs.
    fn next_event(&self) -> Option<f64> {
        let t = self.timed.as_ref()?;
        if let Some((_, _, end)) = &t.on_wire {
            return Some(*end);
        }
        let first = self
            .nodes
            .iter()
            .filter_map(|n| n.tx.front().map(|f| f.1))
            .reduce(f64::min)?;
        Some(first.max(t.free_at))
    }
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
    /// A bus with no node attached, on which frames take no time.
    pub fn new() -> CanBus {
        CanBus::default()
    }

    /// A bus on which frames take the time `timing` gives, read on `clock`
    /// (bus µs).
    pub fn timed(timing: BusTiming, clock: Arc<dyn Clock + Send + Sync>) -> CanBus {
        let bus = CanBus::default();
        lock(&bus.inner).timed = Some(Timed {
            timing,
            clock,
            on_wire: None,
            free_at: 0.0,
        });
        bus
    }

    /// When something next happens on a timed bus (a frame ends, or one
    /// waiting can start), bus µs rounded up; `None` when idle or untimed.
    pub fn next_event_us(&self) -> Option<u64> {
        lock(&self.inner).next_event().map(|t| t.ceil() as u64)
    }

    /// Attaches a node owning `id`.
    pub fn attach(&self, id: u32, extended: bool) -> Result<CanNode, BusError> {
        self.attach_with(id, extended, false)
    }

    /// Attaches a node owning `id` that also receives its own frames, at
    /// their end of frame.
    pub fn attach_hearing_own(&self, id: u32, extended: bool) -> Result<CanNode, BusError> {
        self.attach_with(id, extended, true)
    }

    fn attach_with(&self, id: u32, extended: bool, hears_own: bool) -> Result<CanNode, BusError> {
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
            hears_own,
            ..NodeState::default()
        });
        Ok(CanNode {
            bus: self.clone(),
            index: b.nodes.len() - 1,
            id,
            extended,
        })
    }

    /// One arbitration slot on a bus without time: the winning frame (if
    /// any node has one waiting) is taken off its queue, delivered to every
    /// node that hears it and returned. A timed bus answers `None`: its
    /// clock moves it ([`CanBus::run`]).
    pub fn step(&self) -> Option<CanFrame> {
        let mut b = lock(&self.inner);
        if b.timed.is_some() {
            return None;
        }
        let winner = b.winner(0.0)?;
        let (f, _) = b.nodes[winner].tx.pop_front()?;
        b.deliver(winner, &f, None);
        Some(f)
    }

    /// Carries at most `max_slots` frames: on a bus without time, until no
    /// node has one waiting; on a timed bus, those whose end of frame has
    /// passed on its clock. Returns the frames carried.
    pub fn run(&self, max_slots: usize) -> usize {
        if lock(&self.inner).timed.is_some() {
            return lock(&self.inner).advance(max_slots);
        }
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
        let mut b = lock(&self.bus.inner);
        let at = b.timed.as_ref().map_or(0.0, |t| t.clock.now_us() as f64);
        b.nodes[self.index].tx.push_back((frame, at));
        Ok(())
    }

    /// The next frame received from the bus.
    pub fn receive(&self) -> Option<CanFrame> {
        self.receive_stamped().map(|r| r.frame)
    }

    /// The next frame received from the bus, with its end of frame.
    pub fn receive_stamped(&self) -> Option<Received> {
        lock(&self.bus.inner).nodes[self.index].rx.pop_front()
    }

    /// Frames waiting to be sent.
    pub fn pending(&self) -> usize {
        lock(&self.bus.inner).nodes[self.index].tx.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::SimClock;
    use std::collections::BTreeMap;

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

    /// On a timed bus a frame reaches every receiver at its end of frame,
    /// the next arbitration waits for the wire, and every receiver (the
    /// sender hearing its own included) stamps one instant.
    #[test]
    fn timed_bus_one_instant_for_every_receiver() {
        let clock = SimClock::new();
        let timing = BusTiming::FD_1M_5M;
        let bus = CanBus::timed(timing, Arc::new(clock.clone()));
        let a = bus.attach_hearing_own(0x10, false).unwrap();
        let b = bus.attach(0x20, false).unwrap();
        let c = bus.attach(0x30, false).unwrap();
        let short = timing.frame_us(&CanFrame::fd(0x20, false, &[1; 8]));
        let long = timing.frame_us(&CanFrame::fd(0x10, false, &[2; 64]));
        clock.set(100);
        b.transmit(&[1; 8]).unwrap();
        // a's frame wins the next arbitration, but b's is on the wire.
        clock.set(110);
        a.transmit(&[2; 64]).unwrap();
        assert_eq!(bus.run(10), 0);
        assert_eq!(bus.next_event_us(), Some((100.0 + short).ceil() as u64));
        clock.set((100.0 + short).floor() as u64);
        assert_eq!(bus.run(10), 0, "nothing before its end of frame");
        clock.set(10_000);
        assert_eq!(bus.run(10), 2);
        assert_eq!(bus.next_event_us(), None);
        let heard = |n: &CanNode| {
            std::iter::from_fn(|| n.receive_stamped())
                .map(|r| (r.frame.id, r.at_us.unwrap(), r.own))
                .collect::<Vec<_>>()
        };
        let (first, second) = (100.0 + short, 100.0 + short + long);
        assert_eq!(heard(&c), vec![(0x20, first, false), (0x10, second, false)]);
        assert_eq!(heard(&a), vec![(0x20, first, false), (0x10, second, true)]);
        assert_eq!(heard(&b), vec![(0x10, second, false)]);
        assert_eq!(bus.step(), None, "a timed bus runs on its clock");
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
}
