//! The running graph: components, mappings and channels in fixed-capacity
//! tables, executed frame by frame.
//!
//! # Frame order
//! One core frame ([`Graph::frame`], default 40 µs = 25 kHz) runs:
//! 1. input phase: encoders, analog inputs, stream inputs, players, trajectory
//!    readers, in creation order;
//! 2. the other components, in creation order;
//! 3. channels, in creation order (steps are appended to the [`FrameOut`]);
//! 4. output ports: the frame's steps and per-port wire signals are complete in
//!    `out` (encode them with [`super::wire::encode`]);
//! 5. recorders.
//!
//! Buttons run in the slow frame ([`Graph::slow_frame`], 1 kHz).
//!
//! Before a component runs, its taps pull; after it runs, its outputs push
//! along their mappings. A mapping whose target runs before its source (a
//! later component into an earlier one, or into itself) is therefore seen one
//! frame late: such backward mappings are allowed only in INCREMENTAL mode
//! (they carry changes, so nothing is lost, only delayed by a frame); ABSOLUTE
//! ones are refused when building, which rejects every same-frame cycle.

use heapless::{Deque, Vec};
use motet_trajectory::Segment;

use super::builder::GraphBuilder;
use super::component::{Component, ParamError, Phase};
use super::error::GraphError;
use super::io::{Ctx, FrameOut, Inputs};
use super::port::{Dir, MapKind, Mapping, Mode, Port, PortRef};
use super::record::Tape;

/// Most ports one component has.
pub const MAX_PORTS: usize = 8;
/// Default core frame period, µs (25 kHz).
pub const DEFAULT_FRAME_US: f64 = 40.0;
/// Slow frame period, µs (1 kHz).
pub const SLOW_FRAME_US: f64 = 1000.0;

/// Sets parameter `param` of block `comp`, for the builder and the running
/// graph alike; on error nothing changes.
pub(crate) fn set_block_param(
    blocks: &mut [Block],
    comp: u8,
    param: u8,
    value: f64,
) -> Result<(), GraphError> {
    let b = blocks
        .get_mut(comp as usize)
        .ok_or(GraphError::UnknownComponent(comp))?;
    b.comp
        .set_param(&mut b.ports, param, value)
        .map_err(|e| match e {
            ParamError::Unknown => GraphError::UnknownParam { comp, param },
            ParamError::BadValue => GraphError::BadValue { comp, param },
        })
}

/// A component with its ports and the ranges of its mappings.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    /// The component.
    pub comp: Component,
    /// Its ports' state, in index order.
    pub ports: Vec<Port, MAX_PORTS>,
    /// Push mappings from this block's outputs: `maps[push.0..push.1]`.
    pub(crate) push: (u16, u16),
    /// Taps into this block's inputs: `maps[pull.0..pull.1]`.
    pub(crate) pull: (u16, u16),
}

impl Block {
    pub(crate) fn new(comp: Component) -> Block {
        let mut ports = Vec::new();
        for spec in comp.ports() {
            let _ = ports.push(Port::new(spec));
        }
        Block {
            comp,
            ports,
            push: (0, 0),
            pull: (0, 0),
        }
    }
}

/// A frame-synchronous dataflow graph of at most `C` components and `M`
/// mappings. Build one with [`GraphBuilder`].
#[derive(Clone, Debug, PartialEq)]
pub struct Graph<const C: usize, const M: usize> {
    pub(crate) blocks: Vec<Block, C>,
    pub(crate) maps: Vec<Mapping, M>,
    /// Core-frame execution order.
    pub(crate) order: Vec<u8, C>,
    /// Slow-frame components.
    pub(crate) slow: Vec<u8, C>,
    pub(crate) frame_us: f64,
}

impl<const C: usize, const M: usize> Graph<C, M> {
    /// Frame period, µs.
    pub fn frame_us(&self) -> f64 {
        self.frame_us
    }

    /// Components in the graph.
    pub fn len(&self) -> usize {
        self.blocks.len()
    }

