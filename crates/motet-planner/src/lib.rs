//! The planner: the author side of the trajectory.
//!
//! Job sources turn files into [`Command`]s; the planner turns commands into
//! [`motet_trajectory::Segment`]s and event changes stamped in microseconds. It is pure
//! and deterministic: the same commands and limits give the same trajectory, bit
//! for bit, whether the commands arrive at once or one by one.

pub mod command;
pub mod target;

pub use command::{AuxChannel, Command, Located, Move, MoveKind, SourceError, SourceLoc};
pub use target::{AxisInfo, JobTarget, ToolInfo, ToolKind};
pub mod limits;
pub mod planner;
pub mod ranges;
pub mod strokes;

pub use limits::{AxisLimits, JointLimits, Limits, ToolTiming};
pub use planner::{AuxEvent, PlanError, Planned, Planner, ToolEvent};
pub use ranges::{OutOfRange, ValueRange};
pub use strokes::{StrokeEmitter, StrokeSettings};
