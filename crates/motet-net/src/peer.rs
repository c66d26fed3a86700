//! One node as the host sees it: its transport, the reliable link over it,
//! its clock model, and what it last said.

use crate::node_clock::NodeClock;
use motet_link::Transport;
use motet_wire::frame::{self, Flags, Header, MAX_FRAME, MAX_RAW};
use motet_wire::group::GroupMessage;
use motet_wire::link::{Config as LinkConfig, Link, State};
use motet_wire::service::{port, ServiceReply, ServiceRequest};
use motet_wire::sync::{ClockModel, Exchange};
use motet_wire::{decode, encode, HostMessage, NodeMessage, MAX_MESSAGE};
use std::collections::VecDeque;

/// The host's own address on every link.
pub const HOST_ADDRESS: u16 = 1;

/// A service request from the host to `dst` as a datagram: a frame without
/// link flags, neither acknowledged nor repeated by the link.
pub fn datagram(dst: u16, req: &ServiceRequest) -> Vec<u8> {
    let mut buf = [0u8; MAX_MESSAGE];
    let payload = encode(req, &mut buf).expect("service requests fit MAX_MESSAGE");
    let header = Header {
        dst,
        src: HOST_ADDRESS,
        port: req.port(),
        flags: Flags::NONE,
        seq: 0,
        ack: 0,
    };
    let mut out = [0u8; MAX_FRAME];
    let n = frame::encode(&header, payload, &mut out).expect("one message fits a frame");
    out[..n].to_vec()
}

/// Something a node sent that the run acts on.
#[derive(Clone, Debug, PartialEq)]
pub enum Incoming {
    /// A message on the reliable link's data port: status, position,
    /// refusals, events.
    Motion(NodeMessage),
    /// A reply on a service port (clock exchange, info, status).
    Service(ServiceReply),
}

/// A payload waiting for room in the link's window.
#[derive(Clone, Debug)]
struct Outgoing {
    port: u8,
    bytes: Vec<u8>,
    /// What its acknowledgement tells the host.
    carries: Carries,
}

/// What the link's acknowledgement of a payload tells the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Carries {
    /// Nothing beyond its arrival.
    Message,
    /// A seal, with the node's sequence end it commits: the messages
    /// before it are a committed window, and the node acted on it.
    Seal(u32),
    /// A clock model (`TimeSet`): the node runs it or a later one
    /// ([`NodeClock::model_delivered`]).
    Model,
}

impl Outgoing {
    fn seal(&self) -> Option<u32> {
        match self.carries {
            Carries::Seal(end) => Some(end),
            _ => None,
        }
    }
}

/// The host's end of the link to one node: the reliable link, the frames
/// waiting for room in its window, the node's clock estimate and what came
/// in.
pub struct Peer {
    /// The machine node's name, for messages.
    pub name: String,
    /// The node's address on its link.
    pub address: u16,
    transport: Box<dyn Transport + Send>,
    link: Link,
    /// The node's clock, estimated from the exchanges.
    pub sync: NodeClock,
    outbox: VecDeque<Outgoing>,
    /// Host time of the last frame from the node, µs.
    pub last_heard: Option<u64>,
    /// Host time of the last request the node answers on the reliable
    /// link (a seal), µs: like a clock exchange, it asks the node to speak.
    pub last_asked: Option<u64>,
    /// Frames that came from another address than the node's.
    pub wrong_address: u64,
    /// Frames that did not decode (CRC, COBS, length).
    pub bad_frames: u64,
    /// Replies the run has not taken yet.
    inbox: VecDeque<Incoming>,
    /// Clock exchanges sent and answered.
    pub exchanges: (u64, u64),
    /// Reference samples taken: answers to a sync frame every node heard
    /// at the instant the host heard its own.
    pub references: u64,
    /// How far apart the host's and the node's stamps of one sync frame
    /// may lie, host µs: 0 where both are taken at the wire (a bus
    /// controller, a simulation), a few µs of each process's clock reading
    /// where the system stamps a datagram ([`Peer::reference_slack_us`]).
    reference_slack_us: u64,
    seal_sent: bool,
    /// The host's sync frames to every node heard back: (`t1`, when every
    /// node heard it, host µs). The last few.
    heard_own: VecDeque<(u64, u64)>,
    /// `t1` of the last exchanges asked of this node: an answer to any
    /// other (a request someone else sent in the host's name) is no sample.
    asked: VecDeque<u64>,
    /// Clock answers to no exchange the host asked: ignored.
    pub unasked: u64,
    /// Service datagrams to the host from another address than the node's
    /// (another device on its link: a module replaced or plugged in), the
    /// newest few, with their source.
    strangers: VecDeque<(u16, ServiceReply)>,
    /// Payloads handed to the link and not yet acknowledged, oldest
    /// first: what each one's acknowledgement tells.
    in_link: VecDeque<Carries>,
    /// The sequence end of the last seal the node's link acknowledged: the
    /// node acted on it (a refusal comes back as a message).
    pub sealed: Option<u32>,
    /// The node's last heartbeat on a shared medium: its run and committed
    /// end (how it confirms a group seal).
    pub beat: Option<(u32, u32)>,
}

