//! The simulated plant: motors that move one step per step pulse, tool outputs,
//! and an observer that checks every step against the ideal trajectory.

mod servo_watch;

pub use servo_watch::FollowingStats;

use crate::ideal::IdealTrajectory;
use crate::path::PathRecorder;
use motet_host::Machine;
use motet_trajectory::{JointMap, KinematicsKind, Point, Segment, MAX_AXES};

/// Something a node did, with its exact time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Output {
    /// One step pulse.
    Step {
        /// Index into the machine's actuators.
        actuator: usize,
        /// The driver's direction line: forward is the joint's positive
        /// direction unless the actuator's `steps_per_unit` is negative.
        forward: bool,
    },
    /// A servo's tick: its encoder's count, and where its joint truly is.
    Servo {
        /// Index into the machine's actuators.
        actuator: usize,
        /// The encoder's count (as the node read it).
        count: i64,
        /// The joint's value, joint units (the motor's angle through the
        /// chain).
        joint: f64,
    },
    /// A tool output set.
    Tool {
        /// Index into the machine's tools.
        tool: usize,
        /// The new output value (0 is off).
        value: f32,
    },
}

/// An output with when it happened.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stamped {
    /// On the shared clock, µs.
    pub time: f64,
    /// What happened.
    pub output: Output,
}

/// How one actuator fared over a run.
#[derive(Clone, Debug, Default)]
pub struct ActuatorStats {
    /// Steps made, either direction.
    pub steps: u64,
    /// Where it is, steps along its joint (positive is the joint's positive
    /// direction, whatever the driver's inversion).
    pub position: i64,
    /// Largest |ideal − executed| seen at step instants, steps.
    pub max_deviation_steps: f64,
    /// Largest estimated |step time − ideal crossing time|, µs.
    pub max_step_error_us: f64,
    /// A servo's following error, counts (none for a stepper).
    pub following: Option<FollowingStats>,
}

struct ActuatorModel {
    joint: usize,
    map: JointMap,
    /// Unsigned steps per joint unit.
    spu: f64,
    /// Signed: a servo's counts per joint unit.
    spu_signed: f64,
    invert: bool,
    /// A servo's joint value at its last tick (its count is `position`).
    servo_joint: Option<f64>,
    following: FollowingStats,
    servo: bool,
    position: i64,
    /// Whether a step of it moves the executed point in the drawing's
    /// plane (x or y): only then does the path recorder need the step.
    moves_xy: bool,
    /// The machine axis it alone moves, one to one, when its joint is
    /// that axis and it is the joint's only motor (outside the xy pair):
    /// the executed point then takes its value directly.
    sole_axis: Option<usize>,
    stats: ActuatorStats,
}

/// The machine's mechanics as the simulator sees them.
pub struct Plant {
    actuators: Vec<ActuatorModel>,
    kinematics: KinematicsKind,
    /// The axes the kinematics' joints replace (x, y, and z for a delta):
    /// joints `0..len` come first and move them together.
    replaced: Vec<usize>,
    /// For each joint, the actuators driving it (averaged for the executed path).
    joint_actuators: Vec<Vec<usize>>,
    joint_axis: Vec<Option<usize>>,
    /// Each machine tool's current output value.
    pub tools: Vec<f32>,
    /// Segments sent to nodes and not yet in the past, followed at step
    /// instants.
    ideal: IdealTrajectory,
    /// The executed path, sampled at every step in the drawing's plane and
    /// every tool change.
    pub recorder: PathRecorder,
    /// Largest distance between executed and commanded points at step instants, mm.
    pub max_path_deviation: f64,
    /// Each joint's executed value (its actuators' mean), kept step by step.
    joints: [f64; MAX_JOINTS],
    /// The executed machine point, kept step by step: a step changes one
    /// joint, so only that joint's axes (or the xy pair) are recomputed.
    executed: Point,
    /// Tool outputs executed: (time, tool, value), kept only for observers.
    pub tool_changes: Vec<(f64, usize, f32)>,
    /// Whether to keep `tool_changes` (off by default: a long job's would
    /// grow without bound).
    pub watch_tools: bool,
    /// Outputs given and not yet applied (see `PlantSink`).
    pub(crate) inbox: Vec<Stamped>,
}

