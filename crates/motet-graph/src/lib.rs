//! The host side of node dataflow graphs: a graph file format (TOML), its
//! validation with file locations, the messages that build a graph on a node
//! without recompiling it, live parameter changes, and staged workflows.
//!
//! # Graph file
//!
//! ```toml
//! frame_us = 40                       # core frame period, µs (default 40)
//!
//! [components.knob_x]                 # components run in file order
//! kind = "encoder"
//! ratio = 0.05                        # world units per count
//!
//! [components.kin]
//! kind = "corexy"
//!
//! [components.ch_a]
//! kind = "channel"
//! units = 25.4                        # 25.4 world units are 2874 steps
//! steps = 2874
//! actuator = "motor_a"                # machine actuator (simulation)
//!
//! [[map]]
//! from = "knob_x.out"                 # component.port; `out`/`in` name a
//! to = "kin.x"                        # component's only output/input
//! mode = "incremental"                # default; or "absolute"
//! # tap = true                        # `to` pulls from `from` (fan-out by pull)
//!
//! [inputs]
//! knob_x = "encoder0"                 # the component reading hardware input
//!                                     # encoder0..7, analog0..7, button0..7,
//!                                     # stream0..7
//! ```
//!
//! Any component may set port ratios: `ratios = { out = [1.0, 2400.0] }`
//! (`world` units are `block` units of the port).
//!
//! # Component kinds
//!
//! Each kind's parameters (defaults, units, ranges), live parameters (changed
//! while running with [`GraphFile::set`] or a stage) and ports come from its
//! declaration in the node ([`motet_node::graph::declare`]);
//! [`markdown_table`] renders them, as `examples/dance/README.md` shows.
//! Choices (`mode`, `signal`) take their names or indices; flags take
//! true/false.
//!
//! # Errors
//!
//! Every problem is reported as `file:line:column: `key`: message`: unknown
//! kinds, parameters, ports and modes, components that read an input not
//! named in `[inputs]`, and the runtime builder's own refusals (unit and mode
//! mismatches, absolute fan-in, absolute cycles, capacities) at the
//! `[[map]]` or component they come from.
//!
//! # Stages
//!
//! See [`stage`]. Simulation-only sections: `[[pendulum]]` (input,
//! amplitude, frequency, damping, phase) and `[render]` (pen_channel,
//! pen_down_below).

mod emit;
pub mod file;
pub mod kinds;
mod ports;
mod raw;
mod resolve;
mod simulation;
mod source;
pub mod stage;

pub use file::{
    ChannelDef, ComponentDef, FileError, GraphFile, InputDef, LiveError, Loc, Pendulum, RenderDef,
};
pub use kinds::{markdown_table, COMPONENTS};
pub use stage::{finished, Stage, StageMachine, StageView, Until};
