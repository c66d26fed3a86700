//! The simulation: planner → distributor → bytes → nodes → plant, on one
//! simulated clock.

use crate::collector::{Collector, LOOP_CHUNK_US};
use crate::path::PathRecorder;
use crate::plant::Plant;
use crate::plant_thread::{self, PlantSink};
use crate::report::{ActuatorReport, AxisReport, JointReport, Report};
use motet_host::{Distributor, Machine};
use motet_node::Node;
use motet_planner::{Command, Located, PlanError, Planned, Planner, SourceLoc};
use motet_render::Stroke;
use motet_trajectory::{JointMap, JointPath, Point};
use motet_wire::{encode, HostMessage, NodeMessage, Refusal, MAX_MESSAGE};
use std::time::Instant;

/// Capacity every simulated node is built with; a machine file may ask for less.
pub const NODE_QUEUE: usize = 64;

/// Why a simulation stopped.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The planner refused a command of the job.
    #[error("{loc}: {error}")]
    Plan {
        /// Where the command is in the job.
        loc: SourceLoc,
        /// Why it was refused.
        error: PlanError,
    },
    /// A node refused what the host sent it.
    #[error("node {node} refused a message: {reason}")]
    Refused {
        /// The node's name in the machine file.
        node: String,
        /// The node's reason.
        reason: Refusal,
    },
    /// A segment did not fit the wire's batch format.
    #[error("a segment could not be batched: {0}")]
    Stream(motet_wire::stream::StreamError),
    /// The job's own stream failed (a read error, a bad line).
    #[error("{0}")]
    Source(Box<dyn std::error::Error + Send + Sync>),
    /// A node's loop stopped driving (its following error, a limit
    /// switch, a sensor that stopped reporting), or a source's samples
    /// stopped: the simulation stops there. Names the node, the actuator
    /// or sensor, the field, and the time.
    #[error("{0}")]
    Fault(String),
    /// A heater a node drives tripped (runaway, a lost sensor) or did not
    /// get to a target the job waited for: the run stops there. The
    /// message names the node, the heater, what it saw and when; the
    /// heaters' samples up to then come with it (for their plots).
    #[error("{message}")]
    Heater {
        /// As the person reads it.
        message: String,
        /// Every node-driven heater's samples.
        heaters: Vec<motet_host::heater_trace::HeaterTrace>,
    },
}

/// What a run produced.
pub struct SimResult {
    /// The figures.
    pub report: Report,
    /// The executed path in the machine's x, y, mm.
    pub strokes: Vec<Stroke>,
}

/// Progress of a run: commands planned out of the total.
pub type Progress<'a> = &'a mut dyn FnMut(usize, usize);

/// A machine of simulated nodes on one simulated clock, fed planned items one
/// at a time: the engine under both `simulate` and the scripting API. Its
/// plant is in line (`P` = [`Plant`], which the scripting API reads from),
/// or on a thread of its own for a whole job
/// ([`PlantLink`](crate::plant_thread::PlantLink)).
pub struct SimMachine<P: PlantSink = Plant> {
    pub(crate) machine: Machine,
    nodes: Vec<Node<NODE_QUEUE>>,
    dist: Distributor,
    plant: P,
    frame: f64,
    pub(crate) now: f64,
    buf: [u8; MAX_MESSAGE],
    stats: Stats,
    /// Each node's servo motors, sensors and heaters.
    pub(crate) plants: Vec<crate::node_plant::NodePlant>,
    /// What the nodes' loops sent: samples kept per source, the first fault.
    loops: crate::loops::LoopWatch,
    /// What the host knows of them.
    pub(crate) heaters: crate::heaters::HeaterWatch,
}

#[derive(Default)]
struct Stats {
    segments: usize,
    rests: usize,
    events: usize,
    aux_events: usize,
    pauses: usize,
    axes: Vec<AxisReport>,
    joints: Vec<(usize, JointReport)>,
    tool_on: bool,
    extruding_axis: Option<usize>,
    tool_on_distance: f64,
    travel_distance: f64,
}

