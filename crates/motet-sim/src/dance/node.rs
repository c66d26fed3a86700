//! The simulated node hosting the graph: built from the graph file's wire
//! messages, with a recording loaded into its tape, and its step outputs
//! counted per graph channel.

use super::{DanceError, Recording, DANCE_TAPE};
use motet_graph::GraphFile;
use motet_node::{Board, Node};
use motet_wire::{encode, HostMessage, NodeMessage, MAX_MESSAGE};

/// The node a dance runs on.
pub(super) type DanceNode = Node<8, DANCE_TAPE>;

/// Encodes `m` and hands it to the node, as the host would over the wire; a
/// refusal is an error naming the message (and the graph error the node
/// kept, if any).
pub(super) fn send(node: &mut DanceNode, m: &HostMessage) -> Result<(), DanceError> {
    let mut buf = [0u8; MAX_MESSAGE];
    let bytes = encode(m, &mut buf).map_err(|e| DanceError::Setup(e.to_string()))?;
    match node.handle(bytes) {
        Some(NodeMessage::Refused { reason }) => Err(DanceError::Refused {
            // The node keeps why it refused a graph step.
            what: match node.graph_error() {
                Some(e) => format!("{m:?} ({e})"),
                None => format!("{m:?}"),
            },
            reason,
        }),
        _ => Ok(()),
    }
}

/// A node with `graph` built and committed, and `recording` (when given) in
/// its tape.
pub(super) fn start_node(
    graph: &GraphFile,
    recording: Option<&Recording>,
) -> Result<Box<DanceNode>, DanceError> {
    // Boxed: the tape makes the node too large for the stack.
    let mut node: Box<DanceNode> = Box::new(Node::new());
    for m in graph.messages() {
        send(&mut node, &m)?;
    }
    if let Some(r) = recording {
        node.load_tape(&r.bytes, r.len())
            .map_err(|reason| match reason {
                motet_wire::Refusal::BadConfig => DanceError::Setup(format!(
                    "the recording holds {} samples, the node's tape only {}",
                    r.len(),
                    node.tape_capacity()
                )),
                reason => DanceError::Refused {
                    what: "the recording".into(),
                    reason,
                },
            })?;
    }
    Ok(node)
}

/// The board the node steps: counts each graph channel's steps.
pub(super) struct StepCount {
    /// The node's first graph channel; lower channels are not the graph's.
    base: u8,
    /// Net steps of each graph channel (forward − reverse).
    pub counts: Vec<i64>,
    /// Forward steps of each graph channel.
    pub fwd: Vec<u64>,
    /// Reverse steps of each graph channel.
    pub rev: Vec<u64>,
    /// Whether any channel stepped since the flag was last cleared.
    pub moved: bool,
}

impl StepCount {
    /// Counters for `channels` graph channels of `node`, flagged as moved so
    /// the render samples the start point.
    pub fn new(node: &DanceNode, channels: usize) -> StepCount {
        StepCount {
            base: node.graph_channel_base(),
            counts: vec![0; channels],
            fwd: vec![0; channels],
            rev: vec![0; channels],
            moved: true,
        }
    }
}

impl Board for StepCount {
    fn step(&mut self, channel: u8, forward: bool, _at_us: f64) {
        if let Some(k) = channel.checked_sub(self.base).map(usize::from) {
            if k < self.counts.len() {
                self.counts[k] += if forward { 1 } else { -1 };
                if forward {
                    self.fwd[k] += 1;
                } else {
                    self.rev[k] += 1;
                }
                self.moved = true;
            }
        }
    }
    fn set_tool(&mut self, _: u8, _: f32, _: f64) {}
}
