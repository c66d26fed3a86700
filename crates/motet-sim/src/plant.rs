//! The simulated plant: motors that move one step per step pulse, tool outputs,
//! and an observer that checks every step against the ideal trajectory.

use crate::path::PathRecorder;
use motet_host::Machine;
use motet_trajectory::{JointMap, KinematicsKind, Point, Segment, MAX_AXES};
use std::collections::VecDeque;

/// Something a node did, with its exact time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Output {
    Step { actuator: usize, forward: bool },
    Tool { tool: usize, value: f32 },
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stamped {
    pub time: f64,
    pub output: Output,
}

#[derive(Clone, Debug, Default)]
pub struct ActuatorStats {
    pub steps: u64,
    pub position: i64,
    /// Largest |ideal − executed| seen at step instants, steps.
    pub max_deviation_steps: f64,
    /// Largest estimated |step time − ideal crossing time|, µs.
    pub max_step_error_us: f64,
}

struct ActuatorModel {
    joint: usize,
    map: JointMap,
    /// Unsigned steps per joint unit.
    spu: f64,
    invert: bool,
    position: i64,
    stats: ActuatorStats,
}

/// The machine's mechanics as the simulator sees them.
pub struct Plant {
    actuators: Vec<ActuatorModel>,
    kinematics: KinematicsKind,
    xy: Option<(usize, usize)>,
    /// For each joint, the actuators driving it (averaged for the executed path).
    joint_actuators: Vec<Vec<usize>>,
    joint_axis: Vec<Option<usize>>,
    extruder: Option<usize>,
    pub tools: Vec<f32>,
    /// Segments sent to nodes and not yet in the past, for the ideal trajectory.
    window: VecDeque<Segment>,
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
    pub watch_tools: bool,
}

impl Plant {
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
                    invert: a.steps_per_unit < 0.0,
                    position,
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
            .collect();
        let mut plant = Plant {
            actuators,
            kinematics: machine.kinematics,
            xy: machine.xy,
            joint_actuators,
            joint_axis,
            extruder: machine.axis("e"),
            tools: vec![0.0; machine.tools.len()],
            window: VecDeque::new(),
            recorder,
            max_path_deviation: 0.0,
            joints: [0.0; MAX_JOINTS],
            executed: [0.0; MAX_AXES],
            tool_changes: Vec::new(),
            watch_tools: false,
        };
        for j in 0..plant.joint_actuators.len().min(MAX_JOINTS) {
            plant.update_joint(j);
        }
        plant
    }

    /// A segment was sent to the nodes: it becomes part of the ideal trajectory.
    pub fn planned(&mut self, seg: Segment) {
        self.window.push_back(seg);
    }

    /// Outputs up to `t` (µs) have all been applied: segments that ended
    /// before it are no longer needed. Steps already drop them as they pass;
    /// this keeps the window bounded when time passes without steps (dwells,
    /// moves shorter than a step), one segment kept as the last reference.
    pub fn applied_until(&mut self, t: f64) {
        while self.window.len() > 1 && self.window[0].t1() < t && self.window[1].t0 <= t {
            self.window.pop_front();
        }
    }

    /// Segments held between being planned and being passed.
    pub fn window_len(&self) -> usize {
        self.window.len()
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
        let extruding = match (self.extruder, self.window.front()) {
            (Some(e), Some(seg)) => seg.end[e] > seg.start[e],
            _ => false,
        };
        self.tools.first().is_some_and(|v| *v > 0.0) || extruding
    }

    fn segment_at(&mut self, t: f64) -> Option<&Segment> {
        while self.window.len() > 1 && self.window[0].t1() < t {
            self.window.pop_front();
        }
        self.window.front()
    }

    fn step(&mut self, t: f64, index: usize, forward: bool) {
        if self.segment_at(t).is_none() {
            return;
        }
        let Some(cmd) = point_at(&self.window, t) else {
            return;
        };
        let a = &mut self.actuators[index];
        let before = a.position;
        let positive = forward != a.invert;
        a.position += if positive { 1 } else { -1 };
        a.stats.steps += 1;
        a.stats.position = a.position;

        // Ideal joint value in steps near t, on the branch of the executed value.
        let reference = before as f64 / a.spu;
        let (map, spu) = (a.map, a.spu);
        let after = a.position;
        let ideal = |tt: f64| point_at(&self.window, tt).map(|p| map.value(&p, reference) * spu);
        {
            let v = map.value(&cmd, reference) * spu;
            let dev = (v - before as f64).abs().max((v - after as f64).abs());
            // Time error: how far the crossing of the half-step boundary is from t,
            // to first order in the joint's speed. A residual this small means
            // an error far below a nanosecond at any real speed.
            let boundary = before as f64 + if positive { 0.5 } else { -0.5 };
            let residual = (v - boundary).abs();
            let mut err = 0.0;
            if residual > 1e-9 {
                let h = 0.5;
                if let (Some(v0), Some(v1)) = (ideal(t - h), ideal(t + h)) {
                    let rate = (v1 - v0) / (2.0 * h);
                    if rate.abs() > 1e-12 {
                        err = residual / rate.abs();
                    }
                }
            }
            let st = &mut self.actuators[index].stats;
            st.max_deviation_steps = st.max_deviation_steps.max(dev);
            st.max_step_error_us = st.max_step_error_us.max(err);
        }
        if let Some(j) = self.joint_of(index) {
            self.update_joint(j);
        }
        let p = self.executed;
        let mut d2 = 0.0;
        for i in 0..MAX_AXES {
            if Some(i) != self.extruder {
                d2 += (p[i] - cmd[i]) * (p[i] - cmd[i]);
            }
        }
        // Compared squared; the root is taken only for a new largest.
        if d2 > self.max_path_deviation * self.max_path_deviation {
            self.max_path_deviation = d2.sqrt();
        }
        let on = self.tool_on();
        self.recorder.sample(&p, on);
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
        let value = |i: usize| self.actuators[i].position as f64 / self.actuators[i].spu;
        self.joints[j] = match acts.as_slice() {
            // One motor (the common case): its value, as the mean would give.
            [i] => value(*i),
            _ => acts.iter().map(|&i| value(i)).sum::<f64>() / acts.len().max(1) as f64,
        };
        match self.xy {
            Some((x, y)) if j < 2 => {
                let (px, py) = self.kinematics.forward_xy(self.joints[0], self.joints[1]);
                self.executed[x] = px;
                self.executed[y] = py;
            }
            _ => {
                if let Some(Some(i)) = self.joint_axis.get(j) {
                    self.executed[*i] = self.joints[j];
                }
            }
        }
    }

    /// The machine point the motors are at now (forward kinematics).
    pub fn executed_point(&self) -> Point {
        self.executed
    }

    pub fn actuator_stats(&self) -> Vec<ActuatorStats> {
        self.actuators.iter().map(|a| a.stats.clone()).collect()
    }
}

/// Most joints a machine has: one per axis.
const MAX_JOINTS: usize = MAX_AXES;

/// The ideal machine point at `t` from the segments around it.
fn point_at(window: &VecDeque<Segment>, t: f64) -> Option<Point> {
    // Almost always the front one: segments are dropped as steps pass them.
    if let Some(s) = window.front() {
        if s.t0 <= t && t <= s.t1() {
            return Some(s.position_at(t));
        }
    }
    window
        .iter()
        .find(|s| s.t0 <= t && t <= s.t1())
        .map(|s| s.position_at(t))
}
