//! A Marlin-style printer on top of the session: print hosts (OctoPrint,
//! slicers' print hosts) connect over a pseudo-terminal or TCP and print by
//! streaming G-code as they would to a Marlin board (docs/compat.md).
//!
//! Lines are framed as Marlin frames them ([`frame`]: line numbers,
//! checksums, `Resend:`), queued a few at a time (Marlin's BUFSIZE), and
//! answered in order with one `ok` each. A line's `ok` is held while the
//! machine cannot take it yet (the stream's queue is full), while `M400`
//! or a heating wait (`M109`, `M190`) waits for the motion before it, and
//! while the heater comes to temperature; meanwhile `echo:busy:
//! processing` goes out every couple of seconds, and temperatures every
//! second during a heating wait, as Marlin does. Temperatures come from
//! the session's heaters ([`crate::session::HeaterState`]). `M108`,
//! `M112` and `M410` act as soon as they arrive (Marlin's emergency
//! parser). There is no SD card: hosts print by streaming.

mod commands;
pub mod frame;
pub mod report;

use crate::device::gcode::new_interpreter;
use crate::device::{port::Port, Device};
use crate::server::Server;
use crate::session::Session;
use frame::{FrameError, Framer};
use motet_gcode::Interpreter;
use motet_host::Machine;
use std::collections::VecDeque;

/// Who the session sees acting.
pub const CLIENT: Option<&str> = Some("marlin");
/// Commands queued before the port stops reading (Marlin's BUFSIZE).
pub const BUFSIZE: usize = 4;
/// Keep-alive interval while a line's `ok` is held, µs (`M113` changes it).
pub const BUSY_INTERVAL_US: u64 = 2_000_000;
/// Temperature lines during a heating wait, µs apart.
pub const WAIT_REPORT_US: u64 = 1_000_000;

/// One connected host's printer.
pub struct Marlin {
    file: Machine,
    framer: Framer,
    /// Bytes of the line being received.
    partial: Vec<u8>,
    /// Framed commands waiting their turn.
    queue: VecDeque<String>,
    out: Vec<u8>,
    interp: Interpreter,
    line_no: u32,
    /// The command whose `ok` is held, and what it waits for.
    held: Option<commands::Held>,
    /// `M155 S<n>`: temperatures every this many µs (0: off), next at.
    auto_temp: (u64, u64),
    busy_us: u64,
    /// `M108` came: a heating wait ends.
    cancel_wait: bool,
    /// Commands answered so far (for tests and figures).
    pub replies: u64,
}

impl Marlin {
    /// A device for `machine` (the machine file as loaded).
    pub fn new(machine: &Machine) -> Marlin {
        Marlin {
            file: machine.clone(),
            framer: Framer::default(),
            partial: Vec::new(),
            queue: VecDeque::new(),
            out: Vec::new(),
            interp: new_interpreter(machine),
            line_no: 0,
            held: None,
            auto_temp: (0, 0),
            busy_us: BUSY_INTERVAL_US,
            cancel_wait: false,
            replies: 0,
        }
    }

    /// As a board that has just started.
    pub fn open(&mut self) {
        self.push_line("start");
        self.push_line("echo: motet Marlin-style printer, no SD card");
    }

    /// Bytes from the host: complete lines are framed (errors answered at
    /// once with `Resend:`, as Marlin does while reading its serial port),
    /// emergency commands act now, the rest wait their turn.
    pub fn receive(&mut self, bytes: &[u8], s: &mut Session) {
        for &b in bytes {
            if b != b'\n' && b != b'\r' {
                // A runaway line is cut: the framer refuses it as too long.
                if self.partial.len() <= frame::MAX_LINE {
                    self.partial.push(b);
                }
                continue;
            }
            let raw = String::from_utf8_lossy(&std::mem::take(&mut self.partial)).into_owned();
            match self.framer.frame(&raw) {
                Ok(None) => {}
                Ok(Some(cmd)) => {
                    if !self.emergency(&cmd, s) {
                        self.queue.push_back(cmd);
                    }
                }
                Err(e) => self.refuse(&e),
            }
        }
    }

