//! The node: its state, what it reports about itself, and the frame poll.
//!
//! One concept a file:
//! * `handle`: messages from the host, decoded and dispatched;
//! * `config`: channels, tools, the segment stream and the position, set at rest;
//! * `segments`: the segment queue, taking segments in and retiring them;
//! * `events`: the event queue and the tool outputs it drives;
//! * `window`: windowed mode, seals and the contingency tail;
//! * `hosted`: a dataflow graph the node hosts, and its recording tape;
//! * `poll`: every output due in a frame, handed out in time order.

mod config;
mod events;
mod handle;
mod hosted;
mod poll;
mod segments;
mod window;

use crate::board::Board;
use crate::channel::Channel;
use crate::control::Control;
use crate::graph::spec::BuildError;
use crate::graph::{self, FrameOut, Inputs, MAX_HW};
use crate::tally::{StepTally, Tallying};
use crate::tool::ToolOutput;
use events::Event;
use heapless::{Deque, Vec};
use hosted::{Building, Hosted};
use motet_trajectory::{Point, Segment, MAX_AXES};
use motet_wire::stream::StreamState;
use motet_wire::{NodeMessage, StreamConfig};

pub use hosted::{NodeGraph, GRAPH_COMPONENTS, GRAPH_MAPPINGS};

/// Segment queue capacity (MAXL's maximum buffer).
pub const DEFAULT_QUEUE: usize = 64;
/// Most step channels a node drives.
pub const MAX_CHANNELS: usize = 8;
/// Most tool outputs a node drives.
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

/// What a node reports about itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NodeStatus {
    /// Free places in the segment queue.
    pub segment_space: usize,
    /// Free places in the event queue.
    pub event_space: usize,
    /// The sequence number of the next segment the node takes.
    pub next_seq: u32,
    /// Times the node ran out of segments while moving: the host fell behind.
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
    queue_end: Point,
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
    /// The run was stopped for every node ([`Node::close`]): no more seals.
    closed: bool,
    /// Segments and events the last seal committed, the window a group
    /// stop may take back while the tail before it has not started.
    last_window: (usize, usize),
    /// The run this node's trajectory belongs to (`Windowed`); 0: none, so
    /// the node's position is not one a host can resume from.
    run: u32,
    /// What the outputs did since the last reset, when kept.
    tally: Option<StepTally>,
    stream: StreamConfig,
    /// Context the next batched segment is decoded against.
    stream_state: StreamState,
    /// Fixed-point time's tolerance, µs (0: exact; see
    /// [`Node::use_fixed_time`]).
    fixed_time: f64,
    /// Closed loops: servo and sensor channels, and what they send
    /// upstream.
    control: Control,
}

impl<const Q: usize, const T: usize> Default for Node<Q, T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const Q: usize, const T: usize> Node<Q, T> {
    /// A node with nothing configured or queued, at the origin, before time began (the first poll
    /// sets it).
    pub const fn new() -> Self {
        Node {
            channels: Vec::new(),
            tools: Vec::new(),
            segments: Deque::new(),
            events: Deque::new(),
            next_seq: 0,
            now: f64::NEG_INFINITY,
            queue_end: [0.0; MAX_AXES],
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
            closed: false,
            last_window: (0, 0),
            run: 0,
            tally: None,
            stream: StreamConfig {
                quantum: 1e-4,
                speed_quantum: 1e-3,
                accel_quantum: 1e-3,
                path_mask: 0,
            },
            stream_state: StreamState::at([0.0; MAX_AXES]),
            fixed_time: 0.0,
            control: Control::new(),
        }
    }

    /// Solves its channels' steps in fixed-point time, each within
    /// `tolerance_us` of its exact time (0: exactly, in `f64`, the
    /// default): what a board without a floating-point unit sets at start
    /// (the Raspberry Pi Pico), and what a simulation of one runs. Kept
    /// across resets.
    pub fn use_fixed_time(&mut self, tolerance_us: f64) {
        // Each channel takes it as its own (0 for anything not above 0).
        self.fixed_time = tolerance_us;
        for ch in self.channels.iter_mut() {
            ch.use_fixed_time(self.fixed_time);
        }
    }

    /// The node's queues and sequence numbers, as `Status` reports them.
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
            at: self.queue_end,
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

    /// Whether the run was stopped for every node ([`Node::close`]): the
    /// node takes no more seals and brakes on its committed tail.
    pub fn closed(&self) -> bool {
        self.closed
    }

    /// The run of the windowed mode (0: none).
    pub fn run(&self) -> u32 {
        self.run
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

    /// The step channels, in the order configured.
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
        if let Some(t) = self.control.deadline(self.now, !self.segments.is_empty()) {
            best = Some(best.map_or(t, |b: f64| b.min(t)));
        }
        best
    }

    /// The node's closed loops (servo and sensor channels).
    pub fn control(&self) -> &Control {
        &self.control
    }

    /// The oldest message the node sends unasked (a fault, a batch of
    /// samples), taken: a link's endpoint sends it, a simulator hands it
    /// to its host, as bytes either way.
    pub fn take_upstream(&mut self) -> Option<NodeMessage> {
        self.control.take_upstream()
    }

    /// Runs the frame ending at `until` (µs): every step and tool change due
    /// before then goes to `board`, in time order. A hosted graph runs its
    /// frames at its frame period over `[now, until)`, interleaved in time
    /// with the trajectory: its channels' steps go to `board` at their
    /// frame's time, as channel ids from [`Node::graph_channel_base`] on.
    ///
    /// In windowed mode, reaching the committed window's tail start applies
    /// the tail there, between the outputs before it and those after.
    //
    // Defined in this module, not beside the rest of the poll: `motet bench
    // --instructions` finds the nodes' share by this function's symbol,
    // `motet_node::node::Node<_,_>::poll`, which names the module of its
    // `impl` block.
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
}
