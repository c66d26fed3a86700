//! The Stepdance motion-stream wire encoding: several axes on one step/direction
//! pair, multiplexed by pulse width inside one 40 µs frame.
//!
//! * Six signal codes, X=0, Y=1, R=2, T=3 (θ), Z=4, E=5; the step pulse of code
//!   `c` is `c + 2` µs wide (X 2 µs … E 7 µs).
//! * Active signals are packed in code order inside a 32 µs window, with 2 µs
//!   gaps between pulses. The first pulse rises at 1 µs so that the direction
//!   line can lead it by 1 µs. A signal whose pulse would end past the window
//!   is dropped (with all six active, E does not fit).
//! * For a forward step the direction line is high from 1 µs before the pulse
//!   rises to 1 µs after it falls; for a reverse step it stays low. (Two
//!   forward pulses in a row leave it high across the 2 µs gap.)
//! * The receiver measures each step pulse (rising to falling edge), rounds to
//!   the nearest µs, subtracts 2 to get the code, and samples direction at the
//!   falling edge.
//!
//! Lines are modelled at 1 µs resolution: `step[i]` is the level during
//! `[i, i + 1)` µs of the frame.

use heapless::Vec;

/// Frame length, µs.
pub const FRAME_US: usize = 40;
/// Pulses must end within this many µs of the frame start.
pub const WINDOW_US: usize = 32;
/// Gap between consecutive pulses, µs.
pub const GAP_US: usize = 2;
/// When the first pulse rises, µs (the direction lead).
pub const FIRST_PULSE_US: usize = 1;
/// Number of signal codes.
pub const CODES: usize = 6;

/// The six signal codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Signal {
    /// The x axis: a 2 µs pulse.
    X = 0,
    /// The y axis: a 3 µs pulse.
    Y = 1,
    /// The radius of a polar pair: a 4 µs pulse.
    R = 2,
    /// The angle θ of a polar pair: a 5 µs pulse.
    T = 3,
    /// The z axis: a 6 µs pulse.
    Z = 4,
    /// The extruder (or a seventh axis): a 7 µs pulse, dropped when all six are active.
    E = 5,
}

/// Step pulse width of a code, µs.
pub const fn pulse_width(code: u8) -> usize {
    code as usize + 2
}

/// The steps carried by one frame: bit `c` of `active` is set when code `c`
/// steps, bit `c` of `forward` gives its direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Signals {
    /// Bit `c` set: code `c` steps this frame.
    pub active: u8,
    /// Bit `c` set: code `c` steps forward (meaningful only where `active` is set).
    pub forward: u8,
}

impl Signals {
    /// No code steps.
    pub const NONE: Signals = Signals {
        active: 0,
        forward: 0,
    };

    /// Code `c` steps, forward or back (a second call for the same code replaces the first).
    pub fn set(&mut self, code: u8, forward: bool) {
        let bit = 1u8 << code;
        self.active |= bit;
        if forward {
            self.forward |= bit;
        } else {
            self.forward &= !bit;
        }
    }

    /// `Some(forward)` when `code` steps.
    pub fn get(&self, code: u8) -> Option<bool> {
        let bit = 1u8 << code;
        (self.active & bit != 0).then_some(self.forward & bit != 0)
    }

    /// Only the bits of `mask`.
    pub fn masked(&self, mask: u8) -> Signals {
        Signals {
            active: self.active & mask,
            forward: self.forward & self.active & mask,
        }
    }
}

/// Step and direction lines over one frame at 1 µs resolution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lines {
    /// The step line's level in each µs of the frame.
    pub step: [bool; FRAME_US],
    /// The direction line's level in each µs of the frame.
    pub dir: [bool; FRAME_US],
}

impl Default for Lines {
    fn default() -> Self {
        Lines {
            step: [false; FRAME_US],
            dir: [false; FRAME_US],
        }
    }
}

/// An encoded frame: the lines, what was sent and which codes were dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Encoded {
    /// The lines to drive.
    pub lines: Lines,
    /// The codes that fit the window: what the receiver will decode.
    pub sent: Signals,
    /// Bit `c` set when code `c` was active but did not fit the window.
    pub dropped: u8,
}

/// Encodes one frame.
pub fn encode(signals: Signals) -> Encoded {
    let mut lines = Lines::default();
    let mut sent = Signals::NONE;
    let mut dropped = 0u8;
    let mut t = FIRST_PULSE_US;
    for code in 0..CODES as u8 {
        let Some(forward) = signals.get(code) else {
            continue;
        };
        let w = pulse_width(code);
        if t + w > WINDOW_US {
            dropped |= 1 << code;
            continue;
        }
        lines.step[t..t + w].fill(true);
        if forward {
            lines.dir[t - 1..t + w + 1].fill(true);
        }
        sent.set(code, forward);
        t += w + GAP_US;
    }
    Encoded {
        lines,
        sent,
        dropped,
    }
}

/// Decodes one frame of lines. Pulses of a width that is no code are ignored,
/// as is a pulse still high at the frame's end.
pub fn decode(lines: &Lines) -> Signals {
    let mut out = Signals::NONE;
    let mut rise: Option<usize> = None;
    for i in 0..FRAME_US {
        let prev = i > 0 && lines.step[i - 1];
        match (prev, lines.step[i]) {
            (false, true) => rise = Some(i),
            (true, false) => {
                if let Some(r) = rise.take() {
                    // Direction sampled at the falling edge.
                    accept(&mut out, (i - r) as f64, lines.dir[i]);
                }
            }
            _ => {}
        }
    }
    out
}

fn accept(out: &mut Signals, width_us: f64, dir: bool) {
    let w = crate::graph::math::round(width_us) as i64;
    let code = w - 2;
    if (0..CODES as i64).contains(&code) {
        out.set(code as u8, dir);
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
/// One of the two lines of a motion stream.
pub enum Line {
    /// The step line: pulse widths carry the codes.
    Step,
    /// The direction line: high around a forward step's pulse.
    Dir,
}

/// A level change on a line at `t_us` from the frame start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edge {
    /// When the level changes, µs from the frame start.
    pub t_us: f64,
    /// Which line changes.
    pub line: Line,
    /// Low to high (true) or high to low.
    pub rising: bool,
}

/// The edges of a frame's lines, in time order (both lines start low).
pub fn edges(lines: &Lines) -> Vec<Edge, 48> {
    let mut out = Vec::new();
    let (mut s, mut d) = (false, false);
    for i in 0..=FRAME_US {
        let (ns, nd) = if i < FRAME_US {
            (lines.step[i], lines.dir[i])
        } else {
            (false, false)
        };
        if nd != d {
            let _ = out.push(Edge {
                t_us: i as f64,
                line: Line::Dir,
                rising: nd,
            });
        }
        if ns != s {
            let _ = out.push(Edge {
                t_us: i as f64,
                line: Line::Step,
                rising: ns,
            });
        }
        s = ns;
        d = nd;
    }
    out
}

/// Decodes edges with measured (jittered) times, sorted by time: widths are
/// rounded to the nearest µs.
pub fn decode_edges(edges: &[Edge]) -> Signals {
    let mut out = Signals::NONE;
    let mut dir = false;
    let mut rise: Option<f64> = None;
    for e in edges {
        match (e.line, e.rising) {
            (Line::Dir, level) => dir = level,
            (Line::Step, true) => rise = Some(e.t_us),
            (Line::Step, false) => {
                if let Some(r) = rise.take() {
                    accept(&mut out, e.t_us - r, dir);
                }
            }
        }
    }
    out
}
