//! Wire frames and messages: bytes as a node receives them from a link.
//!
//! Random bytes almost never pass a frame's CRC-32C, and a node acts on
//! motion messages only through an established reliable link, so the input
//! is read as a script whose records reach each layer:
//!
//! | tag & 3 | record bytes | what happens |
//! |---|---|---|
//! | 0 | raw | handed to the node's [`Endpoint`] as received; checked against the frame decoder's round trip and the stream deframer |
//! | 1 | 10 header bytes (the frame's layout) + payload | encoded into a valid frame (CRC included), then handed to the endpoint |
//! | 2 | port + payload | sent by a host [`Link`] (connected before the script) through the endpoint to the node or its services; port-10 payloads also go straight to a separate [`Node`] |
//! | 3 | µs/100 (u16 LE) | time passes (a bounded amount); the endpoint and the node run |
//!
//! A record is `tag, len, len bytes` ([`Script`] writes them). Every
//! payload is also decoded as each message type, and what decodes must
//! re-encode stably. The node must refuse anything it does not take without
//! changing its queues, and everything the endpoint sends must be a valid
//! frame carrying a message the host can decode.

use crate::bounded;
use motet_node::{Board, Endpoint, Node, NodeConfig, NodeStatus, Persisted, RamFlash, RamStore};
use motet_wire::frame::{
    self, Deframer, Flags, Frame, FrameError, Header, HEADER_LEN, MAX_FRAME, MAX_RAW,
};
use motet_wire::link::{Config as LinkConfig, Link};
use motet_wire::service::{port, Kind, ServiceRequest, Version, HOST_ADDRESS};
use motet_wire::{decode, encode, HostMessage, NodeMessage, ServiceReply, MAX_MESSAGE};

/// The node's address (paired before the script).
const NODE: u16 = 2;
const UID: u64 = 0x5157_0000;
/// Rounds of frame exchange after a record before giving up on quiet.
const MAX_ROUNDS: usize = 64;
/// Time one wait record lets pass at most, µs: about a hundred node frames.
const MAX_WAIT_US: u64 = 5_000;
/// Host time an input lets pass in all, µs, and steps after which time stops
/// passing: a node does work for every step (at most
/// [`motet_node::MAX_STEP_RATE`] per channel, and a poll stops after
/// [`motet_node::MAX_OUTPUTS_PER_POLL`] outputs), so these bound the work per
/// input. 200,000 steps take about 5 ms here, and a few seconds under the
/// fuzzer's instrumentation: more would only make its timeouts.
const MAX_TIME_US: u64 = 50_000;
const MAX_STEPS: u64 = 200_000;

type Ep = Endpoint<RamStore, RamFlash<4096>, 64>;

/// Writes the records a [`wire_frame`] input is read as.
#[derive(Clone, Debug, Default)]
pub struct Script(pub Vec<u8>);

impl Script {
    fn record(mut self, tag: u8, bytes: &[u8]) -> Self {
        for chunk in bytes.chunks(255).take(1) {
            self.0.push(tag);
            self.0.push(chunk.len() as u8);
            self.0.extend_from_slice(chunk);
        }
        if bytes.is_empty() {
            self.0.extend_from_slice(&[tag, 0]);
        }
        self
    }
    /// Bytes as received from a transport.
    pub fn raw(self, bytes: &[u8]) -> Self {
        self.record(0, bytes)
    }
    /// A valid frame with this header and payload.
    pub fn framed(self, header: &Header, payload: &[u8]) -> Self {
        let mut b = header.to_bytes().to_vec();
        b.extend_from_slice(payload);
        self.record(1, &b)
    }
    /// A payload sent through the host's link on `port`.
    pub fn link(self, port: u8, payload: &[u8]) -> Self {
        let mut b = vec![port];
        b.extend_from_slice(payload);
        self.record(2, &b)
    }
    /// A message encoded and sent through the host's link on its port.
    pub fn message<T: serde::Serialize>(self, port: u8, msg: &T) -> Self {
        let mut buf = [0u8; MAX_MESSAGE];
        let bytes = encode(msg, &mut buf).expect("messages fit");
        self.link(port, bytes)
    }
    /// Time passing, in steps of 100 µs.
    pub fn wait(self, us: u64) -> Self {
        let n = (us / 100).min(u16::MAX as u64) as u16;
        self.record(3, &n.to_le_bytes())
    }
}

/// A board that counts what it is told.
#[derive(Default)]
struct Count {
    steps: u64,
    tools: u64,
}

impl Board for Count {
    fn step(&mut self, _: u8, _: bool, at_us: f64) {
        assert!(at_us.is_finite(), "a step at {at_us} µs");
        self.steps += 1;
    }
    fn set_tool(&mut self, _: u8, value: f32, at_us: f64) {
        assert!(
            at_us.is_finite() && value.is_finite(),
            "tool {value} at {at_us} µs"
        );
        self.tools += 1;
    }
}

