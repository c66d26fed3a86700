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
//! - `M7`/`M8`/`M9`: [`AuxChannel::Coolant`](motet_planner::AuxChannel::Coolant)
//!   1 (mist), 2 (flood), 0 (off).
//! - `M82`/`M83` absolute/relative E.
//! - `M104 S [T]`, `M109 S|R [T]`:
//!   [`AuxChannel::Hotend`](motet_planner::AuxChannel::Hotend) of extruder T
//!   (or the one selected by the last `T` word), M109 waits. `M140`/`M190` the bed,
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
mod block;
mod codes;
mod interp;
mod lex;

use motet_planner::{Command, JobTarget, Located, SourceError};

use crate::interp::Interp;
pub use crate::interp::Modal;

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
    /// The machine-space commands, each with the line:column of the G-code word
    /// it came from.
    pub commands: Vec<Located<Command>>,
    /// Codes accepted but not acted on (repeats folded, at most
    /// [`MAX_WARNINGS`] kept); the job runs without them.
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
    /// An interpreter in the program's initial modal state for `target`.
    /// Fails (at line 0) when `opts.retract_length` is negative or not finite,
    /// or `opts.retract_speed` is not positive.
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

    /// The modal state and offsets after the last line.
    pub fn modal(&self) -> Modal {
        self.interp.modal()
    }

    /// The machine is at `p` (machine coordinates) after motion this
    /// interpreter did not plan: the next line's relative moves and arcs
    /// start there.
    pub fn set_machine_position(&mut self, p: motet_trajectory::Point) {
        self.interp.set_machine_position(p);
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
