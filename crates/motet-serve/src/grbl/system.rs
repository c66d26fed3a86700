//! `$` commands: settings, reports, unlock, homing, check mode, jogs.

use super::axes::Axes;
use super::errors::code;
use super::settings::{self, Write};
use super::{Grbl, Step, CLIENT};
use crate::session::{Session, State, STREAM_BLOCKS};

impl Grbl {
    pub(super) fn system(&mut self, t: &str, s: &mut Session) -> Step {
        let upper = t.to_ascii_uppercase();
        let cmd = upper.strip_prefix('$').unwrap_or(&upper);
        let moving = matches!(
            s.state(),
            State::Running | State::Holding | State::Stopping | State::Paused
        );
        if let Some(rest) = cmd.strip_prefix("J=") {
            return self.jog(rest, s);
        }
        if self.homing || cmd == "H" {
            return self.home(s);
        }
        match cmd {
            "" => {
                self.push_line(
                    "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]",
                );
                Step::Reply(Ok(()))
            }
            "$" if moving => Step::Reply(Err(code::NOT_IDLE)),
            "$" => {
                for (n, v) in settings::list(s.machine(), &self.axes, &self.local) {
                    self.push_line(&format!("${n}={v}"));
                }
                Step::Reply(Ok(()))
            }
            "#" => {
                self.offsets(s);
                Step::Reply(Ok(()))
            }
            "G" => {
                self.parser_state();
                Step::Reply(Ok(()))
            }
            "I" => {
                self.push_line("[VER:1.1h.motet:]");
                self.push_line(&format!(
                    "[OPT:V,{STREAM_BLOCKS},{}]",
                    super::lines::RX_BUFFER
                ));
                Step::Reply(Ok(()))
            }
            "N" => {
                for k in 0..2 {
                    let l = self.startup[k].clone();
                    self.push_line(&format!("$N{k}={l}"));
                }
                Step::Reply(Ok(()))
            }
            "X" if moving => Step::Reply(Err(code::NOT_IDLE)),
            "X" => {
                if matches!(s.state(), State::Alarm | State::Stopped) {
                    let _ = s.unlock();
                    self.message("Caution: Unlocked");
                }
                Step::Reply(Ok(()))
            }
            "C" if moving => Step::Reply(Err(code::NOT_IDLE)),
            "C" => {
                self.check_mode = !self.check_mode;
                if self.check_mode {
                    self.message("Enabled");
                } else {
                    // grbl resets on leaving check mode: the G-code state
                    // the checked lines left goes.
                    self.restart_interpreter();
                    self.message("Disabled");
                }
                Step::Reply(Ok(()))
            }
            _ => self.numbered(cmd, t, moving, s),
        }
    }

    /// `$N0=…`, `$N1=…` and `$n=value`.
    fn numbered(&mut self, cmd: &str, original: &str, moving: bool, s: &mut Session) -> Step {
        if let Some(rest) = cmd.strip_prefix('N') {
            let Some((k, _)) = rest.split_once('=') else {
                return Step::Reply(Err(code::INVALID_STATEMENT));
            };
            let k: usize = match k.parse() {
                Ok(k) if k < 2 => k,
                _ => return Step::Reply(Err(code::INVALID_STATEMENT)),
            };
            if moving {
                return Step::Reply(Err(code::NOT_IDLE));
            }
            // Kept as sent (reported by `$N`); not run at start-up.
            let at = original.find('=').map_or(original.len(), |i| i + 1);
            self.startup[k] = original[at..].to_string();
            return Step::Reply(Ok(()));
        }
        let Some((n, v)) = cmd.split_once('=') else {
            return Step::Reply(Err(code::INVALID_STATEMENT));
        };
        let Ok(n) = n.parse::<u16>() else {
            return Step::Reply(Err(code::INVALID_STATEMENT));
        };
        let Ok(v) = v.trim().parse::<f64>() else {
            return Step::Reply(Err(code::BAD_NUMBER));
        };
        if moving {
            return Step::Reply(Err(code::NOT_IDLE));
        }
        match settings::check(n, v, &self.file, &self.axes, &self.local) {
            Ok(Write::Local(l)) => {
                self.local = l;
                Step::Reply(Ok(()))
            }
            Ok(Write::Machine { setting, value }) => {
                let axes = self.axes.clone();
                match s.edit_limits(&format!("${setting}"), |m| {
                    settings::apply_to(m, &axes, setting, value)
                }) {
                    Ok(()) => Step::Reply(Ok(())),
                    Err(_) => Step::Reply(Err(code::NOT_IDLE)),
                }
            }
            Err((c, why)) => {
                self.message(&why);
                Step::Reply(Err(c))
            }
        }
    }

