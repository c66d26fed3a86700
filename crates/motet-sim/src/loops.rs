//! What a simulation's nodes' loops send: samples kept per source, the
//! first fault (which stops the run, naming the actuator, its following
//! error and the time), and sources that stop reporting.

use motet_host::loops::{fault_text, sample_every};
use motet_host::samples::{SamplePoint, SampleStore, Series};
use motet_host::Machine;
use motet_trajectory::{JointMap, Segment, PIECES};
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
    /// Per machine sensor, the planned acceleration of its actuator's
    /// axis (units/s²), a step at every profile piece: what its readings
    /// are plotted against.
    pub planned: Vec<Series>,
    /// Per machine sensor, the axis its actuator moves.
    axes: Vec<Option<usize>>,
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
        let axes = machine
            .sensors
            .iter()
            .map(|s| {
                let a = &machine.actuators[s.actuator];
                match machine.joints[a.joint].map {
                    JointMap::Linear { coeffs } => coeffs.iter().position(|&c| c != 0.0),
                    _ => None,
                }
            })
            .collect();
        let planned = machine
            .sensors
            .iter()
            .enumerate()
            .map(|(i, s)| {
                Series::new(
                    0,
                    motet_wire::control::SampleSource::Sensor(i as u8),
                    format!("planned acceleration ({})", s.name),
                )
            })
            .collect();
        LoopWatch {
            store,
            planned,
            axes,
            ..Default::default()
        }
    }

    /// A segment the nodes run: its acceleration along each sensor's axis,
    /// piece by piece.
    pub fn planned(&mut self, seg: &Segment) {
        for (series, axis) in self.planned.iter_mut().zip(&self.axes) {
            let Some(i) = *axis else { continue };
            if seg.profile.length() <= 0.0 {
                // A dwell: standing still.
                for t in [seg.t0, seg.t1()] {
                    series.push(SamplePoint {
                        t_us: t,
                        value: 0.0,
                        lo: 0.0,
                        hi: 0.0,
                    });
                }
                continue;
            }
            let u = seg.axis_rate(i);
            for k in 0..PIECES {
                let p = seg.profile.piece(k);
                if p.duration <= 0.0 {
                    continue;
                }
                let t0 = seg.t0 + p.t0 * 1e6;
                let t1 = t0 + p.duration * 1e6;
                for (t, a) in [(t0, p.a), (t1, p.a + p.j * p.duration)] {
                    let v = a * u;
                    series.push(SamplePoint {
                        t_us: t,
                        value: v,
                        lo: v,
                        hi: v,
                    });
                }
            }
        }
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
