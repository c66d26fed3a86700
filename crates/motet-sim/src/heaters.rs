//! Heaters a node drives, in a simulation: each node's simulated heaters
//! (what its board reads and drives), the host's side of them (their
//! samples kept per heater, readiness, the first trip, which stops the
//! run naming the heater), the wait on the timeline, and their figures and
//! plots for the report.
//!
//! A wait (M109, M190, M191 on a node-driven heater) runs the nodes on
//! simulated time, a heater tick at a time, until the node says the heater
//! is ready at the waited target; the time that took is then a dwell on
//! the timeline, so the trajectory after it starts at that moment (its
//! times shifted by exactly the wait).

use crate::plant_thread::PlantSink;
use crate::report_heaters::{HeatUpReport, HeaterReport};
use crate::run::{SimError, SimMachine};
use motet_host::heater_loop;
use motet_host::heater_trace::HeaterTrace;
pub use motet_host::thermal::NodeHeat;
use motet_host::Machine;
use motet_planner::{AuxEvent, Command, Planned, Planner, SourceLoc};
use motet_render::plot::{Line, Panel, Plot};
use motet_wire::control::SampleSource;
use motet_wire::NodeMessage;

/// Longest a wait for a heater may take, simulated s: a heater that has
/// not got there by then will not.
pub const WAIT_LIMIT_S: f64 = 1800.0;

/// Longest the host leaves a node with heaters without taking what it
/// sent upstream, µs.
pub const TAKE_EVERY_US: f64 = 500_000.0;

/// What the host knows of the node-driven heaters.
#[derive(Clone, Debug, Default)]
pub struct HeaterWatch {
    /// Per machine heater (none for those no node drives).
    traces: Vec<Option<HeaterTrace>>,
    /// Readiness the nodes reported: (machine heater, host µs, target).
    ready: Vec<(usize, f64, f32)>,
    /// The first trip, as the person reads it.
    pub fault: Option<String>,
}

impl HeaterWatch {
    /// Watching `machine`'s node-driven heaters.
    pub fn new(machine: &Machine) -> HeaterWatch {
        HeaterWatch {
            traces: machine
                .heaters
                .iter()
                .map(|h| {
                    let l = h.node_loop.as_ref()?;
                    Some(HeaterTrace::new(&h.name, l.ready.window_c as f64))
                })
                .collect(),
            ready: Vec::new(),
            fault: None,
        }
    }

    /// A message node `k` sent upstream.
    pub fn take(&mut self, machine: &Machine, k: usize, m: &NodeMessage) {
        match m {
            NodeMessage::Samples(b) => {
                if let SampleSource::Heater(i) = b.source {
                    if let Some(t) = self.trace_mut(machine, k, i) {
                        t.take(b);
                    }
                }
            }
            NodeMessage::Fault {
                source: SampleSource::Heater(i),
                kind,
                at,
                value,
            } => {
                let text = heater_loop::fault_text(machine, k, *i, *kind, *at, *value, 0.0);
                if let Some(t) = self.trace_mut(machine, k, *i) {
                    t.fault = Some(text.clone());
                }
                self.fault.get_or_insert(text);
            }
            NodeMessage::HeaterReady { heater, at, target } => {
                if let Some(h) = heater_loop::by_source(machine, k, *heater) {
                    // Only the latest matters to a wait; a few are kept.
                    if self.ready.len() >= 16 {
                        self.ready.remove(0);
                    }
                    self.ready.push((h, *at, *target));
                }
            }
            _ => {}
        }
    }

    fn trace_mut(&mut self, machine: &Machine, k: usize, i: u8) -> Option<&mut HeaterTrace> {
        let h = heater_loop::by_source(machine, k, i)?;
        self.traces.get_mut(h)?.as_mut()
    }

    /// Whether any heater is node-driven.
    pub fn any(&self) -> bool {
        self.traces.iter().any(|t| t.is_some())
    }

    /// When heater `h` was reported ready at `target`, at or after host
    /// time `after` (µs).
    pub fn ready_at(&self, h: usize, target: f32, after: f64) -> Option<f64> {
        self.ready
            .iter()
            .rev()
            .find(|r| r.0 == h && r.2 == target && r.1 >= after)
            .map(|r| r.1)
    }

    /// The traces, per machine heater.
    pub fn traces(&self) -> impl Iterator<Item = &HeaterTrace> {
        self.traces.iter().flatten()
    }

    /// The figures of every node-driven heater.
    pub fn report(&self, machine: &Machine) -> Vec<HeaterReport> {
        machine
            .heaters
            .iter()
            .zip(&self.traces)
            .filter_map(|(h, t)| {
                let t = t.as_ref()?;
                let l = h.node_loop.as_ref()?;
                let heat_ups: Vec<HeatUpReport> = t
                    .heat_ups()
                    .iter()
                    .map(|u| HeatUpReport {
                        target_c: u.target_c,
                        from_c: u.from_c,
                        at_s: u.at_s,
                        settle_s: u.settle_s,
                        overshoot_c: u.overshoot_c,
                        final_error_c: u.final_error_c,
                    })
                    .collect();
                let last = t.last();
                Some(HeaterReport {
                    name: h.name.clone(),
                    node: machine.nodes[l.node].name.clone(),
                    max_c: h.max_c,
                    window_c: l.ready.window_c as f64,
                    max_overshoot_c: heat_ups.iter().map(|u| u.overshoot_c).fold(0.0, f64::max),
                    longest_settle_s: heat_ups
                        .iter()
                        .filter_map(|u| u.settle_s)
                        .fold(0.0, f64::max),
                    heat_up_count: t.heat_up_total(),
                    heat_ups,
                    final_c: last.map(|p| p.reading),
                    final_target_c: last.map(|p| p.target),
                    waits: t.waits,
                    wait_s: t.wait_s,
                    samples: t.samples,
                    samples_dropped: t.dropped,
                    runaway: t.fault.clone(),
                    plot: None,
                })
            })
            .collect()
    }
}

