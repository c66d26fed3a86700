//! The example machines jobs are checked and planned on, parsed once.

use motet_host::Machine;
use std::path::Path;
use std::sync::OnceLock;

/// Machine files of `examples/`, embedded so a fuzz target needs no files.
const SOURCES: &[(&str, &str)] = &[
    (
        "examples/printer.toml",
        include_str!("../../../examples/printer.toml"),
    ),
    (
        "examples/plotter.toml",
        include_str!("../../../examples/plotter.toml"),
    ),
    (
        "examples/laser.toml",
        include_str!("../../../examples/laser.toml"),
    ),
    (
        "examples/clay-printer.toml",
        include_str!("../../../examples/clay-printer.toml"),
    ),
    (
        "examples/gestalt-3axis.toml",
        include_str!("../../../examples/gestalt-3axis.toml"),
    ),
];

fn all() -> &'static [Machine] {
    static MACHINES: OnceLock<Vec<Machine>> = OnceLock::new();
    MACHINES.get_or_init(|| {
        SOURCES
            .iter()
            .map(|(path, text)| {
                Machine::parse(text, Path::new(path)).expect("the example machines are valid")
            })
            .collect()
    })
}

/// The machines G-code is run on: cartesian with an extruder, CoreXY with a
/// pen, a laser with power on the fly, polar, and a spindle.
pub fn gcode_machines() -> &'static [Machine] {
    all()
}

/// The pen plotter: what SVG drawings are made for.
pub fn plotter() -> &'static Machine {
    &all()[1]
}