/// The plant that checks and draws what `machine`'s nodes do.
pub fn plant_for(machine: &Machine) -> Plant {
    let (x, y) = (
        machine.axis("x").unwrap_or(0),
        machine.axis("y").unwrap_or(1.min(machine.axes.len() - 1)),
    );
    let span = |i: usize| {
        let t = machine.axes[i].travel;
        if t[0].is_finite() && t[1].is_finite() {
            t[1] - t[0]
        } else {
            100.0
        }
    };
    // About a pixel of the default render.
    let resolution = span(x).max(span(y)) / 2000.0;
    Plant::new(machine, PathRecorder::new(x, y, resolution))
}

impl SimMachine {
    /// A machine at rest at its start position, nodes configured.
    pub fn new(machine: &Machine) -> Result<SimMachine, SimError> {
        SimMachine::with_plant(machine, plant_for(machine))
    }
}

impl<P: PlantSink> SimMachine<P> {
    /// A machine at rest at its start position, nodes configured, whose
    /// outputs go to `plant`.
    pub fn with_plant(machine: &Machine, plant: P) -> Result<SimMachine<P>, SimError> {
        let dist = Distributor::new(machine);
        let frame = machine
            .nodes
            .iter()
            .map(|n| n.frame_us)
            .fold(f64::INFINITY, f64::min);
        let mut sim = SimMachine {
            machine: machine.clone(),
            nodes: machine
                .nodes
                .iter()
                .map(|spec| {
                    let mut n = Node::new();
                    // A board without an FPU, as its machine file says.
                    n.use_fixed_time(spec.fixed_time_us);
                    n
                })
                .collect(),
            dist,
            plant,
            frame,
            now: 0.0,
            buf: [0; MAX_MESSAGE],
            plants: (0..machine.nodes.len())
                .map(|k| crate::node_plant::NodePlant::of_node(machine, k))
                .collect(),
            loops: crate::loops::LoopWatch::new(machine),
            heaters: crate::heaters::HeaterWatch::new(machine),
            stats: Stats {
                axes: machine
                    .axes
                    .iter()
                    .map(|a| AxisReport { name: a.name.clone(), max_velocity: a.max_velocity, max_acceleration: a.max_acceleration, ..Default::default() })
                    .collect(),
                joints: machine
                    .joints
                    .iter()
                    .enumerate()
                    .filter(|(_, j)| !matches!(j.map, JointMap::Linear { coeffs } if coeffs.iter().filter(|c| **c != 0.0).count() == 1))
                    .map(|(i, j)| (i, JointReport { name: j.name.clone(), max_velocity: j.max_velocity, ..Default::default() }))
                    .collect(),
                extruding_axis: machine.axis("e"),
                ..Default::default()
            },
        };
        let setup = sim.dist.stream_setup(machine, &machine.start);
        for (k, msgs) in setup.into_iter().enumerate() {
            for msg in msgs {
                sim.send(k, &msg)?;
            }
        }
        if motet_host::heater_loop::any(machine) {
            // Every heater reads its sensor at its first tick, at 0: one
            // that does not report stops the run before anything moves.
            let until = sim.frame_after(0.0);
            sim.poll_all(until);
            sim.heater_fault()?;
        }
        Ok(sim)
    }

    fn send(&mut self, node: usize, msg: &HostMessage) -> Result<(), SimError> {
        // Every message crosses as bytes, as it would over a link.
        let bytes = encode(msg, &mut self.buf).expect("messages fit MAX_MESSAGE");
        match self.nodes[node].handle(bytes) {
            Some(NodeMessage::Refused { reason }) => Err(SimError::Refused {
                node: self.machine.nodes[node].name.clone(),
                reason,
            }),
            _ => Ok(()),
        }
    }

    /// Simulated time, µs.
    pub fn now(&self) -> f64 {
        self.now
    }

