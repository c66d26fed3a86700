//! The run: set the node up, then frame after frame feed it the inputs, the
//! stages' parameter changes and the job's segments, let it step, and draw
//! where its channels put the machine; report at the end.

use super::drawing::Drawing;
use super::inputs::{source_changes, InputFeed};
use super::job_feed::JobFeed;
use super::joints::Joints;
use super::node::{start_node, DanceNode, StepCount};
use super::report::{channel_reports, port_values};
use super::stages::Stages;
use super::{DanceError, DanceReport, DanceResult, InputSource, PlannedJob, Recording};
use motet_graph::{ComponentDef, GraphFile};
use motet_host::Machine;

/// What runs alongside the graph, and what the node's tape starts with.
#[derive(Clone, Copy, Debug, Default)]
pub struct DanceOptions<'a> {
    /// A planned job (see [`run_dance_with_job`]).
    pub job: Option<&'a PlannedJob>,
    /// A recording loaded into the node's tape after the graph is committed,
    /// for a `player`.
    pub recording: Option<&'a Recording>,
}

/// Runs `graph` on a simulated node for `seconds`, fed by `inputs`; renders
/// the channels' steps through `machine` (each graph channel drives the
/// actuator its `actuator` key names, else the machine's actuator of the
/// same ordinal). `progress` gets the fraction done.
pub fn run_dance(
    machine: &Machine,
    graph: &GraphFile,
    inputs: &mut dyn InputSource,
    seconds: f64,
    progress: &mut dyn FnMut(f64),
) -> Result<DanceResult, DanceError> {
    run_dance_with_job(machine, graph, inputs, None, seconds, progress)
}

/// [`run_dance`] with a planned job alongside: its segments go to the node
/// through the machine's [`Distributor`](motet_host::Distributor) (the first node's subscription,
/// widened to every machine axis so a `trajectory_reader` can follow any),
/// as the node's queue makes room, interleaved with the graph frames. The
/// render draws pen-up moves as travel by the job's tool 0 events when the
/// graph names no pen channel.
pub fn run_dance_with_job(
    machine: &Machine,
    graph: &GraphFile,
    inputs: &mut dyn InputSource,
    job: Option<&PlannedJob>,
    seconds: f64,
    progress: &mut dyn FnMut(f64),
) -> Result<DanceResult, DanceError> {
    let options = DanceOptions {
        job,
        recording: None,
    };
    run_dance_with(machine, graph, inputs, options, seconds, progress)
}

/// [`run_dance_with_job`] with `options.recording`, when given, loaded into
/// the node's tape once the graph is committed (refused when it does not
/// fit the tape, [`super::DANCE_TAPE`] bytes).
pub fn run_dance_with(
    machine: &Machine,
    graph: &GraphFile,
    inputs: &mut dyn InputSource,
    options: DanceOptions<'_>,
    seconds: f64,
    progress: &mut dyn FnMut(f64),
) -> Result<DanceResult, DanceError> {
    let mut dance = Dance::new(machine, graph, options)?;
    // Whole frames; the report's `seconds` is what they span.
    let n_frames = (seconds * 1e6 / graph.frame_us).round().max(0.0) as u64;
    let every = (n_frames / 200).max(1);
    for f in 0..n_frames {
        dance.frame(f as f64 * graph.frame_us, inputs)?;
        if f % every == 0 {
            progress(f as f64 / n_frames as f64);
        }
    }
    progress(1.0);
    Ok(dance.finish(n_frames))
}

/// A dance in progress: the node and everything fed to it or taken from it.
pub(super) struct Dance<'a> {
    machine: &'a Machine,
    graph: &'a GraphFile,
    job: Option<&'a PlannedJob>,
    /// The graph's channels, in the graph file's order.
    channels: Vec<&'a ComponentDef>,
    joints: Joints<'a>,
    drawing: Drawing<'a>,
    node: Box<DanceNode>,
    board: StepCount,
    inputs: InputFeed,
    stages: Stages,
    job_feed: JobFeed,
}

