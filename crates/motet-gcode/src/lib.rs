//! G-code job source: G-code text to machine-space [`Command`]s for the planner.
//!
//! [`parse`] reads a whole program and returns the commands, each located at
//! the line:column of the word that caused it, plus warnings for codes that
//! were accepted but do nothing here. The first real problem stops the parse
//! with a [`SourceError`] at the offending word.
//!
//! ```
//! use motet_gcode::{parse, GcodeOptions};
//! use motet_planner::{AxisInfo, Command, JobTarget, MoveKind};
//!
//! let axis = |n: &str| AxisInfo { name: n.into(), travel: [0.0, 200.0], path: true };
//! let target = JobTarget {
//!     axes: vec![axis("x"), axis("y")],
//!     tools: vec![],
//!     start: [0.0; 6],
//!     tolerance: 0.01,
//!     draw_feed: 20.0,
//! };
//! let parsed = parse("G21 G90\nG1 X10 Y5 F600 ; 10 mm/s\n", &target, &GcodeOptions::default())?;
//! let Command::Move(m) = parsed.commands[0].item else { panic!() };
//! assert_eq!((m.target[0], m.target[1], m.feed, m.kind), (10.0, 5.0, 10.0, MoveKind::Feed));
//! assert_eq!(parsed.commands[0].loc.to_string(), "2:1");
//! # Ok::<(), motet_planner::SourceError>(())
//! ```
//!
//! The reference is RS274NGC as documented for LinuxCNC's interpreter, plus
//! the Marlin codes 3D-printer slicers emit. Both real slicer files in
//! `bench/data` (PrusaSlicer 2.5 and CuraEngine 4.13) parse with
//! [`GcodeOptions::allow_unknown`] off.
//!
//! # Blocks: modal groups and order of execution
//!
//! Two words of one modal group on a line are an error ("G0 and G1 on one
//! line: they are in the same modal group"). The groups: motion G0 G1 G2 G3;
//! non-modal G4 G10 G11 G28 G28.1 G53 G92 G92.1; plane G17 G18 G19; distance
//! G90 G91; arc distance G90.1 G91.1; feed mode G93 G94; units G20 G21;
//! coordinate system G54…G59; stopping M0 M1 M2 M30; spindle M3 M4 M5;
//! coolant M7 M8 M9; extrusion M82 M83. A non-modal code that uses the axis
//! words (G10 L2/L20, G28, G92) and an explicit motion code with axis words on
//! one line are an error too. A line is executed in this order, whatever the
//! order of its words: modes (units, plane, distance, arc distance, extrusion,
//! coordinate system), feed mode, F, S, T, M3/M4/M5, M7/M8/M9, printer codes
//! (M104 … M400), G4, G10/G11/G28/G28.1/G92/G92.1, motion (with G53), and last
//! M0/M1/M2/M30. F is read in the units selected on its own line; the
//! resulting speed is kept when the units change later.
//!
//! # Coordinates
//!
//! Commands carry machine coordinates: machine = program + work offset
//! (G54…G59, zero unless set with G10) + G92 offset (+ the firmware
//! retraction on E). Axis letters X Y Z E A B C map to the machine axes of
//! the same name. Lengths (X Y Z E I J K R) and feeds scale by 25.4 in inch
//! mode (G20); A B C are degrees and never scaled.
//!
//! # Supported
//!
//! - `G0` rapid, `G1` feed move (G94: needs an `F` seen on this or an earlier
//!   line). Zero-length moves are dropped.
//! - `G2`/`G3` arcs in the plane chosen by `G17` (XY, offsets I J), `G18` (ZX,
//!   offsets K I) or `G19` (YZ, offsets J K); clockwise as seen from the
//!   positive end of the plane's normal axis. Centre form (offsets relative to
//!   the start with `G91.1`, the default, or absolute program coordinates with
//!   `G90.1`; the offset letter normal to the plane may be given as 0) and
//!   radius form (`R`, negative for the long way round). Centre form with
//!   end == start is a full circle. The end must be on the circle within
//!   0.002 mm or 0.1 % of the radius, whichever is larger (an error at the
//!   G2/G3 word otherwise). Arcs are flattened into feed moves whose chord
//!   sagitta is at most [`JobTarget::tolerance`]; the normal axis and every
//!   other axis move linearly along the arc (helix). The last chord ends
//!   exactly at the programmed end.
//! - `G4` dwell: `P` milliseconds or `S` seconds.
//! - `G10 L2 P<n>` sets work offset n (P0 the current system, P1…P6 =
//!   G54…G59) to the axis values; `G10 L20 P<n>` sets it so that the current
//!   position reads as the axis values. Axis values are absolute.
//! - `G10`/`G11` without `L`: Marlin firmware retraction. G10 moves E back by
//!   [`GcodeOptions::retract_length`] at [`GcodeOptions::retract_speed`], G11
//!   undoes it; the program's E coordinate does not change. A second G10 (or a
//!   G11 without a G10) does nothing.
//! - `G20`/`G21` inch/mm.
//! - `G28` goes home: a rapid move to the stored home position (initially
//!   [`JobTarget::start`]) for the named axes (`G28 X Y`; all but E if none are
//!   named), by way of an intermediate point if the axis words have values
//!   (`G28 Z5` rises to program Z5 first). As in Marlin, the G92 offset of the
//!   homed axes is cleared. A warning notes that homing is simulated.
//!   `G28.1` stores the current position as the home position.
//! - `G53` with G0/G1: this line's axis words are absolute machine
//!   coordinates (offsets, G91 and M83 do not apply).
//! - `G54`…`G59` select a work coordinate system (offsets default to zero).
//! - `G90`/`G91` absolute/relative for every axis except E, which follows
//!   `M82`/`M83` (absolute by default). `G90.1`/`G91.1` absolute/relative arc
//!   centres.
//! - `G92` sets the program position of the named axes without moving;
//!   `G92.1` clears the G92 offsets.
//! - `G93` inverse time: on every G1/G2/G3 line `F` says the move takes
//!   1/F minutes, so the feed is length / (60 / F) units/s (length along the
//!   path axes, or along all axes for a move of riding axes only). `G94` units
//!   per minute. Switching between them forgets the feed.
//! - `M0`/`M1` pause ([`Command::Pause`], M1 optional), after the line's motion.
//! - `M2`/`M30` end the program: the tool and coolant are switched off if on
//!   and the lines after are ignored, with one warning if any of them holds
//!   more than a comment.
//! - `M3 [S]` tool on, `M5` off, on [`JobTarget::primary_tool`]. Laser and
//!   spindle power is `S/1000` clamped to 0..=1 (grbl `$30=1000`); without `S`
//!   it is the tool's `on_value`; a pen goes down with 1.0 (`on_value` without
//!   `S`). An `S` word on a later line while the tool is on changes the power.
//! - `M4 [S]` on a laser: [`Command::ToolPerSpeed`] with the current feed in
//!   units/s, so power follows speed. It is emitted again before the next feed
//!   move whenever that move's feed differs (F changed, or G93) and at once
//!   when S changes. On a pen or spindle M4 acts as M3, with a warning.
//! - `M7`/`M8`/`M9`: [`AuxChannel::Coolant`] 1 (mist), 2 (flood), 0 (off).
//! - `M82`/`M83` absolute/relative E.
//! - `M104 S [T]`, `M109 S|R [T]`: [`AuxChannel::Hotend`] of extruder T (or the
//!   one selected by the last `T` word), M109 waits. `M140`/`M190` the bed,
//!   `M141`/`M191` the chamber, the same way. `M106 [P] [S]` fan P (default 0)
//!   at S/255 (full without S), `M107 [P]` fan off. `M400` [`Command::Sync`].
//!   These codes read the rest of their line as their own arguments.
//! - `T0`…`T255` select the extruder that temperatures apply to (with a
//!   warning for T ≠ 0: the machine's moves still drive its one E axis).
//! - `F` modal (G94), `N` line numbers (ignored), `*checksum` suffix (XOR of
//!   all bytes before `*`; verified), `;` and `( )` comments, blank lines,
//!   `\n` or `\r\n`, a leading byte-order mark, lower-case letters,
//!   `G1X10Y5` without spaces, a line holding only `%`.
//! - Accepted with a warning and no command (the rest of such a line is their
//!   arguments and is not interpreted; M117 takes free text): M17 M18 M84
//!   (motors), M114 (position report: it happens on the machine), M105 M115
//!   (reports), M73 (progress), M117 (message), M201 M203 M204 M205 (limits:
//!   they come from the machine file), M220 M221 (overrides), M900 (linear
//!   advance), M862.x (printer checks), G29 (bed levelling), G80 (cancel
//!   canned cycle). Repeated warnings for the same code are folded into the
//!   first one, which then ends with "(N more like this)".
//!
//! # Not supported
//!
//! Everything else is an error "unsupported G-code G38.2" at the word, or with
//! [`GcodeOptions::allow_unknown`] a warning: an unknown G code is skipped and
//! the line's axis words then do not cause an implicit (modal) move; an unknown
//! M code is skipped together with the rest of its line; an unknown letter is
//! skipped. Not implemented: canned cycles (G73, G81…G89), probing (G38.x),
//! G30, G59.1…G59.3, G92.2/G92.3, G10 L1/L10/L11 (tool tables) and G10 R
//! (rotation), cutter and length compensation (G40…G49), path modes (G61,
//! G64), M6 tool change, M48…M53 overrides, M60, parameters and expressions
//! (`#1`, `[...]`, `O` words), block delete `/`, U V W axes. Travel limits are
//! not checked here (`motet_host::check_job` does that).
//!
//! # Ranges
//!
//! Numbers are checked against `motet_planner::ranges` at their word: dwells
//! (`G4 S` 0 to 86,400 s, `G4 P` in ms), feeds (F as mm/s from 0.001 to
//! 100,000; in G93 0.001 to 1e7 per minute), coordinates, offsets and arc
//! words (±1e6 mm, ±1e9 mm on an axis without travel), temperatures (−273.15
//! to 2,000 °C). Power and fan `S` are clamped.

