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

    /// The next live parameter change to make before this frame's stages
    /// (a person at a slider), if any; asked again until `None`. Each one is
    /// sent to the node as the wire carries it (`GraphParam`) and answered
    /// through [`InputSource::changed`].
    fn next_change(&mut self) -> Option<ParamChange> {
        None
    }

    /// A parameter change the node was sent: by this source or by the graph
    /// file's stages, taken (`Ok`) or refused with the node's reason in
    /// words (the node then changed nothing). A stage's change the node refuses ends
    /// the dance instead.
    fn changed(&mut self, _change: &ParamChange, _from: ChangeFrom, _result: Result<(), String>) {}
}

/// A change of one live parameter of a running graph's component, as a
/// [`HostMessage::GraphParam`] carries it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamChange {
    /// The component's index in the graph.
    pub component: u8,
    /// The parameter's live id in the component's declaration.
    pub param: u8,
    /// The new value, in the parameter's unit.
    pub value: f64,
}

impl ParamChange {
    /// The message that makes the change on a node.
    pub fn message(&self) -> HostMessage {
        HostMessage::GraphParam {
            component: self.component,
            param: self.param,
            value: self.value,
        }
    }
}

/// Who asked for a parameter change.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChangeFrom {
    /// The input source ([`InputSource::next_change`]).
    Source,
    /// The graph file's stages.
    Stage,
}

/// Sends the source's parameter changes to the node, each answered to the
/// source; a refusal changes nothing and the dance goes on.
pub(super) fn source_changes(source: &mut dyn InputSource, node: &mut DanceNode) {
    while let Some(c) = source.next_change() {
        let result = send(node, &c.message()).map_err(|e| match e {
            DanceError::Refused { reason, .. } => reason.to_string(),
            e => e.to_string(),
        });
        source.changed(&c, ChangeFrom::Source, result);
    }
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

/// Inputs that hold still, with parameter changes made at the first frame
/// (in order): a reference run of a live graph whose parameters were set
/// before its inputs moved. A change the node refuses is kept in
/// `refused`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HeldWithChanges {
    /// One value per graph input.
    pub values: Vec<f64>,
    /// The changes still to make, first first.
    pub changes: std::collections::VecDeque<ParamChange>,
    /// The changes the node refused, with its reason.
    pub refused: Vec<(ParamChange, String)>,
}

impl InputSource for HeldWithChanges {
    fn values(&mut self, _t_s: f64, out: &mut [f64]) {
        out.copy_from_slice(&self.values);
    }
    fn next_change(&mut self) -> Option<ParamChange> {
        self.changes.pop_front()
    }
    fn changed(&mut self, change: &ParamChange, from: ChangeFrom, result: Result<(), String>) {
        if let (ChangeFrom::Source, Err(why)) = (from, result) {
            self.refused.push((*change, why));
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dance::run_dance;
    use std::path::Path;

    #[test]
    fn a_refused_parameter_change_is_answered_and_the_dance_goes_on() {
        let dir =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/dance/game-controller");
        let m = motet_host::Machine::load(&dir.join("machine.toml")).unwrap();
        let g = GraphFile::load(&dir.join("graph.toml")).unwrap();
        let change = |comp: &str, param: &str, value: f64| {
            let (component, param) = g.param_id(comp, param).unwrap();
            ParamChange {
                component,
                param,
                value,
            }
        };
        let lower = change("ch_a", "lower", 2000.0);
        let mut held = HeldWithChanges {
            values: vec![512.0, 512.0, 100.0, 0.0],
            changes: [
                change("ch_a", "upper", 1000.0),
                lower,
                change("knob_x", "invert", 1.0),
            ]
            .into(),
            refused: Vec::new(),
        };
        let r = run_dance(&m, &g, &mut held, 0.2, &mut |_| {}).unwrap();
        // Only the lower limit above the upper one is refused; the inverted
        // knob takes the pen to −2 mm in x.
        assert_eq!(held.refused.len(), 1, "{:?}", held.refused);
        assert_eq!(held.refused[0].0, lower);
        assert!(
            (r.report.final_xy[0] + 2.0).abs() < 0.01,
            "{:?}",
            r.report.final_xy
        );
    }
}
