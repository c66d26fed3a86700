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
//! # Supported
//!
//! - `G0` (rapid), `G1` (feed move; needs an `F` seen on this or an earlier line).
//! - `G2`/`G3` arcs in the XY plane, centre-offset form (`I` `J`, relative to
//!   the start; `K` is accepted and ignored) and radius form (`R`, negative for
//!   the long way round). IJK with end == start is a full circle. Arcs are
//!   flattened into feed moves whose chord sagitta is at most
//!   [`JobTarget::tolerance`]; other axes (Z, E, …) move linearly along the
//!   arc (helix). The last chord ends exactly at the programmed end.
//! - `G4` dwell: `P` milliseconds or `S` seconds.
//! - `G17` (XY plane) and `G94` (units per minute feed) are accepted silently:
//!   they select the only mode there is.
//! - `G20`/`G21` inch/mm: lengths (X Y Z E I J K R) and feeds scale by 25.4 in
//!   inch mode; A B C are taken as degrees and not scaled.
//! - `G90`/`G91` absolute/relative for every axis except E, which follows
//!   `M82`/`M83` (absolute by default).
//! - `G92` sets the program position of the named axes without moving
//!   (an offset: machine = program + offset). Commands carry machine coordinates.
//! - `G28` home: a rapid move to [`JobTarget::start`] for the named axes (all
//!   axes if none are named, `G28 X Y` without numbers is fine), resetting
//!   their offsets, with a warning that homing is simulated.
//! - `M3 [S]` tool on, `M5` tool off, on [`JobTarget::primary_tool`]. Laser and
//!   spindle power is `S/1000` clamped to 0..=1 (grbl `$30=1000`); without `S`
//!   it is the tool's `on_value`; a pen goes down with 1.0 (`on_value` without `S`). An `S` word on a
//!   later line while the tool is on changes the power (grbl laser style).
//! - `F` in units per minute (stored per second), modal.
//! - `N` line numbers (ignored), `*checksum` suffix (XOR of all bytes before
//!   `*`; verified), `;` and `( )` comments, blank lines, `\n` or `\r\n`,
//!   a leading byte-order mark, lower-case letters, `G1X10Y5` without spaces,
//!   a line holding only `%`.
//! - Axis letters X Y Z E A B C map to the machine axes of the same name.
//! - Slicer codes that do not matter here are accepted with a warning and no
//!   command: M104 M109 M140 M190 M106 M107 M84 M73 M117 M201 M203 M204 M205
//!   M220 M221 M900 M862.x M115 M17 M18 G29 G80, and T0..T9. The rest of such a
//!   line is their arguments and is not interpreted (M117 takes free text).
//!   Repeated warnings for the same code are folded into the first one, which
//!   then ends with "(N more like this)".
//!
//! # Not supported
//!
//! Everything else is an error "unsupported G-code G38.2" at the word, or with
//! [`GcodeOptions::allow_unknown`] a warning: an unknown G code is skipped and
//! the line's axis words then do not cause an implicit (modal) move; an unknown
//! M code is skipped together with the rest of its line; an unknown letter is
//! skipped. Not implemented: G18/G19 planes, G90.1/G91.1 arc distance modes,
//! canned cycles, work coordinate systems (G54…), cutter/length compensation,
//! M4 (dynamic laser power), M6 tool change, parameters and expressions
//! (`#1`, `[...]`), block delete `/`, U V W axes. Travel limits are not checked
//! here (the planner does that).

mod arc;
mod lex;

use motet_planner::{
    Command, JobTarget, Located, Move, MoveKind, SourceError, SourceLoc, ToolKind,
};
use motet_trajectory::{Point, MAX_AXES};

use crate::arc::Arc;
use crate::lex::{code10, number, LexError, Lexer, Word};

/// Options for [`parse`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GcodeOptions {
    /// Skip unsupported codes and words with a warning instead of failing.
    pub allow_unknown: bool,
}

/// The result of a successful [`parse`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Parsed {
    pub commands: Vec<Located<Command>>,
    pub warnings: Vec<SourceError>,
}

/// Parse a G-code program for `target`. See the crate documentation for what
/// is supported.
pub fn parse(text: &str, target: &JobTarget, opts: &GcodeOptions) -> Result<Parsed, SourceError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut p = Interp::new(target, opts);
    for (i, raw) in text.split('\n').enumerate() {
        let line_no = u32::try_from(i.saturating_add(1)).unwrap_or(u32::MAX);
        let line = raw.strip_suffix('\r').unwrap_or(raw);
        p.line(line, line_no)?;
    }
    Ok(p.finish())
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

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum NonModal {
    Dwell,
    Home,
    SetPosition,
}