/// Service datagrams from other addresses kept.
const STRANGERS: usize = 32;
/// Sync frames remembered for their answers.
const HEARD_OWN: usize = 8;
/// Exchanges remembered for their answers: more than are in flight at the
/// fastest rate over the slowest link.
const ASKED: usize = 256;

impl Peer {
    /// A peer reached over `transport` at `address`; `isn` should differ across
    /// host restarts so that the node sees a new session.
    pub fn new(name: &str, address: u16, transport: Box<dyn Transport + Send>, isn: u16) -> Peer {
        let link = Link::new(LinkConfig {
            isn,
            ..LinkConfig::new(HOST_ADDRESS, address, true)
        });
        Peer {
            name: name.to_string(),
            address,
            transport,
            link,
            sync: NodeClock::default(),
            outbox: VecDeque::new(),
            last_heard: None,
            last_asked: None,
            wrong_address: 0,
            bad_frames: 0,
            inbox: VecDeque::new(),
            exchanges: (0, 0),
            references: 0,
            seal_sent: false,
            heard_own: VecDeque::new(),
            reference_slack_us: 0,
            asked: VecDeque::new(),
            unasked: 0,
            strangers: VecDeque::new(),
            in_link: VecDeque::new(),
            sealed: None,
            beat: None,
        }
    }

    /// Has the transport stamp each frame's arrival on `clock` (the one
    /// this peer's `now` is read from), where it can: a clock exchange's
    /// `t4` is then when the answer came, not when the host got to it.
    pub fn stamp_arrivals(&mut self, clock: motet_link::WallClock) -> bool {
        self.transport.stamp_arrivals(clock)
    }

    /// Where the link is: connecting, established (with the protocol version
    /// agreed) or failed.
    pub fn link_state(&self) -> State {
        self.link.state()
    }

    /// The reliable link, for its statistics (round-trip time,
    /// retransmits, CRC errors).
    pub fn link(&self) -> &Link {
        &self.link
    }

    /// The transport under the link, for its traffic counters.
    pub fn transport(&self) -> &dyn Transport {
        self.transport.as_ref()
    }

    /// Queues a motion message on the reliable link.
    pub fn send_motion(&mut self, msg: &HostMessage) {
        let carries = match msg {
            HostMessage::Seal { next_seq } => Carries::Seal(*next_seq),
            _ => Carries::Message,
        };
        self.queue(motet_wire::link::DATA_PORT, msg, carries);
    }

    /// Queues the seal of a window ending at `next_seq`: in the window's
    /// last segment batch when that is the last message queued and still
    /// waits for the link (one frame instead of two), else on its own.
    pub fn send_seal(&mut self, next_seq: u32) {
        let last = self
            .outbox
            .back()
            .filter(|o| o.port == motet_wire::link::DATA_PORT && o.seal().is_none())
            .and_then(|o| decode::<HostMessage>(&o.bytes).ok());
        if let Some(HostMessage::Segments(batch)) = last {
            self.outbox.pop_back();
            let msg = HostMessage::SegmentsSealed(batch);
            self.queue(motet_wire::link::DATA_PORT, &msg, Carries::Seal(next_seq));
        } else {
            self.send_motion(&HostMessage::Seal { next_seq });
        }
    }

    /// Queues a service request on the reliable link.
    pub fn send_service(&mut self, req: &ServiceRequest) {
        self.queue(req.port(), req, Carries::Message);
    }

