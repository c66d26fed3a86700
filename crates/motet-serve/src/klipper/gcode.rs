//! `gcode/script`: each line of a script in order, as Klipper runs them.
//! Traditional G-code (`G1 X10`, `M400`) goes through motet's interpreter
//! into the session's stream ([`Session::stream_push`]); Klipper's extended
//! commands (`SDCARD_PRINT_FILE FILENAME=…`, `PAUSE`, `RESUME`,
//! `CANCEL_PRINT`, `FIRMWARE_RESTART`…) act on the session. A line the
//! machine cannot take yet (the queue is full) waits, and so does the
//! request, as in Klipper.

use super::print::{load, Loaded};
use super::{Klipper, CLIENT};
use crate::device::gcode::{follow_rest, gate, Gate};
use crate::session::{Session, State};
use motet_planner::{Command, Located};

/// What became of a line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Step {
    /// Run (or refused: why, as Klipper's error message).
    Done(Result<(), String>),
    /// Not yet: the line stays first.
    Wait,
}

/// A line's command word, upper case: `G1`, `M112`, `SDCARD_PRINT_FILE`.
pub fn command_word(line: &str) -> String {
    let t = line.trim_start();
    let end = t
        .find(|c: char| c.is_whitespace() || c == ';')
        .unwrap_or(t.len());
    let w = &t[..end];
    // `G1X10`: traditional G-code needs no space after the number.
    let b = w.as_bytes();
    if b.len() >= 2 && b[0].is_ascii_alphabetic() && (b[1].is_ascii_digit() || b[1] == b'.') {
        let n = b[1..]
            .iter()
            .take_while(|c| c.is_ascii_digit() || **c == b'.')
            .count();
        return w[..1 + n].to_ascii_uppercase();
    }
    w.to_ascii_uppercase()
}

/// Whether `word` is traditional G-code (a letter and a number).
fn traditional(word: &str) -> bool {
    let b = word.as_bytes();
    b.len() >= 2
        && b[0].is_ascii_alphabetic()
        && b[1..].iter().all(|c| c.is_ascii_digit() || *c == b'.')
}

/// The value of `KEY=value` (or `KEY="quoted value"`) in an extended
/// command's parameters; keys compare without case.
pub fn param(line: &str, key: &str) -> Option<String> {
    let t = line.trim();
    let rest = t.split_once(char::is_whitespace)?.1;
    let mut s = rest.trim_start();
    while !s.is_empty() {
        let (k, after) = s.split_once('=')?;
        let k = k.trim();
        let after = after.trim_start();
        let (v, next) = if let Some(q) = after.strip_prefix('"') {
            // A quote inside is escaped as \" (as a printer host sends it).
            let mut end = None;
            let mut esc = false;
            for (i, c) in q.char_indices() {
                match c {
                    '\\' if !esc => esc = true,
                    '"' if !esc => {
                        end = Some(i);
                        break;
                    }
                    _ => esc = false,
                }
            }
            let end = end?;
            (q[..end].replace("\\\"", "\""), &q[end + 1..])
        } else {
            let end = after.find(char::is_whitespace).unwrap_or(after.len());
            (after[..end].to_string(), &after[end..])
        };
        if k.eq_ignore_ascii_case(key) {
            return Some(v);
        }
        s = next.trim_start();
    }
    None
}

