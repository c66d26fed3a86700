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
    /// The run it holds; 0 when it holds none (restarted or reset), and then
    /// does not know where it is.
    pub run: u32,
    /// Segments of that run committed (sealed) on the node.
    pub committed: u32,
    /// The committed window's tail has started or its end was reached.
    pub stopped: bool,
    /// Segments still queued: nonzero while the node moves.
    pub queued: u16,
    /// Where its queued trajectory ends (where it rests once `queued` is 0),
    /// on the axes it drives.
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
        /// The board's unique id.
        uid: u64,
        /// The firmware version it runs.
        firmware: Version,
        /// Its answer to `Where`.
        position: Option<NodePosition>,
    },
}

/// Everything a resume is decided on.
pub struct Evidence<'a> {
    /// The machine, from its file as it is now.
    pub machine: &'a Machine,
    /// SHA-256 of the machine file and of the job file as they are now.
    pub machine_sha256: Digest,
    /// The job's commands, read from its file as it is now.
    pub job: &'a [Located<Command>],
    /// See `machine_sha256`.
    pub job_sha256: Digest,
    /// The stopped run's `resume.toml`.
    pub record: &'a RunRecord,
    /// The stopped run's journal, read back.
    pub journal: &'a Journal,
    /// The journal's path, for errors.
    pub journal_path: &'a str,
    /// One per machine node, in the machine's order.
    pub nodes: &'a [NodeSeen],
}