    /// Queues the clock model the node is to run on the reliable link.
    pub fn send_clock_model(&mut self, m: ClockModel) {
        let req = ServiceRequest::TimeSet {
            offset: m.offset,
            skew: m.skew,
        };
        self.queue(req.port(), &req, Carries::Model);
    }

    fn queue<T: serde::Serialize>(&mut self, port: u8, msg: &T, carries: Carries) {
        let mut buf = [0u8; MAX_MESSAGE];
        let bytes = encode(msg, &mut buf).expect("host messages fit MAX_MESSAGE");
        self.outbox.push_back(Outgoing {
            port,
            bytes: bytes.to_vec(),
            carries,
        });
    }

    /// Drops every motion message queued after the last queued seal: a
    /// window that was not sealed must never reach the node, a seal
    /// already queued must. Service requests (a clock model the host
    /// already counts the node as running) still go.
    pub fn drop_unsealed(&mut self) {
        let keep = self
            .outbox
            .iter()
            .rposition(|o| o.seal().is_some())
            .map_or(0, |s| s + 1);
        let mut i = 0;
        self.outbox.retain(|o| {
            i += 1;
            i <= keep || o.port != motet_wire::link::DATA_PORT
        });
    }

    /// A seal queued or sent and not yet acknowledged.
    pub fn seal_in_flight(&self) -> bool {
        self.outbox.iter().any(|o| o.seal().is_some()) || self.seal_sent
    }

    /// Payloads queued or in flight, not yet acknowledged.
    pub fn backlog(&self) -> usize {
        self.outbox.len() + self.link.unacked()
    }

    /// Sends a clock exchange request as a datagram (no retransmission: a
    /// late answer is worthless).
    pub fn send_time_get(&mut self, now: u64) -> std::io::Result<()> {
        self.asked(now);
        self.datagram(&ServiceRequest::TimeGet { t1: now })
    }

    /// A clock exchange with `t1` went out to this node (on its own or to
    /// every node): its answer is a sample.
    pub fn asked(&mut self, t1: u64) {
        self.exchanges.0 += 1;
        if self.asked.len() == ASKED {
            self.asked.pop_front();
        }
        self.asked.push_back(t1);
    }

    /// Sends a clock exchange request to every node at once, on a shared
    /// medium: one frame, answered by each node.
    pub fn send_time_to_all(&mut self, now: u64) -> std::io::Result<()> {
        self.datagram_to(frame::BROADCAST, &ServiceRequest::TimeGet { t1: now })
    }

    /// Sends a service request as a datagram to `dst` (broadcast for scans).
    pub fn datagram_to(&mut self, dst: u16, req: &ServiceRequest) -> std::io::Result<()> {
        self.transport.send(&datagram(dst, req))
    }

    /// Sends a message to every node as one datagram (on a shared medium
    /// every node hears it, whichever peer sends it).
    pub fn broadcast(&mut self, msg: &GroupMessage) -> std::io::Result<()> {
        let mut buf = [0u8; MAX_MESSAGE];
        let payload = encode(msg, &mut buf).expect("group messages fit MAX_MESSAGE");
        let header = Header {
            dst: frame::BROADCAST,
            src: HOST_ADDRESS,
            port: port::GROUP,
            flags: Flags::NONE,
            seq: 0,
            ack: 0,
        };
        let mut out = [0u8; MAX_FRAME];
        let n = frame::encode(&header, payload, &mut out).expect("one message fits a frame");
        self.transport.send(&out[..n])
    }

    fn datagram(&mut self, req: &ServiceRequest) -> std::io::Result<()> {
        self.datagram_to(self.address, req)
    }

    /// Takes every frame the transport has, without blocking.
    pub fn receive(&mut self, now: u64) -> std::io::Result<()> {
        while let Some(bytes) = self.transport.recv(None)? {
            let stamp = self.transport.last_stamp();
            self.on_frame(&bytes, now, stamp);
        }
        self.acknowledged();
        Ok(())
    }

    /// How far apart the host's and the node's stamps of one sync frame
    /// may lie, host µs (0 by default: stamps at the wire).
    pub fn reference_slack_us(&mut self, us: u64) {
        self.reference_slack_us = us;
    }