impl<'a> Dance<'a> {
    /// Maps the channels on the machine, builds the graph on a new node (with
    /// the recording in its tape) and readies the job's feed, in that order:
    /// the first that fails is the error.
    pub(super) fn new(
        machine: &'a Machine,
        graph: &'a GraphFile,
        options: DanceOptions<'a>,
    ) -> Result<Dance<'a>, DanceError> {
        let channels: Vec<_> = graph.channels().collect();
        let joints = Joints::new(machine, graph, &channels)?;
        let drawing = Drawing::new(machine, graph, &channels, options.job);
        let node = start_node(graph, options.recording)?;
        let job_feed = JobFeed::new(machine, options.job)?;
        let board = StepCount::new(&node, channels.len());
        Ok(Dance {
            machine,
            graph,
            job: options.job,
            channels,
            joints,
            drawing,
            node,
            board,
            inputs: InputFeed::new(graph),
            stages: Stages::new(graph),
            job_feed,
        })
    }

    /// The frame starting at `t_us`: inputs, the source's parameter
    /// changes, stages and job segments reach the node, it runs to the
    /// frame's end, and the drawing follows any steps it made.
    pub(super) fn frame(
        &mut self,
        t_us: f64,
        source: &mut dyn InputSource,
    ) -> Result<(), DanceError> {
        let node = &mut self.node;
        self.inputs.update(t_us * 1e-6, source, self.graph, node)?;
        source_changes(source, node);
        let values = &self.inputs.values;
        self.stages
            .update(t_us, self.graph, values, node, &self.board, source)?;
        self.job_feed.fill(node)?;
        node.poll(t_us + self.graph.frame_us, &mut self.board);
        if self.board.moved {
            self.board.moved = false;
            self.joints.update(&self.board.counts);
            self.drawing
                .sample(&self.joints.now, &self.board.counts, t_us);
        }
        Ok(())
    }

    /// The pen's x, y now, mm.
    pub(super) fn xy(&self) -> [f64; 2] {
        self.drawing.xy(&self.joints.now)
    }

    /// Drops the strokes drawn so far (a dance that runs for days keeps
    /// its memory bounded; its watcher keeps what it needs).
    pub(super) fn forget_drawing(&mut self) {
        self.drawing.take();
    }

    /// Whether the pen is down now.
    pub(super) fn pen_down(&self) -> bool {
        let t_us = self.node.graph_frames() as f64 * self.graph.frame_us;
        self.drawing.pen_down(&self.board.counts, t_us)
    }

    /// The report after `n_frames` frames, the drawing and the node's tape.
    pub(super) fn finish(mut self, n_frames: u64) -> DanceResult {
        let g = self.node.graph().expect("committed");
        self.joints.update(&self.board.counts);
        let report = DanceReport {
            machine: self.machine.name.clone(),
            graph: self.graph.file.clone(),
            seconds: n_frames as f64 * self.graph.frame_us * 1e-6,
            frame_us: self.graph.frame_us,
            frames: self.node.graph_frames(),
            channels: channel_reports(&self.channels, g, &self.board, &self.joints),
            final_xy: self.drawing.xy(&self.joints.now),
            stages: self.stages.log().to_vec(),
            stage_marks: self.stages.marks,
            param_changes: self.stages.param_changes,
            ports: port_values(self.graph, g),
            job_segments: self.job_feed.sent,
            job_end_s: self.job.map_or(0.0, |j| j.end_us * 1e-6),
        };
        DanceResult {
            report,
            strokes: self.drawing.take(),
            recording: Recording {
                bytes: self.node.tape().to_vec(),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dance::{CsvTrace, DanceChannel, Pendulums};
    use std::path::{Path, PathBuf};

    fn example(name: &str) -> (Machine, GraphFile, PathBuf) {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/dance")
            .join(name);
        let m = Machine::load(&dir.join("machine.toml")).unwrap();
        let g = GraphFile::load(&dir.join("graph.toml")).unwrap();
        (m, g, dir)
    }

    fn channel<'a>(r: &'a DanceReport, name: &str) -> &'a DanceChannel {
        r.channels.iter().find(|c| c.name == name).unwrap()
    }

    #[test]
    fn harmonograph_follows_the_pendulums_exactly() {
        let (m, g, _) = example("harmonograph");
        let mut p = Pendulums::from_graph(&g).unwrap();
        let r = run_dance(&m, &g, &mut p, 20.0, &mut |_| {}).unwrap();
        assert_eq!(r.report.frames, 500_000);
        for c in &r.report.channels {
            assert!(c.error_steps.abs() <= 0.5, "{c:?}");
            assert!(
                c.steps_forward > 10_000 && c.steps_reverse > 10_000,
                "{c:?}"
            );
        }
        // The figure spans about ±40 mm in x and y.
        let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
        for s in &r.strokes {
            for q in &s.points {
                for k in 0..2 {
                    lo[k] = lo[k].min(q[k]);
                    hi[k] = hi[k].max(q[k]);
                }
            }
        }
        for k in 0..2 {
            assert!(
                hi[k] - lo[k] > 50.0 && hi[k] - lo[k] < 81.0,
                "{lo:?} {hi:?}"
            );
        }
    }

    #[test]
    fn step_a_sketch_draws_with_pen_toggles() {
        let (m, g, dir) = example("step-a-sketch");
        let mut t = CsvTrace::load(&dir.join("inputs.csv"), &g).unwrap();
        let end = t.end();
        let r = run_dance(&m, &g, &mut t, end, &mut |_| {}).unwrap();
        // down, up, down, up, down, up: three pen-down strokes.
        let names: Vec<&str> = r.report.stages.iter().map(|s| s.1.as_str()).collect();
        assert_eq!(
            names,
            ["down#1", "up#1", "down#1", "up#1", "down#1", "up#1"]
        );
        let down = r.strokes.iter().filter(|s| s.tool_on).count();
        assert_eq!(
            down,
            3,
            "{:?}",
            r.strokes.iter().map(|s| s.tool_on).collect::<Vec<_>>()
        );
        assert_eq!(channel(&r.report, "ch_pen").position_steps, 200.0);
        for c in &r.report.channels {
            assert!(c.error_steps.abs() <= 0.5, "{c:?}");
        }
        // The knobs end at (35, 15) mm.
        let [x, y] = r.report.final_xy;
        assert!(
            (x - 35.0).abs() < 0.02 && (y - 15.0).abs() < 0.02,
            "{x} {y}"
        );
    }

    #[test]
    fn wheelbot_rises_a_layer_per_turn() {
        let (m, g, dir) = example("wheelbot");
        let mut t = CsvTrace::load(&dir.join("inputs.csv"), &g).unwrap();
        let r = run_dance(&m, &g, &mut t, 25.0, &mut |_| {}).unwrap();
        let theta = r.report.ports["polar.theta"];
        // 1.375 rad/s for 23.9 s, then the pedal ramps up over 0.1 s.
        assert!((theta - 1.375 * 23.95).abs() < 0.01, "{theta}");
        let turns = theta / std::f64::consts::TAU;
        let z = channel(&r.report, "ch_z");
        // 2 mm per turn at 400 steps/mm.
        assert!(
            (z.position_steps - turns * 2.0 * 400.0).abs() <= 0.5,
            "{z:?}"
        );
        assert!((z.joint.unwrap() - turns * 2.0).abs() <= 0.5 / 400.0);
        assert!(channel(&r.report, "ch_e").steps_forward > 1000);
        assert_eq!(r.report.stages.len(), 2);
        for c in &r.report.channels {
            assert!(c.error_steps.abs() <= 0.5, "{c:?}");
        }
    }
}
