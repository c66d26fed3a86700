//! What a run does with what nodes' closed loops send unasked: a fault
//! stops the run on its tail (every node brakes on the committed
//! trajectory, the faulted loop has already stopped driving); samples are
//! kept for the report.

use super::NetRun;
use motet_wire::NodeMessage;

impl NetRun {
    /// A fault or samples from node `k`.
    pub(super) fn on_loop_message(&mut self, k: usize, m: NodeMessage, now: u64) {
        self.on_heater_message(k, &m, now);
        if let NodeMessage::Fault {
            source: motet_wire::control::SampleSource::Heater(_),
            ..
        } = m
        {
            // A heater's trip stopped the run already, naming it.
            return;
        }
        if let NodeMessage::Fault {
            source,
            kind,
            at,
            value,
        } = m
        {
            let node = self.peers[k].name.clone();
            self.stop(
                &format!("node {node}: {source:?} stopped driving ({kind:?}, {value}) at {at} µs"),
                now,
            );
        }
    }
}
