//! The last stage: the operations a validated file performs, in order, and
//! the messages that perform them on a node.

use motet_node::graph::{Mode, PortRef};
use motet_wire::message::{GraphKind, GraphMode, GraphPort};
use motet_wire::HostMessage;

/// One step of building the graph.
#[derive(Clone, Debug)]
pub(crate) enum Op {
    Add(GraphKind, Vec<f64>),
    Ratio(PortRef, f64, f64),
    Map(PortRef, PortRef, Mode, bool),
}

fn wire_port(p: PortRef) -> GraphPort {
    GraphPort {
        comp: p.comp,
        port: p.port,
    }
}

impl Op {
    /// The message performing the step.
    pub(crate) fn message(&self) -> HostMessage {
        match self {
            Op::Add(kind, params) => HostMessage::GraphAdd {
                kind: *kind,
                params: heapless::Vec::from_slice(params).expect("checked arity"),
            },
            Op::Ratio(p, w, b) => HostMessage::GraphRatio {
                port: wire_port(*p),
                world: *w,
                block: *b,
            },
            Op::Map(from, to, mode, tap) => HostMessage::GraphMap {
                from: wire_port(*from),
                to: wire_port(*to),
                mode: match mode {
                    Mode::Incremental => GraphMode::Incremental,
                    Mode::Absolute => GraphMode::Absolute,
                },
                tap: *tap,
            },
        }
    }
}
