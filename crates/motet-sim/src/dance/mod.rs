//! Dance: a node hosting a dataflow graph (built from a graph file through
//! the wire messages), driven by external inputs (a CSV trace or two damped
//! pendulums), with the steps of its channels rendered through a machine
//! file's kinematics. A planned job may run alongside: its segments reach
//! the node through the machine's distributor, interleaved in time with the
//! graph frames, so `trajectory_reader` components follow it.

pub mod live;

use crate::path::PathRecorder;
use motet_graph::{GraphFile, StageMachine, StageView};
use motet_host::{Distributor, Machine};
use motet_node::graph::{Component, PortRef};
use motet_node::{Board, Node};
use motet_planner::{Command, Located, PlanError, Planned, Planner, SourceLoc};
use motet_render::Stroke;
use motet_trajectory::{Point, MAX_AXES};
use motet_wire::message::GraphInputKind;
use motet_wire::{encode, HostMessage, NodeMessage, MAX_MESSAGE};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Recording tape of the simulated node, bytes (one per core frame: 10 s at
/// 25 kHz).
pub const DANCE_TAPE: usize = 256 * 1024;

#[derive(Debug, thiserror::Error)]
pub enum DanceError {
    #[error("{file}:{line}:{column}: {message}")]
    Trace {
        file: String,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("the node refused {what}: {reason}")]
    Refused {
        what: String,
        reason: motet_wire::Refusal,
    },
    #[error("{0}")]
    Setup(String),
    #[error("{loc}: {error}")]
    Plan { loc: SourceLoc, error: PlanError },
    /// A recording file that cannot be read, written or loaded.
    #[error("{file}: {message}")]
    Recording { file: String, message: String },
}

/// A four-track recording in the paper's format: the bytes (one per frame,
/// track `i` in bits `2i..2i+1`: `11` forward, `10` reverse, `00` none) and
/// the sample count, kept apart (a file `PATH` with the bytes and `PATH.len`
/// with the count as decimal text and a newline).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Recording {
    /// The samples, exactly `len` of them.
    pub bytes: Vec<u8>,
}

impl Recording {
    /// Sample count.
    pub fn len(&self) -> usize {
        self.bytes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// The companion file of `path`: `path` with `.len` appended.
    pub fn len_path(path: &Path) -> std::path::PathBuf {
        let mut s = path.as_os_str().to_owned();
        s.push(".len");
        s.into()
    }

    /// Each sample's steps, tracks 0..3 (−1, 0, +1).
    pub fn steps(&self) -> impl Iterator<Item = [i8; 4]> + '_ {
        self.bytes
            .iter()
            .map(|&b| motet_node::graph::record::unpack(b))
    }

    /// Forward and reverse steps of each track.
    pub fn counts(&self) -> [(u64, u64); 4] {
        let mut out = [(0u64, 0u64); 4];
        for s in self.steps() {
            for (o, x) in out.iter_mut().zip(s) {
                match x {
                    1 => o.0 += 1,
                    -1 => o.1 += 1,
                    _ => {}
                }
            }
        }
        out
    }

    /// Writes `path` (the bytes) and `path.len` (the sample count).
    pub fn save(&self, path: &Path) -> Result<(), DanceError> {
        let err = |p: &Path, e: std::io::Error| DanceError::Recording {
            file: p.display().to_string(),
            message: format!("cannot write: {e}"),
        };
        std::fs::write(path, &self.bytes).map_err(|e| err(path, e))?;
        let lp = Recording::len_path(path);
        std::fs::write(&lp, format!("{}\n", self.len())).map_err(|e| err(&lp, e))
    }

