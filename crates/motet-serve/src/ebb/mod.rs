//! An EiBotBoard (EBB) device on top of the session: the AxiDraw software
//! and other programs built on the `plotink` library connect over a
//! pseudo-terminal or TCP and plot on the motet machine as they would on an
//! AxiDraw (docs/compat.md).
//!
//! Bytes come in through [`Ebb::receive`] and are cut into lines at `\r`
//! ([`parse`]); [`Ebb::poll`] answers them in order, each with exactly the
//! board's reply ([`reply`]). Motion (`SM`, `XM`, `LM`, `LT`, `T3`, `HM`;
//! rate moves timed by [`ramp`])
//! and the pen (`SP`, `TP`) go into the session's stream as moves on the
//! AxiDraw's step geometry mapped to the machine's own axes ([`motion`]);
//! a line the machine cannot take yet (the stream queue is full) waits,
//! and the port stops reading, so nothing is lost. Queries read the
//! session (`queries.rs`).

mod commands;
pub mod motion;
pub mod parse;
mod queries;
pub mod ramp;
pub mod reply;

use crate::device::{port::Port, Device};
use crate::server::Server;
use crate::session::{Session, State};
use motet_host::Machine;
use motet_trajectory::Point;
use reply::{EbbError, Syntax};
use std::collections::{BTreeMap, VecDeque};

/// The version line (the `V` query): plotink checks for "EBB" and reads
/// the number after "Firmware Version " (the AxiDraw software needs 3.0.2
/// or newer).
pub const VERSION: &str = "EBBv13_and_above EB Firmware Version 3.0.3";
/// Who the session sees acting.
pub const CLIENT: Option<&str> = Some("ebb");
/// Longest command line the board takes, bytes.
const MAX_LINE: usize = 255;
/// Complete lines kept waiting before the port stops reading.
const MAX_LINES: usize = 8;

/// What became of a line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Step {
    /// Answered: the reply's bytes.
    Reply(String),
    /// Not yet: the line stays first in the queue.
    Wait,
}

/// One connected program's EiBotBoard.
pub struct Ebb {
    x: usize,
    y: usize,
    pen: Option<u8>,
    /// A line being received (`None` once it overflowed).
    partial: Option<Vec<u8>>,
    lines: VecDeque<Result<String, EbbError>>,
    out: Vec<u8>,
    syntax: Syntax,
    steps: motion::Steps,
    /// The accumulators a motion command leaves, kept once it is queued.
    next_accum: Option<[i64; 2]>,
    /// The machine point of step count zero (set at the first motion).
    origin: Option<Point>,
    pen_up: bool,
    servo: BTreeMap<i64, i64>,
    servo_timeout_ms: i64,
    servo_power: bool,
    vars: [u8; 32],
    pins: BTreeMap<(char, i64), i64>,
    motors: [i64; 2],
    nickname: String,
    /// The pause "button": the session was held by another client.
    button: bool,
    was_held: bool,
    /// `ES` stopped the machine: it is unlocked once at rest, as the
    /// board goes on taking commands after an emergency stop.
    after_es: bool,
    /// Commands answered so far (for tests and figures).
    pub replies: u64,
}

impl Ebb {
    /// A board for `machine`: moves on its `x` and `y` axes, the pen on its
    /// first pen tool (else its first tool).
    pub fn new(machine: &Machine) -> Ebb {
        let pen = machine
            .tools
            .iter()
            .position(|t| t.kind == motet_planner::ToolKind::Pen)
            .or(if machine.tools.is_empty() {
                None
            } else {
                Some(0)
            })
            .and_then(|i| u8::try_from(i).ok());
        Ebb {
            x: machine.axis("x").unwrap_or(0),
            y: machine.axis("y").unwrap_or(1),
            pen,
            partial: Some(Vec::new()),
            lines: VecDeque::new(),
            out: Vec::new(),
            syntax: Syntax::Legacy,
            steps: motion::Steps::new(),
            next_accum: None,
            origin: None,
            pen_up: true,
            servo: BTreeMap::new(),
            servo_timeout_ms: 60_000,
            servo_power: true,
            vars: [0; 32],
            pins: BTreeMap::new(),
            motors: [0, 0],
            nickname: String::new(),
            button: false,
            was_held: false,
            after_es: false,
            replies: 0,
        }
    }