mod arc;
mod lex;

use motet_planner::ranges::{self, ValueRange};
use motet_planner::{
    AuxChannel, Command, JobTarget, Located, Move, MoveKind, SourceError, SourceLoc, ToolKind,
};
use motet_trajectory::{Point, MAX_AXES};

use crate::arc::Arc;
use crate::lex::{code10, number, LexError, Lexer, Word};

/// Options for [`parse`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GcodeOptions {
    /// Skip unsupported codes and words with a warning instead of failing.
    pub allow_unknown: bool,
    /// Firmware retraction (G10 without L): how far E moves back, mm.
    pub retract_length: f64,
    /// Firmware retraction speed (G10 and G11), mm/s.
    pub retract_speed: f64,
}

impl Default for GcodeOptions {
    fn default() -> Self {
        GcodeOptions {
            allow_unknown: false,
            retract_length: 0.8,
            retract_speed: 35.0,
        }
    }
}

/// The result of a successful [`parse`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Parsed {
    pub commands: Vec<Located<Command>>,
    pub warnings: Vec<SourceError>,
}

/// Parse a G-code program for `target`. See the crate documentation for what
/// is supported. The whole program's commands are returned at once; a job of
/// any length is read with an [`Interpreter`], a line at a time.
pub fn parse(text: &str, target: &JobTarget, opts: &GcodeOptions) -> Result<Parsed, SourceError> {
    let mut p = Interpreter::new(target, opts)?;
    let mut commands = Vec::new();
    for (i, raw) in text.split('\n').enumerate() {
        p.line(raw, line_number(i))?;
        commands.extend(p.drain());
    }
    let warnings = p.finish();
    Ok(Parsed { commands, warnings })
}

/// The 1-based line number of the `i`-th line (0-based), saturating.
pub fn line_number(i: usize) -> u32 {
    u32::try_from(i.saturating_add(1)).unwrap_or(u32::MAX)
}

/// Most distinct warnings kept; further ones are only counted, so a file of
/// endless distinct unknown codes cannot grow the list without bound.
pub const MAX_WARNINGS: usize = 256;

/// The G-code interpreter fed one line at a time: memory stays that of its
/// modal state and the commands of the line just read, however long the
/// program. [`parse`] is this over a whole text.
pub struct Interpreter {
    interp: Interp,
    /// Lines after the program end (M2/M30): how many, and the first.
    after_end: u64,
    first_after_end: Option<u32>,
}

impl Interpreter {
    pub fn new(target: &JobTarget, opts: &GcodeOptions) -> Result<Interpreter, SourceError> {
        Ok(Interpreter {
            interp: Interp::new(target, opts)?,
            after_end: 0,
            first_after_end: None,
        })
    }

    /// Interprets line `line_no` (1-based), its `\n` removed; a trailing
    /// `\r` and, on line 1, a byte order mark are ignored. Its commands are
    /// then in [`Interpreter::drain`]. Lines after the program end are only
    /// counted, for a warning.
    pub fn line(&mut self, raw: &str, line_no: u32) -> Result<(), SourceError> {
        let line = raw.strip_suffix('\r').unwrap_or(raw);
        let line = match line_no {
            1 => line.strip_prefix('\u{feff}').unwrap_or(line),
            _ => line,
        };
        if self.interp.ended {
            let t = line.trim();
            if !(t.is_empty() || t.starts_with(';') || t == "%") {
                self.after_end += 1;
                self.first_after_end.get_or_insert(line_no);
            }
            return Ok(());
        }
        self.interp.line(line, line_no)
    }

    /// The commands interpreted since the last call, in order.
    pub fn drain(&mut self) -> std::vec::Drain<'_, Located<Command>> {
        self.interp.out.drain(..)
    }

    /// Whether M2 or M30 ended the program.
    pub fn ended(&self) -> bool {
        self.interp.ended
    }

    /// The warnings: codes accepted but not acted on (repeats folded into
    /// the first, as "(N more like this)"), lines after the program end.
    pub fn finish(mut self) -> Vec<SourceError> {
        if let Some(line) = self.first_after_end {
            let count = self.after_end;
            self.interp.warnings.push(SourceError::new(
                line,
                0,
                format!("{count} line(s) after the program end (M2/M30) ignored"),
            ));
        }
        self.interp.finish().warnings
    }
}

const INCH: f64 = 25.4;

/// Axis letters in slot order.
const AXIS_LETTERS: [u8; 7] = *b"XYZEABC";
const SLOT_E: usize = 3;

fn axis_slot(letter: u8) -> Option<usize> {
    AXIS_LETTERS.iter().position(|&l| l == letter)
}

/// 1-based character column of byte offset `at` in `line`.
fn column(line: &str, at: usize) -> u32 {
    let prefix = line.get(..at).unwrap_or(line);
    let n = if prefix.is_ascii() {
        prefix.len()
    } else {
        prefix.chars().count()
    };
    u32::try_from(n.saturating_add(1)).unwrap_or(u32::MAX)
}

fn code_name(letter: u8, code: u32) -> String {
    let l = letter as char;
    if code % 10 == 0 {
        format!("{l}{}", code / 10)
    } else {
        format!("{l}{}.{}", code / 10, code % 10)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Motion {
    Rapid,
    Linear,
    Cw,
    Ccw,
}

impl Motion {
    fn name(self) -> &'static str {
        match self {
            Motion::Rapid => "G0",
            Motion::Linear => "G1",
            Motion::Cw => "G2",
            Motion::Ccw => "G3",
        }
    }
}

/// Group 0: codes that act once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum NonModal {
    Dwell,
    /// G10 with or without L (decided by the L word).
    G10,
    Unretract,
    Home,
    SetHome,
    Machine,
    SetPosition,
    ResetPosition,
}

