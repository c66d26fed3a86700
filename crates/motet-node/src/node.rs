//! The node: message handling, queues, and the frame poll.

use crate::board::Board;
use crate::channel::{Channel, Step};
use crate::graph::spec::BuildError;
use crate::graph::{
    self, Component, FrameOut, Graph, GraphBuilder, Inputs, Mode, PortRef, Tape, MAX_HW,
    SLOW_FRAME_US,
};
use crate::tally::{StepTally, Tallying};
use crate::tool::ToolOutput;
use heapless::{Deque, Vec};
use motet_trajectory::{Contingency, JointPath, Point, Profile, Segment, MAX_AXES};
use motet_wire::message::{GraphInputKind, GraphMode};
use motet_wire::stream::{BatchReader, StreamState};
use motet_wire::{
    decode, ChannelConfig, HostMessage, NodeMessage, Refusal, SegmentBatch, SegmentMsg,
    StreamConfig, ToolConfig,
};

/// Most components of a graph a node hosts.
pub const GRAPH_COMPONENTS: usize = 32;
/// Most mappings of a graph a node hosts.
pub const GRAPH_MAPPINGS: usize = 64;
/// The graph a node hosts.
pub type NodeGraph = Graph<GRAPH_COMPONENTS, GRAPH_MAPPINGS>;
type NodeGraphBuilder = GraphBuilder<GRAPH_COMPONENTS, GRAPH_MAPPINGS>;

/// A dataflow graph hosted by a node, run frame by frame over the poll
/// interval.
struct Hosted {
    graph: NodeGraph,
    /// Graph channel ordinal of each component (`u8::MAX`: not a channel).
    channel_of: [u8; GRAPH_COMPONENTS],
    /// Time of the next core frame, µs (set at the first poll).
    next: Option<f64>,
    /// Time of the next slow frame, µs.
    next_slow: f64,
    frames: u64,
}

/// A graph being described, between `GraphBegin` and `GraphCommit`.
struct Building {
    builder: NodeGraphBuilder,
    /// Why a step was refused (the first): the commit will be.
    failed: Option<BuildError>,
}

/// Segment queue capacity (MAXL's maximum buffer).
pub const DEFAULT_QUEUE: usize = 64;
pub const MAX_CHANNELS: usize = 8;
pub const MAX_TOOLS: usize = 4;
/// Largest |steps per unit| a channel accepts.
pub const MAX_STEPS_PER_UNIT: f64 = 1e6;
/// Fastest a channel may step along a segment on average, steps per second.
/// Most steps per second a channel takes (see [`motet_wire::MAX_STEP_RATE`]):
/// a segment asking for more (a huge distance in no time) would keep `poll`
/// busy for good, and is refused.
pub use motet_wire::MAX_STEP_RATE;

/// Most outputs (steps, tool changes, graph frames) one [`Node::poll`]
/// hands out: a poll that has more due stops after them, at the last one's
/// time, and the next poll goes on from there. A node is then never busy
/// for long in one call, whatever it was sent, and a firmware main loop
/// stays responsive to its link.
pub const MAX_OUTPUTS_PER_POLL: u32 = 1 << 16;

#[derive(Clone, Copy, Debug, PartialEq)]
struct Event {
    track: u8,
    time: f64,
    value: f32,
    /// Path speed at which the output reaches `value`; 0 for a fixed output.
    feed: f32,
}

/// What a node reports about itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NodeStatus {
    pub segment_space: usize,
    pub event_space: usize,
    pub next_seq: u32,
    pub underruns: u32,
    /// Sequence number after the last committed segment (`next_seq` unless
    /// windowed segments are pending).
    pub committed: u32,
    /// The node stopped on its committed window's tail (or at its end).
    pub stopped: bool,
    /// The run of the windowed mode (0: none).
    pub run: u32,
}

/// A node with a segment queue of `Q` places and a recording tape of `T`
/// bytes for a hosted graph's four-track recorder and player (one byte per
/// core frame).
pub struct Node<const Q: usize = DEFAULT_QUEUE, const T: usize = 0> {
    channels: Vec<Channel, MAX_CHANNELS>,
    tools: Vec<ToolOutput, MAX_TOOLS>,
    segments: Deque<Segment, Q>,
    events: Deque<Event, Q>,
    next_seq: u32,
    /// Time up to which the node has run, µs.
    now: f64,
    /// Where the last queued segment ends (for subscribed axes).
    tail: Point,
    underruns: u32,
    starved: bool,
    hosted: Option<Hosted>,
    building: Option<Building>,
    /// Why the last graph description was refused, until the next
    /// `GraphBegin` or commit.
    graph_error: Option<BuildError>,
    inputs: Inputs,
    frame_out: FrameOut,
    tape: [u8; T],
    tape_len: usize,
    /// Segments and events are held pending until a seal.
    windowed: bool,
    /// Segments at the back of the queue not yet sealed.
    pending: usize,
    /// Events at the back of the event queue not yet sealed.
    pending_events: usize,
    /// When the committed window's contingency tail takes over, µs.
    tail_start: Option<f64>,
    stopped: bool,
    /// The run this node's trajectory belongs to (`Windowed`); 0: none, so
    /// the node's position is not one a host can resume from.
    run: u32,
    /// What the outputs did since the last reset, when kept.
    tally: Option<StepTally>,
    stream: StreamConfig,
    /// Context the next batched segment is decoded against.
    stream_state: StreamState,
}

