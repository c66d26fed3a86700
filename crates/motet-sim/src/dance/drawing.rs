//! The dance's render: the joints through the machine's kinematics to x, y,
//! with the pen down or up by the graph's pen channel or the job's tool.

use super::PlannedJob;
use crate::path::PathRecorder;
use motet_graph::{ComponentDef, GraphFile};
use motet_host::Machine;
use motet_render::Stroke;
use motet_trajectory::{Point, MAX_AXES};

/// Where the pen is, and what it drew.
pub(super) struct Drawing<'a> {
    machine: &'a Machine,
    /// The machine joints the kinematics' first two joints are (x and y
    /// without named joints); none when the machine lacks them, and the
    /// render stays at the origin.
    xy_joints: Option<(usize, usize)>,
    /// The machine joint that is the kinematics' third (a delta's), which
    /// the pen's x and y depend on too.
    third_joint: Option<usize>,
    /// The graph channel whose position puts the pen down.
    pen: Option<usize>,
    /// Below this position, steps, the pen channel's pen is down.
    pen_down_below: f64,
    /// A job whose tool 0 events put the pen down, when no channel does.
    job_pen: Option<&'a PlannedJob>,
    path: PathRecorder,
}

impl<'a> Drawing<'a> {
    /// An empty drawing; its resolution is 1/2000 of the larger of the first
    /// two axes' travel (100 mm for an axis without a finite travel).
    pub fn new(
        machine: &'a Machine,
        graph: &GraphFile,
        channels: &[&ComponentDef],
        job: Option<&'a PlannedJob>,
    ) -> Drawing<'a> {
        let xy_joints = {
            let names = machine
                .kinematics
                .joints()
                .iter()
                .map(|j| j.name)
                .collect::<Vec<_>>();
            let (a, b) = if names.is_empty() {
                ("x", "y")
            } else {
                (names[0], names[1])
            };
            let f = |n: &str| machine.joints.iter().position(|j| j.name == n);
            f(a).zip(f(b))
        };
        let third_joint = machine
            .kinematics
            .joints()
            .get(2)
            .and_then(|c| machine.joints.iter().position(|j| j.name == c.name));
        let pen = graph
            .render
            .pen_channel
            .as_ref()
            .and_then(|n| channels.iter().position(|c| &c.name == n));
        let span = |i: usize| {
            machine
                .axes
                .get(i)
                .map(|a| a.travel[1] - a.travel[0])
                .filter(|s| s.is_finite() && *s > 0.0)
                .unwrap_or(100.0)
        };
        Drawing {
            machine,
            xy_joints,
            third_joint,
            pen,
            pen_down_below: graph.render.pen_down_below,
            job_pen: job.filter(|j| j.has_tool_events()),
            path: PathRecorder::new(0, 1, span(0).max(span(1)) / 2000.0),
        }
    }

    /// The pen's x, y at `joints`, mm.
    pub fn xy(&self, joints: &[f64]) -> [f64; 2] {
        match self.xy_joints {
            Some((a, b)) => {
                let c = self.third_joint.map_or(0.0, |c| joints[c]);
                let [x, y, _] = self
                    .machine
                    .kinematics
                    .forward_or_nan([joints[a], joints[b], c]);
                [x, y]
            }
            None => [0.0, 0.0],
        }
    }

    /// Adds the pen's place at `joints` at `t_us`, given each graph
    /// channel's net step `counts`.
    pub fn sample(&mut self, joints: &[f64], counts: &[i64], t_us: f64) {
        let p = self.xy(joints);
        let tool_on = self.pen_down(counts, t_us);
        let mut pt: Point = [0.0; MAX_AXES];
        pt[0] = p[0];
        pt[1] = p[1];
        self.path.sample(&pt, tool_on);
    }

    /// Whether the pen is down at `t_us`, given each graph channel's net
    /// step `counts`.
    pub fn pen_down(&self, counts: &[i64], t_us: f64) -> bool {
        match (self.pen, self.job_pen) {
            (Some(k), _) => (counts[k] as f64) < self.pen_down_below,
            (None, Some(j)) => j.tool_on(t_us),
            (None, None) => true,
        }
    }

    /// The strokes drawn.
    pub fn take(&mut self) -> Vec<Stroke> {
        self.path.take()
    }
}
