//! A node on the network: frames in, frames out, the motion node and the base
//! service routines behind them.
//!
//! The endpoint routes each frame it is given: datagrams (frames without link
//! flags) straight to the service routines, link frames from the host through
//! the reliable [`Link`] to the motion node (port 10) or the service routines
//! (other ports), and sends each reply back the way its request came. It reads
//! no clock and owns no transport: the firmware's main loop (or a simulated
//! node process, or a test) passes the local time in µs, hands over received
//! bytes with [`Endpoint::on_frame`], runs the motion with [`Endpoint::poll`]
//! and transmits what [`Endpoint::transmit`] returns.
//!
//! Trajectory time is the host's: the motion node runs at the host time that
//! the clock model set by the host gives for the local clock, and not at all
//! before the host has set one.

use crate::board::Board;
use crate::group_watch::GroupWatch;
use crate::node::{Node, DEFAULT_QUEUE};
use crate::service::{Action, Handled, NodeConfig, Services};
use crate::storage::{Flash, Store};
use heapless::{Deque, Vec};
use motet_wire::frame::{self, is_multicast, Flags, Header, BROADCAST, MAX_RAW};
use motet_wire::group::{self, GroupError, GroupMessage};
use motet_wire::link::{Config as LinkConfig, Link, State, WINDOW};
use motet_wire::service::{port, NodeState, ServiceReply, HOST_ADDRESS};
use motet_wire::{encode, NodeMessage, MAX_MESSAGE};

/// A jump back in host time larger than this is a new host's time base.
const NEW_TIME_BASE_US: f64 = 1e6;

/// Replies waiting for room (datagrams, or the link's window).
const OUTBOX: usize = 8;

type Payload = Vec<u8, MAX_MESSAGE>;

/// A reply to send.
#[derive(Clone)]
struct Reply {
    /// Datagram: (destination, source address); `None`: through the link.
    datagram: Option<(u16, u16)>,
    port: u8,
    bytes: Payload,
}

/// Counters of what the endpoint took in, refused or dropped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EndpointStats {
    /// Frames handed to the endpoint (good or not).
    pub frames_in: u64,
    /// Frames that did not decode (CRC, COBS, length, version).
    pub bad_frames: u64,
    /// Frames for another address.
    pub foreign: u64,
    /// Replies dropped because the outbox was full.
    pub replies_dropped: u64,
    /// Link sessions started (the host connected or reconnected).
    pub sessions: u64,
    /// Group frames refused (a seal or stop not from the host, a bad
    /// member list): nothing changed.
    pub group_refused: u64,
    /// The last group frame refused: the address it came from and why.
    pub last_group_refusal: Option<(u16, GroupError)>,
    /// The member whose silence stopped this node (the host or a node).
    pub silent: Option<u16>,
    /// Clock exchanges to every node not from the host: not answered.
    pub sync_refused: u64,
}

/// A node on the network: the link to the host, the base service routines and the motion node, with
/// a segment queue of `Q` places.
pub struct Endpoint<S: Store, F: Flash, const Q: usize = DEFAULT_QUEUE> {
    services: Services<S, F>,
    node: Node<Q>,
    link: Option<Link>,
    /// Replies through the link, in order.
    outbox: Deque<Reply, OUTBOX>,
    /// Replies as datagrams.
    datagrams: Deque<Reply, OUTBOX>,
    /// Host time up to which the motion node has run, µs.
    ran_until: f64,
    /// Local time of the last frame from the host.
    last_host_frame: Option<u64>,
    /// A verified image was started: firmware restarts into its bootloader.
    start_requested: bool,
    stats: EndpointStats,
    /// The other members of the group, on a shared medium.
    group: GroupWatch,
}

