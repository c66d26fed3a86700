//! Why a stopped job cannot be resumed, each with what the person can do.

use crate::digest::Digest;
use motet_planner::{PlanError, SourceLoc};

/// Why [`super::prove`] refused to resume. Nothing has moved when it is
/// returned; each message says what to put right before resuming again.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ResumeError {
    /// The machine file or the job is not the file the run was made from.
    #[error("the {what} {path} changed since the run (SHA-256 {now}; the run had {recorded}): resume needs the files the job ran with")]
    Changed {
        /// `"machine file"` or `"job"`.
        what: &'static str,
        /// The file's path as `resume.toml` records it.
        path: String,
        /// Its SHA-256 when the run was made.
        recorded: Digest,
        /// Its SHA-256 now.
        now: Digest,
    },
    /// The journal's header names another run, other files or another start
    /// than `resume.toml`.
    #[error(
        "{journal}: the journal is not this run's: its {what} is {got}, resume.toml has {want}"
    )]
    OtherRun {
        /// The journal's path.
        journal: String,
        /// Which header field disagrees (`run`, `machine file`, `job`,
        /// `start`).
        what: &'static str,
        /// The journal's value.
        got: String,
        /// `resume.toml`'s value.
        want: String,
    },
    /// `resume.toml` itself is malformed (its run number, say).
    #[error("{0}")]
    Record(String),
    /// Planning the job again failed where the run had planned it: the
    /// planner or its inputs changed.
    #[error("the job does not plan as it did: {loc}: {error}")]
    Replan {
        /// Where in the job the planner refused.
        loc: SourceLoc,
        /// What it refused.
        error: PlanError,
    },
    /// A journaled segment is not bit for bit the one the job plans.
    #[error("{journal}:{line}: segment {index} is not the one the job plans: {what}; the journal, the job or the machine file changed since the run")]
    Differs {
        /// The journal's path.
        journal: String,
        /// The segment's line in the journal (0 if unknown).
        line: usize,
        /// The segment's index in the run.
        index: u32,
        /// The first difference found (command, times, start or end).
        what: String,
    },
    /// The journal holds more segments than the job plans.
    #[error("{journal}: {recorded} segments recorded, but the job plans only {planned}; the journal, the job or the machine file changed since the run")]
    TooMany {
        /// The journal's path.
        journal: String,
        /// Segments in the journal.
        recorded: usize,
        /// Segments the job plans (one beyond the journal asked for).
        planned: usize,
    },
    /// A sealed window's tail does not start where the plan puts it.
    #[error("{journal}: the window ending at segment {end} has its tail from segment {got}, but the plan's tail starts at {want}")]
    Tail {
        /// The journal's path.
        journal: String,
        /// The window's end (segments committed).
        end: u32,
        /// The tail start the seal records.
        got: u32,
        /// The tail start the plan gives.
        want: u32,
    },
    /// A seal claims segments finished before they could have ended.
    #[error("{journal}: a window says {done} segments were finished at {time} µs, but segment {} ends at {ended} µs", done - 1)]
    Done {
        /// The journal's path.
        journal: String,
        /// Segments the seal says were finished.
        done: u32,
        /// When the seal was made, µs on the run's clock.
        time: u64,
        /// When the last of them ends in the plan, µs.
        ended: f64,
    },
    /// A node did not answer the position probe.
    #[error("node {node} does not answer on {link}: where it is cannot be known; bring it back (power, cable, `motet node`) and resume again")]
    Silent {
        /// The node's name in the machine file.
        node: String,
        /// The link the run reached it on.
        link: String,
    },
    /// The board answering is not the one the run used.
    #[error("node {node} on {link} is uid {uid}, but the run used uid {recorded}: is it the same board?")]
    OtherDevice {
        /// The node's name in the machine file.
        node: String,
        /// The link it answered on.
        link: String,
        /// The uid that answered.
        uid: String,
        /// The uid the run recorded.
        recorded: String,
    },
    /// A node still has segments queued: it has not stopped yet.
    #[error("node {node} is still moving ({queued} segments queued); wait for it to stop")]
    Moving {
        /// The node's name in the machine file.
        node: String,
        /// Segments in its queue.
        queued: u16,
    },
    /// A node committed more than the journal records: the journal is
    /// stale (another resume ran since, or it was replaced).
    #[error("node {node} has committed {committed} segments, but the journal records {journal}: the journal is not the run's latest")]
    NodeAhead {
        /// The node's name in the machine file.
        node: String,
        /// Segments the node says were committed.
        committed: u32,
        /// Segments the journal says were committed.
        journal: u32,
    },
    /// A node that kept the run rests somewhere other than the plan says.
    #[error(
        "node {node} rests at {at}, but {place} is at {want}: the node and the journal disagree"
    )]
    Elsewhere {
        /// The node's name in the machine file.
        node: String,
        /// Where the plan says it should rest (`the end of segment 41`).
        place: String,
        /// Where it says it is, its axes as `x=…, y=…`.
        at: String,
        /// Where the plan puts it, same axes.
        want: String,
    },
    /// Two nodes sharing an axis rest at different places on it.
    #[error("nodes {a} and {b} both drive {axis} and rest at different places ({va} and {vb}): the machine may be racked; put it right by hand and give --assume-position")]
    Disagree {
        /// The first node.
        a: String,
        /// The second node.
        b: String,
        /// The axis they share.
        axis: String,
        /// Where the first puts it, machine units.
        va: f64,
        /// Where the second puts it.
        vb: f64,
    },
    /// Nodes lost their position and `--assume-position` does not give
    /// every axis they drive.
    #[error("{nodes}: where {axes} {is} cannot be known. Home the machine or measure where it is, then tell motet with --assume-position {example}")]
    Unknown {
        /// Why each node lost its position, `; `-separated.
        nodes: String,
        /// The axes to give, comma-separated.
        axes: String,
        /// `"is"` or `"are"`, to agree with `axes`.
        is: &'static str,
        /// An `--assume-position` value naming those axes.
        example: String,
    },
    /// `--assume-position` was given but every node kept its position.
    #[error(
        "--assume-position is not needed: every node kept its position (the machine rests at {at})"
    )]
    AssumeNotNeeded {
        /// Where the nodes say the machine rests, `x=…, y=…`.
        at: String,
    },
    /// `--assume-position` contradicts a node that knows the axis.
    #[error("--assume-position {axis}={given}, but node {node} knows that {axis} is at {known}")]
    AssumeConflict {
        /// The axis.
        axis: String,
        /// The value given.
        given: f64,
        /// The node that kept its position on that axis.
        node: String,
        /// Where that node says the axis is.
        known: f64,
    },
    /// `--assume-position` named an axis index the machine does not have.
    #[error("--assume-position names no axis {0:?} of this machine")]
    AssumeAxis(String),
    /// The travel back to where the job continues, or the position the
    /// machine rests at, is outside travel or reach.
    #[error("resume would {what}: {source}")]
    Beyond {
        /// The move refused (`travel to x=…, y=…`).
        what: String,
        /// Why the machine cannot make it.
        source: motet_host::MoveError,
    },
}