fn config() -> NodeConfig {
    NodeConfig {
        kind: Kind::try_from("stepper").expect("short kind"),
        uid: UID,
        firmware: Version {
            major: 0,
            minor: 1,
            patch: 0,
        },
        protocol_min: 1,
        protocol_max: 1,
        queue_capacity: 64,
        channels: 8,
        tools: 4,
        board: None,
        max_step_hz: 0,
    }
}

/// Everything observable about a node's queues and channels without running it.
type Snapshot = (NodeStatus, Vec<i64>, usize, Option<u64>, Option<u64>);

fn snapshot(node: &mut Node<64>) -> Snapshot {
    (
        node.status(),
        node.channels().iter().map(|c| c.position()).collect(),
        node.queued(),
        node.front_end().map(f64::to_bits),
        node.next_deadline().map(f64::to_bits),
    )
}

/// Decodes `bytes` as `T`; what decodes must encode, and encode again to
/// the same bytes.
fn stable<T>(bytes: &[u8])
where
    T: serde::Serialize + serde::de::DeserializeOwned,
{
    let Ok(msg) = decode::<T>(bytes) else { return };
    let mut a = [0u8; MAX_MESSAGE * 2];
    let first = encode(&msg, &mut a)
        .expect("a decoded message encodes")
        .to_vec();
    let again: T = decode(&first).expect("an encoded message decodes");
    let mut b = [0u8; MAX_MESSAGE * 2];
    let second = encode(&again, &mut b).expect("a decoded message encodes");
    assert_eq!(first, second, "re-encoding is not stable");
}

fn messages(bytes: &[u8]) {
    stable::<HostMessage>(bytes);
    stable::<NodeMessage>(bytes);
    stable::<ServiceRequest>(bytes);
    stable::<ServiceReply>(bytes);
}