impl<const Q: usize, const T: usize> Default for Node<Q, T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const Q: usize, const T: usize> Node<Q, T> {
    pub const fn new() -> Self {
        Node {
            channels: Vec::new(),
            tools: Vec::new(),
            segments: Deque::new(),
            events: Deque::new(),
            next_seq: 0,
            now: f64::NEG_INFINITY,
            tail: [0.0; MAX_AXES],
            underruns: 0,
            starved: false,
            hosted: None,
            building: None,
            graph_error: None,
            inputs: Inputs {
                encoders: [0; MAX_HW],
                analog: [0.0; MAX_HW],
                digital: [false; MAX_HW],
                streams: [graph::wire::Signals::NONE; MAX_HW],
            },
            frame_out: FrameOut {
                steps: Vec::new(),
                ports: [graph::wire::Signals::NONE; MAX_HW],
            },
            tape: [0; T],
            tape_len: 0,
            windowed: false,
            pending: 0,
            pending_events: 0,
            tail_start: None,
            stopped: false,
            run: 0,
            tally: None,
            stream: StreamConfig {
                quantum: 1e-4,
                speed_quantum: 1e-3,
                accel_quantum: 1e-3,
                path_mask: 0,
            },
            stream_state: StreamState::at([0.0; MAX_AXES]),
        }
    }

    /// Acts on one message received as bytes. Returns a reply when there is one
    /// to send: a status on request, or a refusal, in which case nothing changed.
    pub fn handle(&mut self, bytes: &[u8]) -> Option<NodeMessage> {
        let msg: HostMessage = match decode(bytes) {
            Ok(m) => m,
            Err(_) => {
                return Some(NodeMessage::Refused {
                    reason: Refusal::Malformed,
                })
            }
        };
        let result = match msg {
            // A node with committed motion keeps it: a reset would lose
            // its position mid-move (a second host, or a stray message).
            HostMessage::Reset if self.moving() => Err(Refusal::NotAtRest),
            HostMessage::Reset => {
                let tally = self.tally.map(|_| StepTally::default());
                *self = Self::new();
                self.tally = tally;
                Ok(())
            }
            HostMessage::ConfigureChannel(c) => self.configure_channel(c),
            HostMessage::ConfigureTool(t) => self.configure_tool(t),
            HostMessage::SetPosition { position } => self.set_position(&position).inspect(|_| {
                // At rest: the next batched segment carries its start.
                self.stream_state.valid = false;
            }),
            HostMessage::Segment(s) => self.push_segment(&s).inspect(|_| {
                // A batch after a plain segment carries its start.
                self.stream_state.valid = false;
            }),
            HostMessage::ConfigureStream(c) => self.configure_stream(c),
            HostMessage::Segments(b) => self.push_batch(&b),
            HostMessage::Event { track, time, value } => self.push_event(track, time, value, 0.0),
            HostMessage::EventPerSpeed {
                track,
                time,
                value,
                feed,
            } => {
                if !(feed.is_finite() && feed > 0.0) {
                    return Some(NodeMessage::Refused {
                        reason: Refusal::Malformed,
                    });
                }
                self.push_event(track, time, value, feed)
            }
            HostMessage::Status => return Some(self.status_message()),
            HostMessage::Where => return Some(self.position()),
            HostMessage::TallyGet => match &self.tally {
                Some(t) => return Some(t.message()),
                None => Err(Refusal::BadConfig),
            },
            HostMessage::GraphBegin { frame_us } => {
                if !(frame_us.is_finite() && frame_us >= 1.0) {
                    Err(Refusal::BadGraph)
                } else {
                    let mut builder = NodeGraphBuilder::new();
                    builder.frame_us(frame_us);
                    self.building = Some(Building {
                        builder,
                        failed: None,
                    });
                    self.graph_error = None;
                    Ok(())
                }
            }
            HostMessage::GraphAdd { kind, params } => {
                self.build_step(|b| graph::spec::add(b, kind, &params).map(|_| ()))
            }
            HostMessage::GraphRatio { port, world, block } => self.build_step(|b| {
                b.set_ratio(PortRef::new(port.comp, port.port), world, block)
                    .map_err(BuildError::from)
            }),
            HostMessage::GraphMap {
                from,
                to,
                mode,
                tap,
            } => self.build_step(|b| {
                let (from, to) = (
                    PortRef::new(from.comp, from.port),
                    PortRef::new(to.comp, to.port),
                );
                let mode = match mode {
                    GraphMode::Incremental => Mode::Incremental,
                    GraphMode::Absolute => Mode::Absolute,
                };
                if tap {
                    b.tap(to, from, mode)
                } else {
                    b.map(from, to, mode)
                }
                .map_err(BuildError::from)
            }),
            HostMessage::GraphCommit => self.commit_graph(),
            HostMessage::GraphParam {
                component,
                param,
                value,
            } => match self.hosted.as_mut() {
                Some(h) => h
                    .graph
                    .set_param(component, param, value)
                    .map_err(|_| Refusal::BadGraph),
                None => Err(Refusal::BadGraph),
            },
            HostMessage::GraphInput { kind, index, value } => self.set_input(kind, index, value),
            HostMessage::GraphClear => {
                self.hosted = None;
                self.building = None;
                Ok(())
            }
            HostMessage::Windowed { run } => {
                if self.segments.is_empty() {
                    self.windowed = true;
                    self.run = run;
                    Ok(())
                } else {
                    Err(Refusal::NotAtRest)
                }
            }
            HostMessage::Seal { next_seq } => {
                // The host learns how full the queue is with every window,
                // in the frame that acknowledges the seal anyway.
                return match self.seal(next_seq) {
                    Ok(()) => Some(self.status_message()),
                    Err(reason) => Some(NodeMessage::Refused { reason }),
                };
            }
        };
        result.err().map(|reason| NodeMessage::Refused { reason })
    }

