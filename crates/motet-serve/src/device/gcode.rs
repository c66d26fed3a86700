//! What devices that take G-code lines share: motet's interpreter set up
//! for the machine, and where a program that ended leaves the machine.

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