    /// Reads `path` and `path.len`: the count must be a decimal number (blank
    /// space around it is allowed) no larger than the bytes `path` holds;
    /// bytes past the count are ignored.
    pub fn load(path: &Path) -> Result<Recording, DanceError> {
        let lp = Recording::len_path(path);
        let err = |p: &Path, message: String| DanceError::Recording {
            file: p.display().to_string(),
            message,
        };
        let text = std::fs::read_to_string(&lp).map_err(|e| {
            err(
                &lp,
                format!("cannot read the sample count of {}: {e}", path.display()),
            )
        })?;
        let t = text.trim();
        let len: usize = t
            .parse()
            .ok()
            .filter(|_| t.bytes().all(|b| b.is_ascii_digit()))
            .ok_or_else(|| {
                err(
                    &lp,
                    format!("expected the sample count as a decimal number, found `{t}`"),
                )
            })?;
        let mut bytes = std::fs::read(path).map_err(|e| err(path, format!("cannot read: {e}")))?;
        if len > bytes.len() {
            return Err(err(
                &lp,
                format!(
                    "says {len} samples, but {} holds only {} bytes",
                    path.display(),
                    bytes.len()
                ),
            ));
        }
        bytes.truncate(len);
        Ok(Recording { bytes })
    }
}

/// What runs alongside the graph, and what the node's tape starts with.
#[derive(Clone, Copy, Debug, Default)]
pub struct DanceOptions<'a> {
    /// A planned job (see [`run_dance_with_job`]).
    pub job: Option<&'a PlannedJob>,
    /// A recording loaded into the node's tape after the graph is committed,
    /// for a `player`.
    pub recording: Option<&'a Recording>,
}

/// A job planned for the machine, to run alongside the graph.
#[derive(Clone, Debug)]
pub struct PlannedJob {
    /// Everything the planner emitted, in order.
    pub items: Vec<Planned>,
    /// When the last item ends, µs.
    pub end_us: f64,
}

impl PlannedJob {
    /// Plans `commands` on `machine` from its start point at time 0.
    pub fn plan(
        machine: &Machine,
        commands: &[Located<Command>],
    ) -> Result<PlannedJob, DanceError> {
        let mut planner = Planner::new(machine.limits(), machine.start, 0.0);
        let mut items = Vec::new();
        for c in commands {
            planner
                .push(&c.item)
                .map_err(|error| DanceError::Plan { loc: c.loc, error })?;
            while let Some(item) = planner.pop() {
                items.push(item);
            }
        }
        planner.finish();
        while let Some(item) = planner.pop() {
            items.push(item);
        }
        Ok(PlannedJob {
            items,
            end_us: planner.clock(),
        })
    }

    /// The planned segments.
    pub fn segments(&self) -> impl Iterator<Item = &motet_trajectory::Segment> {
        self.items.iter().filter_map(|i| match i {
            Planned::Segment(s) => Some(s),
            _ => None,
        })
    }

    /// The planned position at `t_us`: the segment covering it (before the
    /// first, the first's start; after the last, the last's end).
    pub fn position_at(&self, t_us: f64) -> Option<Point> {
        let mut last = None;
        for s in self.segments() {
            if t_us < s.t0 {
                return Some(last.unwrap_or(s.start));
            }
            if t_us < s.t1() {
                return Some(s.position_at(t_us));
            }
            last = Some(s.end);
        }
        last
    }

    /// Whether tool 0 (the pen) is on at `t_us`, by its planned events.
    fn tool_on(&self, t_us: f64) -> bool {
        let mut on = false;
        for i in &self.items {
            if let Planned::Event(e) = i {
                if e.tool == 0 && e.time <= t_us {
                    on = e.value > 0.0;
                }
            }
        }
        on
    }

    fn has_tool_events(&self) -> bool {
        self.items
            .iter()
            .any(|i| matches!(i, Planned::Event(e) if e.tool == 0))
    }
}

/// External input values over time, one per input of the graph's `[inputs]`
/// (in that order).
pub trait InputSource {
    fn values(&mut self, t_s: f64, out: &mut [f64]);
}