impl NonModal {
    fn name(self) -> &'static str {
        match self {
            NonModal::Dwell => "G4",
            NonModal::G10 => "G10",
            NonModal::Unretract => "G11",
            NonModal::Home => "G28",
            NonModal::SetHome => "G28.1",
            NonModal::Machine => "G53",
            NonModal::SetPosition => "G92",
            NonModal::ResetPosition => "G92.1",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Plane {
    Xy,
    Zx,
    Yz,
}

impl Plane {
    fn name(self) -> &'static str {
        match self {
            Plane::Xy => "G17",
            Plane::Zx => "G18",
            Plane::Yz => "G19",
        }
    }

    /// Letter slots of the plane's first and second axis.
    fn slots(self) -> (usize, usize) {
        match self {
            Plane::Xy => (0, 1),
            Plane::Zx => (2, 0),
            Plane::Yz => (1, 2),
        }
    }

    /// Centre-offset letters (first axis, second axis, normal axis), as
    /// indices into [I, J, K].
    fn offsets(self) -> (usize, usize, usize) {
        match self {
            Plane::Xy => (0, 1, 2),
            Plane::Zx => (2, 0, 1),
            Plane::Yz => (1, 2, 0),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Spindle {
    Cw,
    Ccw,
    Off,
}

impl Spindle {
    fn name(self) -> &'static str {
        match self {
            Spindle::Cw => "M3",
            Spindle::Ccw => "M4",
            Spindle::Off => "M5",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stop {
    Pause,
    OptionalPause,
    End(u32),
}

impl Stop {
    fn name(self) -> &'static str {
        match self {
            Stop::Pause => "M0",
            Stop::OptionalPause => "M1",
            Stop::End(20) => "M2",
            Stop::End(_) => "M30",
        }
    }
}

/// Printer codes that read the rest of their line as arguments.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Printer {
    Hotend { wait: bool },
    Bed { wait: bool },
    Chamber { wait: bool },
    FanOn,
    FanOff,
    Sync,
}

/// Arguments of a printer code.
#[derive(Clone, Copy, Debug, Default)]
struct PArgs {
    s: Option<f64>,
    r: Option<f64>,
    p: Option<f64>,
    t: Option<f64>,
}

/// A parameter word: its value (None if the letter had no number) and where.
#[derive(Clone, Copy, Debug)]
struct Param {
    value: Option<f64>,
    at: usize,
}

/// What one line says, before it is executed.
#[derive(Default)]
struct Words {
    motion: Option<(Motion, usize)>,
    nonmodal: Option<(NonModal, usize)>,
    plane: Option<(Plane, usize)>,
    distance: Option<(bool, usize)>,
    arc_distance: Option<(bool, usize)>,
    units: Option<(bool, usize)>,
    /// true: G93 inverse time.
    feed_mode: Option<(bool, usize)>,
    wcs: Option<(usize, usize)>,
    spindle: Option<(Spindle, usize)>,
    coolant: Option<(u8, usize)>,
    stop: Option<(Stop, usize)>,
    extrusion: Option<(bool, usize)>,
    printer: Option<(Printer, u32, usize, PArgs)>,
    axes: [Option<Param>; 7],
    /// I, J, K.
    ijk: [Option<Param>; 3],
    r: Option<Param>,
    f: Option<Param>,
    s: Option<Param>,
    p: Option<Param>,
    l: Option<Param>,
    t: Option<(u8, usize)>,
    /// An unknown code was skipped (allow_unknown): leftover words are its.
    unknown_g: bool,
}

impl Words {
    fn any_axis(&self) -> bool {
        self.axes.iter().any(Option::is_some)
    }

    fn first_axis_at(&self) -> Option<usize> {
        self.axes.iter().flatten().map(|p| p.at).min()
    }
}

/// Key for folding repeated warnings.
#[derive(Clone, Copy, PartialEq, Eq)]
struct WarnKey(u8, u32);

/// Why a slicer code is harmless here, or None if it is not one we accept.
fn ignored_m(code: u32) -> Option<&'static str> {
    Some(match code {
        840 => "(disable motors) accepted: motors are always on in simulation",
        170 => "(enable motors) accepted: motors are always on in simulation",
        180 => "(disable motors) accepted: motors are always on in simulation",
        1140 => "(report position) accepted: the position report happens on the machine",
        1050 => "(report temperatures) ignored",
        730 => "(set print progress) ignored",
        1170 => "(display message) ignored",
        1150 => "(report firmware) ignored",
        2010 => "(set max acceleration) ignored: limits come from the machine file",
        2030 => "(set max feed rate) ignored: limits come from the machine file",
        2040 => "(set acceleration) ignored: limits come from the machine file",
        2050 => "(set jerk) ignored: limits come from the machine file",
        2200 => "(set feed rate percentage) ignored",
        2210 => "(set flow percentage) ignored",
        9000 => "(set linear advance) ignored",
        8620..=8629 => "(printer check) ignored",
        _ => return None,
    })
}

fn ignored_g(code: u32) -> Option<&'static str> {
    Some(match code {
        290 => "(bed levelling) ignored: no probe on this machine",
        800 => "(cancel canned cycle) ignored",
        _ => return None,
    })
}

fn printer_code(code: u32) -> Option<Printer> {
    Some(match code {
        1040 => Printer::Hotend { wait: false },
        1090 => Printer::Hotend { wait: true },
        1400 => Printer::Bed { wait: false },
        1900 => Printer::Bed { wait: true },
        1410 => Printer::Chamber { wait: false },
        1910 => Printer::Chamber { wait: true },
        1060 => Printer::FanOn,
        1070 => Printer::FanOff,
        4000 => Printer::Sync,
        _ => return None,
    })
}

/// The working tool's state.
#[derive(Clone, Copy, Debug, PartialEq)]
enum ToolState {
    Off,
    On(f32),
    /// M4 on a laser: power and the feed of the last ToolPerSpeed emitted.
    PerSpeed(f32, Option<f64>),
}

struct Interp {
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
    ended: bool,

    out: Vec<Located<Command>>,
    warnings: Vec<SourceError>,
    warn_index: Vec<(WarnKey, usize, u64)>,
    /// Warnings beyond [`MAX_WARNINGS`].
    unlisted_warnings: u64,
    scratch: Vec<Point>,

    // Current line, for locations.
    line: String,
    line_no: u32,
}

impl Interp {
    fn new(target: &JobTarget, opts: &GcodeOptions) -> Result<Self, SourceError> {
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

    fn finish(mut self) -> Parsed {
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

    fn loc(&self, at: usize) -> SourceLoc {
        SourceLoc {
            line: self.line_no,
            column: column(&self.line, at),
        }
    }

    fn error(&self, at: usize, msg: impl Into<String>) -> SourceError {
        SourceError {
            loc: self.loc(at),
            message: msg.into(),
        }
    }

    fn warn(&mut self, key: WarnKey, at: usize, msg: impl FnOnce() -> String) {
        if let Some(e) = self.warn_index.iter_mut().find(|e| e.0 == key) {
            e.2 += 1;
            return;
        }
        if self.warnings.len() >= MAX_WARNINGS {
            // Still said at the end, never stored.
            self.unlisted_warnings += 1;
            return;
        }
        let w = SourceError {
            loc: self.loc(at),
            message: msg(),
        };
        self.warn_index.push((key, self.warnings.len(), 0));
        self.warnings.push(w);
    }

    fn emit(&mut self, at: usize, item: Command) {
        let loc = self.loc(at);
        self.out.push(Located { loc, item });
    }

    fn lex_err(&self, e: LexError) -> SourceError {
        self.error(e.at, e.msg)
    }

    fn axes_list(&self) -> String {
        let names: Vec<&str> = self.target.axes.iter().map(|a| a.name.as_str()).collect();
        names.join(", ")
    }

    /// Unknown code or word: error, or warning when allowed.
    fn unknown(&mut self, w: Word<'_>, what: String) -> Result<(), SourceError> {
        if !self.allow_unknown {
            return Err(self.error(w.at, what));
        }
        let key = WarnKey(w.letter, code10(w.text).unwrap_or(u32::MAX));
        self.warn(key, w.at, || format!("{what} skipped"));
        Ok(())
    }

    fn same_group(&self, at: usize, this: &str, other: &str) -> SourceError {
        self.error(
            at,
            format!("{this} and {other} on one line: they are in the same modal group"),
        )
    }

    fn line(&mut self, line: &str, line_no: u32) -> Result<(), SourceError> {
        self.line.clear();
        self.line.push_str(line);
        self.line_no = line_no;
        if line.trim() == "%" {
            return Ok(());
        }
        let mut w = Words::default();
        let mut lx = Lexer::new(line);
        while let Some(word) = lx.next_word().map_err(|e| self.lex_err(e))? {
            match word.letter {
                b'G' => {
                    if self.g_word(&mut w, word)? {
                        lx.skip_rest().map_err(|e| self.lex_err(e))?;
                        break;
                    }
                }
                b'M' => {
                    if self.m_word(&mut w, word, &mut lx)? {
                        break;
                    }
                }
                b'T' => match code10(word.text) {
                    Some(c) if c % 10 == 0 && c <= 2550 => {
                        if w.t.is_some() {
                            return Err(self.error(word.at, "T appears twice on this line"));
                        }
                        w.t = Some(((c / 10) as u8, word.at));
                    }
                    _ => {
                        let what = format!("unsupported tool select T{}", word.text);
                        self.unknown(word, what)?;
                    }
                },
                b'N' => {
                    if word.text.is_empty() || !word.text.bytes().all(|c| c.is_ascii_digit()) {
                        return Err(
                            self.error(word.at, format!("bad line number 'N{}'", word.text))
                        );
                    }
                }
                l => {
                    let slot = match l {
                        b'I' => &mut w.ijk[0],
                        b'J' => &mut w.ijk[1],
                        b'K' => &mut w.ijk[2],
                        b'R' => &mut w.r,
                        b'F' => &mut w.f,
                        b'S' => &mut w.s,
                        b'P' => &mut w.p,
                        b'L' => &mut w.l,
                        _ => match axis_slot(l) {
                            Some(s) => {
                                if self.letter_axis[s].is_none() {
                                    return Err(self.error(
                                        word.at,
                                        format!(
                                            "axis {} is not on this machine (axes: {})",
                                            l as char,
                                            self.axes_list()
                                        ),
                                    ));
                                }
                                &mut w.axes[s]
                            }
                            None => {
                                let what = format!("unsupported word {}{}", l as char, word.text);
                                self.unknown(word, what)?;
                                w.unknown_g = true;
                                continue;
                            }
                        },
                    };
                    if slot.is_some() {
                        return Err(self
                            .error(word.at, format!("{} appears twice on this line", l as char)));
                    }
                    let value = if word.text.is_empty() {
                        if axis_slot(l).is_none() {
                            return Err(
                                self.error(word.at, format!("{} without a number", l as char))
                            );
                        }
                        None
                    } else {
                        match number(word.text) {
                            Some(v) => Some(v),
                            None => {
                                return Err(self.error(
                                    word.at,
                                    format!(
                                        "bad number '{}' in {}{}",
                                        word.text, l as char, word.text
                                    ),
                                ))
                            }
                        }
                    };
                    *slot = Some(Param { value, at: word.at });
                }
            }
        }
        self.execute(&w)
    }

    /// Record a G word. Returns true if the rest of the line is its arguments
    /// and should be skipped.
    fn g_word(&mut self, w: &mut Words, word: Word<'_>) -> Result<bool, SourceError> {
        let Some(code) = code10(word.text) else {
            let what = format!("unsupported G-code G{}", word.text);
            self.unknown(word, what)?;
            w.unknown_g = true;
            return Ok(false);
        };
        let at = word.at;
        let name = || code_name(b'G', code);
        match code {
            0 | 10 | 20 | 30 => {
                let m = match code {
                    0 => Motion::Rapid,
                    10 => Motion::Linear,
                    20 => Motion::Cw,
                    _ => Motion::Ccw,
                };
                claim(&mut w.motion, m, at, |o| {
                    self.same_group(at, &name(), o.name())
                })?;
            }
            40 | 100 | 110 | 280 | 281 | 530 | 920 | 921 => {
                let n = match code {
                    40 => NonModal::Dwell,
                    100 => NonModal::G10,
                    110 => NonModal::Unretract,
                    280 => NonModal::Home,
                    281 => NonModal::SetHome,
                    530 => NonModal::Machine,
                    920 => NonModal::SetPosition,
                    _ => NonModal::ResetPosition,
                };
                claim(&mut w.nonmodal, n, at, |o| {
                    self.same_group(at, &name(), o.name())
                })?;
            }
            170 | 180 | 190 => {
                let p = match code {
                    170 => Plane::Xy,
                    180 => Plane::Zx,
                    _ => Plane::Yz,
                };
                claim(&mut w.plane, p, at, |o| {
                    self.same_group(at, &name(), o.name())
                })?;
            }
            930 | 940 => {
                claim(&mut w.feed_mode, code == 930, at, |inv| {
                    self.same_group(at, &name(), if inv { "G93" } else { "G94" })
                })?;
            }
            200 | 210 => {
                claim(&mut w.units, code == 200, at, |inch| {
                    self.same_group(at, &name(), if inch { "G20" } else { "G21" })
                })?;
            }
            900 | 910 => {
                claim(&mut w.distance, code == 910, at, |rel| {
                    self.same_group(at, &name(), if rel { "G91" } else { "G90" })
                })?;
            }
            901 | 911 => {
                claim(&mut w.arc_distance, code == 911, at, |rel| {
                    self.same_group(at, &name(), if rel { "G91.1" } else { "G90.1" })
                })?;
            }
            540 | 550 | 560 | 570 | 580 | 590 => {
                claim(&mut w.wcs, (code / 10 - 54) as usize, at, |o| {
                    self.same_group(at, &name(), &format!("G{}", 54 + o))
                })?;
            }
            _ => {
                if let Some(why) = ignored_g(code) {
                    self.warn(WarnKey(b'G', code), at, || format!("{} {why}", name()));
                    return Ok(true);
                }
                let what = format!("unsupported G-code {}", name());
                self.unknown(word, what)?;
                w.unknown_g = true;
            }
        }
        Ok(false)
    }

    /// Record an M word. Returns true if the rest of the line was consumed.
    fn m_word(
        &mut self,
        w: &mut Words,
        word: Word<'_>,
        lx: &mut Lexer<'_>,
    ) -> Result<bool, SourceError> {
        let at = word.at;
        let Some(c) = code10(word.text) else {
            self.unknown(word, format!("unsupported M-code M{}", word.text))?;
            lx.skip_rest().map_err(|e| self.lex_err(e))?;
            return Ok(true);
        };
        let name = || code_name(b'M', c);
        match c {
            0 | 10 | 20 | 300 => {
                let s = match c {
                    0 => Stop::Pause,
                    10 => Stop::OptionalPause,
                    _ => Stop::End(c),
                };
                claim(&mut w.stop, s, at, |o| {
                    self.same_group(at, &name(), o.name())
                })?;
            }
            30 | 40 | 50 => {
                let s = match c {
                    30 => Spindle::Cw,
                    40 => Spindle::Ccw,
                    _ => Spindle::Off,
                };
                claim(&mut w.spindle, s, at, |o| {
                    self.same_group(at, &name(), o.name())
                })?;
            }
            70 | 80 | 90 => {
                let v = match c {
                    70 => 1,
                    80 => 2,
                    _ => 0,
                };
                claim(&mut w.coolant, v, at, |o| {
                    self.same_group(at, &name(), ["M9", "M7", "M8"][usize::from(o)])
                })?;
            }
            820 | 830 => {
                claim(&mut w.extrusion, c == 830, at, |rel| {
                    self.same_group(at, &name(), if rel { "M83" } else { "M82" })
                })?;
            }
            _ => {
                if let Some(pc) = printer_code(c) {
                    let args = self.printer_args(lx)?;
                    w.printer = Some((pc, c, at, args));
                    return Ok(true);
                }
                if let Some(why) = ignored_m(c) {
                    self.warn(WarnKey(b'M', c), at, || format!("{} {why}", name()));
                } else {
                    self.unknown(word, format!("unsupported M-code {}", name()))?;
                }
                lx.skip_rest().map_err(|e| self.lex_err(e))?;
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// The rest of a printer code's line: S R P T numbers; other letters
    /// (firmware extras such as M104 B/F or M106 I) are ignored.
    fn printer_args(&mut self, lx: &mut Lexer<'_>) -> Result<PArgs, SourceError> {
        let mut a = PArgs::default();
        while let Some(word) = lx.next_word().map_err(|e| self.lex_err(e))? {
            let slot = match word.letter {
                b'S' => &mut a.s,
                b'R' => &mut a.r,
                b'P' => &mut a.p,
                b'T' => &mut a.t,
                _ => continue,
            };
            let l = word.letter as char;
            if slot.is_some() {
                return Err(self.error(word.at, format!("{l} appears twice on this line")));
            }
            match number(word.text) {
                Some(v) => *slot = Some(v),
                None if word.text.is_empty() => {
                    return Err(self.error(word.at, format!("{l} without a number")))
                }
                None => {
                    return Err(self.error(
                        word.at,
                        format!("bad number '{}' in {l}{}", word.text, word.text),
                    ))
                }
            }
        }
        Ok(a)
    }

    /// Value of a parameter that must have a number (the lexer guarantees it
    /// for non-axis letters).
    fn value(&self, p: Param, letter: char) -> Result<f64, SourceError> {
        p.value
            .ok_or_else(|| self.error(p.at, format!("{letter} without a number")))
    }

    /// `v` (the value of word `p`) if it is in `range`; else an error at
    /// the word.
    fn in_range(
        &self,
        p: Param,
        range: ValueRange,
        what: &str,
        v: f64,
    ) -> Result<f64, SourceError> {
        range
            .check(what, v)
            .map_err(|e| self.error(p.at, e.to_string()))
    }

    /// An axis word's value in machine units (mm, or degrees for A B C),
    /// in its range: [`ranges::COORDINATE`], or [`ranges::RIDING_COORDINATE`]
    /// for an axis without travel limits (an extruder).
    fn axis_value(&self, p: Param, slot: usize) -> Result<f64, SourceError> {
        let letter = AXIS_LETTERS[slot] as char;
        let v = self.value(p, letter)? * self.slot_scale(slot);
        let riding = self.letter_axis[slot]
            .and_then(|i| self.target.axes.get(i))
            .is_some_and(|a| !a.travel.iter().all(|t| t.is_finite()));
        let range = match (riding, slot > SLOT_E) {
            (true, _) => ranges::RIDING_COORDINATE,
            (false, true) => ranges::COORDINATE.scaled(1.0, "°"),
            (false, false) => ranges::COORDINATE,
        };
        self.in_range(p, range, &letter.to_string(), v)
    }

    /// A length word (arc offsets and radius) in mm, within
    /// [`ranges::COORDINATE`].
    fn length_value(&self, p: Param, letter: char) -> Result<f64, SourceError> {
        let v = self.value(p, letter)? * self.length_scale();
        self.in_range(p, ranges::COORDINATE, &letter.to_string(), v)
    }

    fn length_scale(&self) -> f64 {
        if self.inch {
            INCH
        } else {
            1.0
        }
    }

    fn update_offset(&mut self) {
        let wcs = &self.wcs[self.cs];
        for ((o, w), g) in self.offset.iter_mut().zip(wcs).zip(&self.g92) {
            *o = w + g;
        }
        if self.retracted {
            if let Some(e) = self.letter_axis[SLOT_E] {
                self.offset[e] -= self.retract_length;
            }
        }
    }

    fn execute(&mut self, w: &Words) -> Result<(), SourceError> {
        let lenient = w.unknown_g;

        // Modes first: they only change how later steps read the words.
        if let Some((inch, _)) = w.units {
            self.inch = inch;
        }
        if let Some((p, _)) = w.plane {
            self.plane = p;
        }
        if let Some((rel, _)) = w.distance {
            self.relative = rel;
        }
        if let Some((rel, _)) = w.arc_distance {
            self.arc_relative = rel;
        }
        if let Some((rel, _)) = w.extrusion {
            self.e_relative = rel;
        }
        if let Some((cs, _)) = w.wcs {
            if cs != self.cs {
                self.cs = cs;
                self.update_offset();
            }
        }

        // Feed mode, then F.
        if let Some((inv, _)) = w.feed_mode {
            if inv != self.inverse_time {
                self.inverse_time = inv;
                self.feed = None;
            }
        }
        if let Some(p) = w.f {
            let v = self.value(p, 'F')?;
            if !(v.is_finite() && v > 0.0) {
                return Err(self.error(p.at, "feed rate must be positive"));
            }
            if self.inverse_time {
                self.in_range(p, ranges::INVERSE_TIME_F, "F (inverse time, G93)", v)?;
            } else {
                let f = v * self.length_scale() / 60.0;
                if !ranges::VELOCITY.contains(f) {
                    return Err(self.error(
                        p.at,
                        format!(
                            "F{} is a feed of {} units/s; feeds must be {}",
                            ranges::number(v),
                            ranges::number(f),
                            ranges::VELOCITY
                        ),
                    ));
                }
                self.feed = Some(f);
            }
        }

        // T: the extruder temperatures apply to.
        if let Some((t, at)) = w.t {
            if t != 0 {
                self.warn(WarnKey(b'T', 0), at, || {
                    format!("T{t} selects extruder {t} for temperatures; moves still drive the one E axis")
                });
            }
            self.extruder = t;
        }

        // S and M3/M4/M5.
        self.spindle(w, lenient)?;

        // M7/M8/M9.
        if let Some((v, at)) = w.coolant {
            self.coolant_on = v != 0;
            self.emit(
                at,
                Command::Aux {
                    channel: AuxChannel::Coolant,
                    value: f32::from(v),
                    wait: false,
                },
            );
        }

        // Printer codes (temperatures, fans, M400).
        if let Some((pc, code, at, args)) = w.printer {
            self.printer(pc, code, at, args)?;
        }

        // G4.
        if let Some((NonModal::Dwell, at)) = w.nonmodal {
            // With M3/M4 on the line, S is the tool's; otherwise it is seconds.
            let s = if w.spindle.is_some() { None } else { w.s };
            let seconds = match (w.p, s) {
                (Some(_), Some(s)) => {
                    return Err(
                        self.error(s.at, "G4 takes P (milliseconds) or S (seconds), not both")
                    )
                }
                (Some(p), None) => {
                    let ms = ranges::DWELL_S.scaled(1000.0, "ms");
                    let v = self.value(p, 'P')?;
                    self.in_range(p, ms, "G4 P (dwell)", v)? / 1000.0
                }
                (None, Some(s)) => {
                    let v = self.value(s, 'S')?;
                    self.in_range(s, ranges::DWELL_S, "G4 S (dwell)", v)?
                }
                (None, None) => {
                    return Err(self.error(at, "G4 needs P (milliseconds) or S (seconds)"))
                }
            };
            self.emit(at, Command::Dwell { seconds });
        } else if let (Some(p), false) = (w.p, lenient) {
            let g10 = matches!(w.nonmodal, Some((NonModal::G10, _))) && w.l.is_some();
            if !g10 {
                return Err(self.error(p.at, "P is only used with G4 (dwell) and G10 L2/L20 here"));
            }
        }
        if let (Some(l), false) = (w.l, lenient) {
            if !matches!(w.nonmodal, Some((NonModal::G10, _))) {
                return Err(self.error(l.at, "L is only used with G10"));
            }
        }

        // Motion mode.
        if let Some((m, _)) = w.motion {
            self.motion = Some(m);
        }

        // Group 0 codes that use the axis words or change offsets.
        let mut machine_coords = false;
        match w.nonmodal {
            Some((nm @ (NonModal::Home | NonModal::SetPosition), at)) => {
                self.no_motion_axes(w, nm.name(), at)?;
                self.check_arc_words_unused(w, lenient)?;
                if nm == NonModal::Home {
                    self.home(w, at)?;
                } else {
                    self.set_position(w, at)?;
                }
            }
            Some((NonModal::G10, at)) => {
                if w.l.is_some() {
                    self.no_motion_axes(w, "G10", at)?;
                    self.set_offsets(w, at)?;
                    self.check_arc_words_unused(w, lenient)?;
                } else {
                    self.check_arc_words_unused(w, lenient)?;
                    self.no_axes(w, "G10 without L (firmware retraction)")?;
                    self.retract(true, at)?;
                }
            }
            Some((NonModal::Unretract, at)) => {
                self.no_axes(w, "G11 (firmware unretraction)")?;
                self.retract(false, at)?;
            }
            Some((NonModal::SetHome, _)) => {
                self.no_axes(w, "G28.1")?;
                self.home = self.machine;
            }
            Some((NonModal::ResetPosition, _)) => {
                self.no_axes(w, "G92.1")?;
                self.g92 = [0.0; MAX_AXES];
                self.update_offset();
            }
            Some((NonModal::Machine, at)) => {
                if w.any_axis() && !matches!(self.motion, Some(Motion::Rapid | Motion::Linear)) {
                    return Err(self.error(at, "G53 needs G0 or G1"));
                }
                machine_coords = true;
            }
            _ => {}
        }
        let axes_used = matches!(
            w.nonmodal,
            Some((NonModal::Home | NonModal::SetPosition, _))
        ) || (matches!(w.nonmodal, Some((NonModal::G10, _))) && w.l.is_some());
        if !axes_used {
            self.motion(w, machine_coords)?;
        }

        // Stop.
        if let Some((stop, at)) = w.stop {
            match stop {
                Stop::Pause => self.emit(at, Command::Pause { optional: false }),
                Stop::OptionalPause => self.emit(at, Command::Pause { optional: true }),
                Stop::End(_) => {
                    if self.tool_state != ToolState::Off {
                        if let Some((tool, _, _)) = self.tool {
                            self.emit(at, Command::Tool { tool, value: 0.0 });
                        }
                        self.tool_state = ToolState::Off;
                    }
                    if self.coolant_on {
                        self.coolant_on = false;
                        self.emit(
                            at,
                            Command::Aux {
                                channel: AuxChannel::Coolant,
                                value: 0.0,
                                wait: false,
                            },
                        );
                    }
                    self.ended = true;
                }
            }
        }
        Ok(())
    }

    /// An explicit motion code with axis words next to a code that uses them.
    fn no_motion_axes(&self, w: &Words, name: &str, at: usize) -> Result<(), SourceError> {
        if let Some((m, _)) = w.motion {
            if w.any_axis() {
                return Err(self.error(
                    at,
                    format!(
                        "{name} and {} on one line both use the axis words",
                        m.name()
                    ),
                ));
            }
        }
        Ok(())
    }

    fn no_axes(&self, w: &Words, what: &str) -> Result<(), SourceError> {
        if w.motion.is_none() {
            if let Some(p) = w.axes.iter().flatten().next() {
                return Err(self.error(p.at, format!("{what} takes no axis words")));
            }
        }
        Ok(())
    }

    fn spindle(&mut self, w: &Words, lenient: bool) -> Result<(), SourceError> {
        let dwell = matches!(w.nonmodal, Some((NonModal::Dwell, _)));
        if let Some((sp, at)) = w.spindle {
            let Some((tool, kind, on_value)) = self.tool else {
                return Err(self.error(
                    at,
                    format!("{} needs a tool, and this machine has none", sp.name()),
                ));
            };
            let value = match (sp, kind, w.s) {
                (Spindle::Off, _, _) => 0.0,
                (_, _, None) => on_value,
                (_, ToolKind::Pen, Some(_)) => 1.0,
                (_, _, Some(s)) => power(self.value(s, 'S')?),
            };
            match (sp, kind) {
                (Spindle::Ccw, ToolKind::Laser) => {
                    self.tool_state = ToolState::PerSpeed(value, None);
                    if !self.inverse_time {
                        self.per_speed_sync(at, self.feed);
                    }
                    return Ok(());
                }
                (Spindle::Ccw, _) => {
                    self.warn(WarnKey(b'M', 40), at, || {
                        "M4 on a pen or spindle acts as M3 (power following speed is for lasers)"
                            .into()
                    });
                }
                _ => {}
            }
            self.tool_state = if sp == Spindle::Off {
                ToolState::Off
            } else {
                ToolState::On(value)
            };
            self.emit(at, Command::Tool { tool, value });
        } else if let (Some(s), false) = (w.s, dwell) {
            let v = self.value(s, 'S')?;
            match (self.tool, self.tool_state) {
                (Some((_, ToolKind::Pen, _)), ToolState::On(_) | ToolState::PerSpeed(..)) => {}
                (Some((tool, _, _)), ToolState::On(cur)) => {
                    let value = power(v);
                    if value != cur {
                        self.tool_state = ToolState::On(value);
                        self.emit(s.at, Command::Tool { tool, value });
                    }
                }
                (Some(_), ToolState::PerSpeed(cur, _)) => {
                    let value = power(v);
                    if value != cur {
                        self.tool_state = ToolState::PerSpeed(value, None);
                        if !self.inverse_time {
                            self.per_speed_sync(s.at, self.feed);
                        }
                    }
                }
                _ if lenient => {}
                _ => self.warn(WarnKey(b'S', 0), s.at, || {
                    "S without M3 has no effect while the tool is off; put S on the M3 line".into()
                }),
            }
        }
        Ok(())
    }

    /// While M4 is on, emit ToolPerSpeed if `feed` differs from the last one.
    fn per_speed_sync(&mut self, at: usize, feed: Option<f64>) {
        if let (ToolState::PerSpeed(value, last), Some(f), Some((tool, _, _))) =
            (self.tool_state, feed, self.tool)
        {
            if last != Some(f) {
                self.tool_state = ToolState::PerSpeed(value, Some(f));
                self.emit(
                    at,
                    Command::ToolPerSpeed {
                        tool,
                        value,
                        feed: f,
                    },
                );
            }
        }
    }

    fn printer(&mut self, pc: Printer, code: u32, at: usize, a: PArgs) -> Result<(), SourceError> {
        let name = code_name(b'M', code);
        let index = |v: Option<f64>, default: u8, letter: char| -> Result<u8, SourceError> {
            match v {
                None => Ok(default),
                Some(v) if (0.0..=255.0).contains(&v) && v.fract() == 0.0 => Ok(v as u8),
                Some(v) => Err(self.error(at, format!("{name}: bad {letter}{v}"))),
            }
        };
        let temperature = |wait: bool| -> Result<f32, SourceError> {
            let v = match (a.s, a.r, wait) {
                (Some(s), _, _) => s,
                (None, Some(r), true) => r,
                _ => {
                    return Err(self.error(
                        at,
                        format!(
                            "{name} needs S (temperature){}",
                            if wait { " or R" } else { "" }
                        ),
                    ))
                }
            };
            ranges::TEMPERATURE_C
                .check(format_args!("{name}: temperature"), v)
                .map_err(|e| self.error(at, e.to_string()))?;
            Ok(v as f32)
        };
        let (channel, value, wait) = match pc {
            Printer::Hotend { wait } => {
                let e = index(a.t, self.extruder, 'T')?;
                (AuxChannel::Hotend(e), temperature(wait)?, wait)
            }
            Printer::Bed { wait } => (AuxChannel::Bed, temperature(wait)?, wait),
            Printer::Chamber { wait } => (AuxChannel::Chamber, temperature(wait)?, wait),
            Printer::FanOn => {
                let fan = index(a.p, 0, 'P')?;
                let v = a.s.map_or(1.0, |s| (s / 255.0).clamp(0.0, 1.0)) as f32;
                (AuxChannel::Fan(fan), v, false)
            }
            Printer::FanOff => (AuxChannel::Fan(index(a.p, 0, 'P')?), 0.0, false),
            Printer::Sync => {
                self.emit(at, Command::Sync);
                return Ok(());
            }
        };
        self.emit(
            at,
            Command::Aux {
                channel,
                value,
                wait,
            },
        );
        Ok(())
    }

    fn check_arc_words_unused(&self, w: &Words, lenient: bool) -> Result<(), SourceError> {
        if lenient {
            return Ok(());
        }
        let [i, j, k] = w.ijk;
        for (p, l) in [(i, 'I'), (j, 'J'), (k, 'K'), (w.r, 'R')] {
            if let Some(p) = p {
                return Err(self.error(p.at, format!("{l} is only used with G2/G3 arcs")));
            }
        }
        Ok(())
    }

    fn rapid_to(&mut self, at: usize, target: Point) {
        if target != self.machine {
            self.machine = target;
            self.emit(
                at,
                Command::Move(Move {
                    target,
                    feed: f64::INFINITY,
                    kind: MoveKind::Rapid,
                }),
            );
        }
    }

    fn home(&mut self, w: &Words, at: usize) -> Result<(), SourceError> {
        // Intermediate point: the axis words that have values.
        if w.axes.iter().flatten().any(|p| p.value.is_some()) {
            let mid = self.axis_target(w, false, true)?;
            self.rapid_to(at, mid);
        }
        let mut target = self.machine;
        for (slot, &ax) in self.letter_axis.iter().enumerate() {
            let Some(i) = ax else { continue };
            let named = if w.any_axis() {
                w.axes[slot].is_some()
            } else {
                slot != SLOT_E
            };
            if named {
                target[i] = self.home[i];
                self.g92[i] = 0.0;
            }
        }
        self.update_offset();
        self.warn(WarnKey(b'G', 280), at, || {
            "G28 (home) is simulated as a rapid move to the home position".into()
        });
        self.rapid_to(at, target);
        Ok(())
    }

    fn set_position(&mut self, w: &Words, at: usize) -> Result<(), SourceError> {
        if !w.any_axis() {
            return Err(self.error(at, "G92 needs at least one axis word"));
        }
        for (slot, p) in w.axes.iter().enumerate() {
            if let (Some(p), Some(i)) = (*p, self.letter_axis[slot]) {
                let v = self.axis_value(p, slot)?;
                let rest = self.offset[i] - self.g92[i];
                let g = self.machine[i] - v - rest;
                if !g.is_finite() {
                    return Err(self.error(p.at, "coordinate out of range"));
                }
                self.g92[i] = g;
            }
        }
        self.update_offset();
        Ok(())
    }

    /// G10 L2 / L20.
    fn set_offsets(&mut self, w: &Words, at: usize) -> Result<(), SourceError> {
        let l = w.l.map(|l| self.value(l, 'L')).transpose()?;
        let l20 = match l {
            Some(2.0) => false,
            Some(20.0) => true,
            Some(v) => {
                return Err(self.error(
                    at,
                    format!("G10 L{v} is not supported (L2 and L20 set work offsets; G10 without L retracts)"),
                ))
            }
            None => unreachable!("set_offsets is only called with an L word"),
        };
        if let Some(r) = w.r {
            return Err(self.error(r.at, "G10 R (rotation) is not supported"));
        }
        let Some(p) = w.p else {
            return Err(self.error(at, "G10 L2/L20 needs P (coordinate system 0..6)"));
        };
        let pv = self.value(p, 'P')?;
        let cs = match pv {
            0.0 => self.cs,
            v if v.fract() == 0.0 && (1.0..=6.0).contains(&v) => v as usize - 1,
            _ => {
                return Err(self.error(
                    p.at,
                    format!(
                        "G10: P{pv} is not a coordinate system (P0 current, P1..P6 = G54..G59)"
                    ),
                ))
            }
        };
        for (slot, q) in w.axes.iter().enumerate() {
            if let (Some(q), Some(i)) = (*q, self.letter_axis[slot]) {
                let v = self.axis_value(q, slot)?;
                let o = if l20 {
                    let rest = self.offset[i] - self.wcs[self.cs][i] - self.g92[i];
                    self.machine[i] - self.g92[i] - rest - v
                } else {
                    v
                };
                if !o.is_finite() {
                    return Err(self.error(q.at, "coordinate out of range"));
                }
                self.wcs[cs][i] = o;
            }
        }
        self.update_offset();
        Ok(())
    }

    /// G10/G11 without L: firmware retraction.
    fn retract(&mut self, retract: bool, at: usize) -> Result<(), SourceError> {
        let name = if retract { "G10" } else { "G11" };
        let Some(e) = self.letter_axis[SLOT_E] else {
            return Err(self.error(
                at,
                format!(
                    "{name} (firmware retraction) needs an E axis (axes: {})",
                    self.axes_list()
                ),
            ));
        };
        if self.retracted == retract {
            return Ok(());
        }
        self.retracted = retract;
        self.update_offset();
        let mut target = self.machine;
        if retract {
            target[e] -= self.retract_length;
        } else {
            target[e] += self.retract_length;
        }
        if target != self.machine {
            self.machine = target;
            self.emit(
                at,
                Command::Move(Move {
                    target,
                    feed: self.retract_speed,
                    kind: MoveKind::Feed,
                }),
            );
        }
        Ok(())
    }

    fn slot_scale(&self, slot: usize) -> f64 {
        if slot <= SLOT_E {
            self.length_scale()
        } else {
            1.0
        }
    }

    /// Machine target from the line's axis words. `machine_coords`: G53.
    /// `skip_bare`: letters without a number keep their position (G28 X).
    fn axis_target(
        &self,
        w: &Words,
        machine_coords: bool,
        skip_bare: bool,
    ) -> Result<Point, SourceError> {
        let mut t = self.machine;
        for (slot, p) in w.axes.iter().enumerate() {
            if let (Some(p), Some(i)) = (*p, self.letter_axis[slot]) {
                if skip_bare && p.value.is_none() {
                    continue;
                }
                let v = self.axis_value(p, slot)?;
                let rel = if slot == SLOT_E {
                    self.e_relative
                } else {
                    self.relative
                };
                let m = if machine_coords {
                    v
                } else if rel {
                    self.machine[i] + v
                } else {
                    v + self.offset[i]
                };
                if !m.is_finite() {
                    return Err(self.error(p.at, "coordinate out of range"));
                }
                t[i] = m;
            }
        }
        Ok(t)
    }

    /// Length of a move as the planner measures it.
    fn move_length(&self, a: &Point, b: &Point) -> f64 {
        let mut path = 0.0;
        let mut all = 0.0;
        for i in 0..MAX_AXES {
            let d = b[i] - a[i];
            all += d * d;
            if self.path[i] {
                path += d * d;
            }
        }
        let path = path.sqrt();
        if path > 1e-9 {
            path
        } else {
            all.sqrt()
        }
    }

    /// The inverse-time F of a G93 motion line.
    fn inverse_f(&self, w: &Words, motion: Motion, at: usize) -> Result<f64, SourceError> {
        match w.f {
            Some(p) => self.value(p, 'F'),
            None => Err(self.error(
                at,
                format!(
                    "{} in inverse time mode (G93) needs an F word on its line",
                    motion.name()
                ),
            )),
        }
    }

    fn inverse_feed(&self, length: f64, f: f64, at: usize) -> Result<f64, SourceError> {
        let feed = length * f / 60.0;
        if !(feed.is_finite() && feed > 0.0) {
            return Err(self.error(at, "inverse time feed is out of range"));
        }
        Ok(feed)
    }

    fn motion(&mut self, w: &Words, machine_coords: bool) -> Result<(), SourceError> {
        let [i, j, k] = w.ijk;
        let arc_words = i.is_some() || j.is_some() || k.is_some() || w.r.is_some();
        let explicit = w.motion.map(|(_, at)| at);
        // Axis words left over by a skipped unknown code belong to it.
        if w.unknown_g && explicit.is_none() {
            return Ok(());
        }
        let Some(motion) = self.motion else {
            if let Some(at) = w.first_axis_at() {
                return Err(self.error(at, "axis words without a motion mode (no G0/G1/G2/G3 yet)"));
            }
            return self.check_arc_words_unused(w, false);
        };
        let at = explicit.or(w.first_axis_at()).unwrap_or(0);
        match motion {
            Motion::Rapid | Motion::Linear => {
                self.check_arc_words_unused(w, w.unknown_g)?;
                if !w.any_axis() {
                    return Ok(());
                }
                let target = self.axis_target(w, machine_coords, false)?;
                if motion == Motion::Rapid {
                    self.rapid_to(at, target);
                    return Ok(());
                }
                let feed = if self.inverse_time {
                    let f = self.inverse_f(w, motion, at)?;
                    if target == self.machine {
                        return Ok(());
                    }
                    let len = self.move_length(&self.machine, &target);
                    self.inverse_feed(len, f, at)?
                } else {
                    self.need_feed(motion, at)?
                };
                if target != self.machine {
                    self.per_speed_sync(at, Some(feed));
                    self.machine = target;
                    self.emit(
                        at,
                        Command::Move(Move {
                            target,
                            feed,
                            kind: MoveKind::Feed,
                        }),
                    );
                }
                Ok(())
            }
            Motion::Cw | Motion::Ccw => {
                if !w.any_axis() && !arc_words {
                    return Ok(());
                }
                if machine_coords {
                    return Err(self.error(at, "G53 needs G0 or G1"));
                }
                let feed = if self.inverse_time {
                    None
                } else {
                    Some(self.need_feed(motion, at)?)
                };
                self.arc(w, motion, at, feed)
            }
        }
    }

    fn need_feed(&self, motion: Motion, at: usize) -> Result<f64, SourceError> {
        self.feed.ok_or_else(|| {
            self.error(
                at,
                format!("{} without a feed rate (no F word yet)", motion.name()),
            )
        })
    }

    /// `feed`: None in inverse time mode (taken from the line's F).
    fn arc(
        &mut self,
        w: &Words,
        motion: Motion,
        at: usize,
        feed: Option<f64>,
    ) -> Result<(), SourceError> {
        let clockwise = motion == Motion::Cw;
        let name = motion.name();
        let plane = self.plane;
        let (sa, sb) = plane.slots();
        let (Some(x), Some(y)) = (self.letter_axis[sa], self.letter_axis[sb]) else {
            return Err(self.error(
                at,
                format!(
                    "{name} in plane {} needs axes {} and {} (axes: {})",
                    plane.name(),
                    (AXIS_LETTERS[sa] as char).to_ascii_lowercase(),
                    (AXIS_LETTERS[sb] as char).to_ascii_lowercase(),
                    self.axes_list()
                ),
            ));
        };
        let inverse = if feed.is_none() {
            Some(self.inverse_f(w, motion, at)?)
        } else {
            None
        };
        const IJK: [char; 3] = ['I', 'J', 'K'];
        let (oa, ob, on) = plane.offsets();
        let (la, lb) = (IJK[oa], IJK[ob]);
        let start = self.machine;
        let end = self.axis_target(w, false, false)?;
        let (sx, sy) = (start[x], start[y]);
        let (ex, ey) = (end[x], end[y]);
        let arc = if let Some(rp) = w.r {
            if let Some(p) = w.ijk.iter().flatten().next() {
                return Err(self.error(
                    p.at,
                    format!("{name} takes either R or {la}/{lb}, not both"),
                ));
            }
            let r = self.length_value(rp, 'R')?;
            let (dx, dy) = (ex - sx, ey - sy);
            let d2 = dx * dx + dy * dy;
            let d = d2.sqrt();
            if d == 0.0 {
                return Err(self.error(
                    rp.at,
                    format!("{name} in R form needs an end point different from the start (use {la}/{lb} for a full circle)"),
                ));
            }
            let mut h4 = 4.0 * r * r - d2;
            if h4 < 0.0 {
                if r.abs() < d / 2.0 - 1e-9 * d.max(1.0) {
                    return Err(self.error(
                        rp.at,
                        format!(
                            "{name} radius {} is smaller than half the distance to the end point ({})",
                            r.abs(),
                            d / 2.0
                        ),
                    ));
                }
                h4 = 0.0;
            }
            // grbl's construction: centre on the perpendicular bisector; the
            // sign picks the side (short arc for R > 0, long arc for R < 0).
            let mut h = -h4.sqrt() / d;
            if !clockwise {
                h = -h;
            }
            if r < 0.0 {
                h = -h;
            }
            Arc {
                start,
                end,
                center: [sx + 0.5 * (dx - dy * h), sy + 0.5 * (dy + dx * h)],
                x,
                y,
                clockwise,
                full: false,
            }
        } else {
            if let Some(p) = w.ijk[on] {
                if self.value(p, IJK[on])? != 0.0 {
                    return Err(self.error(
                        p.at,
                        format!(
                            "{} is not used by arcs in plane {} ({la}/{lb} are)",
                            IJK[on],
                            plane.name()
                        ),
                    ));
                }
            }
            if w.ijk[oa].is_none() && w.ijk[ob].is_none() {
                return Err(self.error(
                    at,
                    format!("{name} needs {la}/{lb} (centre offset) or R (radius)"),
                ));
            }
            let centre = |p: Option<Param>, letter: char, axis: usize, s: f64| {
                let v = match p {
                    Some(p) => Some(self.length_value(p, letter)?),
                    None => None,
                };
                Ok::<f64, SourceError>(if self.arc_relative {
                    s + v.unwrap_or(0.0)
                } else {
                    // G90.1: absolute program coordinates; a missing one is
                    // the start's.
                    v.map_or(s, |v| v + self.offset[axis])
                })
            };
            let cx = centre(w.ijk[oa], la, x, sx)?;
            let cy = centre(w.ijk[ob], lb, y, sy)?;
            let arc = Arc {
                start,
                end,
                center: [cx, cy],
                x,
                y,
                clockwise,
                full: (ex - sx).hypot(ey - sy) <= 1e-9 * (1.0 + sx.abs().max(sy.abs())),
            };
            let (r0, r1) = arc.radii();
            if !r0.is_finite() || r0 <= 0.0 {
                return Err(self.error(
                    at,
                    format!("{name} radius is zero (the centre is the start)"),
                ));
            }
            if (r0 - r1).abs() > 0.002f64.max(0.001 * r0) {
                return Err(self.error(
                    at,
                    format!(
                        "{name} end point is not on the arc: radius to start {r0:.4}, to end {r1:.4}"
                    ),
                ));
            }
            arc
        };
        let (r0, r1) = arc.radii();
        if !(arc.center[0].is_finite()
            && arc.center[1].is_finite()
            && r0.is_finite()
            && r1.is_finite())
        {
            return Err(self.error(at, format!("{name} arc is out of range")));
        }
        let tol = self.tolerance;
        let mut pts = core::mem::take(&mut self.scratch);
        pts.clear();
        let res = arc.flatten(tol, |p| pts.push(p));
        if let Err(m) = res {
            self.scratch = pts;
            return Err(self.error(at, m));
        }
        let feed = match (feed, inverse) {
            (Some(f), _) => f,
            (None, Some(inv)) => {
                let mut len = 0.0;
                let mut prev = start;
                for p in &pts {
                    len += self.move_length(&prev, p);
                    prev = *p;
                }
                match self.inverse_feed(len, inv, at) {
                    Ok(f) => f,
                    Err(e) => {
                        self.scratch = pts;
                        return Err(e);
                    }
                }
            }
            (None, None) => unreachable!("inverse time arcs have an F"),
        };
        self.per_speed_sync(at, Some(feed));
        let loc = self.loc(at);
        self.out.extend(pts.iter().map(|&target| Located {
            loc,
            item: Command::Move(Move {
                target,
                feed,
                kind: MoveKind::Feed,
            }),
        }));
        self.scratch = pts;
        self.machine = end;
        Ok(())
    }
}

/// Laser/spindle power from an S word, grbl `$30=1000`.
fn power(s: f64) -> f32 {
    ((s / 1000.0).clamp(0.0, 1.0)) as f32
}

/// Puts `v` in a modal group's slot for this line; a second code of the same
/// group on one line is the error `clash` makes from the first.
fn claim<T: Copy>(
    slot: &mut Option<(T, usize)>,
    v: T,
    at: usize,
    clash: impl FnOnce(T) -> SourceError,
) -> Result<(), SourceError> {
    if let Some((other, _)) = *slot {
        return Err(clash(other));
    }
    *slot = Some((v, at));
    Ok(())
}