    /// `$H`: motet has no homing switches; the machine goes to its start
    /// position (where the machine file says it rests at power-up), and the
    /// `ok` comes when it is there.
    fn home(&mut self, s: &mut Session) -> Step {
        if self.homing {
            if matches!(s.state(), State::Running | State::Holding | State::Stopping) {
                return Step::Wait;
            }
            self.homing = false;
            return Step::Reply(Ok(()));
        }
        if matches!(s.state(), State::Alarm | State::Stopped) {
            let _ = s.unlock();
        }
        if s.state() != State::Idle || s.streaming() {
            return Step::Reply(Err(code::NOT_IDLE));
        }
        let start = s.machine().start;
        let axes: Vec<(String, f64)> = s
            .machine()
            .axes
            .iter()
            .enumerate()
            .map(|(i, a)| (a.name.clone(), start[i]))
            .collect();
        let feed = s
            .machine()
            .axes
            .iter()
            .map(|a| a.max_velocity)
            .fold(f64::INFINITY, f64::min);
        if s.rest() == start {
            return Step::Reply(Ok(()));
        }
        match s.jog(&axes, false, Some(feed), CLIENT) {
            Ok(()) => {
                self.homing = true;
                Step::Wait
            }
            Err(e) => {
                self.message(&e.to_string());
                Step::Reply(Err(code::NOT_IDLE))
            }
        }
    }

    /// `$#`: work offsets, G28/G30 positions, G92, tool length, probe.
    fn offsets(&mut self, s: &Session) {
        let m = self.interp.modal();
        let inches = self.local.inches;
        for (k, o) in m.work_offsets.iter().enumerate() {
            let v = Axes::format(&self.axes.values(o), inches);
            self.push_line(&format!("[G{}:{v}]", 54 + k));
        }
        let home = Axes::format(&self.axes.values(&s.machine().start), inches);
        self.push_line(&format!("[G28:{home}]"));
        let zero = Axes::format(&vec![0.0; self.axes.map.len()], inches);
        self.push_line(&format!("[G30:{zero}]"));
        let g92 = Axes::format(&self.axes.values(&m.g92), inches);
        self.push_line(&format!("[G92:{g92}]"));
        self.push_line("[TLO:0.000]");
        self.push_line(&format!("[PRB:{zero}:0]"));
    }

    /// `$G`: the G-code parser's modes.
    fn parser_state(&mut self) {
        let m = self.interp.modal();
        let feed = m
            .feed
            .map_or(0.0, |f| f * 60.0 / if m.inches { 25.4 } else { 1.0 });
        let line = format!(
            "[GC:{} G{} G{} G{} G{} G{} M{} M{} T0 F{:.0} S{:.0}]",
            m.motion.unwrap_or("G0"),
            54 + m.coordinate_system,
            m.plane,
            if m.inches { 20 } else { 21 },
            if m.relative { 91 } else { 90 },
            if m.inverse_time { 93 } else { 94 },
            match m.tool_mode {
                0 => 5,
                t => t,
            },
            if m.coolant { 8 } else { 9 },
            feed,
            f64::from(m.tool_value) * 1000.0 * f64::from(u8::from(m.tool_mode != 0)),
        );
        self.push_line(&line);
    }
}