    /// The host's own sync frame to every node, heard back at `at`.
    fn heard_own(&mut self, payload: &[u8], at: u64) {
        if let Ok(ServiceRequest::TimeGet { t1 }) = decode::<ServiceRequest>(payload) {
            if self.heard_own.len() == HEARD_OWN {
                self.heard_own.pop_front();
            }
            self.heard_own.push_back((t1, at));
        }
    }

    /// A clock exchange answered: an exact reference sample when it
    /// answers a sync frame the host heard back (the node's `t2` and the
    /// host's stamp are one instant), else an exchange.
    fn exchange_answered(&mut self, t1: u64, t2: u64, t3: u64, t4: u64) {
        if !self.asked.contains(&t1) {
            self.unasked += 1;
            return;
        }
        self.exchanges.1 += 1;
        let heard = self.heard_own.iter().find(|h| h.0 == t1).map(|h| h.1);
        let e = match heard {
            Some(at) => {
                self.references += 1;
                // An exchange as wide as the stamps may disagree: the
                // bounds it tells stay hard limits.
                let slack = self.reference_slack_us;
                Exchange {
                    t1: at.saturating_sub(slack),
                    t2,
                    t3: t2,
                    t4: at + slack,
                }
            }
            None => Exchange { t1, t2, t3, t4 },
        };
        self.sync.add(e);
    }

    fn on_frame(&mut self, bytes: &[u8], now: u64, stamp: Option<motet_link::Stamp>) {
        // The frame's arrival as the transport read it, if it can tell
        // (past `now`, the poll's time, when it came during the poll: a
        // `t4` before it came would tell the exchange a false bound).
        let at = stamp.map_or(now, |s| s.at_us);
        let mut raw = [0u8; MAX_RAW];
        let f = match frame::decode(bytes, &mut raw) {
            Ok(f) => f,
            Err(e) => {
                self.bad_frames += 1;
                self.link.on_frame_error(e);
                return;
            }
        };
        if f.header.dst != HOST_ADDRESS {
            // A node's heartbeat to every node says it is alive, and
            // what it committed.
            if f.header.dst == frame::BROADCAST && f.header.src == self.address {
                self.last_heard = Some(now);
                if f.header.port == port::GROUP {
                    if let Ok(GroupMessage::Heartbeat { run, committed }) =
                        decode::<GroupMessage>(f.payload)
                    {
                        self.beat = Some((run, committed));
                    }
                }
            }
            // The host's own sync frame to every node, heard back at the
            // instant every node heard it.
            let own = stamp.is_some_and(|s| s.own) && f.header.src == HOST_ADDRESS;
            if own && f.header.dst == frame::BROADCAST && f.header.port == port::TIME {
                self.heard_own(f.payload, at);
            }
            return;
        }
        if f.header.src != self.address {
            self.wrong_address += 1;
            if f.header.flags == Flags::NONE {
                if let Ok(reply) = decode::<ServiceReply>(f.payload) {
                    if self.strangers.len() == STRANGERS {
                        self.strangers.pop_front();
                    }
                    self.strangers.push_back((f.header.src, reply));
                }
            }
            return;
        }
        self.last_heard = Some(now);
        if f.header.flags == Flags::NONE {
            // A datagram: a service reply outside the link.
            if let Ok(reply) = decode::<ServiceReply>(f.payload) {
                if let ServiceReply::Time { t1, t2, t3 } = reply {
                    self.exchange_answered(t1, t2, t3, at);
                } else {
                    self.inbox.push_back(Incoming::Service(reply));
                }
            }
            return;
        }
        let mut d = self
            .link
            .on_decoded(&f, now)
            .map(|d| (d.port, d.payload.to_vec()));
        while let Some((p, payload)) = d {
            let msg = if p == motet_wire::link::DATA_PORT {
                decode::<NodeMessage>(&payload).ok().map(Incoming::Motion)
            } else if p != port::LINK {
                decode::<ServiceReply>(&payload).ok().map(Incoming::Service)
            } else {
                None
            };
            if let Some(m) = msg {
                self.inbox.push_back(m);
            }
            d = self.link.recv().map(|d| (d.port, d.payload.to_vec()));
        }
    }

    /// Service datagrams that came from another address than the node's,
    /// with their source, oldest first.
    pub fn take_strangers(&mut self) -> Vec<(u16, ServiceReply)> {
        self.strangers.drain(..).collect()
    }