impl<S: Store, F: Flash, const Q: usize> Endpoint<S, F, Q> {
    /// An endpoint with no link yet (the host opens one), a motion node that keeps a tally, and the
    /// services on `store` and `flash`; `now_local_us` is the local clock, µs.
    pub fn new(cfg: NodeConfig, store: S, flash: F, now_local_us: u64) -> Self {
        // A node on a link keeps a tally of its outputs, so that a host can
        // check what a board did against what it computes (`TallyGet`).
        let mut node = Node::new();
        node.keep_tally();
        Endpoint {
            services: Services::new(cfg, store, flash, now_local_us),
            node,
            link: None,
            outbox: Deque::new(),
            datagrams: Deque::new(),
            ran_until: f64::NEG_INFINITY,
            last_host_frame: None,
            start_requested: false,
            stats: EndpointStats::default(),
            group: GroupWatch::default(),
        }
    }

    /// The base service routines (address, pairing, firmware, clock model).
    pub fn services(&self) -> &Services<S, F> {
        &self.services
    }

    /// The motion node.
    pub fn node(&self) -> &Node<Q> {
        &self.node
    }

    /// The motion node, for firmware that feeds its graph the board's own
    /// inputs ([`Node::set_input`]).
    pub fn node_mut(&mut self) -> &mut Node<Q> {
        &mut self.node
    }

    /// A verified image was started (`FirmwareStart`): a board with a
    /// bootloader sends what is queued (the acknowledgement), then restarts
    /// into it to install the image. A simulated node has nothing to do.
    pub fn start_requested(&self) -> bool {
        self.start_requested
    }

    /// What the endpoint took in, refused or dropped.
    pub fn stats(&self) -> &EndpointStats {
        &self.stats
    }

    /// The link to the host, once the host opened one.
    pub fn link(&self) -> Option<&Link> {
        self.link.as_ref()
    }

    /// Local time of the last frame from the host.
    pub fn last_host_frame(&self) -> Option<u64> {
        self.last_host_frame
    }

    /// What the node says of itself on port 8 (see
    /// [`Services::set_description`]).
    pub fn set_description(&mut self, description: motet_wire::describe::Description) {
        self.services.set_description(description);
    }

    /// The node announces itself, as it does when it starts or is plugged
    /// in: the head of its description goes to the host unasked (a
    /// datagram on port 8), so a host watching the bus knows at once that
    /// a module came and whether it is one it knew.
    pub fn announce(&mut self) {
        let head = self.services.description().head(self.services.uid());
        let me = self.services.address();
        let reply = ServiceReply::Description {
            part: 0,
            data: motet_wire::describe::DescribePart::Head(head),
        };
        self.push(Some((HOST_ADDRESS, me)), port::DESCRIBE, &reply);
    }

    /// The node's button (pairing).
    pub fn press_button(&mut self, now_local_us: u64) {
        let old = self.services.address();
        if let Some(h) = self.services.press_button(now_local_us) {
            self.after(h, Some((HOST_ADDRESS, old)), port::ADDRESS);
        }
    }

    /// Takes one received frame (with or without its 0x00 delimiter).
    pub fn on_frame(&mut self, bytes: &[u8], now: u64) {
        self.on_frame_stamped(bytes, now, None);
    }

