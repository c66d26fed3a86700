//! The graph file's stages during a dance: the stage machine looks at the
//! inputs and the node's components, and its parameter changes go to the
//! node; each stage entered is marked with the channels' step counters.

use super::inputs::{ChangeFrom, ParamChange};
use super::node::{send, DanceNode, StepCount};
use super::{DanceError, InputSource, StageMark};
use motet_graph::{GraphFile, StageMachine, StageView};

/// The stage machine and what it did.
pub(super) struct Stages {
    machine: StageMachine,
    /// Whether the machine is still to be started (at the first frame).
    first: bool,
    /// One per stage entered, in order.
    pub marks: Vec<StageMark>,
    /// Parameter changes sent to the node.
    pub param_changes: usize,
}

impl Stages {
    pub fn new(graph: &GraphFile) -> Stages {
        Stages {
            machine: StageMachine::new(graph),
            first: true,
            marks: Vec::new(),
            param_changes: 0,
        }
    }

    /// Starts or updates the stage machine at `t_us` with the source's input
    /// `values`, marks the stages it entered, and sends the node the
    /// parameter changes it made (and tells `source` of each).
    pub fn update(
        &mut self,
        t_us: f64,
        graph: &GraphFile,
        values: &[f64],
        node: &mut DanceNode,
        board: &StepCount,
        source: &mut dyn InputSource,
    ) -> Result<(), DanceError> {
        let msgs = {
            let view = View {
                graph,
                values,
                node,
            };
            if self.first {
                self.first = false;
                self.machine.start(t_us * 1e-6, &view)
            } else {
                self.machine.update(t_us * 1e-6, &view)
            }
        };
        for (t_s, stage) in &self.machine.log()[self.marks.len()..] {
            self.marks.push(StageMark {
                t_s: *t_s,
                stage: stage.clone(),
                steps_forward: board.fwd.clone(),
                steps_reverse: board.rev.clone(),
            });
        }
        for m in &msgs {
            send(node, m)?;
            self.param_changes += 1;
            if let motet_wire::HostMessage::GraphParam {
                component,
                param,
                value,
            } = *m
            {
                let c = ParamChange {
                    component,
                    param,
                    value,
                };
                source.changed(&c, ChangeFrom::Stage, Ok(()));
            }
        }
        Ok(())
    }

    /// Stages entered: time, s, and `name#pass`.
    pub fn log(&self) -> &[(f64, String)] {
        self.machine.log()
    }
}

/// What the stage machine sees: the inputs by name and the node's graph.
struct View<'a> {
    graph: &'a GraphFile,
    values: &'a [f64],
    node: &'a DanceNode,
}

impl StageView for View<'_> {
    fn input(&self, name: &str) -> f64 {
        self.graph
            .inputs
            .iter()
            .position(|d| d.name == name)
            .map_or(0.0, |i| self.values[i])
    }
    fn finished(&self, index: u8) -> bool {
        self.node
            .graph()
            .and_then(|g| g.component(index))
            .is_none_or(motet_graph::finished)
    }
}
