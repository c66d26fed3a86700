//! Building a graph with validation. Every call checks what it can at once and
//! returns a typed error without changing the builder; [`GraphBuilder::build`]
//! checks the whole (fan-in, frame order) and produces a [`Graph`] or an error.

use heapless::Vec;

use super::component::{Component, Phase};
use super::error::{Capacity, GraphError};
use super::graph::{Block, Graph, DEFAULT_FRAME_US};
use super::io::MAX_FRAME_STEPS;
use super::port::{Dir, MapKind, Mapping, Mode, PortRef, Unit};
use super::record::DEFAULT_RESOLUTION;

/// A graph description under construction.
#[derive(Clone, Debug, PartialEq)]
pub struct GraphBuilder<const C: usize, const M: usize> {
    blocks: Vec<Block, C>,
    maps: Vec<Mapping, M>,
    frame_us: f64,
}

impl<const C: usize, const M: usize> Default for GraphBuilder<C, M> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const C: usize, const M: usize> GraphBuilder<C, M> {
    /// An empty description: no components, mappings or ratios, the default frame period.
    pub fn new() -> Self {
        GraphBuilder {
            blocks: Vec::new(),
            maps: Vec::new(),
            frame_us: DEFAULT_FRAME_US,
        }
    }

    /// The description (and state) of a running graph.
    pub fn from_graph(g: &Graph<C, M>) -> Self {
        GraphBuilder {
            blocks: g.blocks.clone(),
            maps: g.maps.clone(),
            frame_us: g.frame_us,
        }
    }

    /// Core frame period, µs (default 40).
    pub fn frame_us(&mut self, us: f64) -> &mut Self {
        if us.is_finite() && us > 0.0 {
            self.frame_us = us;
        }
        self
    }