    /// The machine simulated.
    pub fn machine(&self) -> &Machine {
        &self.machine
    }

    /// Sends every batch still being filled: before time passes for the
    /// caller, so no node waits for segments the host holds.
    pub(crate) fn flush_all(&mut self) {
        for k in 0..self.nodes.len() {
            if let Some(out) = self.dist.flush(k) {
                self.make_room(k, out.segments);
                // Room was made and the batch continues the node's stream:
                // a refusal is a bug in the distributor, not bad input.
                if let Err(e) = self.send(k, &out.message) {
                    debug_assert!(false, "{e}");
                }
            }
        }
    }

    /// Runs the nodes until simulated time `t`.
    pub fn run_until(&mut self, t: f64) {
        self.flush_all();
        let until = self.frame_after(t.max(self.now));
        self.poll_all(until);
    }

    /// Runs until every node has nothing left to do.
    pub fn run_to_rest(&mut self) {
        self.flush_all();
        // A loop that faulted stops the run where it is.
        while self.fault().is_none() {
            let Some(d) = self
                .nodes
                .iter_mut()
                .filter_map(|n| n.next_deadline())
                .reduce(f64::min)
            else {
                break;
            };
            let until = self.frame_after(d.max(self.now));
            self.poll_all(until);
        }
    }

    /// The report of everything run so far, with `plant` the plant that
    /// ran it; `end` is the trajectory's end, µs.
    fn report_with(
        &self,
        plant: &Plant,
        job: &str,
        commands: usize,
        end: f64,
        wall: f64,
    ) -> Report {
        let duration_s = end * 1e-6;
        let stats = plant.actuator_stats();
        let actuators: Vec<ActuatorReport> = self
            .machine
            .actuators
            .iter()
            .zip(&stats)
            .enumerate()
            .map(|(i, (a, st))| ActuatorReport {
                name: a.name.clone(),
                node: self
                    .machine
                    .nodes
                    .iter()
                    .find(|n| n.actuators.contains(&i))
                    .map(|n| n.name.clone())
                    .unwrap_or_default(),
                steps_per_unit: a.steps_per_unit,
                steps: st.steps,
                position: st.position,
                max_deviation_steps: st.max_deviation_steps,
                max_step_time_error_us: st.max_step_error_us,
                following: self.following(i, st, duration_s),
            })
            .collect();
        Report {
            machine: self.machine.name.clone(),
            job: job.to_string(),
            duration_s,
            commands,
            segments: self.stats.segments,
            rests: self.stats.rests,
            tool_events: self.stats.events,
            aux_events: self.stats.aux_events,
            pauses: self.stats.pauses,
            tool_on_distance_mm: self.stats.tool_on_distance,
            travel_distance_mm: self.stats.travel_distance,
            axes: self.stats.axes.clone(),
            joints: self.stats.joints.iter().map(|(_, j)| j.clone()).collect(),
            max_path_deviation_mm: plant.max_path_deviation,
            max_deviation_steps: actuators
                .iter()
                .map(|a| a.max_deviation_steps)
                .fold(0.0, f64::max),
            max_step_time_error_us: actuators
                .iter()
                .map(|a| a.max_step_time_error_us)
                .fold(0.0, f64::max),
            actuators,
            underruns: self.underruns(),
            heaters: self.heaters.report(&self.machine),
            clamped_moves: 0,
            max_clamp_mm: 0.0,
            wall_s: wall,
            speed_factor: duration_s / wall.max(1e-6),
            plots: Vec::new(),
        }
    }

