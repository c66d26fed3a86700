//! The virtual machine: a validated machine description.

use crate::machine_file::MachineFile;
use motet_planner::{
    AxisInfo, AxisLimits, JobTarget, JointLimits, Limits, ToolInfo, ToolKind, ToolTiming,
};
use motet_trajectory::{JointMap, KinematicsKind, Point, ProfileKind, Unit};
use std::path::{Path, PathBuf};

/// A problem in a machine file, with its place (line 0: the whole file, as
/// when it cannot be read).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}: {message}", place(.file, *.line, *.column))]
pub struct MachineError {
    /// The machine file's path as given.
    pub file: String,
    /// Line of the offending key or value, from 1 (a missing section
    /// points at the file's start); 0 when the file could not be read.
    pub line: usize,
    /// Column in characters, from 1 (0 with line 0).
    pub column: usize,
    /// What is wrong, naming the section and key (`axis x: travel must be
    /// [min, max] with min < max`).
    pub message: String,
}

/// `file:line:column`, or the file alone when the error has no line.
fn place(file: &str, line: usize, column: usize) -> String {
    match line {
        0 => file.to_string(),
        _ => format!("{file}:{line}:{column}"),
    }
}

/// One machine axis (`[axes.NAME]`): a coordinate of every [`Point`], in
/// mm (degrees for a rotary axis).
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// Lower-case letters (`x`, `y`, `z`, `e`, ...).
    pub name: String,
    /// `[min, max]`; infinite for axes without travel limits (only axes
    /// that ride along, such as `e`, may leave it out).
    pub travel: [f64; 2],
    /// Fastest the axis moves, units/s.
    pub max_velocity: f64,
    /// Hardest it accelerates, units/s².
    pub max_acceleration: f64,
    /// Jerk limit, units/s³, for S-curve profiles (which need it on at
    /// least one axis); `None`: unlimited.
    pub max_jerk: Option<f64>,
    /// Counts toward path length and feed (x, y, z); `false` for axes that
    /// ride along (`e` by default).
    pub path: bool,
}

/// What an actuator moves: a machine axis, or a joint of the kinematics.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    /// The kinematics' joint name (`a`, `theta`, `shoulder`, ...) or the
    /// axis's name: what an actuator's `joint` key names.
    pub name: String,
    /// How its value follows from a machine-space point.
    pub map: JointMap,
    /// Degrees for an angle joint, mm otherwise: where its actuators'
    /// chains start.
    pub unit: Unit,
    /// The lowest `max_velocity` of its actuators, joint units/s; `None`:
    /// only the axes' limits bound it.
    pub max_velocity: Option<f64>,
    /// The lowest `max_acceleration` of its actuators, joint units/s².
    pub max_acceleration: Option<f64>,
}

/// One motor (`[actuators.NAME]`) and the chain that turns its joint's
/// motion into steps.
#[derive(Clone, Debug, PartialEq)]
pub struct Actuator {
    /// Its name in the machine file, which `[nodes.*] actuators` lists.
    pub name: String,
    /// Index into [`Machine::joints`] of the joint it drives (several
    /// actuators may drive one joint, as two z motors do).
    pub joint: usize,
    /// Signed; negative when the chain inverts.
    pub steps_per_unit: f64,
    /// Step pulse width its driver needs, µs.
    pub pulse_us: f32,
    /// Direction set-up time its driver needs, µs.
    pub dir_setup_us: f32,
    /// The fastest it steps, steps/s, when the joint's speed is bounded
    /// (every joint but a polar angle with no `max_velocity`).
    pub max_step_hz: Option<f64>,
    /// A servo (its chain ends in an encoder): `steps_per_unit` are then
    /// encoder counts, and this is its loop.
    pub servo: Option<crate::servo::ServoSpec>,
}

/// One tool output (`[tools.NAME]`): a pen servo, a laser, a spindle.
#[derive(Clone, Debug, PartialEq)]
pub struct Tool {
    /// Its name in the machine file.
    pub name: String,
    /// What it drives; decides whether motion stops for a change.
    pub kind: ToolKind,
    /// Seconds to stand still after a change (default: pen 0.15, spindle
    /// 1, laser 0).
    pub settle: f64,
    /// The value "on" means when a job gives none, `0.0..=1.0` (default 1).
    pub on_value: f32,
}

/// One simulated heater (`[heaters.NAME]`): a first-order lag toward its
/// target ([`crate::heater`]). A machine file without `[heaters]` gets a
/// hot end and a bed when it has an extruder axis `e`
/// ([`Heater::default_printer`]), none otherwise.
#[derive(Clone, Debug, PartialEq)]
pub struct Heater {
    /// Its name in the machine file.
    pub name: String,
    /// Which temperature commands set it (M104/M109 with T, M140/M190,
    /// M141/M191).
    pub channel: motet_planner::AuxChannel,
    /// Highest target it takes, °C.
    pub max_c: f64,
    /// Time constant, s (the first-order lag `motet serve` and the S3G
    /// bot model it with).
    pub tau_s: f64,
    /// When a node drives it (`[nodes.NAME] heaters`): its loop, model and
    /// runaway watch.
    pub node_loop: Option<crate::heater_loop::HeaterLoop>,
}