    /// Adds a component; returns its index. Recorder and player tracks start
    /// at 0.01 world units per step.
    pub fn add(&mut self, comp: impl Into<Component>) -> Result<u8, GraphError> {
        let comp = comp.into();
        if self.blocks.len() >= C || self.blocks.len() >= u8::MAX as usize {
            return Err(GraphError::CapacityExceeded(Capacity::Components));
        }
        if matches!(comp, Component::Channel(_)) {
            let channels = self
                .blocks
                .iter()
                .filter(|b| matches!(b.comp, Component::Channel(_)))
                .count();
            if channels >= MAX_FRAME_STEPS {
                return Err(GraphError::CapacityExceeded(Capacity::Channels));
            }
        }
        let tracks = matches!(
            comp,
            Component::FourTrackRecorder(_) | Component::FourTrackPlayer(_)
        );
        let mut b = Block::new(comp);
        if tracks {
            for p in b.ports.iter_mut() {
                p.set_ratio(DEFAULT_RESOLUTION, 1.0);
            }
        }
        let i = self.blocks.len() as u8;
        let _ = self.blocks.push(b);
        Ok(i)
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

    fn port(&self, p: PortRef) -> &super::port::Port {
        &self.blocks[p.comp as usize].ports[p.port as usize]
    }

    /// `world` world units are `block` units of the port's component.
    pub fn set_ratio(&mut self, p: PortRef, world: f64, block: f64) -> Result<(), GraphError> {
        self.check(p)?;
        let port = &mut self.blocks[p.comp as usize].ports[p.port as usize];
        if port.set_ratio(world, block) {
            Ok(())
        } else {
            Err(GraphError::BadRatio(p))
        }
    }

    /// A channel's `(units, steps)`: both target inputs and the position
    /// output get it.
    pub fn channel_ratio(&mut self, comp: u8, units: f64, steps: f64) -> Result<(), GraphError> {
        let b = self
            .blocks
            .get(comp as usize)
            .ok_or(GraphError::UnknownComponent(comp))?;
        if !matches!(b.comp, Component::Channel(_)) {
            return Err(GraphError::UnknownPort(PortRef::new(comp, 0)));
        }
        for i in 0..3 {
            self.set_ratio(PortRef::new(comp, i), units, steps)?;
        }
        Ok(())
    }

    /// Declares the quantity a port carries (for ports of unit `Any`).
    pub fn set_unit(&mut self, p: PortRef, unit: Unit) -> Result<(), GraphError> {
        self.check(p)?;
        self.blocks[p.comp as usize].ports[p.port as usize].unit = unit;
        Ok(())
    }

    /// Sets a parameter before the graph runs.
    pub fn set_param(&mut self, comp: u8, param: u8, value: f64) -> Result<(), GraphError> {
        super::graph::set_block_param(&mut self.blocks, comp, param, value)
    }

    fn check_pair(&self, from: PortRef, to: PortRef, mode: Mode) -> Result<(), GraphError> {
        self.check(from)?;
        self.check(to)?;
        let (a, b) = (self.port(from), self.port(to));
        if b.dir != Dir::In {
            return Err(GraphError::NotAnInput(to));
        }
        if !a.unit.compatible(b.unit) {
            return Err(GraphError::UnitMismatch { from, to });
        }
        if mode == Mode::Incremental && (a.level || b.level) {
            return Err(GraphError::ModeMismatch { from, to });
        }
        if self.maps.iter().any(|m| m.from == from && m.to == to) {
            return Err(GraphError::DuplicateMapping { from, to });
        }
        if self.maps.is_full() {
            return Err(GraphError::CapacityExceeded(Capacity::Mappings));
        }
        Ok(())
    }

    /// Maps the output `from` onto the input `to` (pushed after `from`'s
    /// component runs).
    pub fn map(&mut self, from: PortRef, to: PortRef, mode: Mode) -> Result<(), GraphError> {
        self.check(from)?;
        if self.port(from).dir != Dir::Out {
            return Err(GraphError::NotAnOutput(from));
        }
        self.check_pair(from, to, mode)?;
        let _ = self.maps.push(Mapping {
            from,
            to,
            mode,
            kind: MapKind::Push,
            last: self.port(from).value,
            delayed: false,
        });
        Ok(())
    }

    /// The input `listener` taps `source` (an output or another input): it
    /// pulls the source's changes (or absolute value) when its own component
    /// runs. This is fan-out by pull.
    pub fn tap(
        &mut self,
        listener: PortRef,
        source: PortRef,
        mode: Mode,
    ) -> Result<(), GraphError> {
        self.check_pair(source, listener, mode)?;
        let _ = self.maps.push(Mapping {
            from: source,
            to: listener,
            mode,
            kind: MapKind::Tap,
            last: self.port(source).value,
            delayed: false,
        });
        Ok(())
    }

    /// Removes every mapping touching `p`.
    pub fn unmap(&mut self, p: PortRef) {
        self.maps.retain(|m| m.from != p && m.to != p);
    }

    /// Where a component runs: `(phase, creation index)`; slow components
    /// run outside the core frame and count as earliest.
    fn rank(&self, comp: u8) -> (Phase, u8) {
        (self.blocks[comp as usize].comp.phase(), comp)
    }

    /// Validates the whole graph and returns it ready to run.
    pub fn build(&self) -> Result<Graph<C, M>, GraphError> {
        let mut maps = self.maps.clone();
        // Fan-in: an ABSOLUTE mapping must be the only one into its input.
        for m in maps.iter() {
            if m.mode == Mode::Absolute && maps.iter().filter(|n| n.to == m.to).count() > 1 {
                return Err(GraphError::AbsoluteFanIn(m.to));
            }
        }
        // Frame order.
        for k in 0..maps.len() {
            let m = maps[k];
            let t = self.rank(m.to.comp);
            let src_is_input = self.port(m.from).dir == Dir::In;
            let delayed = if m.kind == MapKind::Tap && src_is_input {
                // The tapped input's producers must have run before the listener.
                maps.iter()
                    .filter(|n| n.to == m.from)
                    .any(|n| self.rank(n.from.comp) >= t)
            } else {
                self.rank(m.from.comp) >= t
            };
            if delayed && m.mode == Mode::Absolute {
                return Err(GraphError::BackwardAbsolute {
                    from: m.from,
                    to: m.to,
                });
            }
            maps[k].delayed = delayed;
        }
        // Group: pushes by source component, then taps by listener component,
        // each in creation order of the mappings.
        let mut blocks = self.blocks.clone();
        let mut sorted: Vec<Mapping, M> = Vec::new();
        for (i, b) in blocks.iter_mut().enumerate() {
            let start = sorted.len() as u16;
            for m in maps.iter() {
                if m.kind == MapKind::Push && m.from.comp as usize == i {
                    let _ = sorted.push(*m);
                }
            }
            b.push = (start, sorted.len() as u16);
        }
        for (i, b) in blocks.iter_mut().enumerate() {
            let start = sorted.len() as u16;
            for m in maps.iter() {
                if m.kind == MapKind::Tap && m.to.comp as usize == i {
                    let _ = sorted.push(*m);
                }
            }
            b.pull = (start, sorted.len() as u16);
        }
        let mut order: Vec<u8, C> = Vec::new();
        let mut slow: Vec<u8, C> = Vec::new();
        for phase in [Phase::Input, Phase::Pre, Phase::Channel, Phase::Post] {
            for (i, b) in blocks.iter().enumerate() {
                if b.comp.phase() == phase {
                    let _ = order.push(i as u8);
                }
            }
        }
        for (i, b) in blocks.iter().enumerate() {
            if b.comp.phase() == Phase::Slow {
                let _ = slow.push(i as u8);
            }
        }
        Ok(Graph {
            blocks,
            maps: sorted,
            order,
            slow,
            frame_us: self.frame_us,
        })
    }
}