    /// One step of describing a graph; a failure is refused and fails the
    /// commit.
    fn build_step(
        &mut self,
        f: impl FnOnce(&mut NodeGraphBuilder) -> Result<(), BuildError>,
    ) -> Result<(), Refusal> {
        let b = self.building.as_mut().ok_or(Refusal::BadGraph)?;
        if b.failed.is_some() {
            return Err(Refusal::BadGraph);
        }
        f(&mut b.builder).map_err(|e| {
            b.failed = Some(e);
            self.graph_error = Some(e);
            Refusal::BadGraph
        })
    }

    /// Why the last graph description was refused (a `GraphAdd`, `GraphRatio`
    /// or `GraphMap` step, or the commit's validation of the whole), until
    /// the next `GraphBegin` or a successful commit.
    pub fn graph_error(&self) -> Option<BuildError> {
        self.graph_error
    }

    fn commit_graph(&mut self) -> Result<(), Refusal> {
        let b = self.building.take().ok_or(Refusal::BadGraph)?;
        if b.failed.is_some() {
            return Err(Refusal::BadGraph);
        }
        let graph = b.builder.build().map_err(|e| {
            self.graph_error = Some(e.into());
            Refusal::BadGraph
        })?;
        self.graph_error = None;
        let mut channel_of = [u8::MAX; GRAPH_COMPONENTS];
        let mut n = 0u8;
        for (i, slot) in channel_of.iter_mut().enumerate().take(graph.len()) {
            if matches!(graph.component(i as u8), Some(Component::Channel(_))) {
                *slot = n;
                n += 1;
            }
        }
        self.hosted = Some(Hosted {
            graph,
            channel_of,
            next: None,
            next_slow: 0.0,
            frames: 0,
        });
        self.tape_len = 0;
        Ok(())
    }

    /// A reading for the hosted graph's inputs, as `GraphInput` gives it:
    /// firmware reading its own encoders, ADCs and buttons sets them here.
    pub fn set_input(
        &mut self,
        kind: GraphInputKind,
        index: u8,
        value: f64,
    ) -> Result<(), Refusal> {
        let i = index as usize;
        if i >= MAX_HW || !value.is_finite() {
            return Err(Refusal::BadGraph);
        }
        match kind {
            GraphInputKind::Encoder => {
                if value.abs() > 9.0e18 {
                    return Err(Refusal::BadGraph);
                }
                self.inputs.encoders[i] = libm::round(value) as i64;
            }
            GraphInputKind::Analog => self.inputs.analog[i] = value as f32,
            GraphInputKind::Digital => self.inputs.digital[i] = value != 0.0,
            GraphInputKind::Stream => {
                let bits = value as u32;
                self.inputs.streams[i] = graph::wire::Signals {
                    active: (bits & 0xff) as u8,
                    forward: ((bits >> 8) & 0xff) as u8,
                };
            }
        }
        Ok(())
    }

    /// The hosted graph, if one runs.
    pub fn graph(&self) -> Option<&NodeGraph> {
        self.hosted.as_ref().map(|h| &h.graph)
    }

    /// The hosted graph, mutable (for a simulator or firmware that sets
    /// parameters or resets positions locally).
    pub fn graph_mut(&mut self) -> Option<&mut NodeGraph> {
        self.hosted.as_mut().map(|h| &mut h.graph)
    }

    /// Core frames the hosted graph has run.
    pub fn graph_frames(&self) -> u64 {
        self.hosted.as_ref().map_or(0, |h| h.frames)
    }

    /// The recording tape of the hosted graph's recorder: the recorded
    /// samples (one byte per frame; the slice's length is the sample count).
    pub fn tape(&self) -> &[u8] {
        &self.tape[..self.tape_len]
    }

    /// The tape's size, bytes (the most samples it holds).
    pub fn tape_capacity(&self) -> usize {
        T
    }

