//! A run's nodes replayed in this process from its journal header: the same
//! quantised messages through the same node code, with every output
//! tallied. What a board reports after the run must equal this, step for
//! step and time for time (`NodeMessage::Tally`).

use crate::journal::{JournalHeader, JournalHold, JournalPace};
use crate::plan_feed::{run_limits, PlanFeed};
use crate::run::Tally;
use motet_host::{Distributor, Machine};
use motet_node::{Board, Node};
use motet_planner::{Command, Located, PlanError, SourceLoc};
use motet_wire::{encode, HostMessage, NodeMessage, Refusal, MAX_MESSAGE};
use std::collections::VecDeque;

/// Outputs go nowhere; the node's tally keeps them.
struct Nowhere;

impl Board for Nowhere {
    fn step(&mut self, _: u8, _: bool, _: f64) {}
    fn set_tool(&mut self, _: u8, _: f32, _: f64) {}
}

/// One machine node replayed.
struct Replayed {
    node: Node,
    inbox: VecDeque<HostMessage>,
}

impl Replayed {
    /// Delivers what the node has room for, sealing it as a run does; runs
    /// it on while it is full.
    fn deliver(&mut self, next_seq: Option<u32>, drain: bool) {
        // As a run seals: nodes that take segments.
        if let Some(seq) = next_seq {
            self.inbox.push_back(HostMessage::Seal { next_seq: seq });
        }
        while let Some(m) = self.inbox.front() {
            let mut buf = [0u8; MAX_MESSAGE];
            let Ok(bytes) = encode(m, &mut buf) else {
                self.inbox.pop_front();
                continue;
            };
            match self.node.handle(bytes) {
                Some(NodeMessage::Refused {
                    reason: Refusal::QueueFull,
                }) => match self.node.front_end() {
                    Some(t) => self.node.poll(t + 1.0, &mut Nowhere),
                    None => break,
                },
                _ => {
                    self.inbox.pop_front();
                }
            }
        }
        if drain {
            while let Some(t) = self.node.next_deadline() {
                self.node.poll(t + 1.0, &mut Nowhere);
            }
        }
    }
}

/// Each machine node's tally for a run of `commands` whose journal starts
/// with `header` and journaled the slowdowns and holds given (a host that
/// fell behind planned the moves after it slower), as the nodes would
/// report it after finishing the job.
pub fn replay(
    machine: &Machine,
    commands: Vec<Located<Command>>,
    header: &JournalHeader,
    (paces, holds): (&[JournalPace], &[JournalHold]),
) -> Result<Vec<Tally>, (SourceLoc, PlanError)> {
    let mut dist = Distributor::new(machine);
    let mut nodes: Vec<Replayed> = dist
        .stream_setup(machine, &header.start)
        .into_iter()
        .map(|setup| {
            let mut node = Node::new();
            node.keep_tally();
            let mut inbox: VecDeque<HostMessage> = setup.into();
            // Windowed as a run's nodes are: the job's last window ends at
            // rest, and they stop there, tools off, as they would on a tail.
            inbox.push_back(HostMessage::Windowed { run: 1 });
            Replayed { node, inbox }
        })
        .collect();
    let mut feed = PlanFeed::new(
        run_limits(machine, header.min_move_s),
        header.start,
        header.t0,
        commands,
    )
    .with_paces(paces)
    .with_holds(holds);
    while let Some(item) = feed.next_given(&mut dist)? {
        for (k, n) in nodes.iter_mut().enumerate() {
            // A node that refuses a message is what the tally would show.
            if let Ok(out) = dist.route_batched(k, &item.item) {
                n.inbox.extend(out.into_iter().map(|o| o.message));
            }
            if let Some(o) = dist.flush(k) {
                n.inbox.push_back(o.message);
            }
            n.deliver(dist.next_seq(k), false);
        }
    }
    for (k, n) in nodes.iter_mut().enumerate() {
        n.deliver(dist.next_seq(k), true);
    }
    Ok(nodes
        .iter()
        .map(|n| {
            n.node.tally().map(Tally::from).unwrap_or(Tally {
                steps: [0; 8],
                tool_changes: 0,
                hash: 0,
            })
        })
        .collect())
}
