//! Heaters a node drives, in a networked run: nothing moves until every
//! heater has been heard from (its first samples, at its first tick), a
//! heater's trip stops the run naming it, and a wait (M109, M190, M191)
//! holds the trajectory at rest on the timeline until the node reports
//! the heater ready.
//!
//! The hold is planned a piece at a time: while the heater is not ready,
//! each window gets one more dwell of [`HOLD_PIECE_S`] (journaled, as a
//! `hold` record, before the seal that commits it), so the nodes never
//! reach their tails while they wait and their loops keep ticking. Once
//! the node reports the heater ready, the host plans no more pieces and
//! the job goes on where the last piece ends: at most a lead and a piece
//! after the heater was ready. `motet resume` plans the same pieces at the
//! same place from the journal, so the plan is the run's, bit for bit.

use super::{NetError, NetRun, Phase};
use motet_host::heater_loop;
use motet_host::heater_trace::HeaterTrace;
use motet_planner::AuxEvent;
use motet_wire::control::SampleSource;

/// Length of one piece of a hold, s.
pub const HOLD_PIECE_S: f64 = 0.5;

/// The run's side of its node-driven heaters.
#[derive(Clone, Debug, Default)]
pub(super) struct Heat {
    /// The wait under way: the machine's heater, its target, and from
    /// when (host µs).
    wait: Option<(usize, f32, f64)>,
    /// Readiness the nodes reported: (machine heater, host µs, target).
    ready: Vec<(usize, f64, f32)>,
    /// Per machine heater: whether it has been heard from.
    heard: Vec<bool>,
    /// A heater's trip (machine node, message).
    pub(super) fault: Option<(usize, String)>,
    /// Holds planned, and their seconds.
    pub(super) holds: u64,
    pub(super) hold_s: f64,
    /// Per machine heater a node drives, its samples (for its plot).
    traces: Vec<Option<HeaterTrace>>,
}

impl NetRun {
    /// The samples of every heater a node drives (time in s of the run's
    /// clock), for their plots.
    pub fn heater_traces(&self) -> impl Iterator<Item = &HeaterTrace> {
        self.heat.traces.iter().flatten()
    }

    /// Whether every node-driven heater has been heard from (one that
    /// tripped first is an error naming it).
    pub(super) fn heaters_heard(&mut self) -> Result<bool, NetError> {
        if self.heat.heard.len() != self.machine.heaters.len() {
            self.heat.heard = self
                .machine
                .heaters
                .iter()
                .map(|h| h.node_loop.is_none())
                .collect();
        }
        if let Some((k, message)) = self.heat.fault.clone() {
            return Err(NetError::Node {
                node: self.peers[k].name.clone(),
                message,
            });
        }
        Ok(self.heat.heard.iter().all(|&h| h))
    }

    /// A heater's message from node `k`: samples (it is alive), readiness,
    /// a trip (which stops the run).
    pub(super) fn on_heater_message(&mut self, k: usize, m: &motet_wire::NodeMessage, now: u64) {
        use motet_wire::NodeMessage;
        match *m {
            NodeMessage::Samples(ref b) => {
                if let SampleSource::Heater(i) = b.source {
                    if let Some(h) = heater_loop::by_source(&self.machine, k, i) {
                        if let Some(x) = self.heat.heard.get_mut(h) {
                            *x = true;
                        }
                        if self.heat.traces.len() != self.machine.heaters.len() {
                            self.heat.traces = self
                                .machine
                                .heaters
                                .iter()
                                .map(|h| {
                                    let l = h.node_loop.as_ref()?;
                                    Some(HeaterTrace::new(&h.name, l.ready.window_c as f64))
                                })
                                .collect();
                        }
                        if let Some(Some(t)) = self.heat.traces.get_mut(h) {
                            t.take(b);
                        }
                    }
                }
            }
            NodeMessage::HeaterReady { heater, at, target } => {
                if let Some(h) = heater_loop::by_source(&self.machine, k, heater) {
                    if self.heat.ready.len() >= 16 {
                        self.heat.ready.remove(0);
                    }
                    self.heat.ready.push((h, at, target));
                }
            }
            NodeMessage::Fault {
                source: SampleSource::Heater(i),
                kind,
                at,
                value,
            } => {
                let t0 = if self.feed_t0.is_finite() {
                    self.feed_t0
                } else {
                    at
                };
                let text = heater_loop::fault_text(&self.machine, k, i, kind, at, value, t0);
                let stopped = format!("{text}; the run was stopped on its tail");
                self.heat.fault.get_or_insert((k, text));
                if !matches!(self.phase, Phase::Starting) {
                    self.stop(&stopped, now);
                }
            }
            _ => {}
        }
    }

    /// A planned temperature with `wait` for a heater a node drives: the
    /// hold starts.
    pub(super) fn start_wait(&mut self, a: &AuxEvent) {
        if !a.wait || a.value <= 0.0 {
            return;
        }
        if let Some(h) = heater_loop::by_channel(&self.machine, a.channel) {
            self.heat.wait = Some((h, a.value, a.time));
        }
    }

    /// While a wait is under way: over once its heater is ready (false),
    /// else one more piece of the hold is planned and journaled (true).
    pub(super) fn hold(&mut self) -> Result<bool, NetError> {
        let Some((h, target, since)) = self.heat.wait else {
            return Ok(false);
        };
        let ready = self
            .heat
            .ready
            .iter()
            .any(|r| r.0 == h && r.2 == target && r.1 >= since);
        if ready {
            self.heat.wait = None;
            return Ok(false);
        }
        let Some(feed) = self.feed.as_mut() else {
            return Ok(false);
        };
        let record = feed.hold(HOLD_PIECE_S).map_err(|error| NetError::Plan {
            loc: Default::default(),
            error,
        })?;
        if let Some(j) = self.journal.as_mut() {
            j.hold(&record)?;
        }
        self.heat.holds += 1;
        self.heat.hold_s += HOLD_PIECE_S;
        Ok(true)
    }

    /// Whether the run is holding for a heater.
    pub fn waiting_for_heater(&self) -> bool {
        self.heat.wait.is_some()
    }

    /// Readiness the nodes reported, the latest last: (the machine's
    /// heater, host µs, target °C).
    pub fn heaters_ready(&self) -> &[(usize, f64, f32)] {
        &self.heat.ready
    }

    /// Pieces of holds planned, and their seconds.
    pub fn heater_holds(&self) -> (u64, f64) {
        (self.heat.holds, self.heat.hold_s)
    }
}
