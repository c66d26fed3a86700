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
    pub file: String,
    pub line: usize,
    pub column: usize,
    pub message: String,
}

/// `file:line:column`, or the file alone when the error has no line.
fn place(file: &str, line: usize, column: usize) -> String {
    match line {
        0 => file.to_string(),
        _ => format!("{file}:{line}:{column}"),
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    pub name: String,
    /// `[min, max]`; infinite for axes without travel limits.
    pub travel: [f64; 2],
    pub max_velocity: f64,
    pub max_acceleration: f64,
    pub max_jerk: Option<f64>,
    pub path: bool,
}

/// What an actuator moves: a machine axis, or a joint of the kinematics.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    pub name: String,
    pub map: JointMap,
    pub unit: Unit,
    pub max_velocity: Option<f64>,
    pub max_acceleration: Option<f64>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Actuator {
    pub name: String,
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
}

#[derive(Clone, Debug, PartialEq)]
pub struct Tool {
    pub name: String,
    pub kind: ToolKind,
    pub settle: f64,
    pub on_value: f32,
}

#[derive(Clone, Debug, PartialEq)]
pub struct NodeSpec {
    pub name: String,
    /// Indices into [`Machine::actuators`]; the position is the node's channel id.
    pub actuators: Vec<usize>,
    /// Indices into [`Machine::tools`]; the position is the node's tool output.
    pub tools: Vec<usize>,
    pub queue: usize,
    pub frame_us: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Machine {
    pub name: String,
    pub description: Option<String>,
    pub file: PathBuf,
    pub axes: Vec<Axis>,
    pub kinematics: KinematicsKind,
    /// Indices of the x, y and z axes when the kinematics has joints of
    /// its own; its joints replace the first
    /// [`KinematicsKind::joints`]`.len()` of them (z is `NO_AXIS` unless
    /// they replace it too).
    pub kinematic_axes: Option<[usize; 3]>,
    pub joints: Vec<Joint>,
    pub actuators: Vec<Actuator>,
    pub tools: Vec<Tool>,
    pub nodes: Vec<NodeSpec>,
    pub junction_deviation: f64,
    pub profile: ProfileKind,
    pub tolerance: f64,
    pub draw_feed: f64,
    pub start: Point,
    pub min_radius: f64,
    pub lookahead: usize,
    /// Moves within which the machine can always come to rest (0: off); see
    /// [`motet_planner::Limits::stop_horizon`].
    pub stop_horizon: usize,
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
