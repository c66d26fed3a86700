//! A dataflow graph the node hosts: described step by step between
//! `GraphBegin` and `GraphCommit`, run frame by frame over the poll
//! interval, with the recording tape its recorder and player use.

use super::Node;
use crate::board::Board;
use crate::graph::spec::BuildError;
use crate::graph::{
    self, Component, Graph, GraphBuilder, Mode, PortRef, Tape, MAX_HW, SLOW_FRAME_US,
};
use motet_wire::message::{GraphInputKind, GraphKind, GraphMode, GraphPort};
use motet_wire::Refusal;

/// Most components of a graph a node hosts.
pub const GRAPH_COMPONENTS: usize = 32;
/// Most mappings of a graph a node hosts.
pub const GRAPH_MAPPINGS: usize = 64;
/// The graph a node hosts.
pub type NodeGraph = Graph<GRAPH_COMPONENTS, GRAPH_MAPPINGS>;
type NodeGraphBuilder = GraphBuilder<GRAPH_COMPONENTS, GRAPH_MAPPINGS>;

/// A dataflow graph hosted by a node, run frame by frame over the poll
/// interval.
pub(super) struct Hosted {
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
pub(super) struct Building {
    builder: NodeGraphBuilder,
    /// Why a step was refused (the first): the commit will be.
    failed: Option<BuildError>,
}

impl<const Q: usize, const T: usize> Node<Q, T> {
    /// Starts describing a graph run every `frame_us` µs, dropping any
    /// description under way.
    pub(super) fn begin_graph(&mut self, frame_us: f64) -> Result<(), Refusal> {
        if !(frame_us.is_finite() && frame_us >= 1.0) {
            return Err(Refusal::BadGraph);
        }
        let mut builder = NodeGraphBuilder::new();
        builder.frame_us(frame_us);
        self.building = Some(Building {
            builder,
            failed: None,
        });
        self.graph_error = None;
        Ok(())
    }

    /// Adds a component of `kind` to the graph being described.
    pub(super) fn add_component(&mut self, kind: GraphKind, params: &[f64]) -> Result<(), Refusal> {
        self.build_step(|b| graph::spec::add(b, kind, params).map(|_| ()))
    }

    /// `world` world units are `block` units of `port`.
    pub(super) fn set_port_ratio(
        &mut self,
        port: GraphPort,
        world: f64,
        block: f64,
    ) -> Result<(), Refusal> {
        self.build_step(|b| {
            b.set_ratio(PortRef::new(port.comp, port.port), world, block)
                .map_err(BuildError::from)
        })
    }

    /// Maps the output `from` onto the input `to`; with `tap`, `to` pulls
    /// from `from`.
    pub(super) fn map_ports(
        &mut self,
        from: GraphPort,
        to: GraphPort,
        mode: GraphMode,
        tap: bool,
    ) -> Result<(), Refusal> {
        self.build_step(|b| {
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
        })
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

    pub(super) fn commit_graph(&mut self) -> Result<(), Refusal> {
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

    /// Sets a parameter of the running graph's component.
    pub(super) fn set_graph_param(
        &mut self,
        component: u8,
        param: u8,
        value: f64,
    ) -> Result<(), Refusal> {
        match self.hosted.as_mut() {
            Some(h) => h
                .graph
                .set_param(component, param, value)
                .map_err(|_| Refusal::BadGraph),
            None => Err(Refusal::BadGraph),
        }
    }

    /// Removes the running graph and any graph being described.
    pub(super) fn clear_graph(&mut self) {
        self.hosted = None;
        self.building = None;
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
    pub(super) fn graph_next(&self) -> Option<f64> {
        let h = self.hosted.as_ref()?;
        Some(match h.next {
            Some(t) => t,
            None => first_frame(self.now, h.graph.frame_us()),
        })
    }

    pub(super) fn graph_frame<B: Board>(&mut self, t: f64, board: &mut B) {
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
