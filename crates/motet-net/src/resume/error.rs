//! Why a stopped job cannot be resumed, each with what the person can do.

use crate::digest::Digest;
use motet_planner::{PlanError, SourceLoc};

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ResumeError {
    #[error("the {what} {path} changed since the run (SHA-256 {now}; the run had {recorded}): resume needs the files the job ran with")]
    Changed {
        what: &'static str,
        path: String,
        recorded: Digest,
        now: Digest,
    },
    #[error(
        "{journal}: the journal is not this run's: its {what} is {got}, resume.toml has {want}"
    )]
    OtherRun {
        journal: String,
        what: &'static str,
        got: String,
        want: String,
    },
    #[error("{0}")]
    Record(String),
    #[error("the job does not plan as it did: {loc}: {error}")]
    Replan { loc: SourceLoc, error: PlanError },
    #[error("{journal}:{line}: segment {index} is not the one the job plans: {what}; the journal, the job or the machine file changed since the run")]
    Differs {
        journal: String,
        line: usize,
        index: u32,
        what: String,
    },
    #[error("{journal}: {recorded} segments recorded, but the job plans only {planned}; the journal, the job or the machine file changed since the run")]
    TooMany {
        journal: String,
        recorded: usize,
        planned: usize,
    },
    #[error("{journal}: the window ending at segment {end} has its tail from segment {got}, but the plan's tail starts at {want}")]
    Tail {
        journal: String,
        end: u32,
        got: u32,
        want: u32,
    },
    #[error("{journal}: a window says {done} segments were finished at {time} µs, but segment {} ends at {ended} µs", done - 1)]
    Done {
        journal: String,
        done: u32,
        time: u64,
        ended: f64,
    },
    #[error("node {node} does not answer on {link}: where it is cannot be known; bring it back (power, cable, `motet node`) and resume again")]
    Silent { node: String, link: String },
    #[error("node {node} on {link} is uid {uid}, but the run used uid {recorded}: is it the same board?")]
    OtherDevice {
        node: String,
        link: String,
        uid: String,
        recorded: String,
    },
    #[error("node {node} is still moving ({queued} segments queued); wait for it to stop")]
    Moving { node: String, queued: u16 },
    #[error("node {node} has committed {committed} segments, but the journal records {journal}: the journal is not the run's latest")]
    NodeAhead {
        node: String,
        committed: u32,
        journal: u32,
    },
    #[error(
        "node {node} rests at {at}, but {place} is at {want}: the node and the journal disagree"
    )]
    Elsewhere {
        node: String,
        place: String,
        at: String,
        want: String,
    },
    #[error("nodes {a} and {b} both drive {axis} and rest at different places ({va} and {vb}): the machine may be racked; put it right by hand and give --assume-position")]
    Disagree {
        a: String,
        b: String,
        axis: String,
        va: f64,
        vb: f64,
    },
    #[error("{nodes}: where {axes} {is} cannot be known. Home the machine or measure where it is, then tell motet with --assume-position {example}")]
    Unknown {
        nodes: String,
        axes: String,
        is: &'static str,
        example: String,
    },
    #[error(
        "--assume-position is not needed: every node kept its position (the machine rests at {at})"
    )]
    AssumeNotNeeded { at: String },
    #[error("--assume-position {axis}={given}, but node {node} knows that {axis} is at {known}")]
    AssumeConflict {
        axis: String,
        given: f64,
        node: String,
        known: f64,
    },
    #[error("--assume-position names no axis {0:?} of this machine")]
    AssumeAxis(String),
    #[error("resume would {what}: {source}")]
    Beyond {
        what: String,
        source: motet_host::MoveError,
    },
}