impl Klipper {
    /// Runs one line of a script as far as the machine allows now.
    pub(crate) fn line(&mut self, line: &str, s: &mut Session) -> Step {
        let word = command_word(line);
        match word.as_str() {
            "" => Step::Done(Ok(())),
            "M112" => {
                s.estop();
                Step::Done(Ok(()))
            }
            "SDCARD_PRINT_FILE" => self.print_file(line, s),
            "PAUSE" => done(s.pause(CLIENT)),
            "RESUME" => done(s.resume(CLIENT)),
            "CANCEL_PRINT" => {
                if s.state() == State::Idle && s.streaming() {
                    s.stream_clear();
                    return Step::Done(Ok(()));
                }
                done(s.cancel(CLIENT))
            }
            "SDCARD_RESET_FILE" => {
                let mut st = self.hub.lock();
                if st.print.as_ref().is_some_and(|p| p.ended.is_none()) {
                    return Step::Done(Err("SD busy: the print runs".into()));
                }
                st.print = None;
                Step::Done(Ok(()))
            }
            "FIRMWARE_RESTART" | "RESTART" => {
                if matches!(s.state(), State::Stopped | State::Alarm) {
                    let _ = s.unlock();
                }
                self.restart_interpreter(s);
                Step::Done(Ok(()))
            }
            "M400" => {
                let busy = matches!(s.state(), State::Running | State::Holding | State::Stopping);
                if busy || (s.streaming() && s.state() == State::Idle) {
                    Step::Wait
                } else {
                    Step::Done(Ok(()))
                }
            }
            "M114" | "GET_POSITION" => {
                let p = s.position();
                let v: Vec<String> = ["X", "Y", "Z", "E"]
                    .iter()
                    .map(|n| {
                        let i = s.machine().axis(&n.to_ascii_lowercase());
                        format!("{n}:{:.3}", i.map_or(0.0, |i| p[i]))
                    })
                    .collect();
                self.hub.respond(&v.join(" "));
                Step::Done(Ok(()))
            }
            "M105" => {
                self.hub.respond("ok T:0 /0");
                Step::Done(Ok(()))
            }
            "STATUS" => {
                self.hub
                    .respond(&format!("// motet: the machine is {}", s.state()));
                Step::Done(Ok(()))
            }
            // Display messages and fan speeds: nothing to show them on.
            "M117" | "M106" | "M107" | "M84" | "M18" => Step::Done(Ok(())),
            w if traditional(w) => self.gcode(line, s),
            w => Step::Done(Err(format!("Unknown command:\"{w}\""))),
        }
    }

    fn print_file(&mut self, line: &str, s: &mut Session) -> Step {
        if let Some(l) = &self.loading {
            return match l.poll(&self.hub.shared, s) {
                Loaded::Wait => Step::Wait,
                Loaded::Started(p) => {
                    self.loading = None;
                    let mut st = self.hub.lock();
                    st.loading = false;
                    st.print = Some(p);
                    Step::Done(Ok(()))
                }
                Loaded::Failed(e) => {
                    self.loading = None;
                    self.hub.lock().loading = false;
                    Step::Done(Err(e))
                }
            };
        }
        let Some(name) = param(line, "FILENAME") else {
            return Step::Done(Err("Error on 'SDCARD_PRINT_FILE': missing FILENAME".into()));
        };
        {
            let st = self.hub.lock();
            if st.loading || st.print.as_ref().is_some_and(|p| p.ended.is_none()) {
                return Step::Done(Err("SD busy".into()));
            }
        }
        if s.state() != State::Idle || s.streaming() {
            return Step::Done(Err(format!("SD busy: the machine is {}", s.state())));
        }
        match load(&self.hub.shared, &self.hub.gcodes, &name) {
            Ok(l) => {
                self.loading = Some(l);
                self.hub.lock().loading = true;
                Step::Wait
            }
            Err(e) => Step::Done(Err(e)),
        }
    }

    /// Traditional G-code through motet's interpreter into the stream.
    fn gcode(&mut self, line: &str, s: &mut Session) -> Step {
        match gate(s) {
            Gate::Halted => {
                return Step::Done(Err("Printer is shutdown: FIRMWARE_RESTART to go on".into()))
            }
            Gate::Busy => {
                return Step::Done(Err(format!(
                    "the machine is busy ({}): a print or a jog runs",
                    s.state()
                )))
            }
            Gate::Wait => return Step::Wait,
            Gate::Open => follow_rest(&mut self.interp, s),
        }
        let from = self.interp.modal().machine;
        self.line_no = self.line_no.wrapping_add(1);
        if let Err(e) = self.interp.line(line, self.line_no) {
            self.interp.drain();
            return Step::Done(Err(format!(
                "{line}: column {}: {}",
                e.loc.column, e.message
            )));
        }
        let mut commands: Vec<Located<Command>> = self.interp.drain().collect();
        // A pause for the person has no meaning line by line here.
        commands.retain(|c| !matches!(c.item, Command::Pause { .. }));
        if self.interp.ended() {
            let at = commands
                .iter()
                .rev()
                .find_map(|c| match c.item {
                    Command::Move(m) => Some(m.target),
                    _ => None,
                })
                .unwrap_or(from);
            self.restart_interpreter(s);
            self.interp.set_machine_position(at);
        }
        done(s.stream_push(commands, from))
    }
}

fn done(r: Result<(), crate::session::ActionError>) -> Step {
    Step::Done(r.map_err(|e| e.to_string()))
}
