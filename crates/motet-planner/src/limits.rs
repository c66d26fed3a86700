//! The machine's motion limits as the planner sees them.

use motet_trajectory::{JointMap, ProfileKind, MAX_AXES};

/// Limits of one machine axis, in axis units per second (squared, cubed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisLimits {
    /// Fastest the axis moves, units/s; caps a move's speed by the axis's
    /// share of the move's direction.
    pub max_velocity: f64,
    /// Hardest it accelerates, units/s²; bounds a move's acceleration the
    /// same way.
    pub max_acceleration: f64,
    /// Only used with [`ProfileKind::SCurve`].
    pub max_jerk: Option<f64>,
    /// Counts toward path length (x, y, z) rather than riding along (extruders).
    pub path: bool,
}

/// Limits of a joint after kinematics (a CoreXY motor, a polar turntable), in joint
/// units per second (squared).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointLimits {
    /// How the joint follows from machine-space points; the planner
    /// samples its rate per mm of path along each move.
    pub map: JointMap,
    /// Fastest the joint moves, joint units/s (infinite: only the axes'
    /// limits count). The host lowers it to what the motors' step rate
    /// allows.
    pub max_velocity: f64,
    /// Hardest it accelerates, joint units/s² (infinite: unbounded).
    pub max_acceleration: f64,
}

/// How a tool output is switched.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolTiming {
    /// Motion comes to rest before the change (pen lift, spindle start); otherwise
    /// the change happens on the fly at its place on the path (laser power).
    pub stop: bool,
    /// Seconds to stand still after the change (servo travel, spin-up).
    pub settle: f64,
}

/// Everything the planner obeys: the machine file's limits and motion
/// settings, gathered by the host (`Machine::limits`).
#[derive(Clone, Debug, PartialEq)]
pub struct Limits {
    /// One entry per machine axis, in axis index order (at most [`MAX_AXES`]).
    pub axes: Vec<AxisLimits>,
    /// Extra limits after kinematics.
    pub joints: Vec<JointLimits>,
    /// grbl-style junction deviation, mm.
    pub junction_deviation: f64,
    /// Trapezoid or S-curve ramps; S-curves use the axes' `max_jerk`.
    pub profile: ProfileKind,
    /// One entry per tool index used by [`crate::Command::Tool`].
    pub tools: Vec<ToolTiming>,
    /// Most moves held for lookahead before the oldest is planned as if the queue
    /// ended there (safe, slower). Bounds memory on endless streams of tiny moves.
    pub lookahead: usize,
    /// Stop horizon in moves (0: none). At every move boundary the speed stays
    /// low enough to come to rest within the next this many moves, each at its
    /// own acceleration: `v_i ≤ √(2 Σ_{j=i}^{i+n-1} a_j L_j)`. A node holding
    /// at least this many segments can then always be given a window it can
    /// stop inside, so tiny fast moves slow the machine down instead of
    /// outrunning a node's queue.
    pub stop_horizon: usize,
    /// Shortest time a move may take, seconds (0: none): a move's speed is
    /// capped at its length over this. A networked run sets it so that the
    /// segments a node can hold always last long enough for a seal to reach
    /// it, however short the moves.
    pub min_move_s: f64,
    /// Longest time a move should take, seconds (0: none): longer moves are
    /// planned as straight pieces of about this duration (at their feed),
    /// with the same speeds. A server sets it so that a hold or a stop,
    /// which brakes at the end of the segments already committed, starts
    /// braking soon after it is asked, whatever the moves' lengths.
    pub max_move_s: f64,
}

impl Limits {
    /// Bit i set: axis i counts toward path length.
    pub fn path_mask(&self) -> u8 {
        let mut m = 0;
        for (i, a) in self.axes.iter().enumerate().take(MAX_AXES) {
            if a.path {
                m |= 1 << i;
            }
        }
        m
    }
}
