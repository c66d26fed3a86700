//! G-code lines: read by motet's interpreter in work coordinates, checked
//! against the travel, scaled by the overrides, and queued into the
//! session's stream; `M0` pauses the program once what is before it has
//! run.

use super::errors::{self, alarm, code};
use super::realtime::Overrides;
use super::{Grbl, Step};
use crate::device::gcode::{follow_rest, gate, Gate};
use crate::session::{Session, State};
use motet_planner::{Command, Located, MoveKind};

impl Grbl {
    pub(super) fn gcode(&mut self, t: &str, s: &mut Session) -> Step {
        if self.pausing {
            // Its motion is queued: the `ok` when the machine rests after it.
            if s.streaming() || s.state() != State::Idle {
                return Step::Wait;
            }
            self.pausing = false;
            self.program_paused = true;
            return Step::Reply(Ok(()));
        }
        if self.program_paused {
            return Step::Wait;
        }
        if !self.check_mode {
            if s.jogging() {
                return Step::Reply(Err(code::LOCKED));
            }
            match gate(s) {
                Gate::Halted | Gate::Busy => return Step::Reply(Err(code::LOCKED)),
                Gate::Wait => return Step::Wait,
                Gate::Open => follow_rest(&mut self.interp, s),
            }
        }
        let from = self.interp.modal().machine;
        self.line_no = self.line_no.wrapping_add(1);
        if let Err(e) = self.interp.line(t, self.line_no) {
            self.message(&format!("column {}: {}", e.loc.column, e.message));
            self.interp.drain();
            return Step::Reply(Err(errors::of_gcode(&e.message)));
        }
        let mut commands: Vec<Located<Command>> = self.interp.drain().collect();
        // M0 pauses the program once everything before it has run (grbl's
        // optional stop, M1, is off: it does nothing).
        let pause = commands
            .iter()
            .any(|c| matches!(c.item, Command::Pause { optional: false }));
        commands.retain(|c| !matches!(c.item, Command::Pause { .. }));
        if self.interp.ended() {
            // M2/M30 ends a program, not the connection: the next line
            // starts the next program (grbl resets its modes the same way).
            self.restart_interpreter();
            self.interp
                .set_machine_position(crate::device::gcode::end_of(&commands, from));
        }
        self.apply_overrides(&mut commands);
        for c in &commands {
            match c.item {
                Command::Tool { value, .. } | Command::ToolPerSpeed { value, .. } => {
                    self.tool = f64::from(value)
                }
                _ => {}
            }
        }
        if self.check_mode {
            let mut at = from;
            for c in &commands {
                if let Command::Move(m) = c.item {
                    if let Err(e) = motet_host::check_move(s.machine(), &at, &m.target) {
                        self.message(&e.to_string());
                        return Step::Reply(Err(code::INVALID_TARGET));
                    }
                    at = m.target;
                }
            }
            return Step::Reply(Ok(()));
        }
        match s.stream_push(commands, from) {
            Ok(()) if pause => {
                self.pausing = true;
                Step::Wait
            }
            Ok(()) => Step::Reply(Ok(())),
            Err(crate::session::ActionError::Unreachable(e)) => {
                // grbl's soft limit: the machine stops on its path and
                // nothing more runs until `$X`.
                self.push_line(&format!("ALARM:{}", alarm::SOFT_LIMIT));
                self.message(&e.to_string());
                s.estop();
                Step::Reply(Err(code::LOCKED))
            }
            Err(e) => {
                self.message(&e.to_string());
                Step::Reply(Err(code::LOCKED))
            }
        }
    }

    /// The overrides on lines as they are streamed: feed and spindle scale
    /// feeds and tool power; a rapid override caps rapids at that share of
    /// the slowest path axis's speed.
    fn apply_overrides(&self, commands: &mut [Located<Command>]) {
        let (o, slowest) = (self.overrides, slowest_path_axis(&self.file));
        for c in commands {
            overridden(&mut c.item, Overrides::default(), o, slowest);
        }
    }
}

/// The slowest path axis's top speed (what a rapid override is a share of).
pub(super) fn slowest_path_axis(m: &motet_host::Machine) -> f64 {
    m.axes
        .iter()
        .filter(|a| a.path)
        .map(|a| a.max_velocity)
        .fold(f64::INFINITY, f64::min)
}

/// `c`, streamed under overrides `old`, as it is under `new`. Tool power
/// already at full under `old` stays relative to full.
pub(super) fn overridden(c: &mut Command, old: Overrides, new: Overrides, slowest: f64) {
    match c {
        Command::Move(m) if m.kind == MoveKind::Feed => {
            m.feed *= f64::from(new.feed) / f64::from(old.feed)
        }
        Command::Move(m) => {
            m.feed = if new.rapid < 100 && slowest.is_finite() {
                slowest * f64::from(new.rapid) / 100.0
            } else {
                f64::INFINITY
            }
        }
        Command::Tool { value, .. } | Command::ToolPerSpeed { value, .. } => {
            *value = (*value * f32::from(new.spindle) / f32::from(old.spindle)).min(1.0)
        }
        _ => {}
    }
}
