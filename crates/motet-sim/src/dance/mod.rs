//! Dance: a node hosting a dataflow graph (built from a graph file through
//! the wire messages), driven by external inputs (a CSV trace, two damped
//! pendulums, or values sent live), with the steps of its channels rendered
//! through a machine file's kinematics. A planned job may run alongside: its
//! segments reach the node through the machine's distributor, interleaved in
//! time with the graph frames, so `trajectory_reader` components follow it.

mod drawing;
mod inputs;
mod job;
mod job_feed;
mod joints;
pub mod live;
mod node;
mod pendulums;
mod recording;
mod report;
mod run;
mod stages;
mod trace;
mod watch;

pub use inputs::{ChangeFrom, HeldInputs, HeldWithChanges, InputSource, ParamChange};
pub use job::PlannedJob;
pub use pendulums::Pendulums;
pub use recording::Recording;
pub use report::{DanceChannel, DanceReport, DanceResult, StageMark};
pub use run::{run_dance, run_dance_with, run_dance_with_job, DanceOptions};
pub use trace::CsvTrace;
pub use watch::{watch_dance, DanceMoment};

use motet_planner::{PlanError, SourceLoc};

/// Recording tape of the simulated node, bytes (one per core frame: 10 s at
/// 25 kHz).
pub const DANCE_TAPE: usize = 256 * 1024;

/// Why a dance could not be set up or run.
#[derive(Debug, thiserror::Error)]
pub enum DanceError {
    /// An input trace that cannot be read or parsed, at the place (1-based;
    /// line 0 when the file could not be read at all).
    #[error("{file}:{line}:{column}: {message}")]
    Trace {
        /// The trace's path, as given.
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column, in characters.
        column: usize,
        /// What is wrong there.
        message: String,
    },
    /// The node refused a message (building the graph, an input, a
    /// parameter change, a job segment) or the recording.
    #[error("the node refused {what}: {reason}")]
    Refused {
        /// The message refused, and the graph error the node kept, if any.
        what: String,
        /// The node's reason.
        reason: motet_wire::Refusal,
    },
    /// The machine, graph or recording do not fit together (an actuator the
    /// machine lacks, no node for a job, a recording larger than the tape,
    /// no inputs for the pendulums).
    #[error("{0}")]
    Setup(String),
    /// The job could not be planned at a command of its source.
    #[error("{loc}: {error}")]
    Plan {
        /// Where the command is in the job file.
        loc: SourceLoc,
        /// Why the planner refused it.
        error: PlanError,
    },
    /// A recording file that cannot be read, written or loaded.
    #[error("{file}: {message}")]
    Recording {
        /// The file at fault (the bytes or the `.len` companion).
        file: String,
        /// What went wrong.
        message: String,
    },
}
