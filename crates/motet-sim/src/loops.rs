//! What a simulation's nodes' loops send: samples kept per source, the
//! first fault (which stops the run, naming the actuator, its following
//! error and the time), and sources that stop reporting.

use motet_host::loops::{fault_text, sample_every};
use motet_host::samples::SampleStore;
use motet_host::sensor_plan::SensorPlan;
use motet_host::Machine;
use motet_trajectory::Segment;
use motet_wire::NodeMessage;

/// The loops' side of a simulated machine's host.
#[derive(Clone, Debug, Default)]
pub struct LoopWatch {
    /// The samples, per source.
    pub store: SampleStore,
    /// The first fault, as the person reads it.
    pub fault: Option<String>,
    /// Each source that faulted: (node, source).
    faulted: Vec<(usize, motet_wire::control::SampleSource)>,
    /// The sensors' planned acceleration: what their readings are
    /// plotted against.
    pub planned: SensorPlan,
}

impl LoopWatch {
    /// Watching `machine`'s sampled sources from host time 0.
    pub fn new(machine: &Machine) -> LoopWatch {
        let mut store = SampleStore::new();
        for k in 0..machine.nodes.len() {
            for (source, every) in sample_every(machine, k) {
                if every > 0 {
                    store.expect(machine, k, source, 0.0);
                }
            }
        }
        LoopWatch {
            store,
            planned: SensorPlan::new(machine),
            ..Default::default()
        }
    }

    /// A segment the nodes run (for the sensors' planned acceleration).
    pub fn planned(&mut self, seg: &Segment) {
        self.planned.segment(seg);
    }

    /// A message node `k` sent at host time `now`.
    pub fn take(&mut self, machine: &Machine, k: usize, m: NodeMessage, now: f64) {
        match m {
            NodeMessage::Samples(b) => {
                let mut buf = [0u8; motet_wire::MAX_MESSAGE];
                let n = motet_wire::encode(&NodeMessage::Samples(b.clone()), &mut buf)
                    .map_or(0, |b| b.len());
                self.store.take(machine, k, &b, n, now);
            }
            NodeMessage::Fault {
                source,
                kind,
                at,
                value,
            } => {
                self.faulted.push((k, source));
                if self.fault.is_none() {
                    self.fault = Some(fault_text(machine, k, source, kind, at, value, 0.0));
                }
            }
            _ => {}
        }
    }

    /// At host time `now`: the first source silent too long (not one that
    /// faulted), as an error naming it.
    pub fn watch(&mut self, machine: &Machine, now: f64) {
        if self.fault.is_some() {
            return;
        }
        let faulted = &self.faulted;
        if let Some(s) = self
            .store
            .silent(now, |s| faulted.contains(&(s.node, s.source)))
        {
            let node = &machine.nodes[s.node].name;
            self.fault = Some(format!(
                "node {node}: {}: samples stopped at {:.3} s (none for {:.1} s); the run was stopped",
                s.name,
                s.heard_at * 1e-6,
                (now - s.heard_at) * 1e-6
            ));
        }
    }
}
