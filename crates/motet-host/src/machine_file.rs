//! The machine file as written (TOML), before validation.
//!
//! Every table denies unknown keys, and the fields that later checks complain
//! about are kept with their place in the file.

use serde::Deserialize;
use std::collections::BTreeMap;
use toml::Spanned;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineFile {
    pub name: String,
    #[serde(default)]
    pub description: Option<String>,
    #[serde(default)]
    pub motion: MotionFile,
    /// The kinematics' geometry (arm lengths and the like).
    #[serde(default)]
    pub geometry: Option<crate::machine_kinematics::GeometryFile>,
    pub axes: BTreeMap<String, Spanned<AxisFile>>,
    pub actuators: BTreeMap<String, Spanned<ActuatorFile>>,
    #[serde(default)]
    pub tools: BTreeMap<String, Spanned<ToolFile>>,
    #[serde(default)]
    pub nodes: BTreeMap<String, Spanned<NodeFile>>,
    #[serde(default)]
    pub heaters: BTreeMap<String, Spanned<HeaterFile>>,
    #[serde(default)]
    pub sensors: BTreeMap<String, Spanned<SensorFile>>,
    /// The modules the machine was composed from (`crate::module::record`).
    #[serde(default)]
    pub modules: BTreeMap<String, Spanned<crate::module::record::ModuleRecordFile>>,
}

pub use crate::machine_file_loops::{MotorFile, SensorFile, ServoFile};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionFile {
    #[serde(default = "default_kinematics")]
    pub kinematics: Spanned<String>,
    #[serde(default = "default_junction_deviation")]
    pub junction_deviation: Spanned<f64>,
    #[serde(default = "default_profile")]
    pub profile: Spanned<String>,
    #[serde(default = "default_tolerance")]
    pub tolerance: Spanned<f64>,
    #[serde(default)]
    pub draw_feed: Option<Spanned<f64>>,
    /// Where the machine is at the start of a job; axes not named start at 0, or
    /// at their travel's lower end when 0 is outside it.
    #[serde(default = "default_start")]
    pub start: Spanned<BTreeMap<String, f64>>,
    /// Polar machines: moves may not pass closer than this to the centre, mm.
    #[serde(default = "default_min_radius")]
    pub min_radius: Spanned<f64>,
    #[serde(default = "default_lookahead")]
    pub lookahead: Spanned<i64>,
    /// Moves within which the machine can always come to rest (0: off).
    #[serde(default = "default_stop_horizon")]
    pub stop_horizon: Spanned<i64>,
}

impl Default for MotionFile {
    fn default() -> Self {
        MotionFile {
            kinematics: default_kinematics(),
            junction_deviation: default_junction_deviation(),
            profile: default_profile(),
            tolerance: default_tolerance(),
            draw_feed: None,
            start: default_start(),
            min_radius: default_min_radius(),
            lookahead: default_lookahead(),
            stop_horizon: default_stop_horizon(),
        }
    }
}

