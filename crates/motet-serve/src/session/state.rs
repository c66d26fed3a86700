//! What a session's machine is doing, and why an action was refused.

use motet_host::MoveError;
use serde::Serialize;

/// What the machine is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum State {
    /// At rest, ready.
    Idle,
    /// Moving: a job, a jog or a tool change.
    Running,
    /// A feed hold: braking on the path.
    Holding,
    /// A held job at rest on its path; it can resume or be cancelled.
    Paused,
    /// A cancel or an emergency stop: braking on the path.
    Stopping,
    /// Stopped by an emergency stop, at rest; ready for a new action.
    Stopped,
    /// Something went wrong (a node lost, a run that could not start):
    /// where the machine is may not be known. Cleared by [`Session::unlock`](super::Session::unlock).
    Alarm,
}

impl std::fmt::Display for State {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            State::Idle => "idle",
            State::Running => "running",
            State::Holding => "holding",
            State::Paused => "paused",
            State::Stopping => "stopping",
            State::Stopped => "stopped",
            State::Alarm => "in alarm",
        })
    }
}

/// Why an action was refused. Nothing changed.
#[derive(Debug, thiserror::Error)]
pub enum ActionError {
    /// The action does not fit what the machine is doing.
    #[error("cannot {action} while the machine is {state}")]
    WrongState {
        /// The action asked for.
        action: &'static str,
        /// What the machine is doing.
        state: State,
    },
    /// Another client has control; take it first.
    #[error("another client controls the machine: take control first")]
    NotController,
    /// An axis the machine does not have.
    #[error("no axis `{name}` (the machine's axes: {axes})")]
    UnknownAxis {
        /// The name asked for.
        name: String,
        /// The machine's axes.
        axes: String,
    },
    /// A tool the machine does not have.
    #[error("no tool `{name}` (the machine's tools: {tools})")]
    UnknownTool {
        /// The name asked for.
        name: String,
        /// The machine's tools.
        tools: String,
    },
    /// A heater the machine does not have (its temperature channel).
    #[error("no {channel} heater (the machine's heaters: {heaters})")]
    UnknownHeater {
        /// The channel asked for.
        channel: String,
        /// The machine's heaters.
        heaters: String,
    },
    /// A value out of its range (a feed, a tool value, a coordinate).
    #[error("{what} = {value} is out of range ({range})")]
    OutOfRange {
        /// Which value.
        what: &'static str,
        /// The value given.
        value: f64,
        /// What it may be.
        range: String,
    },
    /// The target is beyond the machine's travel or reach.
    #[error("{0}")]
    Unreachable(#[from] MoveError),
    /// No job with this id.
    #[error("no job {0}")]
    UnknownJob(u64),
    /// No node of this name.
    #[error("no node `{name}` (the machine's nodes: {nodes})")]
    UnknownNode {
        /// The name asked for.
        name: String,
        /// The machine's nodes.
        nodes: String,
    },
    /// A graph drives the machine by hand (`motet serve --graph`).
    #[error("cannot {action}: the machine is driven by hand through its graph ({graph})")]
    HandDriven {
        /// The action asked for.
        action: &'static str,
        /// The graph file.
        graph: String,
    },
    /// The queue holds as many jobs as it takes.
    #[error("the queue is full ({0} jobs)")]
    QueueFull(usize),
    /// The queue has no job to start.
    #[error("the queue is empty")]
    QueueEmpty,
    /// The nodes could not be paired (simulated nodes, or the devices on
    /// their links did not allow it).
    #[error("cannot pair the nodes: {0}")]
    Pair(#[from] crate::engine::PairRefusal),
    /// No queue entry at this place.
    #[error("no queue entry {index} (the queue holds {len})")]
    NoSuchEntry {
        /// The place asked for, from 0.
        index: usize,
        /// Jobs in the queue.
        len: usize,
    },
}

/// Who asks: a client id (any string the client chose) for control.
pub type Client<'a> = Option<&'a str>;
