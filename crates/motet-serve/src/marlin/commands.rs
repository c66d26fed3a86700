//! What the device does with one command: the M-codes it answers itself
//! (temperatures, firmware, position, reports, SD), and G-code through
//! motet's interpreter into the session's stream, its `ok` held while the
//! machine cannot take it yet or a wait is on.

use super::frame::code;
use super::{report, Marlin};
use crate::device::gcode::{end_of, follow_rest, new_interpreter};
use crate::session::{ActionError, Session, State};
use motet_host::heater::READY_WITHIN_C;
use motet_planner::{AuxChannel, Command, Located};
use motet_trajectory::Point;

/// A command's answer: lines, then `ok` (with `ok_tail` after it, as
/// M105's temperatures).
#[derive(Default)]
pub(super) struct Reply {
    pub(super) lines: Vec<String>,
    pub(super) ok_tail: Option<String>,
}

impl Reply {
    fn ok() -> Reply {
        Reply::default()
    }

    fn line(l: impl Into<String>) -> Reply {
        Reply {
            lines: vec![l.into()],
            ok_tail: None,
        }
    }
}

pub(super) enum Outcome {
    Reply(Reply),
    Hold(Held),
}

/// What a held command waits for.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Wait {
    /// Room in the stream's queue.
    Room,
    /// The motion before it to be done (M400, a heating wait).
    Motion,
    /// A heater to come to `target` (only upward when `heating_only`).
    Heat {
        channel: AuxChannel,
        target: f64,
        heating_only: bool,
    },
}

/// A command whose `ok` is held.
pub(super) struct Held {
    /// Its commands not yet given to the session, machine coordinates.
    commands: Vec<Located<Command>>,
    /// Where they start.
    from: Point,
    wait: Wait,
    /// `M109 R`/`M190 R`: the wait goes both ways.
    both_ways: bool,
    pub(super) last_busy: u64,
    pub(super) last_report: u64,
}

impl Held {
    pub(super) fn heating(&self) -> bool {
        matches!(self.wait, Wait::Heat { .. })
    }
}

/// The `S<n>` argument of a command, if any.
fn arg(command: &str, letter: char) -> Option<f64> {
    let up = command.to_ascii_uppercase();
    let i = up.find(letter)?;
    let rest = &up[i + 1..];
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .unwrap_or(rest.len());
    rest[..end].parse().ok()
}

fn halted() -> Reply {
    Reply::line("Error:Printer halted: emergency stop or alarm, send M999 to restart")
}

impl Marlin {
    /// `M108`, `M112`, `M410` act as they arrive; `true` if the command is
    /// done with (M112: nothing after it runs).
    pub(super) fn emergency(&mut self, cmd: &str, s: &mut Session) -> bool {
        match code(cmd).as_str() {
            "M108" => self.cancel_wait = true,
            "M112" => {
                s.estop();
                self.queue.clear();
                self.held = None;
                self.push_line("Error:Printer halted. kill() called!");
                return true;
            }
            "M410" => {
                self.queue.clear();
                self.held = None;
                if s.streaming() {
                    let _ = s.cancel(super::CLIENT);
                }
                self.stream_restart(s);
            }
            _ => {}
        }
        false
    }

    /// The interpreter takes the machine's position again (after a stop).
    fn stream_restart(&mut self, s: &Session) {
        self.interp.set_machine_position(s.rest());
    }

    pub(super) fn command(&mut self, cmd: &str, now: u64, s: &mut Session) -> Outcome {
        let reply = match code(cmd).as_str() {
            "M105" => Reply {
                lines: vec![],
                ok_tail: Some(report::temperatures(s.heaters())),
            },
            "M108" | "M110" | "M410" => Reply::ok(),
            "M112" => halted(),
            "M114" => Reply::line(self.position(s)),
            "M115" => Reply {
                lines: report::firmware(&self.file.name, usize::from(self.has_hotend(s))),
                ok_tail: None,
            },
            "M155" => {
                let every = (arg(cmd, 'S').unwrap_or(0.0).clamp(0.0, 60.0) * 1e6) as u64;
                self.auto_temp = (every, now + every);
                Reply::ok()
            }
            "M113" => {
                self.busy_us = (arg(cmd, 'S').unwrap_or(2.0).clamp(0.0, 60.0) * 1e6) as u64;
                Reply::ok()
            }
            "M20" => Reply {
                lines: vec!["Begin file list".into(), "End file list".into()],
                ok_tail: None,
            },
            "M21" => Reply::line("echo:SD init fail"),
            "M22" | "M23" | "M24" | "M25" | "M26" | "M27" | "M28" | "M29" | "M32" | "M33"
            | "M524" | "M928" => Reply::line("echo:No SD card"),
            "M999" => {
                if matches!(s.state(), State::Stopped | State::Alarm) {
                    let _ = s.unlock();
                }
                self.stream_restart(s);
                Reply::ok()
            }
            "M400" => {
                return Outcome::Hold(self.hold(Vec::new(), Wait::Motion, false, now));
            }
            _ => return self.gcode(cmd, now, s),
        };
        Outcome::Reply(reply)
    }

    fn has_hotend(&self, s: &Session) -> bool {
        s.heaters()
            .iter()
            .any(|h| matches!(h.channel, AuxChannel::Hotend(_)))
    }

    /// Program coordinates of the axes X Y Z E the machine has.
    fn position(&self, s: &Session) -> String {
        let m = self.interp.modal();
        // At rest with nothing queued the machine is the truth; otherwise
        // where the lines sent so far end.
        let at = if s.state() == State::Idle && !s.streaming() && self.held.is_none() {
            s.rest()
        } else {
            m.machine
        };
        let letters: Vec<(char, f64)> = ['x', 'y', 'z', 'e']
            .iter()
            .filter_map(|l| {
                let i = self
                    .file
                    .axes
                    .iter()
                    .position(|a| a.name == l.to_string())?;
                Some((l.to_ascii_uppercase(), at[i] - m.offset[i]))
            })
            .collect();
        report::position(&letters)
    }