/// A CSV trace: a header `time_s,<input>,<input>...` naming inputs of the
/// graph, then rows of numbers with increasing times. Encoders and analog
/// inputs are interpolated linearly, buttons hold their value until the next
/// row. Inputs without a column stay 0; before the first row the first row's
/// values hold, after the last the last's.
#[derive(Clone, Debug)]
pub struct CsvTrace {
    /// For each graph input, its column (or none).
    columns: Vec<Option<usize>>,
    step: Vec<bool>,
    times: Vec<f64>,
    rows: Vec<Vec<f64>>,
    cursor: usize,
}

impl CsvTrace {
    pub fn load(path: &Path, graph: &GraphFile) -> Result<CsvTrace, DanceError> {
        let text = std::fs::read_to_string(path).map_err(|e| DanceError::Trace {
            file: path.display().to_string(),
            line: 0,
            column: 0,
            message: format!("cannot read: {e}"),
        })?;
        CsvTrace::parse(&text, &path.display().to_string(), graph)
    }

    pub fn parse(text: &str, file: &str, graph: &GraphFile) -> Result<CsvTrace, DanceError> {
        let err = |line: usize, column: usize, message: String| DanceError::Trace {
            file: file.to_string(),
            line,
            column,
            message,
        };
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let Some((hl, header)) = lines.next() else {
            return Err(err(
                1,
                1,
                "empty trace: expected a header `time_s,...`".into(),
            ));
        };
        // Fields with their 1-based columns.
        let fields = |l: &str| {
            let mut col = 1;
            l.split(',')
                .map(|f| {
                    let c = col + (f.len() - f.trim_start().len());
                    col += f.chars().count() + 1;
                    (c, f.trim().to_string())
                })
                .collect::<Vec<_>>()
        };
        let head = fields(header);
        if head[0].1 != "time_s" {
            return Err(err(
                hl + 1,
                head[0].0,
                format!("the first column must be `time_s`, not `{}`", head[0].1),
            ));
        }
        let mut columns = vec![None; graph.inputs.len()];
        for (k, (c, name)) in head.iter().enumerate().skip(1) {
            let Some(i) = graph.inputs.iter().position(|d| &d.name == name) else {
                return Err(err(
                    hl + 1,
                    *c,
                    format!(
                        "`{name}` is not an input of the graph; its inputs: {}",
                        graph
                            .inputs
                            .iter()
                            .map(|d| d.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ));
            };
            if columns[i].is_some() {
                return Err(err(hl + 1, *c, format!("`{name}` appears twice")));
            }
            columns[i] = Some(k - 1);
        }
        let mut times: Vec<f64> = Vec::new();
        let mut rows = Vec::new();
        for (ln, l) in lines {
            let f = fields(l);
            if f.len() != head.len() {
                return Err(err(
                    ln + 1,
                    f.last().map_or(1, |x| x.0),
                    format!("expected {} fields, found {}", head.len(), f.len()),
                ));
            }
            let mut row = Vec::with_capacity(f.len());
            for (c, v) in &f {
                let x: f64 = v
                    .parse()
                    .ok()
                    .filter(|x: &f64| x.is_finite())
                    .ok_or_else(|| err(ln + 1, *c, format!("`{v}` is not a number")))?;
                row.push(x);
            }
            let t = row.remove(0);
            if times.last().is_some_and(|&p| t <= p) {
                return Err(err(ln + 1, f[0].0, format!("time {t} does not increase")));
            }
            times.push(t);
            rows.push(row);
        }
        if rows.is_empty() {
            return Err(err(hl + 1, 1, "the trace has no rows".into()));
        }
        let step = graph
            .inputs
            .iter()
            .map(|d| d.kind == GraphInputKind::Digital)
            .collect();
        Ok(CsvTrace {
            columns,
            step,
            times,
            rows,
            cursor: 0,
        })
    }

    /// Time of the last row, s.
    pub fn end(&self) -> f64 {
        *self.times.last().unwrap_or(&0.0)
    }
}

impl InputSource for CsvTrace {
    fn values(&mut self, t: f64, out: &mut [f64]) {
        if self.cursor > 0 && self.times[self.cursor] > t {
            self.cursor = 0;
        }
        while self.cursor + 1 < self.times.len() && self.times[self.cursor + 1] <= t {
            self.cursor += 1;
        }
        let k = self.cursor;
        for (i, o) in out.iter_mut().enumerate() {
            let Some(c) = self.columns.get(i).copied().flatten() else {
                *o = 0.0;
                continue;
            };
            let a = self.rows[k][c];
            *o = if self.step[i] || k + 1 >= self.times.len() || t <= self.times[k] {
                a
            } else {
                let b = self.rows[k + 1][c];
                let u = (t - self.times[k]) / (self.times[k + 1] - self.times[k]);
                a + (b - a) * u
            };
        }
    }
}

/// Damped pendulums swinging inputs (the harmonograph): each input reads
/// `amplitude · e^(−damping·t) · sin(2π·frequency·t + phase)`.
#[derive(Clone, Debug)]
pub struct Pendulums {
    /// (input index, amplitude, frequency, damping, phase).
    swings: Vec<(usize, f64, f64, f64, f64)>,
}

impl Pendulums {
    /// The graph file's `[[pendulum]]` entries; without any, two pendulums on
    /// the first two encoder inputs (2000 counts, 1 Hz and 1.5 Hz, damping
    /// 0.02/s, a quarter turn apart).
    pub fn from_graph(graph: &GraphFile) -> Result<Pendulums, DanceError> {
        let mut swings = Vec::new();
        if graph.pendulums.is_empty() {
            let enc: Vec<usize> = graph
                .inputs
                .iter()
                .enumerate()
                .filter(|(_, d)| d.kind == GraphInputKind::Encoder)
                .map(|(i, _)| i)
                .take(2)
                .collect();
            if enc.len() < 2 {
                return Err(DanceError::Setup(
                    "pendulums need two encoder inputs or [[pendulum]] entries".into(),
                ));
            }
            swings.push((enc[0], 2000.0, 1.0, 0.02, std::f64::consts::FRAC_PI_2));
            swings.push((enc[1], 2000.0, 1.5, 0.02, 0.0));
        }
        for p in &graph.pendulums {
            let i = graph
                .inputs
                .iter()
                .position(|d| d.name == p.input)
                .expect("validated");
            swings.push((i, p.amplitude, p.frequency, p.damping, p.phase));
        }
        Ok(Pendulums { swings })
    }
}

impl InputSource for Pendulums {
    fn values(&mut self, t: f64, out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        for &(i, a, f, d, ph) in &self.swings {
            out[i] += a * (-d * t).exp() * (std::f64::consts::TAU * f * t + ph).sin();
        }
    }
}

/// The step counters of every channel (in report order) when a stage was
/// entered: the steps a stage made are the difference to the next mark (or
/// to the channels' final counts).
#[derive(Clone, Debug, Serialize)]
pub struct StageMark {
    pub t_s: f64,
    /// `name#pass`, or `end`.
    pub stage: String,
    pub steps_forward: Vec<u64>,
    pub steps_reverse: Vec<u64>,
}

/// One graph channel after the run.
#[derive(Clone, Debug, Serialize)]
pub struct DanceChannel {
    pub name: String,
    pub actuator: Option<String>,
    pub steps_forward: u64,
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

#[derive(Clone, Debug, Serialize)]
pub struct DanceReport {
    pub machine: String,
    pub graph: String,
    pub seconds: f64,
    pub frame_us: f64,
    pub frames: u64,
    pub channels: Vec<DanceChannel>,
    /// Final x, y of the render.
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

pub struct DanceResult {
    pub report: DanceReport,
    pub strokes: Vec<Stroke>,
    /// The node's tape after the run (what a `recorder` recorded, or the
    /// loaded recording).
    pub recording: Recording,
}

struct StepCount {
    base: u8,
    counts: Vec<i64>,
    fwd: Vec<u64>,
    rev: Vec<u64>,
    moved: bool,
}

impl Board for StepCount {
    fn step(&mut self, channel: u8, forward: bool, _at_us: f64) {
        if let Some(k) = channel.checked_sub(self.base).map(usize::from) {
            if k < self.counts.len() {
                self.counts[k] += if forward { 1 } else { -1 };
                if forward {
                    self.fwd[k] += 1;
                } else {
                    self.rev[k] += 1;
                }
                self.moved = true;
            }
        }
    }
    fn set_tool(&mut self, _: u8, _: f32, _: f64) {}
}

struct View<'a> {
    graph: &'a GraphFile,
    values: &'a [f64],
    node: &'a Node<8, DANCE_TAPE>,
}

impl StageView for View<'_> {
    fn input(&self, name: &str) -> f64 {
        self.graph
            .inputs
            .iter()
            .position(|d| d.name == name)
            .map_or(0.0, |i| self.values[i])
    }
    fn finished(&self, index: u8) -> bool {
        self.node
            .graph()
            .and_then(|g| g.component(index))
            .is_none_or(motet_graph::finished)
    }
}

fn send(node: &mut Node<8, DANCE_TAPE>, m: &HostMessage) -> Result<(), DanceError> {
    let mut buf = [0u8; MAX_MESSAGE];
    let bytes = encode(m, &mut buf).map_err(|e| DanceError::Setup(e.to_string()))?;
    match node.handle(bytes) {
        Some(NodeMessage::Refused { reason }) => Err(DanceError::Refused {
            // The node keeps why it refused a graph step.
            what: match node.graph_error() {
                Some(e) => format!("{m:?} ({e})"),
                None => format!("{m:?}"),
            },
            reason,
        }),
        _ => Ok(()),
    }
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
/// through the machine's [`Distributor`] (the first node's subscription,
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
/// fit the tape, [`DANCE_TAPE`] bytes).
pub fn run_dance_with(
    machine: &Machine,
    graph: &GraphFile,
    inputs: &mut dyn InputSource,
    options: DanceOptions<'_>,
    seconds: f64,
    progress: &mut dyn FnMut(f64),
) -> Result<DanceResult, DanceError> {
    let job = options.job;
    // Graph channel → machine actuator.
    let chans: Vec<_> = graph.channels().collect();
    let mut actuator_of = Vec::new();
    for (k, c) in chans.iter().enumerate() {
        let def = c.channel.as_ref().expect("a channel");
        let a = match &def.actuator {
            Some(n) => Some(
                machine
                    .actuators
                    .iter()
                    .position(|a| &a.name == n)
                    .ok_or_else(|| {
                        DanceError::Setup(format!(
                            "{}: channel `{}` names actuator `{n}`, which {} does not have",
                            graph.file, c.name, machine.name
                        ))
                    })?,
            ),
            None => (k < machine.actuators.len()).then_some(k),
        };
        actuator_of.push(a);
    }
    // Joints at the start, from the machine's start point.
    let joints0: Vec<f64> = machine
        .joints
        .iter()
        .map(|j| j.map.value(&machine.start, 0.0))
        .collect();
    let kin = machine.kinematics;
    let xy_idx: Option<(usize, usize)> = {
        let names = kin.joints().iter().map(|j| j.name).collect::<Vec<_>>();
        let (a, b) = if names.is_empty() {
            ("x", "y")
        } else {
            (names[0], names[1])
        };
        let f = |n: &str| machine.joints.iter().position(|j| j.name == n);
        f(a).zip(f(b))
    };
    let pen = graph
        .render
        .pen_channel
        .as_ref()
        .and_then(|n| chans.iter().position(|c| &c.name == n));

    let mut node: Box<Node<8, DANCE_TAPE>> = Box::new(Node::new());
    for m in graph.messages() {
        send(&mut node, &m)?;
    }
    if let Some(r) = options.recording {
        node.load_tape(&r.bytes, r.len())
            .map_err(|reason| match reason {
                motet_wire::Refusal::BadConfig => DanceError::Setup(format!(
                    "the recording holds {} samples, the node's tape only {}",
                    r.len(),
                    node.tape_capacity()
                )),
                reason => DanceError::Refused {
                    what: "the recording".into(),
                    reason,
                },
            })?;
    }
    let mut dist = Distributor::new(machine);
    if job.is_some() {
        let Some(sub) = dist.subscriptions.first_mut() else {
            return Err(DanceError::Setup(format!(
                "{} has no node to send the job to",
                machine.name
            )));
        };
        sub.axes = ((1u16 << machine.axes.len().min(MAX_AXES)) - 1) as u8;
    }
    let job_segments: Vec<Planned> = job
        .map(|j| {
            j.items
                .iter()
                .filter(|i| matches!(i, Planned::Segment(_)))
                .cloned()
                .collect()
        })
        .unwrap_or_default();
    let mut next_segment = 0;
    let job_pen = job.filter(|j| j.has_tool_events());
    let mut board = StepCount {
        base: node.graph_channel_base(),
        counts: vec![0; chans.len()],
        fwd: vec![0; chans.len()],
        rev: vec![0; chans.len()],
        moved: true,
    };
    let joint_values = |counts: &[i64], joints: &mut Vec<f64>| {
        for (k, a) in actuator_of.iter().enumerate() {
            if let Some(a) = a {
                let act = &machine.actuators[*a];
                joints[act.joint] = joints0[act.joint] + counts[k] as f64 / act.steps_per_unit;
            }
        }
    };
    let xy = |joints: &[f64]| -> [f64; 2] {
        match xy_idx {
            Some((a, b)) => {
                let (x, y) = kin.forward_xy(joints[a], joints[b]);
                [x, y]
            }
            None => [0.0, 0.0],
        }
    };
    let span = |i: usize| {
        machine
            .axes
            .get(i)
            .map(|a| a.travel[1] - a.travel[0])
            .filter(|s| s.is_finite() && *s > 0.0)
            .unwrap_or(100.0)
    };
    let mut path = PathRecorder::new(0, 1, span(0).max(span(1)) / 2000.0);
    let mut joints = joints0.clone();

    let frame = graph.frame_us;
    let n_frames = (seconds * 1e6 / frame).round().max(0.0) as u64;
    let mut values = vec![0.0; graph.inputs.len()];
    let mut sent = vec![f64::NAN; graph.inputs.len()];
    let mut stages = StageMachine::new(graph);
    let mut param_changes = 0;
    let mut stage_marks: Vec<StageMark> = Vec::new();
    let mut first = true;
    let every = (n_frames / 200).max(1);
    for f in 0..n_frames {
        let t_us = f as f64 * frame;
        inputs.values(t_us * 1e-6, &mut values);
        for (i, d) in graph.inputs.iter().enumerate() {
            let v = if d.kind == GraphInputKind::Encoder {
                values[i].round()
            } else {
                values[i]
            };
            if v != sent[i] {
                sent[i] = v;
                send(
                    &mut node,
                    &HostMessage::GraphInput {
                        kind: d.kind,
                        index: d.index,
                        value: v,
                    },
                )?;
            }
        }
        let msgs = {
            let view = View {
                graph,
                values: &values,
                node: &node,
            };
            if first {
                first = false;
                stages.start(t_us * 1e-6, &view)
            } else {
                stages.update(t_us * 1e-6, &view)
            }
        };
        for (t_s, stage) in &stages.log()[stage_marks.len()..] {
            stage_marks.push(StageMark {
                t_s: *t_s,
                stage: stage.clone(),
                steps_forward: board.fwd.clone(),
                steps_reverse: board.rev.clone(),
            });
        }
        for m in &msgs {
            send(&mut node, m)?;
            param_changes += 1;
        }
        while next_segment < job_segments.len() && node.status().segment_space > 0 {
            if let Some(m) = dist.route(0, &job_segments[next_segment]) {
                send(&mut node, &m)?;
            }
            next_segment += 1;
        }
        node.poll(t_us + frame, &mut board);
        if board.moved {
            board.moved = false;
            joint_values(&board.counts, &mut joints);
            let p = xy(&joints);
            let tool_on = match (pen, job_pen) {
                (Some(k), _) => (board.counts[k] as f64) < graph.render.pen_down_below,
                (None, Some(j)) => j.tool_on(t_us),
                (None, None) => true,
            };
            let mut pt: Point = [0.0; MAX_AXES];
            pt[0] = p[0];
            pt[1] = p[1];
            path.sample(&pt, tool_on);
        }
        if f % every == 0 {
            progress(f as f64 / n_frames as f64);
        }
    }
    progress(1.0);

    let g = node.graph().expect("committed");
    joint_values(&board.counts, &mut joints);
    let mut channels = Vec::new();
    for (k, c) in chans.iter().enumerate() {
        let (pos, target) = match g.component(c.index) {
            Some(Component::Channel(ch)) => (ch.current_position(), ch.target_position()),
            _ => (0.0, 0.0),
        };
        channels.push(DanceChannel {
            name: c.name.clone(),
            actuator: actuator_of[k].map(|a| machine.actuators[a].name.clone()),
            steps_forward: board.fwd[k],
            steps_reverse: board.rev[k],
            position_steps: pos,
            target_steps: target,
            error_steps: pos - target,
            joint: actuator_of[k].map(|a| joints[machine.actuators[a].joint]),
        });
    }
    let mut ports = BTreeMap::new();
    for c in &graph.components {
        for (p, name) in c.info_ports().iter().enumerate() {
            if let Some(v) = g.value(PortRef::new(c.index, p as u8)) {
                ports.insert(format!("{}.{}", c.name, name), v);
            }
        }
    }
    let report = DanceReport {
        machine: machine.name.clone(),
        graph: graph.file.clone(),
        seconds: n_frames as f64 * frame * 1e-6,
        frame_us: frame,
        frames: node.graph_frames(),
        channels,
        final_xy: xy(&joints),
        stages: stages.log().to_vec(),
        stage_marks,
        param_changes,
        ports,
        job_segments: next_segment,
        job_end_s: job.map_or(0.0, |j| j.end_us * 1e-6),
    };
    Ok(DanceResult {
        report,
        strokes: path.take(),
        recording: Recording {
            bytes: node.tape().to_vec(),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

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

    #[test]
    fn malformed_traces_name_the_place() {
        let (_, g, _) = example("wheelbot");
        let cases = [
            ("time,pedal\n0,1\n", "t.csv:1:1:"),
            ("time_s,pedal,nope\n0,1,2\n", "t.csv:1:14:"),
            ("time_s,pedal\n0,1\n1,x\n", "t.csv:3:3:"),
            ("time_s,pedal\n0,1\n0,2\n", "t.csv:3:1:"),
            ("time_s,pedal\n0,1,3\n", "t.csv:2:5:"),
        ];
        for (text, at) in cases {
            let e = CsvTrace::parse(text, "t.csv", &g).unwrap_err().to_string();
            assert!(e.starts_with(at), "{text:?}: {e}");
        }
        let mut t = CsvTrace::parse("time_s,pedal\n0,0\n1,100\n", "t.csv", &g).unwrap();
        let mut v = [0.0; 2];
        t.values(0.25, &mut v);
        assert_eq!(v, [25.0, 0.0]);
    }
}
