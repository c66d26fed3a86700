//! The node: message handling, queues, and the frame poll.

use crate::board::Board;
use crate::channel::Channel;
use crate::tool::ToolOutput;
use heapless::{Deque, Vec};
use motet_trajectory::{JointMap, Point, Profile, Segment, MAX_AXES};
use motet_wire::{
    decode, ChannelConfig, HostMessage, NodeMessage, Refusal, SegmentMsg, ToolConfig,
};

/// Segment queue capacity (MAXL's maximum buffer).
pub const DEFAULT_QUEUE: usize = 64;
pub const MAX_CHANNELS: usize = 8;
pub const MAX_TOOLS: usize = 4;
/// Largest |steps per unit| a channel accepts.
pub const MAX_STEPS_PER_UNIT: f64 = 1e6;

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
}

/// A node with a segment queue of `Q` places.
pub struct Node<const Q: usize = DEFAULT_QUEUE> {
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
}

impl<const Q: usize> Default for Node<Q> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const Q: usize> Node<Q> {
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
            HostMessage::Reset => {
                *self = Self::new();
                Ok(())
            }
            HostMessage::ConfigureChannel(c) => self.configure_channel(c),
            HostMessage::ConfigureTool(t) => self.configure_tool(t),
            HostMessage::SetPosition { position } => self.set_position(&position),
            HostMessage::Segment(s) => self.push_segment(&s),
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
        };
        result.err().map(|reason| NodeMessage::Refused { reason })
    }

    fn configure_channel(&mut self, c: ChannelConfig) -> Result<(), Refusal> {
        // Beyond a million steps per unit the step counter and the poll loop
        // would run away; no real drive comes near it.
        let spu = c.steps_per_unit.abs();
        let valid =
            spu.is_finite() && spu > 0.0 && spu <= MAX_STEPS_PER_UNIT && map_is_valid(&c.map);
        if !valid || !self.segments.is_empty() {
            return Err(Refusal::BadConfig);
        }
        let ch = Channel::new(c);
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
        self.events
            .push_back(Event {
                track,
                time,
                value,
                feed,
            })
            .map_err(|_| Refusal::QueueFull)
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
        let last = self.segments.back()?;
        if t >= last.t1() {
            return None;
        }
        for s in self.segments.iter() {
            if t < s.t0 {
                return Some(0.0);
            }
            if t < s.t1() {
                return Some(s.profile.state((t - s.t0) * 1e-6).1);
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
        Ok(())
    }

    fn push_segment(&mut self, m: &SegmentMsg) -> Result<(), Refusal> {
        if m.seq != self.next_seq {
            return Err(Refusal::OutOfOrder {
                expected: self.next_seq,
                got: m.seq,
            });
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
        // Checked above: the queue has room.
        let _ = self.segments.push_back(seg);
        self.tail = end;
        self.next_seq = self.next_seq.wrapping_add(1);
        self.starved = false;
        let t0 = m.t0.max(self.now);
        for t in self.tools.iter_mut() {
            t.wake(t0);
        }
        Ok(())
    }

    pub fn status(&self) -> NodeStatus {
        NodeStatus {
            segment_space: Q - self.segments.len(),
            event_space: Q - self.events.len(),
            next_seq: self.next_seq,
            underruns: self.underruns,
        }
    }

    fn status_message(&self) -> NodeMessage {
        let s = self.status();
        NodeMessage::Status {
            segment_space: s.segment_space as u16,
            event_space: s.event_space as u16,
            next_seq: s.next_seq,
            underruns: s.underruns,
        }
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
        let mut best = self.events.front().map(|e| e.time);
        for t in self.tools.iter() {
            if let Some(u) = t.next_update() {
                best = Some(best.map_or(u, |b: f64| b.min(u)));
            }
        }
        for ch in self.channels.iter_mut() {
            if let Some(st) = ch.next_step(&self.segments) {
                best = Some(best.map_or(st.time, |b: f64| b.min(st.time)));
            }
        }
        best
    }

    /// Runs the frame ending at `until` (µs): every step and tool change due
    /// before then goes to `board`, in time order.
    pub fn poll<B: Board>(&mut self, until: f64, board: &mut B) {
        loop {
            let mut best: Option<(usize, f64)> = None;
            for (i, ch) in self.channels.iter_mut().enumerate() {
                if let Some(st) = ch.next_step(&self.segments) {
                    if st.time < until && best.is_none_or(|(_, t)| st.time < t) {
                        best = Some((i, st.time));
                    }
                }
            }
            let event_time = self.events.front().map(|e| e.time).filter(|&t| t < until);
            let refresh = self
                .tools
                .iter()
                .enumerate()
                .filter_map(|(i, t)| t.next_update().map(|u| (i, u)))
                .filter(|&(_, u)| u < until)
                .min_by(|a, b| a.1.total_cmp(&b.1));
            // Ties: events, then refreshes, then steps.
            let step_time = best.map(|(_, t)| t);
            if let Some((i, u)) = refresh {
                if event_time.is_none_or(|te| u < te) && step_time.is_none_or(|ts| u <= ts) {
                    let speed = self.speed_at(u);
                    let tool = &mut self.tools[i];
                    if let Some(v) = tool.refresh(u, speed) {
                        board.set_tool(tool.output(), v, u);
                    }
                    continue;
                }
            }
            match (best, event_time) {
                (None, None) => break,
                (Some((_, ts)), Some(te)) if te <= ts => self.fire_event(board),
                (None, Some(_)) => self.fire_event(board),
                (Some((i, _)), _) => {
                    let ch = &mut self.channels[i];
                    let id = ch.config().channel;
                    if let Some((t, dir)) = ch.take_step() {
                        board.step(id, dir, t);
                    }
                }
            }
        }
        self.now = until;
        self.retire();
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

/// Whether a joint map only names axes a point has and has finite coefficients:
/// a polar map naming axis 6 or more would index out of every point (a panic on
/// the next SetPosition or poll), a non-finite coefficient makes every joint
/// value NaN (a channel that silently never steps).
fn map_is_valid(map: &JointMap) -> bool {
    match *map {
        JointMap::Linear { coeffs } => coeffs.iter().all(|c| c.is_finite()),
        JointMap::PolarRadius { x, y } | JointMap::PolarAngle { x, y } => {
            (x as usize) < MAX_AXES && (y as usize) < MAX_AXES
        }
    }
}