    /// Loads a recording into the tape for a hosted graph's player: the
    /// first `len` bytes of `bytes`. Refused (`Malformed`) when `bytes`
    /// holds fewer than `len`, (`BadConfig`) when the tape is smaller than
    /// `len`; the tape is unchanged then. A graph committed afterwards starts
    /// with an empty tape: load after `GraphCommit`.
    pub fn load_tape(&mut self, bytes: &[u8], len: usize) -> Result<(), Refusal> {
        if len > bytes.len() {
            return Err(Refusal::Malformed);
        }
        if len > T {
            return Err(Refusal::BadConfig);
        }
        self.tape[..len].copy_from_slice(&bytes[..len]);
        self.tape_len = len;
        Ok(())
    }

    /// The board channel id of the first graph channel: graph channel `k` (in
    /// creation order) steps as `graph_channel_base() + k`, after the
    /// trajectory channels' ids.
    pub fn graph_channel_base(&self) -> u8 {
        self.channels
            .iter()
            .map(|c| c.config().channel.saturating_add(1))
            .max()
            .unwrap_or(0)
    }

    /// The time of the hosted graph's next frame, if a graph runs.
    fn graph_next(&self) -> Option<f64> {
        let h = self.hosted.as_ref()?;
        Some(match h.next {
            Some(t) => t,
            None => first_frame(self.now, h.graph.frame_us()),
        })
    }

    fn configure_channel(&mut self, c: ChannelConfig) -> Result<(), Refusal> {
        // Beyond a million steps per unit the step counter and the poll loop
        // would run away; no real drive comes near it.
        let spu = c.steps_per_unit.abs();
        let valid = spu.is_finite()
            && spu > 0.0
            && spu <= MAX_STEPS_PER_UNIT
            && c.map.is_valid()
            && c.timing_is_valid();
        if !valid || !self.segments.is_empty() {
            return Err(Refusal::BadConfig);
        }
        // At rest where the node is: a new or changed channel takes its step
        // count from the current point instead of stepping there.
        let mut ch = Channel::new(c);
        ch.set_position(&self.tail);
        match self
            .channels
            .iter_mut()
            .find(|x| x.config().channel == c.channel)
        {
            Some(existing) => *existing = ch,
            None => self.channels.push(ch).map_err(|_| Refusal::BadConfig)?,
        }
        Ok(())
    }

    fn push_event(&mut self, track: u8, time: f64, value: f32, feed: f32) -> Result<(), Refusal> {
        // A NaN time would never come due and block the event queue for good.
        if !(time.is_finite() && value.is_finite()) {
            return Err(Refusal::Malformed);
        }
        if self.stopped {
            return Err(Refusal::Stopped);
        }
        self.events
            .push_back(Event {
                track,
                time,
                value,
                feed,
            })
            .map_err(|_| Refusal::QueueFull)?;
        if self.windowed {
            self.pending_events += 1;
        }
        Ok(())
    }

    /// Segments that run: all but the pending ones.
    fn committed_len(&self) -> usize {
        self.segments.len() - self.pending
    }

    /// Whether a committed event is queued.
    fn event_due(&self) -> Option<f64> {
        if self.events.len() > self.pending_events {
            self.events.front().map(|e| e.time)
        } else {
            None
        }
    }

    /// Commits the pending segments and events, if the window they close can
    /// still stop on its tail.
    fn seal(&mut self, next_seq: u32) -> Result<(), Refusal> {
        if !self.windowed {
            return Err(Refusal::BadConfig);
        }
        if self.stopped {
            return Err(Refusal::TailStarted);
        }
        if next_seq != self.next_seq {
            return Err(Refusal::OutOfOrder {
                expected: self.next_seq,
                got: next_seq,
            });
        }
        if self.pending > 0 {
            // The queue may have retired the window's head; the tail is found
            // from the end, so a tail still ahead of `now` is found the same.
            let c = Contingency::of(self.segments.iter()).map_err(|_| Refusal::TailStarted)?;
            if c.start_time < self.now {
                return Err(Refusal::TailStarted);
            }
            let first = self.segments.get(self.committed_len()).map(|s| s.t0);
            self.tail_start = Some(c.start_time);
            self.pending = 0;
            self.starved = false;
            if let Some(t0) = first {
                for t in self.tools.iter_mut() {
                    t.wake(t0.max(self.now));
                }
            }
        }
        self.pending_events = 0;
        Ok(())
    }

    /// The committed window's tail takes over at `at`: the tail's profiles
    /// replace the planned ones, anything not yet committed or due later is
    /// dropped, every tool goes to 0, and the node stops taking segments.
    fn stop_on_tail<B: Board>(&mut self, at: f64, board: &mut B) {
        for _ in 0..self.pending {
            self.segments.pop_back();
        }
        self.next_seq = self.next_seq.wrapping_sub(self.pending as u32);
        self.pending = 0;
        self.pending_events = 0;
        self.events.clear();
        if let Ok(c) = Contingency::of(self.segments.iter()) {
            let mut walk = c.walk();
            for j in c.start..c.len {
                if let Some(s) = self.segments.get_mut(j) {
                    *s = walk.next(s);
                }
            }
            for ch in self.channels.iter_mut() {
                ch.retime(&self.segments, c.start);
            }
            self.tail = c.stop;
        }
        for t in self.tools.iter_mut() {
            t.set(0.0, 0.0, at, None);
            board.set_tool(t.output(), 0.0, at);
        }
        self.tail_start = None;
        self.stopped = true;
    }