    /// Actuator `i`'s following figures, when it is a servo.
    fn following(
        &self,
        i: usize,
        st: &crate::plant::ActuatorStats,
        duration_s: f64,
    ) -> Option<crate::report::FollowingReport> {
        let f = st.following.as_ref()?;
        let servo = self.machine.actuators[i].servo.as_ref()?;
        let (k, ch) = self
            .machine
            .nodes
            .iter()
            .enumerate()
            .find_map(|(k, n)| n.actuators.iter().position(|&a| a == i).map(|c| (k, c)))?;
        let series = self
            .loops
            .store
            .get(k, motet_wire::control::SampleSource::Servo(ch as u8));
        Some(crate::report::FollowingReport {
            loop_hz: servo.rate_hz,
            ticks: f.ticks,
            max_cruise_counts: f.max_cruise,
            max_settled_cruise_counts: f.max_settled,
            max_accel_counts: f.max_accel,
            max_rest_counts: f.max_rest,
            rms_counts: f.rms(),
            samples: series.map_or(0, |s| s.received),
            samples_dropped: series.map_or(0, |s| s.dropped),
            sample_bytes_per_s: series.map_or(0.0, |s| s.bytes as f64 / duration_s.max(1e-6)),
        })
    }

    /// Segments queued on the nodes.
    fn node_segments(&self) -> usize {
        self.nodes
            .iter()
            .map(|n| NODE_QUEUE - n.status().segment_space)
            .sum()
    }

    /// Node underruns so far.
    pub fn underruns(&self) -> u32 {
        self.nodes.iter().map(|n| n.status().underruns).sum()
    }

    /// First frame boundary strictly after `t`. Far from zero a frame can
    /// be finer than an `f64` resolves there; then the next representable
    /// time, so that the clock always moves on and whatever is due at `t`
    /// runs.
    pub(crate) fn frame_after(&self, t: f64) -> f64 {
        let f = ((t / self.frame).floor() + 1.0) * self.frame;
        if f > t || !t.is_finite() {
            f
        } else {
            // Times are not negative: the next larger f64 is one bit up.
            f64::from_bits(t.max(0.0).to_bits() + 1)
        }
    }

    /// Runs every node up to `until` and applies their outputs to the plant.
    pub(crate) fn poll_all(&mut self, until: f64) {
        if self.heaters.any() {
            // A node holds four messages upstream and its heaters send a
            // batch about every second: the host takes them at least as
            // often, as a link would.
            while until - self.now > crate::heaters::TAKE_EVERY_US {
                let t = self.now + crate::heaters::TAKE_EVERY_US;
                self.poll_once(t);
            }
        }
        self.poll_once(until);
    }

    fn poll_once(&mut self, until: f64) {
        if until <= self.now {
            return;
        }
        let single = self.nodes.len() == 1;
        for (k, node) in self.nodes.iter_mut().enumerate() {
            let spec = &self.machine.nodes[k];
            let mut c = Collector {
                actuators: &spec.actuators,
                tools: &spec.tools,
                plant: &mut self.plant,
                loops: &mut self.plants[k],
                single,
            };
            // The plant takes every node's outputs up to `until` together
            // (several nodes' are merged in time there): a poll that stops
            // at its output budget is continued.
            // A node with loops is polled a quarter second at a time, so
            // that what they send never waits in its short queue for
            // longer (the outputs are the same: each carries its time).
            let loops = c.loops.has_loops() || !spec.sensors.is_empty();
            let chunk = if loops { LOOP_CHUNK_US } else { f64::INFINITY };
            while node.time() < until {
                let to = (node.time().max(self.now) + chunk).min(until);
                node.poll(to, &mut c);
                // What its loops sent, as bytes, as over a link.
                while let Some(m) = node.take_upstream() {
                    if let Ok(bytes) = encode(&m, &mut self.buf) {
                        if let Ok(m) = motet_wire::decode::<NodeMessage>(bytes) {
                            // A heater's messages to the heaters' watch
                            // (its trip says what the runaway watch saw).
                            if motet_host::heater_loop::is_heater_message(&m) {
                                self.heaters.take(&self.machine, k, &m);
                            } else {
                                self.loops.take(&self.machine, k, m, node.time());
                            }
                        }
                    }
                }
            }
        }
        self.loops.watch(&self.machine, until);
        self.plant.applied(until);
        self.now = until;
    }