impl Heater {
    /// A printer's heaters when the file names none: hot end (at most
    /// 275 °C, 20 s) and bed (at most 120 °C, 60 s).
    pub fn default_printer() -> Vec<Heater> {
        vec![
            Heater {
                name: "hotend".into(),
                channel: motet_planner::AuxChannel::Hotend(0),
                max_c: 275.0,
                tau_s: 20.0,
                node_loop: None,
            },
            Heater {
                name: "bed".into(),
                channel: motet_planner::AuxChannel::Bed,
                max_c: 120.0,
                tau_s: 60.0,
                node_loop: None,
            },
        ]
    }
}

/// One node (`[nodes.NAME]`): the board that steps some actuators and
/// switches some tools. A file without `[nodes]` gets one node `main` with
/// everything.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeSpec {
    /// Its name in the machine file.
    pub name: String,
    /// Indices into [`Machine::actuators`]; the position is the node's channel id.
    pub actuators: Vec<usize>,
    /// Indices into [`Machine::tools`]; the position is the node's tool output.
    pub tools: Vec<usize>,
    /// Segments its queue holds (default 64); bounds `[motion]
    /// stop_horizon`.
    pub queue: usize,
    /// Its frame period, µs (default 40): how often it polls for the steps
    /// and tool changes due (each still carries its own exact time).
    pub frame_us: f64,
    /// Its steps solved in fixed-point time, each within this many µs of
    /// its exact time, as a board without a floating-point unit solves
    /// them (`motet_node::Node::use_fixed_time`; the Pico: 0.05); 0 (the
    /// default): exactly. What the simulator runs the node with: a board
    /// sets its own.
    pub fixed_time_us: f64,
    /// Indices into [`Machine::sensors`]; the position is the node's
    /// sensor index.
    pub sensors: Vec<usize>,
    /// Bytes a second its samples may take upstream (frames included).
    pub sample_budget: f64,
}

/// A machine file, validated: everything the planner, the job checks and
/// the distribution to nodes need. Built only by [`Machine::load`] or
/// [`Machine::parse`], so its indices are consistent (every joint driven,
/// every actuator on one node).
#[derive(Clone, Debug, PartialEq)]
pub struct Machine {
    /// The machine's `name`.
    pub name: String,
    /// Its `description`, if the file has one.
    pub description: Option<String>,
    /// The file it was read from, as given.
    pub file: PathBuf,
    /// In the order x, y, z, e, a, b, c, then the others alphabetically;
    /// axis `i` is coordinate `i` of a [`Point`].
    pub axes: Vec<Axis>,
    /// `[motion] kinematics` with its `[geometry]`.
    pub kinematics: KinematicsKind,
    /// Indices of the x, y and z axes when the kinematics has joints of
    /// its own; its joints replace the first
    /// [`KinematicsKind::joints`]`.len()` of them (z is `NO_AXIS` unless
    /// they replace it too).
    pub kinematic_axes: Option<[usize; 3]>,
    /// The kinematics' joints first, then every axis they do not replace
    /// as a joint of its own.
    pub joints: Vec<Joint>,
    /// By name (the machine file's tables are read sorted).
    pub actuators: Vec<Actuator>,
    /// By name; a tool's index is what [`motet_planner::Command::Tool`]
    /// names.
    pub tools: Vec<Tool>,
    /// By name; each actuator is on exactly one, each tool on at most one.
    pub nodes: Vec<NodeSpec>,
    /// grbl-style junction deviation, mm: how fast corners are taken.
    pub junction_deviation: f64,
    /// Trapezoid or S-curve ramps.
    pub profile: ProfileKind,
    /// Chord tolerance for flattening curves (arcs, SVG), mm.
    pub tolerance: f64,
    /// Feed for drawing when a job gives none, units/s (default: half the
    /// slowest path axis's `max_velocity`).
    pub draw_feed: f64,
    /// Where the machine is when a job starts: `[motion] start`, else 0 or
    /// the travel's low end; within travel and reach.
    pub start: Point,
    /// Polar machines: the closest a move may pass to the centre, mm.
    pub min_radius: f64,
    /// Most moves the planner holds for lookahead.
    pub lookahead: usize,
    /// Moves within which the machine can always come to rest (0: off); see
    /// [`motet_planner::Limits::stop_horizon`].
    pub stop_horizon: usize,
    /// Simulated heaters (`[heaters.NAME]`; see [`Heater`]).
    pub heaters: Vec<Heater>,
    /// Sensors (`[sensors.NAME]`), by name.
    pub sensors: Vec<crate::servo::SensorSpec>,
    /// The modules it was composed from, in chain order
    /// (`[modules.NAME]`; empty for a machine written by hand).
    pub modules: Vec<crate::module::ModuleRecord>,
}

