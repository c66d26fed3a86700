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
//! Construction parameters (with defaults; `mode` takes "incremental" or
//! "absolute"; flags take true/false) and **live** parameters (changed while
//! running with [`GraphFile::set`] or a stage):
//!
//! | kind | reads | parameters | live | ports |
//! |---|---|---|---|---|
//! | `analog` | analogN | floor_value 0, floor_raw 0, ceiling_value 1, ceiling_raw 1023, deadband_center 0, deadband_width 0, average 1 | all of them | value (level) |
//! | `button` | buttonN | toggle false, debounce_ms 5 | debounce_ms | state (level) |
//! | `encoder` | encoderN | invert false, ratio (units per count) | invert | count (`out`) |
//! | `stream_input` | streamN | — | — | x y r t z e |
//! | `scale` | | ratio 1, mode incremental | ratio | in out |
//! | `scale2d` | | ratio 1, mode incremental | ratio | in_x in_y out_x out_y |
//! | `threshold` | | lower, upper (required) | lower, upper | in out flag |
//! | `corexy` | | — | — | x y a b |
//! | `polar` | | — | — | r theta x y |
//! | `fivebar` | | s, l1, l2, l3, l4 (required), ext 0 | all of them | theta1 theta2 x y |
//! | `velocity` | | speed 0 | speed | speed (level) out |
//! | `position` | | speed 0 | speed, go, go_relative, stop | out |
//! | `wave` | | amplitude (required), frequency 0, phase 0, per_input 0 | all of them | drive out |
//! | `wave2d` | | amplitude (required), frequency 0, phase 0, per_distance 0 | all of them | in_x in_y out_x out_y |
//! | `circle` | | radius, rev_per_s (required) | radius, rev_per_s | x y |
//! | `path_length` | | ratio 1 | ratio | in_x in_y out |
//! | `path_length3d` | | ratio 1 | ratio | in_x in_y in_z out |
//! | `recorder` | | — | record | track0..track3 |
//! | `player` | | loop false | play, loop | track0..track3 |
//! | `homing` | | speed (required), backoff 0, home 0 | start, speed, backoff, home | limit (level) out |
//! | `trajectory_reader` | | axis 0 | axis | position |
//! | `channel` | | filter 0, invert false, max_pulse_rate 0, lower −∞, upper +∞, output −1 (wire port; −1 none), signal 0 (or "x".."e"), units 1, steps 1, actuator | filter, invert, max_pulse_rate, lower, upper | target target_b position |
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
pub use kinds::{markdown_table, KINDS};
pub use stage::{finished, Stage, StageMachine, StageView, Until};