fn default_start() -> Spanned<BTreeMap<String, f64>> {
    Spanned::new(0..0, BTreeMap::new())
}
fn default_kinematics() -> Spanned<String> {
    Spanned::new(0..0, "cartesian".into())
}
fn default_profile() -> Spanned<String> {
    Spanned::new(0..0, "trapezoid".into())
}
fn default_junction_deviation() -> Spanned<f64> {
    Spanned::new(0..0, 0.05)
}
fn default_tolerance() -> Spanned<f64> {
    Spanned::new(0..0, 0.01)
}
fn default_min_radius() -> Spanned<f64> {
    Spanned::new(0..0, 1.0)
}
fn default_lookahead() -> Spanned<i64> {
    Spanned::new(0..0, 4096)
}
/// Half the default node queue of 64: a node can always be given a window it
/// can stop inside, with room to spare for the next.
pub const DEFAULT_STOP_HORIZON: usize = 32;
fn default_stop_horizon() -> Spanned<i64> {
    Spanned::new(0..0, DEFAULT_STOP_HORIZON as i64)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisFile {
    /// `[min, max]`; optional for axes that ride along (extruders). A `Vec`, not
    /// `[f64; 2]`: the TOML deserializer would silently drop a third number.
    #[serde(default)]
    pub travel: Option<Spanned<Vec<f64>>>,
    pub max_velocity: Spanned<f64>,
    pub max_acceleration: Spanned<f64>,
    #[serde(default)]
    pub max_jerk: Option<Spanned<f64>>,
    /// Counts toward path length; defaults to true except for an axis named `e`.
    #[serde(default)]
    pub path: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorFile {
    pub joint: Spanned<String>,
    pub chain: Spanned<Vec<Spanned<ElementFile>>>,
    #[serde(default)]
    pub max_velocity: Option<Spanned<f64>>,
    #[serde(default)]
    pub max_acceleration: Option<Spanned<f64>>,
    /// Step pulse width for the driver, µs.
    #[serde(default)]
    pub pulse_us: Option<Spanned<f64>>,
    /// Direction set-up time for the driver, µs.
    #[serde(default)]
    pub dir_setup_us: Option<Spanned<f64>>,
    /// A servo's loop (its chain ends in an encoder).
    #[serde(default)]
    pub servo: Option<Spanned<ServoFile>>,
    /// A servo's simulated motor and load.
    #[serde(default)]
    pub motor: Option<Spanned<MotorFile>>,
}

/// One element of a chain, e.g. `{ pulley = { teeth = 20, belt_pitch = 2 } }`,
/// `{ microstep = 16 }` or `"invert"`.
#[derive(Debug, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ElementFile {
    Pulley(PulleyFile),
    Leadscrew { lead: f64 },
    Gear { ratio: f64 },
    Stepper { step_angle: f64 },
    Microstep(u32),
    Invert,
    Encoder { lines: u32 },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PulleyFile {
    #[serde(default)]
    pub pitch_diameter: Option<f64>,
    #[serde(default)]
    pub teeth: Option<u32>,
    #[serde(default)]
    pub belt_pitch: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolFile {
    pub kind: Spanned<String>,
    /// Seconds to stand still after switching (servo travel, spin-up).
    #[serde(default)]
    pub settle: Option<Spanned<f64>>,
    /// Value for "on" when a job gives none (pen down = 1, full power = 1).
    #[serde(default)]
    pub on_value: Option<Spanned<f32>>,
}

/// A heater: which temperature commands set it, its highest target, and
/// either its time constant (a simulated first-order lag) or, when a node
/// drives it, its loop, model and runaway watch.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeaterFile {
    /// `hotend` (with `index`), `bed` or `chamber`.
    pub channel: Spanned<String>,
    /// The extruder a hot end heats (M104 T), default 0.
    #[serde(default)]
    pub index: Option<Spanned<i64>>,
    /// °C.
    pub max: Spanned<f64>,
    /// Seconds; needed unless a node drives the heater.
    #[serde(default)]
    pub time_constant: Option<Spanned<f64>>,
    /// A wait is over once the reading is within this of the target, °C.
    #[serde(default)]
    pub window: Option<Spanned<f64>>,
    /// for this long, s.
    #[serde(default)]
    pub residency: Option<Spanned<f64>>,
    #[serde(default)]
    pub pid: Option<Spanned<crate::machine_file_heaters::HeaterPidFile>>,
    #[serde(default)]
    pub model: Option<Spanned<crate::machine_file_heaters::HeaterModelFile>>,
    #[serde(default)]
    pub runaway: Option<Spanned<crate::machine_file_heaters::HeaterRunawayFile>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeFile {
    #[serde(default)]
    pub actuators: Vec<Spanned<String>>,
    #[serde(default)]
    pub tools: Vec<Spanned<String>>,
    /// Heaters it drives (`[heaters.NAME]`), in the order of their index.
    #[serde(default)]
    pub heaters: Vec<Spanned<String>>,
    /// Segment queue capacity the node is built with.
    #[serde(default)]
    pub queue: Option<Spanned<i64>>,
    /// Frame period, µs.
    #[serde(default)]
    pub frame_us: Option<Spanned<f64>>,
    /// Fixed-point time's tolerance, µs: the node solves steps as a board
    /// without a floating-point unit does.
    #[serde(default)]
    pub fixed_time_us: Option<Spanned<f64>>,
    /// Sensors it reads.
    #[serde(default)]
    pub sensors: Vec<Spanned<String>>,
    /// Bytes a second its samples may take upstream.
    #[serde(default)]
    pub sample_budget: Option<Spanned<f64>>,
}
