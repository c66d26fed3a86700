//! A grbl 1.1 device on top of the session: senders (CNCjs, Universal
//! G-code Sender, bCNC, gSender) connect over a pseudo-terminal or TCP and
//! drive the machine as they would a grbl board (docs/compat.md).
//!
//! Bytes come in through [`Grbl::receive`]: real-time bytes act at once;
//! the rest fill a 128-byte receive buffer ([`lines`]). [`Grbl::poll`]
//! takes complete lines out in order, each answered by exactly one `ok` or
//! `error:N`; a line the machine cannot take yet (the planner queue is full,
//! a jog still runs) stays in the buffer, its bytes counted, so a sender
//! counting characters waits. G-code goes through motet's own interpreter
//! (work coordinates, offsets, arcs) into the session's stream
//! ([`crate::session::Session::stream_push`]).

pub mod axes;
pub mod errors;
mod gcode;
mod jog;
pub mod lines;
pub mod realtime;
pub mod settings;
pub mod status;
mod system;

use crate::device::gcode::new_interpreter;
use crate::device::{port::Port, Device};
use crate::server::Server;
use crate::session::{Session, State};
use axes::Axes;
use errors::{alarm, code};
use lines::{Line, RxBuffer};
use motet_gcode::Interpreter;
use motet_host::Machine;
use realtime::{classify, ignored, Overrides, Realtime};
use settings::Local;

/// The welcome line, as grbl 1.1h prints it (senders look for it).
pub const WELCOME: &str = "Grbl 1.1h ['$' for help]";
/// Who the session sees acting.
pub const CLIENT: Option<&str> = Some("grbl");

/// What became of a line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Step {
    /// Answered: `ok` or `error:N`.
    Reply(Result<(), u8>),
    /// Not yet: the line stays in the buffer.
    Wait,
}

/// One connected sender's grbl device.
pub struct Grbl {
    file: Machine,
    axes: Axes,
    rx: RxBuffer,
    out: Vec<u8>,
    interp: Interpreter,
    line_no: u32,
    local: Local,
    overrides: Overrides,
    check_mode: bool,
    startup: [String; 2],
    /// A `$H` move runs; its `ok` comes when it ends.
    homing: bool,
    /// An `M0` line's motion before the pause was queued; its `ok` comes
    /// when the machine has run it and rests.
    pausing: bool,
    /// Stopped by `M0`: lines wait until `~`.
    program_paused: bool,
    /// Tool power last streamed, 0..=1.
    tool: f64,
    /// Lines answered so far (for tests and figures).
    pub replies: u64,
}

impl Grbl {
    /// A device for `machine` (the machine file as loaded: the limits a
    /// sender may go back up to).
    pub fn new(machine: &Machine) -> Grbl {
        Grbl {
            file: machine.clone(),
            axes: Axes::of(machine),
            rx: RxBuffer::default(),
            out: Vec::new(),
            interp: new_interpreter(machine),
            line_no: 0,
            local: Local::default(),
            overrides: Overrides::default(),
            check_mode: false,
            startup: Default::default(),
            homing: false,
            pausing: false,
            program_paused: false,
            tool: 0.0,
            replies: 0,
        }
    }

    /// The welcome, as on power-up or a new connection.
    pub fn open(&mut self) {
        self.push_line("");
        self.push_line(WELCOME);
    }

    /// Bytes from the sender: real-time bytes act now, the others wait in
    /// the receive buffer for [`Grbl::poll`].
    pub fn receive(&mut self, bytes: &[u8], s: &mut Session) {
        for &b in bytes {
            if let Some(r) = classify(b) {
                self.realtime(r, s);
            } else if !ignored(b) {
                self.rx.push(b);
            }
        }
    }

    /// Answers the complete lines the machine can take now, in order.
    pub fn poll(&mut self, s: &mut Session) {
        while let Some(line) = self.rx.peek() {
            let step = match line {
                Line::TooLong => Step::Reply(Err(code::OVERFLOW)),
                Line::Text(t) => self.line(&t, s),
            };
            match step {
                Step::Wait => break,
                Step::Reply(r) => {
                    self.rx.pop();
                    self.replies += 1;
                    match r {
                        Ok(()) => self.push_line("ok"),
                        Err(n) => self.push_line(&format!("error:{n}")),
                    }
                }
            }
        }
    }