    fn configure_tool(&mut self, t: ToolConfig) -> Result<(), Refusal> {
        let out = ToolOutput::new(t);
        match self.tools.iter_mut().find(|x| x.output() == t.output) {
            Some(existing) => *existing = out,
            None => self.tools.push(out).map_err(|_| Refusal::BadConfig)?,
        }
        Ok(())
    }

    /// Path speed at host time `t`, from the queued segments; `None` when nothing
    /// is queued at or after `t`.
    fn speed_at(&self, t: f64) -> Option<f64> {
        let n = self.committed_len();
        let last = self.segments.get(n.checked_sub(1)?)?;
        if t >= last.t1() {
            return None;
        }
        for s in self.segments.iter().take(n) {
            if t < s.t0 {
                return Some(0.0);
            }
            if t < s.t1() {
                return Some(s.profile.state((t - s.t0) * 1e-6).1);
            }
        }
        None
    }

    /// When motion resumes if the machine stands still at host time `t`
    /// (inside a dwell, or before the next committed segment starts).
    fn still_until(&self, t: f64) -> Option<f64> {
        for s in self.segments.iter().take(self.committed_len()) {
            if t < s.t0 {
                return Some(s.t0);
            }
            if t < s.t1() {
                return (s.profile.length() <= 0.0).then(|| s.t1());
            }
        }
        None
    }

    fn set_position(&mut self, p: &Point) -> Result<(), Refusal> {
        if !p.iter().all(|x| x.is_finite()) {
            return Err(Refusal::Malformed);
        }
        if !self.segments.is_empty() {
            return Err(Refusal::NotAtRest);
        }
        for ch in self.channels.iter_mut() {
            ch.set_position(p);
        }
        self.tail = *p;
        self.stopped = false;
        self.pending_events = 0;
        self.events.clear();
        Ok(())
    }

    fn push_segment(&mut self, m: &SegmentMsg) -> Result<(), Refusal> {
        if m.seq != self.next_seq {
            return Err(Refusal::OutOfOrder {
                expected: self.next_seq,
                got: m.seq,
            });
        }
        if self.stopped {
            return Err(Refusal::Stopped);
        }
        if self.segments.is_full() {
            return Err(Refusal::QueueFull);
        }
        let mut start = self.tail;
        let mut end = self.tail;
        for span in &m.axes {
            let i = span.axis as usize;
            if i >= MAX_AXES || !span.from.is_finite() || !span.to.is_finite() {
                return Err(Refusal::Malformed);
            }
            start[i] = span.from;
            end[i] = span.to;
        }
        let p = &m.profile;
        if ![p.length, p.v0, p.vc, p.v1, p.accel, p.jerk, p.dwell, m.t0]
            .iter()
            .all(|x| x.is_finite())
        {
            return Err(Refusal::Malformed);
        }
        let seg = Segment {
            t0: m.t0,
            start,
            end,
            profile: Profile::from_params(p),
        };
        self.check_segment(&seg)?;
        // Checked above: the queue has room.
        let _ = self.segments.push_back(seg);
        self.tail = end;
        self.next_seq = self.next_seq.wrapping_add(1);
        if self.windowed {
            // Runs only once sealed.
            self.pending += 1;
            return Ok(());
        }
        self.starved = false;
        let t0 = m.t0.max(self.now);
        for t in self.tools.iter_mut() {
            t.wake(t0);
        }
        Ok(())
    }

    fn configure_stream(&mut self, c: StreamConfig) -> Result<(), Refusal> {
        if !c.is_valid() || !self.segments.is_empty() {
            return Err(Refusal::BadConfig);
        }
        self.stream = c;
        self.stream_state.valid = false;
        Ok(())
    }

    /// Takes a whole batch or, refused, none of it: a first pass decodes and
    /// checks every segment as [`Node::push_segment`] will, the second pushes.
    fn push_batch(&mut self, b: &SegmentBatch) -> Result<(), Refusal> {
        let start = StreamState {
            tail: self.tail,
            ..self.stream_state
        };
        let mut reader = BatchReader::new(self.stream, b).map_err(|_| Refusal::Malformed)?;
        if reader.next_seq() != self.next_seq {
            return Err(Refusal::OutOfOrder {
                expected: self.next_seq,
                got: reader.next_seq(),
            });
        }
        let mut state = start;
        let mut n = 0;
        while let Some(item) = reader.next(&mut state) {
            let (m, _) = item.map_err(|_| Refusal::Malformed)?;
            if !segment_is_finite(&m) {
                return Err(Refusal::Malformed);
            }
            // Axes a batch does not carry keep the node's tail throughout.
            let (mut start, mut end) = (self.tail, self.tail);
            for span in &m.axes {
                start[span.axis as usize] = span.from;
                end[span.axis as usize] = span.to;
            }
            let seg = Segment {
                t0: m.t0,
                start,
                end,
                profile: Profile::from_params(&m.profile),
            };
            self.check_segment(&seg)?;
            n += 1;
        }
        if n == 0 {
            return Err(Refusal::Malformed);
        }
        if n > Q - self.segments.len() {
            return Err(Refusal::QueueFull);
        }
        let mut reader = BatchReader::new(self.stream, b).map_err(|_| Refusal::Malformed)?;
        let mut state = start;
        while let Some(Ok((m, _))) = reader.next(&mut state) {
            self.push_segment(&m)?;
        }
        self.stream_state = state;
        Ok(())
    }