    /// Lets time pass until node `k` has room for `segments` more segments
    /// (0: for an event).
    fn make_room(&mut self, k: usize, segments: usize) {
        let window = self.machine.nodes[k].queue.min(NODE_QUEUE);
        // After a fault the run stops: `submit` says so.
        while self.fault().is_none() {
            let st = self.nodes[k].status();
            let full = if segments > 0 {
                NODE_QUEUE - st.segment_space + segments > window
            } else {
                st.event_space == 0
            };
            if !full {
                return;
            }
            // Jumping straight to the end of the oldest segment gives the same
            // outputs as polling every frame up to it: each output has its own time.
            let target = match self.nodes[k].front_end() {
                Some(t) => t,
                None => self.nodes[k].next_deadline().unwrap_or(self.now),
            };
            let until = self.frame_after(target.max(self.now));
            self.poll_all(until);
        }
    }

    /// New gains for servo actuator `name`, sent to its node now, moving or
    /// not (as `HostMessage::ServoGains`); the node takes them at its next
    /// tick. An error when there is no such servo or the node refuses them.
    pub fn set_servo_gains(
        &mut self,
        name: &str,
        gains: motet_wire::control::ServoGains,
    ) -> Result<(), SimError> {
        let Some(a) = self.machine.actuators.iter().position(|x| x.name == name) else {
            return Err(SimError::Fault(format!("no actuator `{name}`")));
        };
        let Some((k, ch)) = self
            .machine
            .nodes
            .iter()
            .enumerate()
            .find_map(|(k, n)| n.actuators.iter().position(|&x| x == a).map(|c| (k, c)))
        else {
            return Err(SimError::Fault(format!("actuator {name} is on no node")));
        };
        self.flush_all();
        self.send(
            k,
            &HostMessage::ServoGains {
                channel: ch as u8,
                gains,
            },
        )
    }

    /// The first fault of a node's loop (or a source that stopped
    /// reporting), as the person reads it.
    pub fn fault(&self) -> Option<&str> {
        self.loops.fault.as_deref()
    }

    /// What the nodes' loops sent: samples per source.
    pub fn samples(&self) -> &motet_host::samples::SampleStore {
        &self.loops.store
    }

    /// Sends one planned item to the nodes that subscribe to it, letting time
    /// pass when a node's queue is full.
    pub fn submit(&mut self, item: Planned) -> Result<(), SimError> {
        if let Some(f) = self.fault() {
            return Err(SimError::Fault(f.to_string()));
        }
        self.heater_fault()?;
        // The nodes run the quantized trajectory the batches carry: that is
        // the record every output is checked against.
        let planned = item;
        let item = self.dist.quantize(&planned);
        match &item {
            Planned::Segment(s) => {
                self.stats.segments += 1;
                self.plant.planned(*s);
                self.loops.planned(s);
                // Peak figures are the plan's: the quantized direction of a
                // tiny move may differ from it by a position quantum over its
                // length, which says nothing about the planner's limits.
                if let Planned::Segment(p) = &planned {
                    self.account(p);
                }
            }
            Planned::Event(e) => {
                self.stats.events += 1;
                if e.tool == 0 {
                    self.stats.tool_on = e.value > 0.0;
                }
            }
            Planned::Aux(a) => {
                self.stats.aux_events += 1;
                if a.channel == motet_planner::AuxChannel::Fan(0) {
                    // The part-cooling fan blows on the hot ends.
                    for p in self.plants.iter_mut() {
                        p.heat_mut().fan_at(a.time, a.value as f64);
                    }
                }
            }
            // The simulated operator resumes at once.
            Planned::Pause { .. } => self.stats.pauses += 1,
        }
        for k in 0..self.nodes.len() {
            for out in self
                .dist
                .route_batched(k, &item)
                .map_err(SimError::Stream)?
            {
                self.make_room(k, out.segments);
                self.send(k, &out.message)?;
            }
        }
        Ok(())
    }