    /// The next reply the node sent.
    pub fn take(&mut self) -> Option<Incoming> {
        self.inbox.pop_front()
    }

    /// Moves queued payloads into the link and transmits what the link has.
    pub fn flush(&mut self, now: u64) -> std::io::Result<()> {
        while let Some(o) = self.outbox.front() {
            if self.link.send_space() == 0 {
                break;
            }
            match self.link.send_port(o.port, &o.bytes, now) {
                Ok(()) => {
                    // The seal is acknowledged once nothing is unacked.
                    self.seal_sent |= o.seal().is_some();
                    self.in_link.push_back(o.carries);
                    self.outbox.pop_front();
                }
                Err(_) => break,
            }
        }
        let mut out = [0u8; MAX_FRAME];
        while let Some(f) = self.link.poll(now, &mut out) {
            self.transport.send(f)?;
        }
        self.acknowledged();
        Ok(())
    }

    /// Takes what the link's acknowledgements say: the last seal the node
    /// acted on.
    fn acknowledged(&mut self) {
        while self.in_link.len() > self.link.unacked() {
            match self.in_link.pop_front() {
                Some(Carries::Seal(end)) => self.sealed = Some(end),
                Some(Carries::Model) => self.sync.model_delivered(),
                _ => {}
            }
        }
        if self.link.unacked() == 0 {
            self.seal_sent = false;
        }
    }

    /// When the link wants to be polled again.
    pub fn next_timeout(&self) -> Option<u64> {
        if !self.outbox.is_empty() && self.link.send_space() > 0 {
            return Some(0);
        }
        self.link.next_timeout()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motet_wire::SegmentBatch;

    fn queued(p: &Peer) -> Vec<(HostMessage, Option<u32>)> {
        p.outbox
            .iter()
            .map(|o| (decode::<HostMessage>(&o.bytes).unwrap(), o.seal()))
            .collect()
    }

    #[test]
    fn a_seal_rides_in_the_last_batch_when_it_can() {
        let (a, _b) = motet_link::pair("host", "node");
        let mut p = Peer::new("n", 2, Box::new(a), 1);
        let batch = SegmentBatch {
            bytes: heapless::Vec::from_slice(&[4, 0x21, 7]).unwrap(),
        };
        p.send_motion(&HostMessage::Segments(batch.clone()));
        p.send_seal(5);
        assert_eq!(
            queued(&p),
            vec![(HostMessage::SegmentsSealed(batch.clone()), Some(5))]
        );
        assert!(p.seal_in_flight());
        // An event after the batch: the seal goes on its own, after it.
        let event = HostMessage::Event {
            track: 0,
            time: 1.0,
            value: 0.5,
        };
        p.send_motion(&HostMessage::Segments(batch.clone()));
        p.send_motion(&event);
        p.send_seal(9);
        let q = queued(&p);
        assert_eq!(q.len(), 4);
        assert_eq!(q[1], (HostMessage::Segments(batch), None));
        assert_eq!(q[3], (HostMessage::Seal { next_seq: 9 }, Some(9)));
        // What was not sealed never goes.
        p.send_motion(&event);
        p.drop_unsealed();
        assert_eq!(queued(&p).len(), 4);
    }

    /// A stop drops the motion after the last seal, not a clock model
    /// queued among it: the host already counts the node as running it.
    #[test]
    fn a_stop_keeps_the_clock_model_queued_after_the_last_seal() {
        let (a, _b) = motet_link::pair("host", "node");
        let mut p = Peer::new("n", 2, Box::new(a), 1);
        let event = HostMessage::Event {
            track: 0,
            time: 1.0,
            value: 0.5,
        };
        p.send_motion(&HostMessage::Seal { next_seq: 3 });
        p.send_motion(&event);
        p.send_clock_model(ClockModel {
            offset: 5.0,
            skew: 1e-4,
        });
        p.send_motion(&event);
        p.drop_unsealed();
        let kept: Vec<Carries> = p.outbox.iter().map(|o| o.carries).collect();
        assert_eq!(kept, vec![Carries::Seal(3), Carries::Model]);
        // With no seal queued, only the model stays.
        p.send_motion(&event);
        p.outbox.pop_front();
        p.drop_unsealed();
        let kept: Vec<Carries> = p.outbox.iter().map(|o| o.carries).collect();
        assert_eq!(kept, vec![Carries::Model]);
    }
}