impl Plant {
    /// The plant of `machine` with its motors at the machine's start point,
    /// tools off, drawing into `recorder`.
    pub fn new(machine: &Machine, recorder: PathRecorder) -> Plant {
        let mut joint_actuators = vec![Vec::new(); machine.joints.len()];
        let actuators = machine
            .actuators
            .iter()
            .enumerate()
            .map(|(i, a)| {
                joint_actuators[a.joint].push(i);
                let map = machine.joints[a.joint].map;
                let spu = a.steps_per_unit.abs();
                let value = map.value(&machine.start, 0.0);
                let position = (value * spu).round() as i64;
                ActuatorModel {
                    joint: a.joint,
                    map,
                    spu,
                    spu_signed: a.steps_per_unit,
                    invert: a.steps_per_unit < 0.0,
                    servo_joint: None,
                    following: FollowingStats {
                        last_rate: f64::NAN,
                        ..FollowingStats::default()
                    },
                    servo: a.servo.is_some(),
                    position,
                    moves_xy: false,
                    sole_axis: None,
                    stats: ActuatorStats {
                        position,
                        ..Default::default()
                    },
                }
            })
            .collect();
        let joint_axis = machine
            .joints
            .iter()
            .map(|j| match j.map {
                JointMap::Linear { coeffs } => {
                    let nz: Vec<usize> = (0..MAX_AXES).filter(|&i| coeffs[i] != 0.0).collect();
                    (nz.len() == 1 && coeffs[nz[0]] == 1.0).then_some(nz[0])
                }
                _ => None,
            })
            .collect::<Vec<Option<usize>>>();
        let (x, y) = (recorder.x(), recorder.y());
        let replaced: Vec<usize> = machine.kinematic_axes.map_or(Vec::new(), |axes| {
            axes[..machine.kinematics.joints().len()].to_vec()
        });
        let mut actuators: Vec<ActuatorModel> = actuators;
        for a in actuators.iter_mut() {
            let in_xy_pair = a.joint < replaced.len();
            let axis = joint_axis.get(a.joint).copied().flatten();
            a.moves_xy = in_xy_pair || axis.is_some_and(|i| i == x || i == y);
            let sole = joint_actuators[a.joint].len() == 1;
            a.sole_axis = axis.filter(|_| sole && !in_xy_pair && a.joint < MAX_JOINTS);
        }
        // The axes whose deviation is checked: all but the extruder's.
        let extruder = machine.axis("e");
        let axes = machine.axes.len().min(MAX_AXES);
        let checked_axes: Vec<usize> = (0..axes).filter(|&i| Some(i) != extruder).collect();
        let ideal = IdealTrajectory::new(
            actuators.iter().map(|a| (a.map, a.spu)),
            extruder,
            &checked_axes,
        );
        let mut plant = Plant {
            actuators,
            kinematics: machine.kinematics,
            replaced,
            joint_actuators,
            joint_axis,
            tools: vec![0.0; machine.tools.len()],
            ideal,
            recorder,
            max_path_deviation: 0.0,
            joints: [0.0; MAX_JOINTS],
            executed: [0.0; MAX_AXES],
            tool_changes: Vec::new(),
            watch_tools: false,
            inbox: Vec::new(),
        };
        for j in 0..plant.joint_actuators.len().min(MAX_JOINTS) {
            plant.update_joint(j);
        }
        plant
    }

    /// A segment was sent to the nodes: it becomes part of the ideal trajectory.
    pub fn planned(&mut self, seg: Segment) {
        self.ideal.push(seg);
    }

    /// Outputs up to `t` (µs) have all been applied: segments that ended
    /// before it are no longer needed. Steps already drop them as they pass;
    /// this keeps the window bounded when time passes without steps (dwells,
    /// moves shorter than a step), one segment kept as the last reference.
    pub fn applied_until(&mut self, t: f64) {
        self.ideal.applied_until(t);
    }

    /// Segments held between being planned and being passed.
    pub fn window_len(&self) -> usize {
        self.ideal.len()
    }

    /// Applies the outputs of one frame, in time order.
    pub fn apply(&mut self, outputs: &mut [Stamped]) {
        // Each node emits in time order; only several nodes need merging.
        if !outputs.is_sorted_by(|a, b| a.time <= b.time) {
            outputs.sort_by(|a, b| a.time.total_cmp(&b.time));
        }
        for o in outputs.iter() {
            match o.output {
                Output::Step { actuator, forward } => self.step(o.time, actuator, forward),
                Output::Servo {
                    actuator,
                    count,
                    joint,
                } => self.servo_tick(o.time, actuator, count, joint),
                Output::Tool { tool, value } => {
                    self.tools[tool] = value;
                    if self.watch_tools {
                        self.tool_changes.push((o.time, tool, value));
                    }
                    let p = self.executed_point();
                    self.recorder.sample(&p, self.tool_on());
                }
            }
        }
    }

    /// Whether the tool works: the first tool is on, or the planned segment
    /// being executed extrudes.
    fn tool_on(&self) -> bool {
        self.tools.first().is_some_and(|v| *v > 0.0) || self.ideal.extruding()
    }

