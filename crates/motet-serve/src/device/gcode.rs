//! What devices that take G-code lines share: motet's interpreter set up
//! for the machine, whether a line may go into the session's stream now,
//! and where a program that ended leaves the machine.

use crate::session::{Session, State};
use motet_gcode::{GcodeOptions, Interpreter};
use motet_host::Machine;
use motet_planner::{Command, Located};
use motet_trajectory::Point;

/// A fresh interpreter for `machine`'s job target, default options.
pub(crate) fn new_interpreter(machine: &Machine) -> Interpreter {
    // The default options are valid: this cannot fail.
    Interpreter::new(&machine.job_target(), &GcodeOptions::default())
        .unwrap_or_else(|e| unreachable!("default G-code options: {e}"))
}

/// Where `commands` leave the machine: the last move's target, or `from`.
pub(crate) fn end_of(commands: &[Located<Command>], from: Point) -> Point {
    commands
        .iter()
        .rev()
        .find_map(|c| match c.item {
            Command::Move(m) => Some(m.target),
            _ => None,
        })
        .unwrap_or(from)
}

/// Whether a streamed G-code line may go into the session now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Gate {
    /// The machine is stopped or in alarm: nothing is taken.
    Halted,
    /// A job or a jog of another front end owns the machine.
    Busy,
    /// A stop is still braking, or the stream is full: the line waits.
    Wait,
    /// The line goes in.
    Open,
}

/// The gate for a streamed line on `s`.
pub(crate) fn gate(s: &Session) -> Gate {
    match s.state() {
        State::Alarm | State::Stopped => Gate::Halted,
        State::Stopping => Gate::Wait,
        State::Running | State::Holding | State::Paused if !s.streaming() => Gate::Busy,
        _ if s.stream_status().blocks_free == 0 => Gate::Wait,
        _ => Gate::Open,
    }
}

/// Relative moves start from where the machine rests when something else
/// (a job, a jog, the web page) moved it since the last line.
pub(crate) fn follow_rest(interp: &mut Interpreter, s: &Session) {
    if s.state() == State::Idle && !s.streaming() {
        interp.set_machine_position(s.rest());
    }
}