    /// Whether the graph has no component.
    pub fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }

    /// Component `i`, by index in the order added.
    pub fn component(&self, i: u8) -> Option<&Component> {
        self.blocks.get(i as usize).map(|b| &b.comp)
    }

    /// The port `p`'s state (value in block units, ratio, direction).
    pub fn port(&self, p: PortRef) -> Option<&Port> {
        self.blocks.get(p.comp as usize)?.ports.get(p.port as usize)
    }

    /// A port's absolute value in world units.
    pub fn value(&self, p: PortRef) -> Option<f64> {
        self.port(p).map(|q| q.world_value())
    }

    /// The mappings, pushes grouped by source then taps grouped by listener.
    pub fn mappings(&self) -> &[Mapping] {
        &self.maps
    }

    /// Execution order of the core frame.
    pub fn order(&self) -> &[u8] {
        &self.order
    }

    /// A builder holding this graph's description (and current state), to
    /// edit and [`Graph::replace`] it.
    pub fn to_builder(&self) -> GraphBuilder<C, M> {
        GraphBuilder::from_graph(self)
    }

    /// Replaces the graph by `builder`'s if it builds; on error the running
    /// graph is untouched.
    pub fn replace(&mut self, builder: GraphBuilder<C, M>) -> Result<(), GraphError> {
        let g = builder.build()?;
        *self = g;
        Ok(())
    }

    /// Sets parameter `param` of component `comp`; on error nothing changes.
    pub fn set_param(&mut self, comp: u8, param: u8, value: f64) -> Result<(), GraphError> {
        set_block_param(&mut self.blocks, comp, param, value)
    }

    /// Parameter `param` of component `comp`, if the kind reports it.
    pub fn param(&self, comp: u8, param: u8) -> Option<f64> {
        let b = self.blocks.get(comp as usize)?;
        b.comp.param(&b.ports, param)
    }

    /// Runs one core frame at host time `now_us`.
    pub fn frame<const Q: usize>(
        &mut self,
        now_us: f64,
        inputs: &Inputs,
        segments: &Deque<Segment, Q>,
        out: &mut FrameOut,
        tape: &mut Tape<'_>,
    ) {
        out.clear();
        let mut ctx = Ctx {
            comp: 0,
            now_us,
            dt: self.frame_us * 1e-6,
            inputs,
            segments,
            out,
            tape,
        };
        for k in 0..self.order.len() {
            let i = self.order[k] as usize;
            self.run_block(i, &mut ctx);
        }
    }

    #[inline]
    fn run_block<const Q: usize>(&mut self, i: usize, ctx: &mut Ctx<'_, '_, Q>) {
        let (p0, p1) = self.blocks[i].pull;
        for k in p0 as usize..p1 as usize {
            self.transfer(k);
        }
        ctx.comp = i as u8;
        let b = &mut self.blocks[i];
        b.comp.run(&mut b.ports, ctx);
        let (s0, s1) = b.push;
        for k in s0 as usize..s1 as usize {
            self.transfer(k);
        }
        if let Some((port, v)) = self.blocks[i].comp.take_reset() {
            let _ = self.reset_deep(PortRef::new(i as u8, port), v);
        }
    }

    #[inline]
    fn transfer(&mut self, k: usize) {
        let m = &mut self.maps[k];
        let src = self.blocks[m.from.comp as usize].ports[m.from.port as usize];
        let dst = &mut self.blocks[m.to.comp as usize].ports[m.to.port as usize];
        m.transfer(&src, dst);
    }

    /// Runs one slow frame (1 kHz): buttons and digital inputs.
    pub fn slow_frame(&mut self, inputs: &Inputs) {
        for k in 0..self.slow.len() {
            let i = self.slow[k] as usize;
            let b = &mut self.blocks[i];
            b.comp.slow(&mut b.ports, inputs, SLOW_FRAME_US * 1e-6);
            let (s0, s1) = b.push;
            for k in s0 as usize..s1 as usize {
                self.transfer(k);
            }
        }
    }

    fn check(&self, p: PortRef) -> Result<(), GraphError> {
        let b = self
            .blocks
            .get(p.comp as usize)
            .ok_or(GraphError::UnknownComponent(p.comp))?;
        if (p.port as usize) < b.ports.len() {
            Ok(())
        } else {
            Err(GraphError::UnknownPort(p))
        }
    }

    /// Sets `port` to the absolute position `value` (world units of `port`)
    /// and carries it down the chain to the channels without producing steps:
    /// kinematics recompute their outputs from their inputs' absolute values,
    /// an INCREMENTAL mapping shifts its target by the source's change (so other
    /// contributions to a fan-in input are kept), an ABSOLUTE mapping sets its
    /// target, and every mapping on the way absorbs the change. A channel takes
    /// the new target as its position (rounded to a whole step). Components
    /// whose outputs are not a function of their inputs (generators) end the
    /// walk.
    pub fn reset_deep(&mut self, port: PortRef, value: f64) -> Result<(), GraphError> {
        self.check(port)?;
        if !value.is_finite() {
            return Err(GraphError::BadValue {
                comp: port.comp,
                param: port.port,
            });
        }
        self.reset_port(port, value, 0)
    }

    fn absorb(&mut self, p: PortRef) {
        let v = self.blocks[p.comp as usize].ports[p.port as usize].value;
        for m in self.maps.iter_mut() {
            if m.from == p {
                m.last = v;
            }
        }
    }

    fn reset_port(&mut self, p: PortRef, v: f64, depth: usize) -> Result<(), GraphError> {
        if depth > self.blocks.len() + 1 {
            return Err(GraphError::TooDeep);
        }
        let (ci, pi) = (p.comp as usize, p.port as usize);
        let (dir, old_w) = {
            let port = &mut self.blocks[ci].ports[pi];
            let old_w = port.world_value();
            let vb = port.from_world(v);
            port.value = vb;
            port.last = vb;
            (port.dir, old_w)
        };
        match dir {
            Dir::Out => {
                let b = &mut self.blocks[ci];
                b.comp.reset_output(&mut b.ports, pi);
                self.absorb(p);
                let w = self.blocks[ci].ports[pi].world_value();
                let dw = w - old_w;
                for k in 0..self.maps.len() {
                    let m = self.maps[k];
                    if m.from == p && m.kind == MapKind::Push {
                        let target = match m.mode {
                            Mode::Incremental => {
                                self.blocks[m.to.comp as usize].ports[m.to.port as usize]
                                    .world_value()
                                    + dw
                            }
                            Mode::Absolute => w,
                        };
                        self.reset_port(m.to, target, depth + 1)?;
                    }
                }
                // The component may have moved its other ports (a channel).
                self.absorb_outputs(ci, Some(pi));
            }
            Dir::In => {
                self.absorb(p);
                let b = &mut self.blocks[ci];
                let mut before = [0.0; MAX_PORTS];
                for (o, q) in b.ports.iter().enumerate() {
                    before[o] = q.value;
                }
                let propagate = b.comp.reset_input(&mut b.ports, pi);
                #[allow(clippy::needless_range_loop)]
                for o in 0..self.blocks[ci].ports.len() {
                    let q = self.blocks[ci].ports[o];
                    if q.dir != Dir::Out || q.value == before[o] {
                        continue;
                    }
                    let op = PortRef::new(p.comp, o as u8);
                    if propagate {
                        // reset_port measures the change from the old value.
                        self.blocks[ci].ports[o].value = before[o];
                        self.reset_port(op, q.world_value(), depth + 1)?;
                    } else {
                        self.absorb(op);
                    }
                }
            }
        }
        Ok(())
    }

    fn absorb_outputs(&mut self, ci: usize, except: Option<usize>) {
        for o in 0..self.blocks[ci].ports.len() {
            if Some(o) != except && self.blocks[ci].ports[o].dir == Dir::Out {
                self.absorb(PortRef::new(ci as u8, o as u8));
            }
        }
    }

    /// The absolute position at `port` as seen from the end of its chain, in
    /// world units of `port`, without side effects: an output follows its first
    /// push mapping; an input of an invertible component (kinematics, scaling
    /// filters, channels) is solved from its outputs' deep values; otherwise the
    /// port's own value is returned. A channel answers with its current
    /// (emitted) position.
    pub fn read_deep(&self, port: PortRef) -> Result<f64, GraphError> {
        self.check(port)?;
        self.read_port(port, 0)
    }

    fn read_port(&self, p: PortRef, depth: usize) -> Result<f64, GraphError> {
        if depth > self.blocks.len() + 1 {
            return Err(GraphError::TooDeep);
        }
        let b = &self.blocks[p.comp as usize];
        let port = &b.ports[p.port as usize];
        match port.dir {
            Dir::Out => {
                if let Some(m) = self
                    .maps
                    .iter()
                    .find(|m| m.from == p && m.kind == MapKind::Push)
                {
                    return self.read_port(m.to, depth + 1);
                }
                Ok(port.world_value())
            }
            Dir::In => {
                if !b.comp.invertible() {
                    return Ok(port.world_value());
                }
                let mut outs = [0.0; MAX_PORTS];
                if b.comp.phase() != Phase::Channel {
                    for (o, q) in b.ports.iter().enumerate() {
                        if q.dir == Dir::Out {
                            let w = self.read_port(PortRef::new(p.comp, o as u8), depth + 1)?;
                            outs[o] = q.from_world(w);
                        }
                    }
                }
                Ok(match b.comp.inverse(&b.ports, p.port as usize, &outs) {
                    Some(v) => port.to_world(v),
                    None => port.world_value(),
                })
            }
        }
    }
}