    /// One step of actuator `index` at `t`, checked against the ideal
    /// trajectory there. Steps come in time order, so the ideal point is
    /// followed incrementally (see [`IdealTrajectory`]).
    fn step(&mut self, t: f64, index: usize, forward: bool) {
        let Some(at) = self.ideal.at(t) else {
            return;
        };
        let Some(a) = self.actuators.get_mut(index) else {
            return;
        };
        let before = a.position;
        let positive = forward != a.invert;
        a.position += if positive { 1 } else { -1 };
        a.stats.steps += 1;
        let (after, spu, moves_xy, sole_axis) = (a.position, a.spu, a.moves_xy, a.sole_axis);

        // Ideal joint value in steps at t, on the branch of the executed value.
        let reference = before as f64 / spu;
        let v = match self.ideal.joint_steps(index, at) {
            Some(v) => v,
            None => {
                self.actuators[index]
                    .map
                    .value(&self.ideal.point(at), reference)
                    * spu
            }
        };
        let dev = (v - before as f64).abs().max((v - after as f64).abs());
        // Time error: how far the crossing of the half-step boundary is from t,
        // to first order in the joint's speed. A residual this small means
        // an error far below a nanosecond at any real speed.
        let boundary = before as f64 + if positive { 0.5 } else { -0.5 };
        let residual = (v - boundary).abs();
        let err = if residual <= 1e-9 {
            0.0
        } else {
            // Far into a long job a time's last bit is a fraction of a
            // nanosecond, so most residuals are above the threshold: the
            // speed comes from the same piece polynomial, not a search.
            match self.ideal.joint_rate(index, at) {
                Some(rate) if rate.abs() > 1e-12 => residual / rate.abs(),
                Some(_) => 0.0,
                None => self.time_error(t, index, reference, residual),
            }
        };
        let st = &mut self.actuators[index].stats;
        if dev > st.max_deviation_steps {
            st.max_deviation_steps = dev;
        }
        if err > st.max_step_error_us {
            st.max_step_error_us = err;
        }
        match sole_axis {
            Some(i) => self.executed[i] = after as f64 / spu,
            None => {
                if let Some(j) = self.joint_of(index) {
                    self.update_joint(j);
                }
            }
        }
        let d2 = self.ideal.distance2(at, &self.executed);
        // Compared squared; the root is taken only for a new largest.
        if d2 > self.max_path_deviation * self.max_path_deviation {
            self.max_path_deviation = d2.sqrt();
        }
        // A step off the drawing's plane changes nothing the recorder keeps
        // unless the tool's state changed with it.
        let on = self.tool_on();
        if moves_xy || self.recorder.tool_on() != Some(on) {
            let (x, y) = (self.recorder.x(), self.recorder.y());
            let q = [self.executed[x], self.executed[y]];
            self.recorder.sample_xy(q, on);
        }
    }

    /// The step-time error estimate where a joint that is not linear in the
    /// axes missed its half-step boundary by `residual` steps: the joint's
    /// speed from the ideal trajectory half a microsecond either side.
    #[cold]
    fn time_error(&self, t: f64, index: usize, reference: f64, residual: f64) -> f64 {
        let (map, spu) = (self.actuators[index].map, self.actuators[index].spu);
        let h = 0.5;
        let ideal = |tt: f64| {
            self.ideal
                .point_anywhere(tt)
                .map(|p| map.value(&p, reference) * spu)
        };
        if let (Some(v0), Some(v1)) = (ideal(t - h), ideal(t + h)) {
            let rate = (v1 - v0) / (2.0 * h);
            if rate.abs() > 1e-12 {
                return residual / rate.abs();
            }
        }
        0.0
    }

    /// The joint actuator `index` drives.
    fn joint_of(&self, index: usize) -> Option<usize> {
        self.actuators.get(index).map(|a| a.joint)
    }

    /// Recomputes joint `j` from its actuators and the axes it moves.
    fn update_joint(&mut self, j: usize) {
        if j >= MAX_JOINTS {
            return;
        }
        let acts = &self.joint_actuators[j];
        let value = |i: usize| {
            let a = &self.actuators[i];
            a.servo_joint.unwrap_or(a.position as f64 / a.spu)
        };
        self.joints[j] = match acts.as_slice() {
            // One motor (the common case): its value, as the mean would give.
            [i] => value(*i),
            _ => acts.iter().map(|&i| value(i)).sum::<f64>() / acts.len().max(1) as f64,
        };
        if j < self.replaced.len() {
            // The kinematics' joints, then what they leave alone (unused
            // by planar kinematics, whose forward passes it through).
            let mut input = [self.joints[0], self.joints[1], 0.0];
            if let Some(v) = self.joints.get(2).filter(|_| self.replaced.len() > 2) {
                input[2] = *v;
            }
            let p = self.kinematics.forward_or_nan(input);
            for (axis, v) in self.replaced.iter().zip(p) {
                self.executed[*axis] = v;
            }
        } else if let Some(Some(i)) = self.joint_axis.get(j) {
            self.executed[*i] = self.joints[j];
        }
    }

    /// The machine point the motors are at now (forward kinematics).
    pub fn executed_point(&self) -> Point {
        self.executed
    }

    /// Each machine actuator's statistics so far, in the machine's order.
    pub fn actuator_stats(&self) -> Vec<ActuatorStats> {
        self.actuators
            .iter()
            .map(|a| ActuatorStats {
                position: a.position,
                following: a.servo.then(|| a.following.clone()),
                ..a.stats.clone()
            })
            .collect()
    }
}

/// Most joints a machine has: one per axis.
const MAX_JOINTS: usize = MAX_AXES;
