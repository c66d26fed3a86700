//! The graph's external inputs: where their values come from
//! ([`InputSource`]) and how they reach the node (only changes are sent).

use super::node::{send, DanceNode};
use super::DanceError;
use motet_graph::GraphFile;
use motet_wire::message::GraphInputKind;
use motet_wire::HostMessage;

/// External input values over time, one per input of the graph's `[inputs]`
/// (in that order).
pub trait InputSource {
    /// Writes every input's value at simulated time `t_s` (seconds from the
    /// start of the run) into `out`, one slot per graph input. Times come in
    /// non-decreasing order during a run.
    fn values(&mut self, t_s: f64, out: &mut [f64]);
}

/// Inputs that hold still: one value per graph input, the same at every
/// time (a reference run of a live graph, or a graph checked at rest).
#[derive(Clone, Debug, PartialEq)]
pub struct HeldInputs(pub Vec<f64>);

impl InputSource for HeldInputs {
    fn values(&mut self, _t_s: f64, out: &mut [f64]) {
        out.copy_from_slice(&self.0);
    }
}

/// The input values of the current frame and the last ones sent to the node.
pub(super) struct InputFeed {
    /// This frame's values, as the source gave them.
    pub values: Vec<f64>,
    /// What the node was last sent (NaN before the first send, so the first
    /// frame sends every input).
    sent: Vec<f64>,
}

impl InputFeed {
    pub fn new(graph: &GraphFile) -> InputFeed {
        InputFeed {
            values: vec![0.0; graph.inputs.len()],
            sent: vec![f64::NAN; graph.inputs.len()],
        }
    }

    /// Reads `source` at `t_s` and sends the node each input whose value
    /// changed (encoders as whole counts).
    pub fn update(
        &mut self,
        t_s: f64,
        source: &mut dyn InputSource,
        graph: &GraphFile,
        node: &mut DanceNode,
    ) -> Result<(), DanceError> {
        source.values(t_s, &mut self.values);
        for (i, d) in graph.inputs.iter().enumerate() {
            let v = if d.kind == GraphInputKind::Encoder {
                self.values[i].round()
            } else {
                self.values[i]
            };
            if v != self.sent[i] {
                self.sent[i] = v;
                send(
                    node,
                    &HostMessage::GraphInput {
                        kind: d.kind,
                        index: d.index,
                        value: v,
                    },
                )?;
            }
        }
        Ok(())
    }
}