    /// [`Endpoint::on_frame`] for a frame the board's controller stamped on
    /// arrival (`stamp`, local µs): a clock exchange takes
    /// that instant as its `t2`, not the moment the frame was handled, so
    /// the time it waited for the main loop counts as the node's.
    pub fn on_frame_stamped(&mut self, bytes: &[u8], now: u64, stamp: Option<u64>) {
        self.stats.frames_in += 1;
        let mut raw = [0u8; MAX_RAW];
        let f = match frame::decode(bytes, &mut raw) {
            Ok(f) => f,
            Err(e) => {
                self.stats.bad_frames += 1;
                if let Some(l) = self.link.as_mut() {
                    l.on_frame_error(e);
                }
                return;
            }
        };
        let me = self.services.address();
        let h = f.header;
        // On a bus every frame a member sends is a sign of life.
        self.group.heard(h.src, now);
        if h.dst == BROADCAST && h.port == port::GROUP && h.flags == Flags::NONE {
            self.on_group(&h, f.payload, now);
            return;
        }
        let broadcast = is_multicast(h.dst);
        if !broadcast && h.dst != me {
            self.stats.foreign += 1;
            return;
        }
        if h.src == HOST_ADDRESS {
            self.last_host_frame = Some(now);
        }
        if h.flags == Flags::NONE {
            if h.port == port::MOTION || h.port == port::LINK {
                // Motion needs the link's order and exactly-once delivery.
                return;
            }
            let at = if h.port == port::TIME {
                if broadcast && h.src != HOST_ADDRESS {
                    // Every node would answer a sync frame to every node:
                    // only the host's is one.
                    self.stats.sync_refused += 1;
                    return;
                }
                // The arrival as stamped, even past `now` (a loop's time
                // read before it got to the frame): a `t2` taken earlier
                // than the frame came would tell the exchange a false
                // bound (the reply's `t3` is never before it).
                stamp.unwrap_or(now)
            } else {
                now
            };
            let handled = self.services.handle(h.port, f.payload, broadcast, at);
            self.after(handled, Some((h.src, me)), h.port);
            return;
        }
        if broadcast || !self.services.paired() {
            return;
        }
        // A SYN without ACK opens a session: a host that restarted (or a new
        // host) gets a new link, not a reset of the old one. A SYN repeated
        // during a handshake still goes to the link that is connecting.
        let opening = h.flags == Flags::SYN;
        let fresh = match &self.link {
            None => true,
            Some(l) => {
                l.config().peer != h.src
                    || (opening && !matches!(l.state(), State::Connecting))
                    || (matches!(l.state(), State::Failed(_)) && h.flags.contains(Flags::SYN))
            }
        };
        if fresh {
            if !h.flags.contains(Flags::SYN) {
                return;
            }
            self.stats.sessions += 1;
            // A different initial sequence number each session, so the host
            // tells a restarted node from a retransmission.
            let isn = (now as u16) ^ ((self.stats.sessions as u16) << 11);
            self.link = Some(Link::new(LinkConfig {
                isn,
                port: port::MOTION,
                ..LinkConfig::new(me, h.src, false)
            }));
        }
        // Copied out first: acting on a payload needs the rest of `self`.
        let mut got: Vec<(u8, Payload), WINDOW> = Vec::new();
        if let Some(link) = self.link.as_mut() {
            let mut d = link.on_decoded(&f, now);
            while let Some(del) = d {
                let _ = got.push((del.port, Vec::from_slice(del.payload).unwrap_or_default()));
                d = link.recv();
            }
            let up = matches!(link.state(), State::Established { .. });
            self.services.set_link_up(up);
        }
        for (p, payload) in got {
            if p == port::MOTION {
                if self.services.in_bootloader() {
                    continue;
                }
                if let Some(reply) = self.node.handle(&payload) {
                    self.push(None, port::MOTION, &reply);
                }
                // A service request in the same batch sees what this did.
                self.report_state();
            } else {
                let handled = self.services.handle(p, &payload, false, now);
                self.after(handled, None, p);
            }
        }
    }

    /// A frame to every node: a group seal or stop from the host is acted
    /// on when it is for this node's run and lists this node (the answer,
    /// its status, goes through the link); anything refused is counted and
    /// changes nothing.
    fn on_group(&mut self, h: &Header, payload: &[u8], now: u64) {
        let msg = match group::parse(h.dst, h.src, h.port, payload) {
            Ok(m) => m,
            Err(e) => {
                self.stats.group_refused += 1;
                self.stats.last_group_refusal = Some((h.src, e));
                return;
            }
        };
        let me = self.services.address();
        let run = self.node.run();
        if run == 0 || msg.run() != run || self.services.in_bootloader() {
            return;
        }
        if let GroupMessage::Heartbeat { .. } = msg {
            // The host's heartbeat: a shared medium, so this node sends its
            // own, even before (or without) a group seal reaching it.
            if h.src == HOST_ADDRESS {
                self.group.join(run, me, &[], now);
            }
            return;
        }
        let Some(next_seq) = msg.next_seq_of(me) else {
            return;
        };
        match &msg {
            GroupMessage::Seal { members, .. } => {
                self.group.join(run, me, members, now);
                match self.node.group_seal(next_seq) {
                    // The heartbeat, at once, carries the committed end.
                    Ok(()) => self.group.confirm(),
                    Err(reason) => self.push(None, port::MOTION, &NodeMessage::Refused { reason }),
                }
            }
            GroupMessage::Stop { .. } => {
                self.node.close(Some(next_seq));
                let reply = self.node.position();
                self.push(None, port::MOTION, &reply);
            }
            GroupMessage::Heartbeat { .. } => {}
        }
        self.report_state();
    }