    /// A segment the node can run: every channel within [`MAX_STEP_RATE`].
    /// (A late one, after an underrun, is taken: its steps catch up, at most
    /// [`MAX_OUTPUTS_PER_POLL`] a poll.)
    fn check_segment(&self, seg: &Segment) -> Result<(), Refusal> {
        if self.steppable(seg) {
            Ok(())
        } else {
            Err(Refusal::Malformed)
        }
    }

    /// Whether every channel can follow `seg` within [`MAX_STEP_RATE`] on
    /// average over the segment. (The peak may be higher for a moment: a
    /// polar angle turns through up to half a turn as a line passes its
    /// centre, a bounded number of steps however fast.)
    fn steppable(&self, seg: &Segment) -> bool {
        let p = &seg.profile;
        let length = p.length();
        if length <= 0.0 {
            return true;
        }
        let seconds = p.duration();
        self.channels.iter().all(|ch| {
            let c = ch.config();
            let mut travel = JointPath::new(&c.map, seg, 0.0).max_rate(0.0, length) * length;
            if c.map.is_angle() {
                // A straight line subtends less than half a turn.
                travel = travel.min(180.0);
            }
            let steps = travel * c.steps_per_unit.abs();
            // NaN is refused too; a segment that moves no joint always passes.
            steps == 0.0 || steps <= MAX_STEP_RATE * seconds
        })
    }

    pub fn status(&self) -> NodeStatus {
        NodeStatus {
            segment_space: Q - self.segments.len(),
            event_space: Q - self.events.len(),
            next_seq: self.next_seq,
            underruns: self.underruns,
            committed: self.next_seq.wrapping_sub(self.pending as u32),
            stopped: self.stopped,
            run: self.run,
        }
    }

    /// Where the node is on its run (the answer to `Where`).
    pub fn position(&self) -> NodeMessage {
        NodeMessage::Position {
            run: self.run,
            committed: self.status().committed,
            stopped: self.stopped,
            queued: self.segments.len() as u16,
            at: self.tail,
        }
    }

    fn status_message(&self) -> NodeMessage {
        let s = self.status();
        NodeMessage::Status {
            segment_space: s.segment_space as u16,
            event_space: s.event_space as u16,
            next_seq: s.next_seq,
            underruns: s.underruns,
            committed: s.committed,
            stopped: s.stopped,
            run: s.run,
        }
    }

    /// Whether the node stopped on its contingency tail.
    pub fn stopped(&self) -> bool {
        self.stopped
    }

    /// When the committed window's tail takes over, µs, if a window is
    /// committed and the tail has not started.
    pub fn tail_start(&self) -> Option<f64> {
        self.tail_start
    }

    /// The node has motion queued that it has not finished: it is moving or
    /// will move (on its tail, if it stopped).
    pub fn moving(&self) -> bool {
        !self.segments.is_empty()
    }

    /// Segments queued (including the one executing).
    pub fn queued(&self) -> usize {
        self.segments.len()
    }

    /// When the oldest queued segment ends, µs: the earliest time its place in the
    /// queue can free up.
    pub fn front_end(&self) -> Option<f64> {
        self.segments.front().map(|s| s.t1())
    }

    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// The earliest time at which the node has something to do, if it knows one.
    /// A caller may skip frames up to it; the outputs are the same as polling
    /// every frame because every output carries its own exact time.
    pub fn next_deadline(&mut self) -> Option<f64> {
        let mut best = self.event_due();
        if let Some(t) = self.tail_start {
            best = Some(best.map_or(t, |b: f64| b.min(t)));
        }
        let end = self.committed_len();
        for t in self.tools.iter() {
            if let Some(u) = t.next_update() {
                best = Some(best.map_or(u, |b: f64| b.min(u)));
            }
        }
        for ch in self.channels.iter_mut() {
            if let Some(st) = ch.next_step_within(&self.segments, end) {
                best = Some(best.map_or(st.time, |b: f64| b.min(st.time)));
            }
        }
        if let Some(t) = self.graph_next() {
            best = Some(best.map_or(t, |b: f64| b.min(t)));
        }
        best
    }

    /// Runs the frame ending at `until` (µs): every step and tool change due
    /// before then goes to `board`, in time order. A hosted graph runs its
    /// frames at its frame period over `[now, until)`, interleaved in time
    /// with the trajectory: its channels' steps go to `board` at their
    /// frame's time, as channel ids from [`Node::graph_channel_base`] on.
    ///
    /// In windowed mode, reaching the committed window's tail start applies
    /// the tail there, between the outputs before it and those after.
    pub fn poll<B: Board>(&mut self, until: f64, board: &mut B) {
        if let Some(mut tally) = self.tally.take() {
            self.poll_outputs(
                until,
                &mut Tallying {
                    inner: board,
                    tally: &mut tally,
                },
            );
            self.tally = Some(tally);
        } else {
            self.poll_outputs(until, board);
        }
    }