    /// Peak speeds and distances from the planned segment.
    fn account(&mut self, s: &motet_trajectory::Segment) {
        let p = &s.profile;
        let (vc, acc) = (p.vc().max(p.v0()).max(p.v1()), p.peak_accel());
        for (i, a) in self.stats.axes.iter_mut().enumerate() {
            let u = s.axis_rate(i).abs();
            a.distance += (s.end[i] - s.start[i]).abs();
            a.peak_velocity = a.peak_velocity.max(u * vc);
            a.peak_acceleration = a.peak_acceleration.max(u * acc);
        }
        for (j, r) in self.stats.joints.iter_mut() {
            let map: JointMap = self.machine.joints[*j].map;
            let path = JointPath::new(&map, s, 0.0);
            r.peak_velocity = r.peak_velocity.max(path.max_rate(0.0, p.length()) * vc);
        }
        if p.length() > 0.0 && p.v1() == 0.0 {
            self.stats.rests += 1;
        }
        let extruding = self
            .stats
            .extruding_axis
            .is_some_and(|e| s.end[e] > s.start[e]);
        if self.stats.tool_on || extruding {
            self.stats.tool_on_distance += p.length();
        } else {
            self.stats.travel_distance += p.length();
        }
    }
}

impl SimMachine {
    /// Where the motors are now, as a machine point.
    pub fn executed_point(&self) -> Point {
        self.plant.executed_point()
    }

    /// Keep the tool changes the plant executes for [`SimMachine::take_tool_changes`].
    pub fn watch_tools(&mut self, on: bool) {
        self.plant.watch_tools = on;
    }

    /// Tool changes the plant has executed since the last call, with their times.
    pub fn take_tool_changes(&mut self) -> Vec<(f64, usize, f32)> {
        std::mem::take(&mut self.plant.tool_changes)
    }

    /// The report of everything run so far; `end` is the trajectory's end, µs.
    pub fn report(&self, job: &str, commands: usize, end: f64, wall: f64) -> Report {
        self.report_with(&self.plant, job, commands, end, wall)
    }

    /// The executed path so far as strokes; recording starts afresh.
    pub fn take_strokes(&mut self) -> Vec<Stroke> {
        self.plant.recorder.take()
    }

    /// The strokes of the executed path finished since the last call, each
    /// simplified; the one being drawn stays until it ends.
    pub fn take_finished_strokes(&mut self) -> Vec<Stroke> {
        self.plant.recorder.take_finished()
    }

    /// What the simulation holds that depends on the job, as counts: the
    /// plant's segment window and recorded points, and the nodes' queued
    /// segments. Each is bounded whatever the job's length (ARCHITECTURE.md,
    /// "Constant memory").
    pub fn held(&self) -> Held {
        Held {
            plant_segments: self.plant.window_len(),
            path_points: self.plant.recorder.held_points(),
            node_segments: self.node_segments(),
        }
    }
}

/// Counts of what a simulation holds (see [`SimMachine::held`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Held {
    /// Segments the plant keeps to check steps against.
    pub plant_segments: usize,
    /// Points the path recorder holds: the open stroke's and finished
    /// strokes' not yet taken.
    pub path_points: usize,
    /// Segments queued in the nodes, all nodes together.
    pub node_segments: usize,
}

impl Held {
    /// The larger of each count.
    pub fn max(self, o: Held) -> Held {
        Held {
            plant_segments: self.plant_segments.max(o.plant_segments),
            path_points: self.path_points.max(o.path_points),
            node_segments: self.node_segments.max(o.node_segments),
        }
    }
}

/// Plans `commands` on `machine` and executes them on simulated nodes.
pub fn simulate(
    machine: &Machine,
    job: &str,
    commands: &[Located<Command>],
    progress: Progress,
) -> Result<SimResult, SimError> {
    let mut strokes = Vec::new();
    let items = commands
        .iter()
        .map(|c| Ok::<_, std::convert::Infallible>(c.clone()));
    let run = simulate_stream(machine, job, items, commands.len(), progress, &mut |s| {
        strokes.push(s)
    })?;
    Ok(SimResult {
        report: run.report,
        strokes,
    })
}