    /// A node with committed motion that no longer hears a member of its
    /// group takes no more seals: it brakes on its committed tail, as every
    /// other member that stops hearing the same one does.
    fn watch_group(&mut self, now: u64) {
        if self.group.run() == 0 || self.group.run() != self.node.run() {
            return;
        }
        if self.node.closed() || self.node.stopped() || !self.node.moving() {
            return;
        }
        if let Some(a) = self.group.silent(now) {
            self.node.close(None);
            self.stats.silent = Some(a);
        }
    }

    /// This node's heartbeat to every node, when one is due, encoded into
    /// `out`: its length. Due when it confirms a group seal, or while the
    /// node moves and has sent nothing else for a while.
    fn heartbeat(&mut self, now: u64, out: &mut [u8]) -> Option<usize> {
        let wanted = self.node.moving() || self.group.confirming();
        if self.group.run() != self.node.run() || !wanted || !self.group.beat_due(now) {
            return None;
        }
        let msg = GroupMessage::Heartbeat {
            run: self.node.run(),
            committed: self.node.status().committed,
        };
        let mut buf = [0u8; MAX_MESSAGE];
        let bytes = encode(&msg, &mut buf).ok()?;
        let header = Header {
            dst: BROADCAST,
            src: self.services.address(),
            port: port::GROUP,
            flags: Flags::NONE,
            seq: 0,
            ack: 0,
        };
        frame::encode(&header, bytes, out).ok()
    }

    fn push<T: serde::Serialize>(&mut self, datagram: Option<(u16, u16)>, port: u8, msg: &T) {
        let mut buf = [0u8; MAX_MESSAGE];
        let Ok(bytes) = encode(msg, &mut buf) else {
            return;
        };
        let r = Reply {
            datagram,
            port,
            bytes: Vec::from_slice(bytes).unwrap_or_default(),
        };
        let q = if datagram.is_some() {
            &mut self.datagrams
        } else {
            &mut self.outbox
        };
        if q.push_back(r).is_err() {
            self.stats.replies_dropped += 1;
        }
    }

    fn after(&mut self, h: Handled, datagram: Option<(u16, u16)>, port: u8) {
        if let Some(r) = h.reply.as_ref() {
            self.push(datagram, port, r);
        }
        match h.action {
            Action::None => {}
            Action::Reset => {
                self.node = Node::new();
                self.node.keep_tally();
                self.ran_until = f64::NEG_INFINITY;
                // The host reconnects with a new SYN; a reply through the old
                // link would be lost with it, so a reset is acknowledged
                // as the request came and the link dropped after it.
                if datagram.is_some() {
                    self.link = None;
                }
            }
            Action::AddressChanged(_) => {
                self.link = None;
            }
            Action::EnterBootloader | Action::StartApplication => {
                self.node = Node::new();
                self.node.keep_tally();
                self.ran_until = f64::NEG_INFINITY;
                self.start_requested |= h.action == Action::StartApplication;
            }
        }
    }

    /// Runs the motion node up to the host time of `now` (local µs); every
    /// step and tool change goes to `board` with its host time.
    pub fn poll<B: Board>(&mut self, now: u64, board: &mut B) {
        if self.services.in_bootloader() {
            return;
        }
        let Some(t) = self.services.host_time(now as f64) else {
            return;
        };
        // A new clock model may put host time a hair back: never run
        // backwards. A host that restarted has a new time base altogether:
        // an idle node follows it.
        let new_base = self.node.queued() == 0 && t < self.ran_until - NEW_TIME_BASE_US;
        if t > self.ran_until || new_base {
            self.node.poll(t, board);
            // Short of `t` if the node had more due than one poll hands
            // out: the next poll goes on.
            self.ran_until = self.node.time();
        }
        // What the loops send unasked (faults, samples) goes through the
        // link as replies do, while the outbox has room; the rest waits in
        // the node's own bounded queue.
        while !self.outbox.is_full() {
            let Some(m) = self.node.take_upstream() else {
                break;
            };
            self.push(None, port::MOTION, &m);
        }
        self.watch_group(now);
        self.report_state();
    }

