//! What job sources produce and the planner consumes.

use motet_trajectory::Point;

/// A place in a source file, 1-based. `column` 0 means "the whole line".
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct SourceLoc {
    pub line: u32,
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
    pub loc: SourceLoc,
    pub message: String,
}

impl SourceError {
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
    pub loc: SourceLoc,
    pub item: T,
}

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
    /// Requested speed along the path in units per second; ignored for rapids.
    pub feed: f64,
    pub kind: MoveKind,
}

/// One step of a job, in machine space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    Move(Move),
    /// Stand still for this many seconds after the previous move has ended.
    Dwell {
        seconds: f64,
    },
    /// Set a tool output (index into [`crate::JobTarget::tools`]) to a value:
    /// pen 1.0 down / 0.0 up, laser or spindle power 0.0..=1.0.
    Tool {
        tool: u8,
        value: f32,
    },
    /// Laser power that follows the actual speed (G-code M4): the output is
    /// `value × speed / feed`, so corners and ramps are not burnt darker.
    ToolPerSpeed {
        tool: u8,
        value: f32,
        feed: f64,
    },
    /// Set an auxiliary channel (temperatures, fans, coolant). `wait` asks the
    /// machine to hold motion until the channel has reached the value.
    Aux {
        channel: AuxChannel,
        value: f32,
        wait: bool,
    },
    /// Come to rest and wait for the person (M0, M1, a pen change).
    Pause {
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