    fn hold(&self, commands: Vec<Located<Command>>, wait: Wait, both: bool, now: u64) -> Held {
        Held {
            from: self.interp.modal().machine,
            commands,
            wait,
            both_ways: both,
            last_busy: now,
            last_report: now,
        }
    }

    fn gcode(&mut self, cmd: &str, now: u64, s: &mut Session) -> Outcome {
        if matches!(s.state(), State::Stopped | State::Alarm) {
            return Outcome::Reply(halted());
        }
        follow_rest(&mut self.interp, s);
        let from = self.interp.modal().machine;
        self.line_no = self.line_no.wrapping_add(1);
        if let Err(e) = self.interp.line(cmd, self.line_no) {
            self.interp.drain();
            return Outcome::Reply(if e.message.starts_with("unsupported") {
                Reply::line(format!("echo:Unknown command: \"{cmd}\""))
            } else {
                Reply::line(format!("Error:{}", e.message))
            });
        }
        let commands: Vec<Located<Command>> = self.interp.drain().collect();
        if self.interp.ended() {
            // M2/M30 ends a program, not the connection.
            self.interp = new_interpreter(&self.file);
            self.interp.set_machine_position(end_of(&commands, from));
        }
        // A target above a heater's maximum refuses the whole line.
        for c in &commands {
            if let Command::Aux { channel, value, .. } = c.item {
                if let Some(h) = s.heaters().iter().find(|h| h.channel == channel) {
                    if f64::from(value) > h.max {
                        self.interp.set_machine_position(from);
                        return Outcome::Reply(Reply::line(format!(
                            "Error:{} target {value} °C is above its maximum {} °C",
                            h.name, h.max
                        )));
                    }
                }
            }
        }
        let waits = commands.iter().any(|c| {
            matches!(c.item, Command::Aux { channel, wait: true, .. }
                if s.heater_ready(channel).is_some())
                || matches!(c.item, Command::Sync)
        });
        let both = arg(cmd, 'S').is_none() && arg(cmd, 'R').is_some();
        let mut h = self.hold(
            commands,
            if waits { Wait::Motion } else { Wait::Room },
            both,
            now,
        );
        h.from = from;
        // Taken now if it can be; held otherwise.
        match self.advance(h, now, s) {
            Ok(r) => Outcome::Reply(r),
            Err(h) => Outcome::Hold(h),
        }
    }

    /// Moves a held command on: its answer once done, or itself still held.
    pub(super) fn advance(
        &mut self,
        mut h: Held,
        now: u64,
        s: &mut Session,
    ) -> Result<Reply, Held> {
        loop {
            if matches!(s.state(), State::Stopped | State::Alarm) {
                return Ok(halted());
            }
            match h.wait {
                Wait::Room => {
                    if s.state() == State::Stopping || s.stream_status().blocks_free == 0 {
                        return Err(h);
                    }
                    let commands = std::mem::take(&mut h.commands);
                    return match s.stream_push(commands, h.from) {
                        Ok(()) => Ok(Reply::ok()),
                        Err(e) => {
                            // Nothing of the line was taken: the next one
                            // starts where this one started.
                            self.interp.set_machine_position(h.from);
                            Ok(Reply::line(format!("Error:{e}")))
                        }
                    };
                }
                Wait::Motion => {
                    if s.streaming() || s.state() != State::Idle {
                        return Err(h);
                    }
                    self.cancel_wait = false;
                    h.wait = match self.set_targets(&mut h, s) {
                        Err(e) => return Ok(Reply::line(format!("Error:{e}"))),
                        Ok(Some(w)) => w,
                        Ok(None) if h.commands.is_empty() => return Ok(Reply::ok()),
                        Ok(None) => Wait::Room,
                    };
                    h.last_report = now.saturating_sub(super::WAIT_REPORT_US);
                }
                Wait::Heat {
                    channel,
                    target,
                    heating_only,
                } => {
                    let temp = s
                        .heaters()
                        .iter()
                        .find(|x| x.channel == channel)
                        .map_or(target, |x| x.temp);
                    let there = if heating_only && !h.both_ways {
                        temp >= target - READY_WITHIN_C
                    } else {
                        s.heater_ready(channel).unwrap_or(true)
                    };
                    if !(there || std::mem::take(&mut self.cancel_wait)) {
                        return Err(h);
                    }
                    if h.commands.is_empty() {
                        return Ok(Reply::line(report::temperatures(s.heaters())));
                    }
                    h.wait = Wait::Room;
                }
            }
        }
    }

    /// The machine is at rest after what came before: the line's heater
    /// targets are set now (they run now); its heating wait, if any, is
    /// what it waits for next. Its other commands stay for the stream.
    fn set_targets(&mut self, h: &mut Held, s: &mut Session) -> Result<Option<Wait>, ActionError> {
        let mut wait = None;
        let mut rest = Vec::new();
        for c in std::mem::take(&mut h.commands) {
            match c.item {
                Command::Aux {
                    channel,
                    value,
                    wait: w,
                } if s.heater_ready(channel).is_some() => {
                    let target = f64::from(value);
                    s.set_heater_target(channel, target)?;
                    // Waiting for a heater switched off is no wait.
                    if w && target > 0.0 {
                        wait = Some(Wait::Heat {
                            channel,
                            target,
                            heating_only: true,
                        });
                    }
                }
                Command::Sync => {}
                _ => rest.push(c),
            }
        }
        h.commands = rest;
        Ok(wait)
    }
}