    /// What to send to the sender, taken.
    pub fn take_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.out)
    }

    /// Whether the port should read more bytes: false while a sender that
    /// does not count characters has filled [`lines::MAX_KEPT`].
    pub fn wants_input(&self) -> bool {
        self.rx.has_room()
    }

    /// Whether a complete line waits in the receive buffer.
    pub fn has_line(&self) -> bool {
        self.rx.peek().is_some()
    }

    /// Room left in the receive buffer, bytes.
    pub fn rx_free(&self) -> usize {
        self.rx.free()
    }

    fn push_line(&mut self, l: &str) {
        self.out.extend_from_slice(l.as_bytes());
        self.out.extend_from_slice(b"\r\n");
    }

    fn message(&mut self, m: &str) {
        // `]` would end the message early in a sender's parser.
        let m = m.replace(']', ")");
        self.push_line(&format!("[MSG:{m}]"));
    }

    fn realtime(&mut self, r: Realtime, s: &mut Session) {
        match r {
            Realtime::Status => {
                let line = status::report(
                    s,
                    &status::Report {
                        axes: &self.axes,
                        local: &self.local,
                        overrides: &self.overrides,
                        wco: self.interp.modal().offset,
                        tool: self.tool,
                        check_mode: self.check_mode,
                        program_paused: self.program_paused,
                        rx_free: self.rx.free(),
                    },
                );
                self.push_line(&line);
            }
            Realtime::Hold | Realtime::Door => {
                // grbl cancels a jog on a hold; anything else brakes on
                // its path and waits for `~`.
                let _ = if s.jogging() {
                    s.cancel(CLIENT)
                } else {
                    s.pause(CLIENT)
                };
            }
            Realtime::Resume => {
                if self.program_paused {
                    self.program_paused = false;
                } else if s.state() == State::Paused {
                    let _ = s.resume(CLIENT);
                }
            }
            Realtime::JogCancel => {
                if s.jogging() {
                    let _ = s.cancel(CLIENT);
                }
            }
            Realtime::Reset => self.reset(s),
            Realtime::Feed(_) | Realtime::Rapid(_) | Realtime::Spindle(_) => {
                // Applied live: to every queued line not yet planned, as
                // well as to lines still to come.
                let old = self.overrides;
                self.overrides.apply(r);
                let new = self.overrides;
                if new != old {
                    let slowest = gcode::slowest_path_axis(&self.file);
                    s.stream_adjust(&mut |c| gcode::overridden(c, old, new, slowest));
                }
            }
            Realtime::Toggle => {}
        }
    }

    /// Soft reset: whatever moves brakes on its tail (an alarm, as in grbl,
    /// since the motion was cut short), queued lines and the receive buffer
    /// are dropped, the G-code state starts again (work offsets kept).
    fn reset(&mut self, s: &mut Session) {
        let moving = matches!(s.state(), State::Running | State::Holding | State::Stopping);
        if moving {
            s.estop();
            self.push_line(&format!("ALARM:{}", alarm::ABORT_CYCLE));
        } else {
            s.stream_clear();
        }
        self.rx.clear();
        self.check_mode = false;
        self.homing = false;
        self.pausing = false;
        self.program_paused = false;
        self.overrides = Overrides::default();
        self.restart_interpreter();
        self.open();
        if matches!(s.state(), State::Alarm | State::Stopped) {
            self.message("'$H'|'$X' to unlock");
        }
    }

    /// A fresh G-code state keeping the work offsets (grbl keeps them in
    /// its EEPROM): they are set again through the interpreter itself.
    fn restart_interpreter(&mut self) {
        let wcs = self.interp.modal().work_offsets;
        self.interp = new_interpreter(&self.file);
        for (k, o) in wcs.iter().enumerate() {
            if o.iter().all(|v| *v == 0.0) {
                continue;
            }
            let words: String = self
                .axes
                .map
                .iter()
                .zip(&self.axes.letters)
                .filter_map(|(m, l)| m.map(|i| format!(" {l}{}", o[i])))
                .collect();
            let _ = self.interp.line(&format!("G10 L2 P{}{words}", k + 1), 0);
            self.interp.drain();
        }
    }

    fn line(&mut self, text: &str, s: &mut Session) -> Step {
        let t = text.trim();
        if t.is_empty() {
            return Step::Reply(Ok(()));
        }
        if t.starts_with('$') {
            return self.system(t, s);
        }
        self.gcode(t, s)
    }
}

impl Device for Grbl {
    fn open(&mut self) {
        Grbl::open(self)
    }
    fn receive(&mut self, bytes: &[u8], s: &mut Session) {
        Grbl::receive(self, bytes, s)
    }
    fn poll(&mut self, s: &mut Session) {
        Grbl::poll(self, s)
    }
    fn take_output(&mut self) -> Vec<u8> {
        Grbl::take_output(self)
    }
    fn wants_input(&self) -> bool {
        Grbl::wants_input(self)
    }
}

impl Server {
    /// Opens a grbl device on `port` for this server's session; returns
    /// where senders connect (the pty's path, or `tcp:ADDRESS:PORT`).
    pub fn grbl(&self, port: &Port) -> std::io::Result<String> {
        let machine = self.shared.machine.as_ref().clone();
        self.device("grbl", port, move || Grbl::new(&machine))
    }
}