/// Frame decoding agrees with itself: what decodes re-encodes to a frame
/// that decodes the same, and a stream deframer finds the same frame.
fn frame_round_trip(bytes: &[u8]) {
    let mut raw = [0u8; MAX_RAW];
    let direct = frame::decode(bytes, &mut raw).map(|f| (f.header, f.payload.to_vec()));
    if let Ok((h, p)) = &direct {
        let mut enc = [0u8; MAX_FRAME];
        let n = frame::encode(h, p, &mut enc).expect("a decoded frame encodes");
        let mut raw2 = [0u8; MAX_RAW];
        let f = frame::decode(&enc[..n], &mut raw2).expect("an encoded frame decodes");
        assert_eq!((f.header, f.payload), (*h, &p[..]), "frame round trip");
    }
    let body = bytes.strip_suffix(&[0]).unwrap_or(bytes);
    if !body.is_empty() && !body.contains(&0) {
        let mut d = Deframer::new();
        let mut stream = body.to_vec();
        stream.push(0);
        let (used, got) = d.push(&stream);
        let got: Option<Result<(Header, Vec<u8>), FrameError>> =
            got.map(|r| r.map(|f: Frame<'_>| (f.header, f.payload.to_vec())));
        assert_eq!(used, stream.len(), "the deframer stopped inside a frame");
        assert_eq!(got, Some(direct), "deframer and decoder disagree");
    }
}

struct Rig {
    ep: Box<Ep>,
    host: Box<Link>,
    node: Box<Node<64>>,
    board: Count,
    now: u64,
    /// Local time when the script starts.
    start: u64,
    buf: Box<[u8; MAX_FRAME]>,
}

impl Rig {
    /// A paired node with a clock model and a connected host link.
    fn new() -> Rig {
        let store = RamStore {
            record: Some(Persisted {
                uid: UID,
                address: NODE,
                firmware: config().firmware,
            }),
            saves: 0,
        };
        let mut rig = Rig {
            ep: Box::new(Endpoint::new(config(), store, RamFlash::new(), 0)),
            host: Box::new(Link::new(LinkConfig {
                isn: 0x1000,
                ..LinkConfig::new(HOST_ADDRESS, NODE, true)
            })),
            node: Box::new(Node::new()),
            board: Count::default(),
            now: 1_000,
            start: 0,
            buf: Box::new([0; MAX_FRAME]),
        };
        let time = ServiceRequest::TimeSet {
            offset: 0.0,
            skew: 0.0,
        };
        let mut b = [0u8; MAX_MESSAGE];
        let payload = encode(&time, &mut b).expect("fits").to_vec();
        rig.datagram(port::TIME, &payload);
        rig.exchange();
        rig.start = rig.now;
        rig
    }

    fn datagram(&mut self, port: u8, payload: &[u8]) {
        let h = Header {
            dst: NODE,
            src: HOST_ADDRESS,
            port,
            flags: Flags::NONE,
            seq: 0,
            ack: 0,
        };
        if let Ok(n) = frame::encode(&h, payload, &mut self.buf[..]) {
            let f = self.buf[..n].to_vec();
            self.ep.on_frame(&f, self.now);
        }
    }

    /// Frames both ways until both sides are quiet.
    fn exchange(&mut self) {
        for _ in 0..MAX_ROUNDS {
            let mut quiet = true;
            while let Some(f) = self.host.poll(self.now, &mut self.buf[..]) {
                let f = f.to_vec();
                quiet = false;
                self.ep.on_frame(&f, self.now);
            }
            while let Some(f) = self.ep.transmit(self.now, &mut self.buf[..]) {
                let f = f.to_vec();
                quiet = false;
                self.node_sent(&f);
            }
            if quiet {
                return;
            }
            self.now += 50;
        }
    }

    /// A frame the endpoint sent: valid, and carrying what the host reads.
    fn node_sent(&mut self, bytes: &[u8]) {
        let mut raw = [0u8; MAX_RAW];
        let f = match frame::decode(bytes, &mut raw) {
            Ok(f) => f,
            Err(e) => panic!("the node sent a frame that does not decode: {e}"),
        };
        assert!(
            f.payload.len() <= MAX_MESSAGE,
            "payload of {} bytes",
            f.payload.len()
        );
        if f.header.flags == Flags::NONE {
            assert!(
                decode::<ServiceReply>(f.payload).is_ok(),
                "a datagram reply on port {} does not decode: {:?}",
                f.header.port,
                f.payload
            );
            return;
        }
        if f.header.dst != HOST_ADDRESS {
            return;
        }
        let mut d = self
            .host
            .on_decoded(&f, self.now)
            .map(|d| (d.port, d.payload.to_vec()));
        while let Some((p, payload)) = d {
            if p == port::MOTION {
                assert!(
                    decode::<NodeMessage>(&payload).is_ok(),
                    "a motion reply does not decode: {payload:?}"
                );
            } else {
                assert!(
                    decode::<ServiceReply>(&payload).is_ok(),
                    "a service reply on port {p} does not decode: {payload:?}"
                );
            }
            d = self.host.recv().map(|d| (d.port, d.payload.to_vec()));
        }
    }

    /// A motion message straight to the separate node: taken, or refused
    /// with its queues untouched.
    fn send_to_node(&mut self, payload: &[u8]) {
        let before = snapshot(&mut self.node);
        match self.node.handle(payload) {
            Some(NodeMessage::Refused { reason }) => assert_eq!(
                snapshot(&mut self.node),
                before,
                "state changed by a refused message ({reason:?}): {payload:?}"
            ),
            Some(
                NodeMessage::Status { .. }
                | NodeMessage::Position { .. }
                | NodeMessage::Tally { .. },
            )
            | None => {}
            // Sent unasked, never as a reply.
            Some(
                m @ (NodeMessage::Fault { .. }
                | NodeMessage::Samples(_)
                | NodeMessage::HeaterReady { .. }),
            ) => {
                panic!("a reply that is never one: {m:?}")
            }
        }
    }

    fn run(&mut self, record: &[u8], tag: u8) {
        match tag & 3 {
            0 => {
                frame_round_trip(record);
                self.ep.on_frame(record, self.now);
            }
            1 if record.len() >= HEADER_LEN => {
                let b = record;
                let h = Header {
                    flags: Flags::from_bits(b[0] & 0x0f),
                    dst: u16::from_le_bytes([b[1], b[2]]),
                    src: u16::from_le_bytes([b[3], b[4]]),
                    port: b[5],
                    seq: u16::from_le_bytes([b[6], b[7]]),
                    ack: u16::from_le_bytes([b[8], b[9]]),
                };
                let payload = &b[HEADER_LEN..];
                messages(payload);
                if let Ok(n) = frame::encode(&h, payload, &mut self.buf[..]) {
                    let f = self.buf[..n].to_vec();
                    self.ep.on_frame(&f, self.now);
                }
            }
            1 => {}
            2 => {
                let Some((&p, payload)) = record.split_first() else {
                    return;
                };
                messages(payload);
                if p == port::MOTION {
                    self.send_to_node(payload);
                }
                // A full window or a failed link keeps nothing: as on a host.
                let _ = self.host.send_port(p, payload, self.now);
            }
            _ => {
                let n = u16::from_le_bytes([
                    record.first().copied().unwrap_or(0),
                    record.get(1).copied().unwrap_or(0),
                ]);
                self.now += (n as u64 * 100).min(MAX_WAIT_US);
                if self.may_run() {
                    self.ep.poll(self.now, &mut self.board);
                    self.node.poll(self.now as f64, &mut self.board);
                }
            }
        }
        self.exchange();
        if self.may_run() {
            self.ep.poll(self.now, &mut self.board);
        }
    }

    /// Whether the nodes still run: within the input's time and step budget.
    fn may_run(&self) -> bool {
        self.now <= self.start + MAX_TIME_US && self.board.steps <= MAX_STEPS
    }
}

/// Runs a script of frames and messages against a node (see the module
/// documentation for the layout).
pub fn wire_frame(data: &[u8]) {
    let mut data = bounded(data);
    let mut rig = Rig::new();
    while let [tag, len, rest @ ..] = data {
        let n = (*len as usize).min(rest.len());
        let (record, tail) = rest.split_at(n);
        rig.run(record, *tag);
        data = tail;
    }
}