    /// Tells the services what the motion node is doing. A node braking on
    /// its tail is still moving: `Running` until it is at rest.
    fn report_state(&mut self) {
        let state = if self.node.moving() {
            NodeState::Running
        } else if self.node.stopped() {
            NodeState::Stopped
        } else {
            NodeState::Idle
        };
        self.services.set_state(state);
    }

    /// The next frame to transmit, encoded into `out` (at least
    /// `frame::MAX_FRAME` bytes). Call until `None`.
    pub fn transmit<'o>(&mut self, now: u64, out: &'o mut [u8]) -> Option<&'o [u8]> {
        let (n, beat) = self.next_frame(now, out)?;
        // On a shared medium every frame tells the others this node is
        // there: the heartbeat waits for a silence.
        self.group.sent(now, beat);
        Some(&out[..n])
    }

    /// The next frame to transmit into `out`: its length, and whether it
    /// is the heartbeat.
    fn next_frame(&mut self, now: u64, out: &mut [u8]) -> Option<(usize, bool)> {
        // Link replies move into the link's window in order.
        while let Some(r) = self.outbox.front() {
            let Some(link) = self.link.as_mut() else {
                self.outbox.pop_front();
                continue;
            };
            if link.send_space() == 0 || link.send_port(r.port, &r.bytes, now).is_err() {
                break;
            }
            self.outbox.pop_front();
        }
        if let Some(n) = self.heartbeat(now, out) {
            return Some((n, true));
        }
        if let Some(mut r) = self.datagrams.pop_front() {
            let (dst, src) = r
                .datagram
                .unwrap_or((HOST_ADDRESS, self.services.address()));
            stamp_time(&mut r.bytes, now);
            let header = Header {
                dst,
                src,
                port: r.port,
                flags: Flags::NONE,
                seq: 0,
                ack: 0,
            };
            let n = frame::encode(&header, &r.bytes, out).ok()?;
            return Some((n, false));
        }
        let n = self.link.as_mut()?.poll(now, out)?.len();
        Some((n, false))
    }

    /// The earliest local time at which the endpoint has something to do.
    pub fn next_wakeup(&mut self, now: u64) -> Option<u64> {
        if !self.datagrams.is_empty() || self.group.confirming() {
            return Some(now);
        }
        let mut best = self.link.as_ref().and_then(|l| l.next_timeout());
        if self.group.run() != 0 && self.node.moving() {
            for t in [self.group.next_beat(), self.group.silence_deadline()]
                .into_iter()
                .flatten()
            {
                best = Some(best.map_or(t, |b| b.min(t)));
            }
        }
        if let Some(d) = self.node.next_deadline() {
            if let Some(local) = self.services.local_time(d) {
                let l = if local <= now as f64 {
                    now
                } else {
                    local as u64
                };
                best = Some(best.map_or(l, |b| b.min(l)));
            }
        }
        best
    }
}

/// Sets `t3` of an encoded clock exchange reply to `now`, so that the time the
/// reply waited in the outbox counts as the node's, not as the link's.
fn stamp_time(bytes: &mut Payload, now: u64) {
    if let Ok(mut r) = motet_wire::decode::<ServiceReply>(bytes) {
        if matches!(r, ServiceReply::Time { .. }) {
            r.stamp_t3(now);
            let mut buf = [0u8; MAX_MESSAGE];
            if let Ok(b) = encode(&r, &mut buf) {
                *bytes = Vec::from_slice(b).unwrap_or_default();
            }
        }
    }
}