    /// Host time up to which the node has run, µs (the last poll's `until`,
    /// or its last output's time if that poll stopped at
    /// [`MAX_OUTPUTS_PER_POLL`]).
    pub fn time(&self) -> f64 {
        self.now
    }

    /// Keeps a tally of every output from now on (kept across `Reset`, which
    /// starts it again), reported on `TallyGet`.
    pub fn keep_tally(&mut self) {
        self.tally.get_or_insert_with(StepTally::default);
    }

    /// The tally, when kept.
    pub fn tally(&self) -> Option<&StepTally> {
        self.tally.as_ref()
    }

    fn poll_outputs<B: Board>(&mut self, until: f64, board: &mut B) {
        let mut budget = MAX_OUTPUTS_PER_POLL;
        if let Some(ts) = self.tail_start.filter(|&t| t < until) {
            if !self.poll_until(ts, board, &mut budget) {
                // Stopped short of the tail: the next poll gets there.
                return;
            }
            self.stop_on_tail(ts, board);
        }
        self.poll_until(until, board, &mut budget);
    }

    /// Runs to `until`; false when the budget ran out first (the node's time
    /// is then that of its last output).
    fn poll_until<B: Board>(&mut self, until: f64, board: &mut B, budget: &mut u32) -> bool {
        while let Some(t) = self.graph_next().filter(|&t| t < until) {
            if !self.poll_trajectory(t, board, budget) || *budget == 0 {
                return false;
            }
            self.graph_frame(t, board);
            *budget -= 1;
        }
        self.poll_trajectory(until, board, budget)
    }

    fn graph_frame<B: Board>(&mut self, t: f64, board: &mut B) {
        let base = self.graph_channel_base();
        let Some(h) = self.hosted.as_mut() else {
            return;
        };
        let period = h.graph.frame_us();
        if h.next.is_none() {
            h.next_slow = t;
        }
        if t >= h.next_slow {
            h.graph.slow_frame(&self.inputs);
            h.next_slow += SLOW_FRAME_US;
            if h.next_slow <= t {
                h.next_slow = t + SLOW_FRAME_US;
            }
        }
        let mut tape = Tape::with_len(&mut self.tape, self.tape_len);
        h.graph.frame(
            t,
            &self.inputs,
            &self.segments,
            &mut self.frame_out,
            &mut tape,
        );
        self.tape_len = tape.len();
        for s in self.frame_out.steps.iter() {
            let k = h.channel_of[s.channel as usize];
            board.step(base.saturating_add(k), s.forward, t);
        }
        // Stream inputs carry one frame's signals.
        self.inputs.streams = [graph::wire::Signals::NONE; MAX_HW];
        h.frames += 1;
        // Where a period no longer changes an `f64` (a nonsensical clock
        // model), the graph stops rather than run the same frame for good.
        h.next = Some(if t + period > t {
            t + period
        } else {
            f64::INFINITY
        });
    }