/// A heater's plot: its reading and target against time over its power.
pub fn heater_plot(machine: &Machine, t: &HeaterTrace) -> Plot {
    let pts = t.points();
    let line = |label: &str, color, f: fn(&motet_host::heater_trace::TracePoint) -> f64| Line {
        label: label.into(),
        color,
        points: pts.iter().map(|p| (p.t_s, f(p))).collect(),
        band: vec![],
    };
    let title = match &t.fault {
        Some(_) => format!("heater {} on {}: tripped", t.name, machine.name),
        None => format!("heater {} on {}", t.name, machine.name),
    };
    Plot {
        title,
        panels: vec![
            Panel {
                label: "°C".into(),
                lines: vec![
                    line("target", [40, 110, 220], |p| p.target),
                    line("reading", [210, 40, 30], |p| p.reading),
                ],
            },
            Panel {
                label: "power (0-1)".into(),
                lines: vec![line("power", [60, 60, 60], |p| p.power)],
            },
        ],
    }
}

impl<P: PlantSink> SimMachine<P> {
    /// A wait for `aux` (a temperature with `wait`): the nodes run on until
    /// the heater that follows its channel is ready at its value, a tick
    /// of the heater at a time. Returns when the trajectory may go on
    /// (host µs; `aux.time` when no node drives the channel's heater or the
    /// value switches it off), or the heater's trip, or that it did not get
    /// there within [`WAIT_LIMIT_S`].
    pub fn wait_heater(&mut self, aux: &AuxEvent) -> Result<f64, SimError> {
        let machine = &self.machine;
        let Some(h) = heater_loop::by_channel(machine, aux.channel) else {
            return Ok(aux.time);
        };
        let heater = &machine.heaters[h];
        let l = heater.node_loop.as_ref().expect("node-driven");
        if aux.value <= 0.0 {
            return Ok(aux.time);
        }
        let period = 1e6 / l.rate_hz;
        let (name, rule) = (heater.name.clone(), l.ready);
        self.flush_all();
        loop {
            self.heater_fault()?;
            if self.heaters.ready_at(h, aux.value, aux.time).is_some() {
                let end = self.now.max(aux.time);
                if let Some(t) = self.heaters.traces.get_mut(h).and_then(|t| t.as_mut()) {
                    t.waited(aux.time * 1e-6, end * 1e-6);
                }
                return Ok(end);
            }
            if self.now > aux.time + WAIT_LIMIT_S * 1e6 {
                let reading = self
                    .heaters
                    .traces
                    .get(h)
                    .and_then(|t| t.as_ref()?.last())
                    .map_or(f64::NAN, |p| p.reading);
                return Err(SimError::Heater {
                    message: format!(
                        "heater {name} did not reach {} °C (within {} °C for {} s) in {WAIT_LIMIT_S} s of waiting from {:.1} s; it reads {reading:.1} °C",
                        aux.value, rule.window_c, rule.residency_s, aux.time * 1e-6
                    ),
                    heaters: self.heaters.traces().cloned().collect(),
                });
            }
            // To just past the heater's next tick (ticks are at k · period).
            let next = ((self.now / period).floor() + 1.0) * period;
            let until = self.frame_after(next);
            self.poll_all(until);
        }
    }

    /// The first heater trip, as the error that stops the run.
    pub(crate) fn heater_fault(&self) -> Result<(), SimError> {
        match &self.heaters.fault {
            Some(message) => Err(SimError::Heater {
                message: message.clone(),
                heaters: self.heaters.traces().cloned().collect(),
            }),
            None => Ok(()),
        }
    }

    /// What the host knows of the node-driven heaters.
    pub fn heaters(&self) -> &HeaterWatch {
        &self.heaters
    }

    /// The block temperature of the machine's heater `h` (the plant's
    /// truth, which no node reads), °C.
    pub fn heater_block_c(&self, h: usize) -> Option<f64> {
        self.plants.iter().find_map(|p| p.heat().block_c(h))
    }
}

/// Submits everything `planner` has planned to `sim`, each item shown to
/// `seen` first; at a wait for a node-driven heater (the command at
/// `loc`), the nodes run until it is ready and the time that took becomes
/// a dwell on the timeline, so what the planner plans next starts then. A
/// wait comes when everything before it is planned and at rest: the
/// planner holds nothing then.
pub fn submit_planned<P: PlantSink>(
    sim: &mut SimMachine<P>,
    planner: &mut Planner,
    loc: SourceLoc,
    seen: &mut dyn FnMut(&Planned),
) -> Result<(), SimError> {
    while let Some(item) = planner.pop() {
        seen(&item);
        sim.submit(item)?;
        let Planned::Aux(aux) = item else {
            continue;
        };
        if !aux.wait {
            continue;
        }
        let resume = sim.wait_heater(&aux)?;
        let seconds = (resume - planner.clock()) * 1e-6;
        if seconds > 0.0 {
            planner
                .push(&Command::Dwell { seconds })
                .map_err(|error| SimError::Plan { loc, error })?;
        }
    }
    Ok(())
}