    /// Bytes from the program: complete lines wait for [`Ebb::poll`].
    pub fn receive(&mut self, bytes: &[u8], _s: &mut Session) {
        for &b in bytes {
            match b {
                b'\r' => {
                    let line = match self.partial.replace(Vec::new()) {
                        Some(l) => Ok(String::from_utf8_lossy(&l).trim().to_string()),
                        None => Err(EbbError::RxOverrun),
                    };
                    self.lines.push_back(line);
                }
                // The board ends lines at `\r`; `\n` and NUL are noise.
                b'\n' | 0 => {}
                _ => match &mut self.partial {
                    Some(l) if l.len() < MAX_LINE => l.push(b),
                    _ => self.partial = None,
                },
            }
        }
    }

    /// Answers the lines the machine can take now, in order.
    pub fn poll(&mut self, s: &mut Session) {
        self.watch(s);
        while let Some(line) = self.lines.front().cloned() {
            let step = match line {
                Err(e) => Step::Reply(self.syntax.error("", &e)),
                Ok(t) if t.is_empty() => Step::Reply(String::new()),
                Ok(t) => match parse::split(&t) {
                    // Only an unknown name fails here: it heads the error.
                    Err(e) => {
                        let name = match &e {
                            EbbError::Unknown(n) => n.clone(),
                            _ => String::new(),
                        };
                        Step::Reply(self.syntax.error(&name, &e))
                    }
                    Ok(l) => match self.command(&l, s) {
                        Ok(step) => step,
                        Err(e) => Step::Reply(self.syntax.error(&l.name, &e)),
                    },
                },
            };
            match step {
                Step::Wait => break,
                Step::Reply(r) => {
                    self.lines.pop_front();
                    self.replies += 1;
                    self.out.extend_from_slice(r.as_bytes());
                }
            }
        }
    }

    /// What to send to the program, taken.
    pub fn take_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.out)
    }

    /// Whether the port should read more: false while lines wait for the
    /// machine (the stream queue is full).
    pub fn wants_input(&self) -> bool {
        self.lines.len() < MAX_LINES
    }

    /// Whether a complete line waits for an answer.
    pub fn has_line(&self) -> bool {
        !self.lines.is_empty()
    }

    /// The session seen between lines: a hold by another client presses
    /// the pause button; an `ES` stop is unlocked once at rest.
    fn watch(&mut self, s: &mut Session) {
        let held = matches!(s.state(), State::Holding | State::Paused) && s.streaming();
        if held && !self.was_held {
            self.button = true;
        }
        self.was_held = held;
        if self.after_es && s.state() == State::Stopped {
            let _ = s.unlock();
        }
        if self.after_es && s.state() == State::Idle {
            self.after_es = false;
            // Moves were cut short: the counters say where the motors are.
            if let Some(o) = self.origin {
                let r = s.rest();
                self.steps
                    .settle_at(r[self.x] - o[self.x], r[self.y] - o[self.y]);
            }
        }
    }
}

impl Device for Ebb {
    fn open(&mut self) {}
    fn receive(&mut self, bytes: &[u8], s: &mut Session) {
        Ebb::receive(self, bytes, s)
    }
    fn poll(&mut self, s: &mut Session) {
        Ebb::poll(self, s)
    }
    fn take_output(&mut self) -> Vec<u8> {
        Ebb::take_output(self)
    }
    fn wants_input(&self) -> bool {
        Ebb::wants_input(self)
    }
}

impl Server {
    /// Opens an EiBotBoard device on `port` for this server's session;
    /// returns where programs connect (the pty's path, or
    /// `tcp:ADDRESS:PORT`).
    pub fn ebb(&self, port: &Port) -> std::io::Result<String> {
        let machine = self.shared.machine.as_ref().clone();
        self.device("ebb", port, move || Ebb::new(&machine))
    }
}
