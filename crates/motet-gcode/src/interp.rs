//! The interpreter's modal state and the order a block is executed in. Each
//! family of codes is interpreted in its own submodule.

mod arc_words;
mod collect;
mod diagnostics;
mod execute;
mod modal;
mod motion;
mod offsets;
mod tools;
mod units;

use motet_planner::{Command, JobTarget, Located, SourceError, ToolKind};
use motet_trajectory::{Point, MAX_AXES};

use crate::codes::{Motion, Plane, AXIS_LETTERS};
use crate::{GcodeOptions, Parsed, MAX_WARNINGS};
use diagnostics::WarnKey;
pub use modal::Modal;

/// The working tool's state.
#[derive(Clone, Copy, Debug, PartialEq)]
enum ToolState {
    Off,
    On(f32),
    /// M4 on a laser: power and the feed of the last ToolPerSpeed emitted.
    PerSpeed(f32, Option<f64>),
}

pub(crate) struct Interp {
    target: JobTarget,
    allow_unknown: bool,
    retract_length: f64,
    retract_speed: f64,
    /// Machine axis index for each letter slot.
    letter_axis: [Option<usize>; 7],
    /// Path axes, as the planner measures move length.
    path: [bool; MAX_AXES],
    tolerance: f64,
    tool: Option<(u8, ToolKind, f32)>,

    machine: Point,
    /// machine = program + offset; offset = wcs[cs] + g92 + retract.
    offset: Point,
    wcs: [Point; 6],
    cs: usize,
    g92: Point,
    retracted: bool,
    home: Point,

    inch: bool,
    relative: bool,
    arc_relative: bool,
    e_relative: bool,
    plane: Plane,
    inverse_time: bool,
    motion: Option<Motion>,
    /// Feed in axis units per second (G94).
    feed: Option<f64>,
    tool_state: ToolState,
    coolant_on: bool,
    extruder: u8,
    pub(crate) ended: bool,

    pub(crate) out: Vec<Located<Command>>,
    pub(crate) warnings: Vec<SourceError>,
    warn_index: Vec<(WarnKey, usize, u64)>,
    /// Warnings beyond [`MAX_WARNINGS`].
    unlisted_warnings: u64,
    scratch: Vec<Point>,

    // Current line, for locations.
    line: String,
    line_no: u32,
}

impl Interp {
    pub(crate) fn new(target: &JobTarget, opts: &GcodeOptions) -> Result<Self, SourceError> {
        let mut letter_axis = [None; 7];
        for (slot, &l) in AXIS_LETTERS.iter().enumerate() {
            let name = [l.to_ascii_lowercase()];
            letter_axis[slot] = core::str::from_utf8(&name)
                .ok()
                .and_then(|n| target.axis(n));
        }
        let tol = target.tolerance;
        let tolerance = if tol.is_finite() && tol > 0.0 {
            tol.max(1e-6)
        } else {
            0.01
        };
        let tool = target.primary_tool().and_then(|t| {
            target
                .tools
                .get(usize::from(t))
                .map(|info| (t, info.kind, info.on_value))
        });
        let mut path = [false; MAX_AXES];
        for (p, a) in path.iter_mut().zip(&target.axes) {
            *p = a.path;
        }
        if !(opts.retract_length.is_finite() && opts.retract_length >= 0.0) {
            return Err(SourceError::new(
                0,
                0,
                "retract_length must be a finite length >= 0",
            ));
        }
        if !(opts.retract_speed.is_finite() && opts.retract_speed > 0.0) {
            return Err(SourceError::new(0, 0, "retract_speed must be positive"));
        }
        Ok(Interp {
            target: target.clone(),
            allow_unknown: opts.allow_unknown,
            retract_length: opts.retract_length,
            retract_speed: opts.retract_speed,
            letter_axis,
            path,
            tolerance,
            tool,
            machine: target.start,
            offset: [0.0; MAX_AXES],
            wcs: [[0.0; MAX_AXES]; 6],
            cs: 0,
            g92: [0.0; MAX_AXES],
            retracted: false,
            home: target.start,
            inch: false,
            relative: false,
            arc_relative: true,
            e_relative: false,
            plane: Plane::Xy,
            inverse_time: false,
            motion: None,
            feed: None,
            tool_state: ToolState::Off,
            coolant_on: false,
            extruder: 0,
            ended: false,
            out: Vec::new(),
            warnings: Vec::new(),
            warn_index: Vec::new(),
            unlisted_warnings: 0,
            scratch: Vec::new(),
            line: String::new(),
            line_no: 0,
        })
    }

    pub(crate) fn finish(mut self) -> Parsed {
        for &(_, idx, count) in &self.warn_index {
            if count > 0 {
                if let Some(w) = self.warnings.get_mut(idx) {
                    w.message.push_str(&format!(" ({count} more like this)"));
                }
            }
        }
        if self.unlisted_warnings > 0 {
            self.warnings.push(SourceError::new(
                self.line_no,
                0,
                format!(
                    "{} further warning(s) of other kinds not listed (only the first {MAX_WARNINGS} kinds are)",
                    self.unlisted_warnings
                ),
            ));
        }
        Parsed {
            commands: self.out,
            warnings: self.warnings,
        }
    }
}