/// What [`simulate_stream`] returns: the report, and the most it held.
pub struct StreamRun {
    /// The figures.
    pub report: Report,
    /// The largest of each count in [`SimMachine::held`] over the run.
    pub held: Held,
    /// What the nodes' loops sent (samples per source), and each sensor's
    /// planned acceleration.
    pub loops: crate::loops::LoopWatch,
    /// The samples of every heater a node drives, for their plots.
    pub heaters: Vec<motet_host::heater_trace::HeaterTrace>,
}

/// Plans and executes a job read as it runs: `commands` is consumed one
/// command at a time, and each stroke of the executed path goes to `strokes`
/// as soon as it is finished, so nothing here grows with the job. `total` is
/// the number of commands, for `progress` (0 if not known). An error from
/// `commands` ends the run with [`SimError::Source`].
pub fn simulate_stream<E>(
    machine: &Machine,
    job: &str,
    commands: impl Iterator<Item = Result<Located<Command>, E>>,
    total: usize,
    progress: Progress,
    strokes: &mut (dyn FnMut(Stroke) + Send),
) -> Result<StreamRun, SimError>
where
    E: std::error::Error + Send + Sync + 'static,
{
    let started = Instant::now();
    std::thread::scope(|scope| {
        let (link, plant) = plant_thread::spawn(scope, plant_for(machine), strokes);
        let mut sim = SimMachine::with_plant(machine, link)?;
        let ran = run_commands(&mut sim, commands, total, progress);
        // Ends the plant's run, whether the job ran to its end or not.
        sim.plant.close();
        let run = match plant.join() {
            Ok(run) => run,
            Err(panic) => std::panic::resume_unwind(panic),
        };
        let (n, end, node_segments) = ran?;
        let wall = started.elapsed().as_secs_f64();
        Ok(StreamRun {
            report: sim.report_with(&run.plant, job, n, end, wall),
            held: Held {
                node_segments,
                ..run.held
            },
            loops: std::mem::take(&mut sim.loops),
            heaters: sim.heaters().traces().cloned().collect(),
        })
    })
}

/// Plans `commands` and runs them on `sim` to rest: the commands run, the
/// trajectory's end (µs), and the most segments the nodes held.
fn run_commands<P: PlantSink, E>(
    sim: &mut SimMachine<P>,
    commands: impl Iterator<Item = Result<Located<Command>, E>>,
    total: usize,
    progress: Progress,
) -> Result<(usize, f64, usize), SimError>
where
    E: std::error::Error + Send + Sync + 'static,
{
    // From the host's time: past the heaters' first check, if any.
    let mut planner = Planner::new(sim.machine.limits(), sim.machine.start, sim.now());
    let mut node_segments = 0;
    let mut n = 0usize;
    for c in commands {
        let c = c.map_err(|e| SimError::Source(Box::new(e)))?;
        planner
            .push(&c.item)
            .map_err(|error| SimError::Plan { loc: c.loc, error })?;
        crate::heaters::submit_planned(sim, &mut planner, c.loc, &mut |_| {})?;
        node_segments = node_segments.max(sim.node_segments());
        if n.is_multiple_of(1024) {
            progress(n, total);
        }
        n += 1;
    }
    planner.finish();
    while let Some(item) = planner.pop() {
        sim.submit(item)?;
    }
    let end = planner.clock();
    // Run to the end, then until nothing is left to do.
    sim.run_until(end);
    sim.run_to_rest();
    if let Some(f) = sim.fault() {
        return Err(SimError::Fault(f.to_string()));
    }
    sim.heater_fault()?;
    node_segments = node_segments.max(sim.node_segments());
    progress(n, total.max(n));
    Ok((n, end, node_segments))
}
