//! What a dance reports: each channel's steps and position, the stages
//! entered, the graph's final port values; and the render and tape that come
//! with it.

use super::joints::Joints;
use super::node::StepCount;
use super::Recording;
use motet_graph::{ComponentDef, GraphFile};
use motet_node::graph::{Component, PortRef};
use motet_node::NodeGraph;
use motet_render::Stroke;
use serde::Serialize;
use std::collections::BTreeMap;

/// The step counters of every channel (in report order) when a stage was
/// entered: the steps a stage made are the difference to the next mark (or
/// to the channels' final counts).
#[derive(Clone, Debug, Serialize)]
pub struct StageMark {
    /// When the stage was entered, s of simulated time.
    pub t_s: f64,
    /// `name#pass`, or `end`.
    pub stage: String,
    /// Each channel's forward steps so far.
    pub steps_forward: Vec<u64>,
    /// Each channel's reverse steps so far.
    pub steps_reverse: Vec<u64>,
}

/// One graph channel after the run.
#[derive(Clone, Debug, Serialize)]
pub struct DanceChannel {
    /// The channel component's name in the graph file.
    pub name: String,
    /// The machine actuator it drives (none: its steps move no joint).
    pub actuator: Option<String>,
    /// Steps made forward over the run.
    pub steps_forward: u64,
    /// Steps made in reverse over the run.
    pub steps_reverse: u64,
    /// The channel's position, steps (as the runtime counts it).
    pub position_steps: f64,
    /// The exact sum of its inputs, steps.
    pub target_steps: f64,
    /// position − target, steps.
    pub error_steps: f64,
    /// Final joint value of its actuator, joint units.
    pub joint: Option<f64>,
}

/// How a dance went; written as `report.json`.
#[derive(Clone, Debug, Serialize)]
pub struct DanceReport {
    /// The machine's name.
    pub machine: String,
    /// The graph file, as it was named when loaded.
    pub graph: String,
    /// Simulated time run, s (whole frames).
    pub seconds: f64,
    /// The graph's frame period, µs.
    pub frame_us: f64,
    /// Frames the node's graph ran.
    pub frames: u64,
    /// Every graph channel, in the graph file's order.
    pub channels: Vec<DanceChannel>,
    /// Final x, y of the render, mm.
    pub final_xy: [f64; 2],
    /// Stages entered (time s, `name#pass`).
    pub stages: Vec<(f64, String)>,
    /// Each channel's step counters as each stage was entered.
    pub stage_marks: Vec<StageMark>,
    /// Parameter changes sent while running.
    pub param_changes: usize,
    /// Final world value of every port, `component.port`.
    pub ports: BTreeMap<String, f64>,
    /// Planned segments sent to the node (a job running alongside).
    pub job_segments: usize,
    /// When the job's plan ends, s (0 without a job).
    pub job_end_s: f64,
}

impl DanceReport {
    /// A few lines for the terminal: the run's length, then each channel's
    /// steps and how far its position is from the exact target.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{} on {}: {:.2} s, {} frames",
            self.graph, self.machine, self.seconds, self.frames
        );
        for c in &self.channels {
            s += &format!(
                "\n  {}: {} steps (+{} −{}), at {:.0}, exact {:.2} (error {:+.2})",
                c.name,
                c.steps_forward + c.steps_reverse,
                c.steps_forward,
                c.steps_reverse,
                c.position_steps,
                c.target_steps,
                c.error_steps
            );
        }
        s
    }
}

/// Everything a dance produces.
pub struct DanceResult {
    /// The figures.
    pub report: DanceReport,
    /// The render: the pen's path through the machine's kinematics, mm.
    pub strokes: Vec<Stroke>,
    /// The node's tape after the run (what a `recorder` recorded, or the
    /// loaded recording).
    pub recording: Recording,
}

/// Each graph channel's report: its step counts from `board`, position and
/// target from the node's graph `g`, its joint from `joints` (up to date).
pub(super) fn channel_reports(
    channels: &[&ComponentDef],
    g: &NodeGraph,
    board: &StepCount,
    joints: &Joints,
) -> Vec<DanceChannel> {
    let mut out = Vec::new();
    for (k, c) in channels.iter().enumerate() {
        let (pos, target) = match g.component(c.index) {
            Some(Component::Channel(ch)) => (ch.current_position(), ch.target_position()),
            _ => (0.0, 0.0),
        };
        let actuator = joints.actuator(k);
        out.push(DanceChannel {
            name: c.name.clone(),
            actuator: actuator.map(|a| a.name.clone()),
            steps_forward: board.fwd[k],
            steps_reverse: board.rev[k],
            position_steps: pos,
            target_steps: target,
            error_steps: pos - target,
            joint: actuator.map(|a| joints.now[a.joint]),
        });
    }
    out
}

/// The value of every port of `graph`'s components that the node's graph
/// `g` holds, keyed `component.port`.
pub(super) fn port_values(graph: &GraphFile, g: &NodeGraph) -> BTreeMap<String, f64> {
    let mut ports = BTreeMap::new();
    for c in &graph.components {
        for (p, name) in c.info_ports().iter().enumerate() {
            if let Some(v) = g.value(PortRef::new(c.index, p as u8)) {
                ports.insert(format!("{}.{}", c.name, name), v);
            }
        }
    }
    ports
}
