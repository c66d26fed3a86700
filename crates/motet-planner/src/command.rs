//! What job sources produce and the planner consumes.

use motet_trajectory::Point;

/// A place in a source file, 1-based. `column` 0 means "the whole line".
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct SourceLoc {
    /// Line in the source file, from 1; 0 for commands no line of a file
    /// gave (a job made from an image).
    pub line: u32,
    /// Column in characters, from 1; 0 when the place is the whole line.
    pub column: u32,
}

impl core::fmt::Display for SourceLoc {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if self.column == 0 {
            write!(f, "{}", self.line)
        } else {
            write!(f, "{}:{}", self.line, self.column)
        }
    }
}

/// A job source's complaint about its input, with the place it applies to.
/// The caller adds the file name: `file:line:column: message`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{loc}: {message}")]
pub struct SourceError {
    /// Where in the source the problem is.
    pub loc: SourceLoc,
    /// What is wrong, for the person who wrote the file (no place in it).
    pub message: String,
}

impl SourceError {
    /// An error at `line` and `column` (1-based; column 0: the whole line).
    pub fn new(line: u32, column: u32, message: impl Into<String>) -> Self {
        SourceError {
            loc: SourceLoc { line, column },
            message: message.into(),
        }
    }
}

/// An item together with where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Located<T> {
    /// Where `item` came from, for errors about it later (job checks,
    /// planning).
    pub loc: SourceLoc,
    /// The command (or whatever a source produced).
    pub item: T,
}

/// How a move's speed is chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MoveKind {
    /// Travel at the fastest speed the limits allow (G0, pen-up travel).
    Rapid,
    /// Move at the commanded feed (G1, arcs after flattening, drawing).
    Feed,
}

/// A straight move in machine space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Move {
    /// Absolute target for every machine axis, in axis units (mm or degrees).
    pub target: Point,
    /// Requested speed along the path in units per second. For a rapid, a
    /// finite positive value caps its speed (a rapid override); infinity
    /// leaves it to the axes' limits.
    pub feed: f64,
    /// Rapid or feed move; decides whether `feed` counts.
    pub kind: MoveKind,
}

/// One step of a job, in machine space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// A straight move to an absolute target.
    Move(Move),
    /// Stand still for this many seconds after the previous move has ended.
    Dwell {
        /// Seconds, within [`crate::ranges::DWELL_S`].
        seconds: f64,
    },
    /// Set a tool output (index into [`crate::JobTarget::tools`]) to a value:
    /// pen 1.0 down / 0.0 up, laser or spindle power 0.0..=1.0.
    Tool {
        /// Index into the machine's tools; an unknown one is
        /// [`crate::PlanError::UnknownTool`].
        tool: u8,
        /// The output's new value, `0.0..=1.0`.
        value: f32,
    },
    /// Laser power that follows the actual speed (G-code M4): the output is
    /// `value × speed / feed`, so corners and ramps are not burnt darker.
    ToolPerSpeed {
        /// Index into the machine's tools.
        tool: u8,
        /// The output at `feed` and above, `0.0..=1.0`.
        value: f32,
        /// The path speed (units/s) at which the output reaches `value`;
        /// must be positive.
        feed: f64,
    },
    /// Set an auxiliary channel (temperatures, fans, coolant). `wait` asks the
    /// machine to hold motion until the channel has reached the value.
    Aux {
        /// Which output.
        channel: AuxChannel,
        /// Its new value, in the channel's unit (°C, 0..=1, coolant mode).
        value: f32,
        /// Come to rest and hold motion until the channel reaches `value`
        /// (M109, M190); otherwise it changes on the fly where the next
        /// move starts.
        wait: bool,
    },
    /// Come to rest and wait for the person (M0, M1, a pen change).
    Pause {
        /// An optional stop (M1): the operator may have it skipped; M0
        /// and pen changes are not optional.
        optional: bool,
    },
    /// Come to rest before going on (M400).
    Sync,
}

/// Outputs that are not motion and not the working tool.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AuxChannel {
    /// Hot-end temperature, °C; the index is the extruder.
    Hotend(u8),
    /// Bed temperature, °C.
    Bed,
    /// Chamber temperature, °C.
    Chamber,
    /// Fan speed 0..=1; the index is the fan.
    Fan(u8),
    /// Coolant: 0 off, 1 mist, 2 flood.
    Coolant,
}
