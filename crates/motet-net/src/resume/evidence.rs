//! What a resume is decided on: the files, the run's record and journal, and
//! what each node answered when asked where it is.

use crate::digest::Digest;
use crate::journal::Journal;
use crate::run_record::RunRecord;
use motet_host::Machine;
use motet_planner::{Command, Located};
use motet_trajectory::Point;
use motet_wire::service::Version;
use motet_wire::NodeMessage;

/// What a node answered when asked where it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodePosition {
    pub run: u32,
    pub committed: u32,
    pub stopped: bool,
    pub queued: u16,
    pub at: Point,
}

impl NodePosition {
    /// From a node's answer to `Where`.
    pub fn from_message(m: &NodeMessage) -> Option<NodePosition> {
        match *m {
            NodeMessage::Position {
                run,
                committed,
                stopped,
                queued,
                at,
            } => Some(NodePosition {
                run,
                committed,
                stopped,
                queued,
                at,
            }),
            _ => None,
        }
    }
}

/// What the probe found at one machine node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NodeSeen {
    /// No answer.
    Silent,
    /// It answered: the device it is, and where it is (`None`: it did not
    /// say).
    Answered {
        uid: u64,
        firmware: Version,
        position: Option<NodePosition>,
    },
}

/// Everything a resume is decided on.
pub struct Evidence<'a> {
    pub machine: &'a Machine,
    /// SHA-256 of the machine file and of the job file as they are now.
    pub machine_sha256: Digest,
    pub job: &'a [Located<Command>],
    pub job_sha256: Digest,
    pub record: &'a RunRecord,
    pub journal: &'a Journal,
    /// The journal's path, for errors.
    pub journal_path: &'a str,
    /// One per machine node, in the machine's order.
    pub nodes: &'a [NodeSeen],
}
