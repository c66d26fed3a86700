//! What a job source needs to know about the machine it writes for.

use motet_trajectory::{Point, MAX_AXES};

/// One machine axis as a job source sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisInfo {
    /// Lower-case name as in the machine file (`x`, `y`, `z`, `e`, …).
    pub name: String,
    /// Soft travel limits `[min, max]` in axis units.
    pub travel: [f64; 2],
    /// Counts toward path length (x, y, z); false for extruders, whose moves
    /// ride along the path of the others.
    pub path: bool,
}

/// What a tool output drives: decides whether motion stops for a change
/// and how a source's on/off maps to a value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToolKind {
    /// A pen lifted and lowered by a servo: value 1 down, 0 up.
    Pen,
    /// Laser power 0..=1, switched on the fly along the path.
    Laser,
    /// Spindle speed 0..=1 of its maximum.
    Spindle,
}

/// One tool output as a job source sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct ToolInfo {
    /// Its name as in the machine file's `[tools.NAME]`.
    pub name: String,
    /// What it drives.
    pub kind: ToolKind,
    /// Value meaning "on" when a source has no explicit power (pen down, full power).
    pub on_value: f32,
}

/// The machine as a job source sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct JobTarget {
    /// Machine axes in index order; index `i` is coordinate `i` of a [`Point`].
    pub axes: Vec<AxisInfo>,
    /// Tool outputs in index order: [`crate::Command::Tool`]'s `tool`.
    pub tools: Vec<ToolInfo>,
    /// Where the machine is when the job starts.
    pub start: Point,
    /// Chord tolerance for flattening curves, in mm.
    pub tolerance: f64,
    /// Feed for drawing when a source gives none (SVG), units/s.
    pub draw_feed: f64,
}

impl JobTarget {
    /// Index of the axis with this name (case-insensitive).
    pub fn axis(&self, name: &str) -> Option<usize> {
        self.axes
            .iter()
            .position(|a| a.name.eq_ignore_ascii_case(name))
            .filter(|&i| i < MAX_AXES)
    }

    /// The first tool of the given kind, as an index for [`crate::Command::Tool`].
    pub fn tool_of_kind(&self, kind: ToolKind) -> Option<u8> {
        self.tools
            .iter()
            .position(|t| t.kind == kind)
            .map(|i| i as u8)
    }

    /// The tool that G-code M3/M5 and SVG strokes switch: the first tool.
    pub fn primary_tool(&self) -> Option<u8> {
        if self.tools.is_empty() {
            None
        } else {
            Some(0)
        }
    }
}