    fn poll_trajectory<B: Board>(&mut self, until: f64, board: &mut B, budget: &mut u32) -> bool {
        let end = self.committed_len();
        // Each channel's next step time (infinite: none). Within this loop
        // only a step changes its channel's next step, and only an event or
        // a refresh changes what is due besides steps, so both are kept and
        // updated where they change instead of asked for on every output.
        let n = self.channels.len();
        let mut next = [f64::INFINITY; MAX_CHANNELS];
        for (t, ch) in next.iter_mut().zip(self.channels.iter_mut()) {
            *t = time_of(ch.next_step_within(&self.segments, end));
        }
        let mut others = self.others_due(until);
        // Time of the last output handed out.
        let mut last = None;
        loop {
            // The earliest step before `until`, the first channel on a tie,
            // and the time of the next earliest.
            let (mut bi, mut bt, mut second) = (usize::MAX, until, until);
            for (i, &t) in next[..n].iter().enumerate() {
                if t < bt {
                    second = bt;
                    (bi, bt) = (i, t);
                } else if t < second {
                    second = t;
                }
            }
            let (event_time, refresh, other) = others;
            if bi != usize::MAX && bt < other {
                // Only steps are due first: the common case, taken directly.
                // The channel goes on stepping while its next step is still
                // strictly the earliest, without looking at the others again
                // (a tie goes back to the full rule).
                let limit = if second < other { second } else { other };
                let ch = &mut self.channels[bi];
                let id = ch.config().channel;
                let mut out_of_budget = false;
                loop {
                    if *budget == 0 && last.is_some() {
                        out_of_budget = true;
                        break;
                    }
                    *budget = budget.saturating_sub(1);
                    last = Some(bt);
                    if let Some((t, dir)) = ch.take_step() {
                        board.step(id, dir, t);
                    }
                    let t = time_of(ch.next_step_within(&self.segments, end));
                    next[bi] = t;
                    if t < limit {
                        bt = t;
                    } else {
                        break;
                    }
                }
                if out_of_budget {
                    if let Some(t) = last {
                        self.now = t;
                        self.retire();
                        return false;
                    }
                }
                continue;
            }
            let best = (bi != usize::MAX).then_some((bi, bt));
            // Ties: events, then refreshes, then steps.
            let step_time = best.map(|(_, t)| t);
            let next_out = [step_time, event_time, refresh.map(|r| r.1)]
                .into_iter()
                .flatten()
                .min_by(f64::total_cmp);
            match (next_out, last) {
                (None, _) => break,
                (Some(_), Some(t)) if *budget == 0 => {
                    // Everything before `t` is out; what is due at `t` or
                    // after waits for the next poll.
                    self.now = t;
                    self.retire();
                    return false;
                }
                _ => {}
            }
            *budget = budget.saturating_sub(1);
            last = next_out;
            if let Some((i, u)) = refresh {
                if event_time.is_none_or(|te| u < te) && step_time.is_none_or(|ts| u <= ts) {
                    let speed = self.speed_at(u);
                    let still = self.still_until(u);
                    let tool = &mut self.tools[i];
                    if let Some(v) = tool.refresh(u, speed) {
                        board.set_tool(tool.output(), v, u);
                    }
                    // Standing still (a dwell, a wait for the next segment),
                    // the speed stays 0 and so does the output: no refresh
                    // until motion resumes, however long the dwell.
                    if let Some(t) = still {
                        tool.defer(t);
                    }
                    others = self.others_due(until);
                    continue;
                }
            }
            match (best, event_time) {
                (None, None) => break,
                (Some((_, ts)), Some(te)) if te <= ts => {
                    self.fire_event(board);
                    others = self.others_due(until);
                }
                (None, Some(_)) => {
                    self.fire_event(board);
                    others = self.others_due(until);
                }
                (Some((i, _)), _) => {
                    let ch = &mut self.channels[i];
                    let id = ch.config().channel;
                    if let Some((t, dir)) = ch.take_step() {
                        board.step(id, dir, t);
                    }
                    next[i] = time_of(ch.next_step_within(&self.segments, end));
                }
            }
        }
        self.now = until;
        self.retire();
        true
    }

    /// The committed event due before `until`, the earliest tool refresh
    /// due before it (the first tool on a tie), and the earlier of their
    /// times (infinite: neither).
    fn others_due(&self, until: f64) -> (Option<f64>, Option<(usize, f64)>, f64) {
        let event_time = self.event_due().filter(|&t| t < until);
        let refresh = self
            .tools
            .iter()
            .enumerate()
            .filter_map(|(i, t)| t.next_update().map(|u| (i, u)))
            .filter(|&(_, u)| u < until)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let first = event_time
            .unwrap_or(f64::INFINITY)
            .min(refresh.map_or(f64::INFINITY, |r| r.1));
        (event_time, refresh, first)
    }

    fn fire_event<B: Board>(&mut self, board: &mut B) {
        if let Some(e) = self.events.pop_front() {
            let speed = if e.feed > 0.0 {
                self.speed_at(e.time)
            } else {
                None
            };
            for t in self.tools.iter_mut().filter(|t| t.config.track == e.track) {
                let v = t.set(e.value, e.feed, e.time, speed);
                board.set_tool(t.output(), v, e.time);
            }
        }
    }

    /// Drops segments that every channel is done with and whose time has passed.
    fn retire(&mut self) {
        let done = self
            .channels
            .iter()
            .map(|c| c.segments_done())
            .min()
            .unwrap_or(usize::MAX);
        let done = done.min(self.committed_len());
        let mut n = 0;
        let mut exit_speed = 0.0;
        while n < done {
            match self.segments.front() {
                Some(s) if s.t1() <= self.now => {
                    exit_speed = s.profile.v1();
                    self.segments.pop_front();
                    n += 1;
                }
                _ => break,
            }
        }
        for ch in self.channels.iter_mut() {
            ch.drop_segments(n);
        }
        if n > 0 && self.segments.is_empty() && exit_speed > 0.0 && !self.starved {
            // Out of trajectory while not at rest: the host fell behind.
            self.underruns += 1;
            self.starved = true;
        }
    }
}

/// A step's time; infinite for none.
#[inline]
fn time_of(step: Option<Step>) -> f64 {
    step.map_or(f64::INFINITY, |s| s.time)
}

/// The checks [`Node::push_segment`] makes on a message's values.
fn segment_is_finite(m: &SegmentMsg) -> bool {
    let p = &m.profile;
    m.axes
        .iter()
        .all(|s| (s.axis as usize) < MAX_AXES && s.from.is_finite() && s.to.is_finite())
        && [p.length, p.v0, p.vc, p.v1, p.accel, p.jerk, p.dwell, m.t0]
            .iter()
            .all(|x| x.is_finite())
}

/// The first frame of a graph committed when the node had run up to `now`:
/// the first multiple of the period at or after it (0 before any poll).
fn first_frame(now: f64, period: f64) -> f64 {
    if now.is_finite() {
        libm::ceil(now / period) * period
    } else {
        0.0
    }
}
