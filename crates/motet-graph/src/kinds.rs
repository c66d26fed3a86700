//! The component kinds a graph file names, with their parameters.

use motet_wire::message::{GraphInputKind, GraphKind};

/// One component kind as a graph file knows it.
#[derive(Debug)]
pub struct KindInfo {
    /// `kind = "..."` in the graph file.
    pub name: &'static str,
    pub kind: GraphKind,
    /// The hardware input this kind reads (named in `[inputs]`), if any.
    pub input: Option<GraphInputKind>,
    /// Construction parameters in wire order (after the hardware index for
    /// input kinds), with defaults; `None`: required.
    pub build: &'static [(&'static str, Option<f64>)],
    /// Parameters changeable while the graph runs: name and id.
    pub live: &'static [(&'static str, u8)],
    pub doc: &'static str,
}

const INF: f64 = f64::INFINITY;

/// Every kind.
pub const KINDS: &[KindInfo] = &[
    KindInfo {
        name: "analog",
        kind: GraphKind::AnalogInput,
        input: Some(GraphInputKind::Analog),
        build: &[
            ("floor_value", Some(0.0)),
            ("floor_raw", Some(0.0)),
            ("ceiling_value", Some(1.0)),
            ("ceiling_raw", Some(1023.0)),
            ("deadband_center", Some(0.0)),
            ("deadband_width", Some(0.0)),
            ("average", Some(1.0)),
        ],
        live: &[
            ("floor_value", 0),
            ("floor_raw", 1),
            ("ceiling_value", 2),
            ("ceiling_raw", 3),
            ("deadband_center", 4),
            ("deadband_width", 5),
            ("average", 6),
        ],
        doc: "analog reading mapped from raw floor..ceiling to values, deadband, averaging; port `value` (level)",
    },
    KindInfo {
        name: "button",
        kind: GraphKind::Button,
        input: Some(GraphInputKind::Digital),
        build: &[("toggle", Some(0.0)), ("debounce_ms", Some(5.0))],
        live: &[("debounce_ms", 0)],
        doc: "debounced digital input (1 kHz), standard or toggle; port `state` (level, 0/1)",
    },
    KindInfo {
        name: "encoder",
        kind: GraphKind::Encoder,
        input: Some(GraphInputKind::Encoder),
        build: &[("invert", Some(0.0))],
        live: &[("invert", 0)],
        doc: "quadrature count; `ratio` = world units per count; port `count` (alias `out`)",
    },
    KindInfo {
        name: "stream_input",
        kind: GraphKind::StreamInput,
        input: Some(GraphInputKind::Stream),
        build: &[],
        live: &[],
        doc: "motion-stream input port; ports `x y r t z e`",
    },
    KindInfo {
        name: "scale",
        kind: GraphKind::ScalingFilter1D,
        input: None,
        build: &[("ratio", Some(1.0)), ("mode", Some(0.0))],
        live: &[("ratio", 0)],
        doc: "out = in × ratio, `mode` incremental (changes scaled) or absolute; ports `in`, `out`",
    },
    KindInfo {
        name: "scale2d",
        kind: GraphKind::ScalingFilter2D,
        input: None,
        build: &[("ratio", Some(1.0)), ("mode", Some(0.0))],
        live: &[("ratio", 0)],
        doc: "two inputs scaled alike; ports `in_x in_y out_x out_y`",
    },
    KindInfo {
        name: "threshold",
        kind: GraphKind::ThresholdGenerator,
        input: None,
        build: &[("lower", None), ("upper", None)],
        live: &[("lower", 0), ("upper", 1)],
        doc: "clamps between lower and upper, flag −1/0/+1; ports `in out flag`",
    },
    KindInfo {
        name: "corexy",
        kind: GraphKind::CoreXY,
        input: None,
        build: &[],
        live: &[],
        doc: "a = x + y, b = x − y; ports `x y a b`",
    },
    KindInfo {
        name: "polar",
        kind: GraphKind::PolarToCartesian,
        input: None,
        build: &[],
        live: &[],
        doc: "x = r cos θ, y = r sin θ (θ radians; also the Lever); ports `r theta x y`",
    },
    KindInfo {
        name: "fivebar",
        kind: GraphKind::FiveBarForward,
        input: None,
        build: &[
            ("s", None),
            ("l1", None),
            ("l2", None),
            ("l3", None),
            ("l4", None),
            ("ext", Some(0.0)),
        ],
        live: &[("s", 0), ("l1", 1), ("l2", 2), ("l3", 3), ("l4", 4), ("ext", 5)],
        doc: "five-bar linkage forward kinematics (pivots s apart); ports `theta1 theta2 x y`",
    },
    KindInfo {
        name: "velocity",
        kind: GraphKind::VelocityGenerator,
        input: None,
        build: &[("speed", Some(0.0))],
        live: &[("speed", 0)],
        doc: "integrates a speed (units/s); ports `speed` (level), `out`",
    },
    KindInfo {
        name: "position",
        kind: GraphKind::PositionGenerator,
        input: None,
        build: &[("speed", Some(0.0))],
        live: &[("speed", 0), ("go", 1), ("go_relative", 2), ("stop", 3)],
        doc: "moves to a target at constant speed (`go` absolute, `go_relative`); port `out`",
    },
    KindInfo {
        name: "wave",
        kind: GraphKind::WaveGenerator1D,
        input: None,
        build: &[
            ("amplitude", None),
            ("frequency", Some(0.0)),
            ("phase", Some(0.0)),
            ("per_input", Some(0.0)),
        ],
        live: &[("amplitude", 0), ("frequency", 1), ("phase", 2), ("per_input", 3)],
        doc: "amplitude × sin(2π·cycles + phase); cycles advance by frequency (Hz) and per_input × drive change; ports `drive out`",
    },
    KindInfo {
        name: "wave2d",
        kind: GraphKind::WaveGenerator2D,
        input: None,
        build: &[
            ("amplitude", None),
            ("frequency", Some(0.0)),
            ("phase", Some(0.0)),
            ("per_distance", Some(0.0)),
        ],
        live: &[
            ("amplitude", 0),
            ("frequency", 1),
            ("phase", 2),
            ("per_distance", 3),
        ],
        doc: "adds a sine across the direction of travel; ports `in_x in_y out_x out_y`",
    },
    KindInfo {
        name: "circle",
        kind: GraphKind::CircleGenerator,
        input: None,
        build: &[("radius", None), ("rev_per_s", None)],
        live: &[("radius", 0), ("rev_per_s", 1)],
        doc: "a circle from where it starts; ports `x y`",
    },
    KindInfo {
        name: "path_length",
        kind: GraphKind::PathLength2D,
        input: None,
        build: &[("ratio", Some(1.0))],
        live: &[("ratio", 0)],
        doc: "out grows by ratio × distance travelled by (in_x, in_y); ports `in_x in_y out`",
    },
    KindInfo {
        name: "path_length3d",
        kind: GraphKind::PathLength3D,
        input: None,
        build: &[("ratio", Some(1.0))],
        live: &[("ratio", 0)],
        doc: "path length in 3D; ports `in_x in_y in_z out`",
    },
    KindInfo {
        name: "recorder",
        kind: GraphKind::FourTrackRecorder,
        input: None,
        build: &[],
        live: &[("record", 0)],
        doc: "four-track recorder (0.01 units per recorded step); ports `track0..track3`",
    },
    KindInfo {
        name: "player",
        kind: GraphKind::FourTrackPlayer,
        input: None,
        build: &[("loop", Some(0.0))],
        live: &[("play", 0), ("loop", 1)],
        doc: "four-track player; ports `track0..track3`",
    },
    KindInfo {
        name: "homing",
        kind: GraphKind::Homing,
        input: None,
        build: &[("speed", None), ("backoff", Some(0.0)), ("home", Some(0.0))],
        live: &[("start", 0), ("speed", 1), ("backoff", 2), ("home", 3)],
        doc: "seek until the limit, back off, reset the chain to home; ports `limit` (level), `out`",
    },
    KindInfo {
        name: "trajectory_reader",
        kind: GraphKind::TrajectoryReader,
        input: None,
        build: &[("axis", Some(0.0))],
        live: &[("axis", 0)],
        doc: "the node's planned trajectory, one machine axis (index); port `position`",
    },
    KindInfo {
        name: "channel",
        kind: GraphKind::Channel,
        input: None,
        build: &[
            ("filter", Some(0.0)),
            ("invert", Some(0.0)),
            ("max_pulse_rate", Some(0.0)),
            ("lower", Some(-INF)),
            ("upper", Some(INF)),
            ("output", Some(-1.0)),
            ("signal", Some(0.0)),
        ],
        live: &[
            ("filter", 0),
            ("invert", 1),
            ("max_pulse_rate", 2),
            ("lower", 3),
            ("upper", 4),
        ],
        doc: "step channel: `units` world units are `steps` steps; ports `target target_b position`",
    },
];

/// The kind named `name` in a graph file.
pub fn kind(name: &str) -> Option<&'static KindInfo> {
    KINDS.iter().find(|k| k.name == name)
}

/// The kind of a wire kind.
pub fn info(kind: GraphKind) -> &'static KindInfo {
    KINDS
        .iter()
        .find(|k| k.kind == kind)
        .expect("every kind is listed")
}

/// Keys a component table may hold besides its kind's parameters.
pub const COMMON_KEYS: &[&str] = &["kind", "ratios"];
/// Extra keys per kind.
pub fn extra_keys(kind: GraphKind) -> &'static [&'static str] {
    match kind {
        GraphKind::Encoder => &["ratio"],
        GraphKind::Channel => &["units", "steps", "actuator"],
        _ => &[],
    }
}

/// Names of the kinds, for messages.
pub fn kind_names() -> String {
    KINDS.iter().map(|k| k.name).collect::<Vec<_>>().join(", ")
}