impl Machine {
    /// Reads and validates a machine file.
    pub fn load(path: &Path) -> Result<Machine, MachineError> {
        let text = std::fs::read_to_string(path).map_err(|e| MachineError {
            file: path.display().to_string(),
            line: 0,
            column: 0,
            message: format!("cannot read machine file: {e}"),
        })?;
        Machine::parse(&text, path)
    }

    /// Validates a machine description given as TOML text.
    pub fn parse(text: &str, file: &Path) -> Result<Machine, MachineError> {
        let src = crate::machine_build::Source {
            file: file.display().to_string(),
            text,
        };
        let raw: MachineFile = toml::from_str(text).map_err(|e| {
            let span = e.span().unwrap_or(0..0);
            src.err(span, e.message().to_string())
        })?;
        crate::machine_build::build(&src, raw, file)
    }

    /// The planner's view of the limits.
    pub fn limits(&self) -> Limits {
        Limits {
            axes: self
                .axes
                .iter()
                .map(|a| AxisLimits {
                    max_velocity: a.max_velocity,
                    max_acceleration: a.max_acceleration,
                    max_jerk: a.max_jerk,
                    path: a.path,
                })
                .collect(),
            joints: self
                .joints
                .iter()
                .enumerate()
                .filter_map(|(k, j)| {
                    // No joint outruns its motors' step rate: a node refuses
                    // a segment that asks more.
                    let spu = self
                        .actuators
                        .iter()
                        .filter(|a| a.joint == k)
                        .map(|a| a.steps_per_unit.abs())
                        .fold(0.0, f64::max);
                    let step_cap = if spu > 0.0 {
                        motet_wire::MAX_STEP_RATE / spu
                    } else {
                        f64::INFINITY
                    };
                    let max_velocity = j.max_velocity.unwrap_or(f64::INFINITY).min(step_cap);
                    (max_velocity.is_finite() || j.max_acceleration.is_some()).then(|| {
                        JointLimits {
                            map: j.map,
                            max_velocity,
                            max_acceleration: j.max_acceleration.unwrap_or(f64::INFINITY),
                        }
                    })
                })
                .collect(),
            junction_deviation: self.junction_deviation,
            profile: self.profile,
            tools: self
                .tools
                .iter()
                .map(|t| ToolTiming {
                    stop: t.kind != ToolKind::Laser,
                    settle: t.settle,
                })
                .collect(),
            lookahead: self.lookahead,
            stop_horizon: self.stop_horizon,
            min_move_s: 0.0,
            max_move_s: 0.0,
        }
    }

    /// What job sources need to know.
    pub fn job_target(&self) -> JobTarget {
        JobTarget {
            axes: self
                .axes
                .iter()
                .map(|a| AxisInfo {
                    name: a.name.clone(),
                    travel: a.travel,
                    path: a.path,
                })
                .collect(),
            tools: self
                .tools
                .iter()
                .map(|t| ToolInfo {
                    name: t.name.clone(),
                    kind: t.kind,
                    on_value: t.on_value,
                })
                .collect(),
            start: self.start,
            tolerance: self.tolerance,
            draw_feed: self.draw_feed,
        }
    }

    /// Index of the axis named `name` (exactly, as in the machine file).
    pub fn axis(&self, name: &str) -> Option<usize> {
        self.axes.iter().position(|a| a.name == name)
    }

    /// How far axis `axis` may move before one of the motors it drives
    /// moves half a step (the smallest over its motors), in axis units. A
    /// polar angle's step is taken at `min_radius`, where it is shortest.
    pub fn half_step(&self, axis: usize) -> f64 {
        let mut half = f64::INFINITY;
        for a in &self.actuators {
            let spu = a.steps_per_unit.abs();
            let per_unit = match self.joints[a.joint].map {
                JointMap::Linear { coeffs } => coeffs.get(axis).map_or(0.0, |c| c.abs()),
                JointMap::Kinematic {
                    kinematics,
                    joint,
                    axes,
                } if axes[..kinematics.joints().len()].contains(&(axis as u8)) => {
                    match (kinematics.gradient_bound(joint as usize), kinematics) {
                        (Some(g), _) => g,
                        // Degrees per mm of x or y at the closest allowed radius.
                        (None, KinematicsKind::Polar(_)) if self.min_radius > 0.0 => {
                            1.0f64.to_degrees() / self.min_radius
                        }
                        (None, KinematicsKind::Polar(_)) => f64::INFINITY,
                        (None, _) => 0.0,
                    }
                }
                _ => 0.0,
            };
            if per_unit > 0.0 {
                half = half.min(0.5 / (spu * per_unit));
            }
        }
        if half.is_finite() {
            half
        } else {
            0.0
        }
    }
}