    /// Answers the queued commands as far as the machine allows now; sends
    /// keep-alives and temperature reports that are due.
    pub fn poll(&mut self, s: &mut Session) {
        let now = s.now_us();
        let (every, next) = self.auto_temp;
        if every > 0 && now >= next {
            self.auto_temp.1 = now + every;
            let t = report::temperatures(s.heaters());
            if !t.is_empty() {
                self.push_line(&format!(" {t}"));
            }
        }
        loop {
            if let Some(h) = self.held.take() {
                match self.advance(h, now, s) {
                    Ok(reply) => self.answer(reply),
                    Err(h) => {
                        self.held = Some(h);
                        self.keep_alive(now, s);
                        return;
                    }
                }
            }
            let Some(cmd) = self.queue.pop_front() else {
                return;
            };
            match self.command(&cmd, now, s) {
                commands::Outcome::Reply(r) => self.answer(r),
                commands::Outcome::Hold(h) => self.held = Some(h),
            }
        }
    }

    /// What to send to the host, taken.
    pub fn take_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.out)
    }

    /// Whether the port should read more: false once [`BUFSIZE`] commands
    /// wait, so the host's writes block.
    pub fn wants_input(&self) -> bool {
        self.queue.len() < BUFSIZE
    }

    /// Whether a command waits or is held.
    pub fn busy(&self) -> bool {
        self.held.is_some() || !self.queue.is_empty()
    }

    /// The last line number accepted.
    pub fn last_line(&self) -> u32 {
        self.framer.last
    }

    fn refuse(&mut self, e: &FrameError) {
        self.push_line(&format!("Error:{e}"));
        if e.resend() {
            self.push_line(&format!("Resend: {}", self.framer.last.wrapping_add(1)));
        }
        self.push_line("ok");
    }

    fn answer(&mut self, r: commands::Reply) {
        for l in &r.lines {
            self.push_line(l);
        }
        match r.ok_tail {
            Some(t) if !t.is_empty() => self.push_line(&format!("ok {t}")),
            _ => self.push_line("ok"),
        }
        self.replies += 1;
    }

    fn keep_alive(&mut self, now: u64, s: &Session) {
        let Some(h) = self.held.as_mut() else { return };
        let mut lines = Vec::new();
        if self.busy_us > 0 && now >= h.last_busy + self.busy_us {
            h.last_busy = now;
            lines.push("echo:busy: processing".to_string());
        }
        if h.heating() && now >= h.last_report + WAIT_REPORT_US {
            h.last_report = now;
            lines.push(format!("{} W:?", report::temperatures(s.heaters())));
        }
        for l in lines {
            self.push_line(&l);
        }
    }

    fn push_line(&mut self, l: &str) {
        self.out.extend_from_slice(l.as_bytes());
        self.out.push(b'\n');
    }
}

impl Device for Marlin {
    fn open(&mut self) {
        Marlin::open(self)
    }
    fn receive(&mut self, bytes: &[u8], s: &mut Session) {
        Marlin::receive(self, bytes, s)
    }
    fn poll(&mut self, s: &mut Session) {
        Marlin::poll(self, s)
    }
    fn take_output(&mut self) -> Vec<u8> {
        Marlin::take_output(self)
    }
    fn wants_input(&self) -> bool {
        Marlin::wants_input(self)
    }
}

impl Server {
    /// Opens a Marlin-style printer on `port` for this server's session;
    /// returns where hosts connect (the pty's path, or `tcp:ADDRESS:PORT`).
    pub fn marlin(&self, port: &Port) -> std::io::Result<String> {
        let machine = self.shared.machine.as_ref().clone();
        self.device("marlin", port, move || Marlin::new(&machine))
    }
}