impl NonModal {
    fn name(self) -> &'static str {
        match self {
            NonModal::Dwell => "G4",
            NonModal::Home => "G28",
            NonModal::SetPosition => "G92",
        }
    }
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
    distance: Option<(bool, usize)>,
    units: Option<(bool, usize)>,
    plane: Option<usize>,
    feed_mode: Option<usize>,
    nonmodal: Option<(NonModal, usize)>,
    spindle: Option<(bool, usize)>,
    extrusion: Option<(bool, usize)>,
    axes: [Option<Param>; 7],
    i: Option<Param>,
    j: Option<Param>,
    k: Option<Param>,
    r: Option<Param>,
    f: Option<Param>,
    s: Option<Param>,
    p: Option<Param>,
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

/// Why a slicer code is harmless here, or None if it is not one we ignore.
fn ignored_m(code: u32) -> Option<&'static str> {
    Some(match code {
        1040 => "(set hotend temperature) ignored: no heater on this machine",
        1090 => "(wait for hotend temperature) ignored: no heater on this machine",
        1400 => "(set bed temperature) ignored: no heater on this machine",
        1900 => "(wait for bed temperature) ignored: no heater on this machine",
        1060 => "(fan on) ignored: no fan on this machine",
        1070 => "(fan off) ignored: no fan on this machine",
        840 => "(disable motors) ignored: motors are always on in simulation",
        170 => "(enable motors) ignored: motors are always on in simulation",
        180 => "(disable motors) ignored: motors are always on in simulation",
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

struct Interp<'t> {
    target: &'t JobTarget,
    allow_unknown: bool,
    /// Machine axis index for each letter slot.
    letter_axis: [Option<usize>; 7],
    n_axes: usize,
    tolerance: f64,
    tool: Option<(u8, ToolKind, f32)>,

    machine: Point,
    offset: Point,
    inch: bool,
    relative: bool,
    e_relative: bool,
    motion: Option<Motion>,
    /// Feed in mm (axis units) per second.
    feed: Option<f64>,
    /// Current tool value while on.
    tool_on: Option<f32>,

    out: Vec<Located<Command>>,
    warnings: Vec<SourceError>,
    warn_index: Vec<(WarnKey, usize, u64)>,

    // Current line, for locations.
    line: &'t str,
    line_no: u32,
}

impl<'t> Interp<'t> {
    fn new(target: &'t JobTarget, opts: &GcodeOptions) -> Self {
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
        Interp {
            target,
            allow_unknown: opts.allow_unknown,
            letter_axis,
            n_axes: target.axes.len().min(MAX_AXES),
            tolerance,
            tool,
            machine: target.start,
            offset: [0.0; MAX_AXES],
            inch: false,
            relative: false,
            e_relative: false,
            motion: None,
            feed: None,
            tool_on: None,
            out: Vec::new(),
            warnings: Vec::new(),
            warn_index: Vec::new(),
            line: "",
            line_no: 0,
        }
    }

    fn finish(mut self) -> Parsed {
        for &(_, idx, count) in &self.warn_index {
            if count > 0 {
                if let Some(w) = self.warnings.get_mut(idx) {
                    w.message.push_str(&format!(" ({count} more like this)"));
                }
            }
        }
        Parsed {
            commands: self.out,
            warnings: self.warnings,
        }
    }

    fn loc(&self, at: usize) -> SourceLoc {
        SourceLoc {
            line: self.line_no,
            column: column(self.line, at),
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

    fn line(&mut self, line: &'t str, line_no: u32) -> Result<(), SourceError> {
        self.line = line;
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
                    if self.m_word(&mut w, word)? {
                        lx.skip_rest().map_err(|e| self.lex_err(e))?;
                        break;
                    }
                }
                b'T' => match code10(word.text) {
                    Some(c) if c % 10 == 0 && c <= 90 => {
                        self.warn(WarnKey(b'T', 0), word.at, || {
                            format!(
                                "T{} (tool select) ignored: the machine has fixed tools",
                                c / 10
                            )
                        });
                    }
                    _ => {
                        let what = format!(
                            "unsupported tool select T{} (T0..T9 are accepted and ignored)",
                            word.text
                        );
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
                        b'I' => &mut w.i,
                        b'J' => &mut w.j,
                        b'K' => &mut w.k,
                        b'R' => &mut w.r,
                        b'F' => &mut w.f,
                        b'S' => &mut w.s,
                        b'P' => &mut w.p,
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
        let twice = |s: &Self, other: &str| {
            Err(s.error(
                at,
                format!(
                    "{} and {other} on one line: they are in the same modal group",
                    code_name(b'G', code)
                ),
            ))
        };
        match code {
            0 | 10 | 20 | 30 => {
                let m = match code {
                    0 => Motion::Rapid,
                    10 => Motion::Linear,
                    20 => Motion::Cw,
                    _ => Motion::Ccw,
                };
                if let Some((o, _)) = w.motion {
                    return twice(self, o.name());
                }
                w.motion = Some((m, at));
            }
            40 | 280 | 920 => {
                let n = match code {
                    40 => NonModal::Dwell,
                    280 => NonModal::Home,
                    _ => NonModal::SetPosition,
                };
                if let Some((o, _)) = w.nonmodal {
                    return twice(self, o.name());
                }
                w.nonmodal = Some((n, at));
            }
            170 => {
                if w.plane.is_some() {
                    return twice(self, "G17");
                }
                w.plane = Some(at);
            }
            940 => {
                if w.feed_mode.is_some() {
                    return twice(self, "G94");
                }
                w.feed_mode = Some(at);
            }
            200 | 210 => {
                if let Some((inch, _)) = w.units {
                    return twice(self, if inch { "G20" } else { "G21" });
                }
                w.units = Some((code == 200, at));
            }
            900 | 910 => {
                if let Some((rel, _)) = w.distance {
                    return twice(self, if rel { "G91" } else { "G90" });
                }
                w.distance = Some((code == 910, at));
            }
            _ => {
                if let Some(why) = ignored_g(code) {
                    self.warn(WarnKey(b'G', code), at, || {
                        format!("{} {why}", code_name(b'G', code))
                    });
                    return Ok(true);
                }
                let what = format!("unsupported G-code {}", code_name(b'G', code));
                self.unknown(word, what)?;
                w.unknown_g = true;
            }
        }
        Ok(false)
    }

    /// Record an M word. Returns true if the rest of the line is its arguments.
    fn m_word(&mut self, w: &mut Words, word: Word<'_>) -> Result<bool, SourceError> {
        let at = word.at;
        let code = code10(word.text);
        match code {
            Some(c @ (30 | 50)) => {
                if let Some((on, _)) = w.spindle {
                    return Err(self.error(
                        at,
                        format!(
                            "{} and {} on one line: they are in the same modal group",
                            code_name(b'M', c),
                            if on { "M3" } else { "M5" }
                        ),
                    ));
                }
                w.spindle = Some((c == 30, at));
            }
            Some(c @ (820 | 830)) => {
                if let Some((rel, _)) = w.extrusion {
                    return Err(self.error(
                        at,
                        format!(
                            "{} and {} on one line: they are in the same modal group",
                            code_name(b'M', c),
                            if rel { "M83" } else { "M82" }
                        ),
                    ));
                }
                w.extrusion = Some((c == 830, at));
            }
            Some(c) => {
                if let Some(why) = ignored_m(c) {
                    self.warn(WarnKey(b'M', c), at, || {
                        format!("{} {why}", code_name(b'M', c))
                    });
                    return Ok(true);
                }
                self.unknown(word, format!("unsupported M-code {}", code_name(b'M', c)))?;
                return Ok(true);
            }
            None => {
                self.unknown(word, format!("unsupported M-code M{}", word.text))?;
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// Value of a parameter that must have a number (the lexer guarantees it
    /// for non-axis letters).
    fn value(&self, p: Param, letter: char) -> Result<f64, SourceError> {
        p.value
            .ok_or_else(|| self.error(p.at, format!("{letter} without a number")))
    }

    fn length_scale(&self) -> f64 {
        if self.inch {
            INCH
        } else {
            1.0
        }
    }

    fn execute(&mut self, w: &Words) -> Result<(), SourceError> {
        // 1. Modes: units, distance, extrusion.
        if let Some((inch, _)) = w.units {
            self.inch = inch;
        }
        if let Some((rel, _)) = w.distance {
            self.relative = rel;
        }
        if let Some((rel, _)) = w.extrusion {
            self.e_relative = rel;
        }
        let lenient = w.unknown_g;

        // 2. Feed.
        if let Some(p) = w.f {
            let f = self.value(p, 'F')? * self.length_scale() / 60.0;
            if !(f.is_finite() && f > 0.0) {
                return Err(self.error(p.at, "feed rate must be positive"));
            }
            self.feed = Some(f);
        }

        let dwell = matches!(w.nonmodal, Some((NonModal::Dwell, _)));

        // 3. Tool.
        if let Some((on, at)) = w.spindle {
            let Some((tool, kind, on_value)) = self.tool else {
                return Err(self.error(
                    at,
                    format!(
                        "{} needs a tool, and this machine has none",
                        if on { "M3" } else { "M5" }
                    ),
                ));
            };
            let value = if !on {
                0.0
            } else {
                match (kind, w.s) {
                    (_, None) => on_value,
                    (ToolKind::Pen, Some(_)) => 1.0,
                    (_, Some(s)) => power(self.value(s, 'S')?),
                }
            };
            self.tool_on = on.then_some(value);
            self.emit(at, Command::Tool { tool, value });
        } else if let (Some(s), false) = (w.s, dwell) {
            let v = self.value(s, 'S')?;
            match (self.tool, self.tool_on) {
                (Some((tool, kind, _)), Some(cur)) if kind != ToolKind::Pen => {
                    let value = power(v);
                    if value != cur {
                        self.tool_on = Some(value);
                        self.emit(s.at, Command::Tool { tool, value });
                    }
                }
                (Some((_, ToolKind::Pen, _)), Some(_)) => {}
                _ if lenient => {}
                _ => self.warn(WarnKey(b'S', 0), s.at, || {
                    "S without M3 has no effect while the tool is off; put S on the M3 line".into()
                }),
            }
        }

        // 4. Dwell.
        if let Some((NonModal::Dwell, at)) = w.nonmodal {
            // With M3 on the line, S is the tool's; otherwise it is seconds.
            let s = if w.spindle.is_some() { None } else { w.s };
            let seconds = match (w.p, s) {
                (Some(_), Some(s)) => {
                    return Err(
                        self.error(s.at, "G4 takes P (milliseconds) or S (seconds), not both")
                    )
                }
                (Some(p), None) => self.value(p, 'P')? / 1000.0,
                (None, Some(s)) => self.value(s, 'S')?,
                (None, None) => {
                    return Err(self.error(at, "G4 needs P (milliseconds) or S (seconds)"))
                }
            };
            if !(seconds >= 0.0 && seconds.is_finite()) {
                return Err(self.error(at, "dwell time must not be negative"));
            }
            self.emit(at, Command::Dwell { seconds });
        } else if let (Some(p), false) = (w.p, lenient) {
            return Err(self.error(p.at, "P is only used with G4 (dwell) here"));
        }

        // 5. Motion mode.
        if let Some((m, _)) = w.motion {
            self.motion = Some(m);
        }

        // 6. Non-modal codes that use the axis words.
        match w.nonmodal {
            Some((nm @ (NonModal::Home | NonModal::SetPosition), at)) => {
                if let Some((m, _)) = w.motion {
                    if w.any_axis() {
                        return Err(self.error(
                            at,
                            format!(
                                "{} and {} on one line both use the axis words",
                                nm.name(),
                                m.name()
                            ),
                        ));
                    }
                }
                self.check_arc_words_unused(w, lenient)?;
                if nm == NonModal::Home {
                    self.home(w, at)
                } else {
                    self.set_position(w, at)
                }
            }
            _ => self.motion(w),
        }
    }

    fn check_arc_words_unused(&self, w: &Words, lenient: bool) -> Result<(), SourceError> {
        if lenient {
            return Ok(());
        }
        for (p, l) in [(w.i, 'I'), (w.j, 'J'), (w.k, 'K'), (w.r, 'R')] {
            if let Some(p) = p {
                return Err(self.error(p.at, format!("{l} is only used with G2/G3 arcs")));
            }
        }
        Ok(())
    }

    fn home(&mut self, w: &Words, at: usize) -> Result<(), SourceError> {
        let mut target = self.machine;
        if w.any_axis() {
            for (slot, p) in w.axes.iter().enumerate() {
                if let (Some(_), Some(i)) = (p, self.letter_axis[slot]) {
                    target[i] = self.target.start[i];
                    self.offset[i] = 0.0;
                }
            }
        } else {
            let n = self.n_axes;
            target[..n].copy_from_slice(&self.target.start[..n]);
            self.offset[..n].fill(0.0);
        }
        self.warn(WarnKey(b'G', 280), at, || {
            "G28 (home) is simulated as a rapid move to the start position".into()
        });
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
        Ok(())
    }

    fn set_position(&mut self, w: &Words, at: usize) -> Result<(), SourceError> {
        if !w.any_axis() {
            return Err(self.error(at, "G92 needs at least one axis word"));
        }
        for (slot, p) in w.axes.iter().enumerate() {
            if let (Some(p), Some(i)) = (*p, self.letter_axis[slot]) {
                let v = self.value(p, AXIS_LETTERS[slot] as char)? * self.slot_scale(slot);
                let off = self.machine[i] - v;
                if !off.is_finite() {
                    return Err(self.error(p.at, "coordinate out of range"));
                }
                self.offset[i] = off;
            }
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

    /// Machine target from the line's axis words.
    fn axis_target(&self, w: &Words) -> Result<Point, SourceError> {
        let mut t = self.machine;
        for (slot, p) in w.axes.iter().enumerate() {
            if let (Some(p), Some(i)) = (*p, self.letter_axis[slot]) {
                let v = self.value(p, AXIS_LETTERS[slot] as char)? * self.slot_scale(slot);
                let rel = if slot == SLOT_E {
                    self.e_relative
                } else {
                    self.relative
                };
                let m = if rel {
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

    fn motion(&mut self, w: &Words) -> Result<(), SourceError> {
        let arc_words = w.i.is_some() || w.j.is_some() || w.k.is_some() || w.r.is_some();
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
                let target = self.axis_target(w)?;
                let (feed, kind) = if motion == Motion::Rapid {
                    (f64::INFINITY, MoveKind::Rapid)
                } else {
                    (self.need_feed(motion, at)?, MoveKind::Feed)
                };
                if target != self.machine {
                    self.machine = target;
                    self.emit(at, Command::Move(Move { target, feed, kind }));
                }
                Ok(())
            }
            Motion::Cw | Motion::Ccw => {
                if !w.any_axis() && !arc_words {
                    return Ok(());
                }
                let feed = self.need_feed(motion, at)?;
                self.arc(w, motion == Motion::Cw, at, feed)
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

    fn arc(&mut self, w: &Words, clockwise: bool, at: usize, feed: f64) -> Result<(), SourceError> {
        let name = if clockwise { "G2" } else { "G3" };
        let (Some(x), Some(y)) = (self.letter_axis[0], self.letter_axis[1]) else {
            return Err(self.error(
                at,
                format!("{name} needs axes x and y (axes: {})", self.axes_list()),
            ));
        };
        let start = self.machine;
        let end = self.axis_target(w)?;
        let scale = self.length_scale();
        let (sx, sy) = (start[x], start[y]);
        let (ex, ey) = (end[x], end[y]);
        let arc = if let Some(rp) = w.r {
            if let Some(p) = w.i.or(w.j).or(w.k) {
                return Err(self.error(p.at, format!("{name} takes either R or I/J, not both")));
            }
            let r = self.value(rp, 'R')? * scale;
            let (dx, dy) = (ex - sx, ey - sy);
            let d2 = dx * dx + dy * dy;
            let d = d2.sqrt();
            if d == 0.0 {
                return Err(self.error(
                    rp.at,
                    format!("{name} in R form needs an end point different from the start (use I/J for a full circle)"),
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
            if w.i.is_none() && w.j.is_none() {
                return Err(self.error(
                    at,
                    format!("{name} needs I/J (centre offset) or R (radius)"),
                ));
            }
            let i = match w.i {
                Some(p) => self.value(p, 'I')? * scale,
                None => 0.0,
            };
            let j = match w.j {
                Some(p) => self.value(p, 'J')? * scale,
                None => 0.0,
            };
            let arc = Arc {
                start,
                end,
                center: [sx + i, sy + j],
                x,
                y,
                clockwise,
                full: (ex - sx).hypot(ey - sy) <= 1e-9 * (1.0 + sx.abs().max(sy.abs())),
            };
            let (r0, r1) = arc.radii();
            if !r0.is_finite() || r0 <= 0.0 {
                return Err(self.error(at, format!("{name} radius is zero (I and J are both 0)")));
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
        let mut out = core::mem::take(&mut self.out);
        let loc = self.loc(at);
        let res = arc.flatten(tol, |target| {
            out.push(Located {
                loc,
                item: Command::Move(Move {
                    target,
                    feed,
                    kind: MoveKind::Feed,
                }),
            });
        });
        self.out = out;
        res.map_err(|m| self.error(at, m))?;
        self.machine = end;
        Ok(())
    }
}

/// Laser/spindle power from an S word, grbl `$30=1000`.
fn power(s: f64) -> f32 {
    ((s / 1000.0).clamp(0.0, 1.0)) as f32
}
