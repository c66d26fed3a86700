//! Building the virtual machine from its file: each section checked,
//! with errors at their place in the file, then composed into a
//! [`Machine`].

use crate::machine::{Actuator, Axis, Joint, Machine, MachineError, NodeSpec, Tool};
use crate::machine_file::{ElementFile, MachineFile};
use motet_planner::ranges::{self, ValueRange};
use motet_planner::ToolKind;
use motet_trajectory::{
    Element, ElementChain, JointMap, KinematicsKind, ProfileKind, Unit, MAX_AXES,
};
use std::ops::Range;
use std::path::Path;

/// Turns byte offsets into line and column for error messages.
pub(crate) struct Source<'a> {
    pub file: String,
    pub text: &'a str,
}

impl Source<'_> {
    pub fn err(&self, span: Range<usize>, message: impl Into<String>) -> MachineError {
        let at = span.start.min(self.text.len());
        let before = &self.text[..at];
        let line = before.matches('\n').count() + 1;
        let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        MachineError {
            file: self.file.clone(),
            line,
            column,
            message: message.into(),
        }
    }

    /// `v` if it is in `range`, else an error at `span` that names `what`.
    fn in_range(
        &self,
        span: Range<usize>,
        range: ValueRange,
        what: impl std::fmt::Display,
        v: f64,
    ) -> Result<f64, MachineError> {
        range
            .check(what, v)
            .map_err(|e| self.err(span, e.to_string()))
    }
}

/// The fastest a joint moves, units/s: its own limit, or what its axes'
/// limits allow (a linear joint: the sum of each axis's share; a polar
/// radius: the planar speed). A polar angle near the centre has no bound
/// but its own.
fn joint_speed_bound(j: &Joint, axes: &[Axis]) -> Option<f64> {
    let v = |i: usize| axes.get(i).map_or(f64::INFINITY, |a| a.max_velocity);
    let derived = match j.map {
        JointMap::Linear { coeffs } => Some(
            coeffs
                .iter()
                .enumerate()
                .filter(|(_, c)| **c != 0.0)
                .map(|(i, c)| c.abs() * v(i))
                .sum::<f64>(),
        ),
        // A polar radius moves no faster than the planar speed.
        JointMap::Plane {
            kinematics: KinematicsKind::Polar(_),
            joint: 0,
            x,
            y,
        } => Some(v(x as usize).hypot(v(y as usize))),
        JointMap::Plane { .. } => None,
    };
    match (j.max_velocity, derived) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
    .filter(|v| v.is_finite())
}

pub(crate) fn build(src: &Source, raw: MachineFile, file: &Path) -> Result<Machine, MachineError> {
    let m = &raw.motion;
    let kinematics =
        crate::machine_kinematics::kinematics_from(&m.kinematics, raw.geometry.as_ref())
            .map_err(|(span, message)| src.err(span, message))?;
    let profile = match m.profile.get_ref().as_str() {
        "trapezoid" => ProfileKind::Trapezoid,
        "scurve" => ProfileKind::SCurve,
        other => {
            return Err(src.err(
                m.profile.span(),
                format!("unknown profile `{other}`; expected trapezoid or scurve"),
            ))
        }
    };
    for (v, range, what) in [
        (
            &m.junction_deviation,
            ranges::JUNCTION_DEVIATION_MM,
            "junction_deviation",
        ),
        (&m.tolerance, ranges::TOLERANCE_MM, "tolerance"),
        (&m.min_radius, ranges::MIN_RADIUS_MM, "min_radius"),
    ] {
        src.in_range(
            v.span(),
            range,
            format_args!("[motion] {what}"),
            *v.get_ref(),
        )?;
    }
    let lookahead = ranges::LOOKAHEAD
        .check_count("[motion] lookahead", *m.lookahead.get_ref())
        .map_err(|e| src.err(m.lookahead.span(), e.to_string()))?;

    // Axes, in file order of their names (BTreeMap: alphabetical) would scramble
    // x, y, z: order them by the conventional letters first.
    let mut names: Vec<&String> = raw.axes.keys().collect();
    let rank = |n: &str| {
        ["x", "y", "z", "e", "a", "b", "c"]
            .iter()
            .position(|k| *k == n)
            .unwrap_or(99)
    };
    names.sort_by_key(|n| (rank(n), (*n).clone()));
    if names.is_empty() {
        return Err(src.err(0..0, "the machine has no [axes]"));
    }
    if names.len() > MAX_AXES {
        let span = raw.axes[names[MAX_AXES]].span();
        return Err(src.err(span, format!("at most {MAX_AXES} axes are supported")));
    }
    let mut axes = Vec::new();
    for name in &names {
        let a = &raw.axes[*name];
        let span = a.span();
        let a = a.get_ref();
        if !name.chars().all(|c| c.is_ascii_lowercase()) || name.is_empty() {
            return Err(src.err(
                span,
                format!("axis name `{name}` must be lower-case letters"),
            ));
        }
        let path = a.path.unwrap_or(name.as_str() != "e");
        let travel = match &a.travel {
            Some(t) => {
                let (lo, hi) = match t.get_ref()[..] {
                    [lo, hi] => (lo, hi),
                    _ => (f64::NAN, f64::NAN),
                };
                if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                    return Err(src.err(
                        t.span(),
                        format!("axis {name}: travel must be [min, max] with min < max"),
                    ));
                }
                for v in [lo, hi] {
                    src.in_range(
                        t.span(),
                        ranges::COORDINATE,
                        format_args!("axis {name}: travel"),
                        v,
                    )?;
                }
                [lo, hi]
            }
            None if !path => [f64::NEG_INFINITY, f64::INFINITY],
            None => return Err(src.err(span, format!("axis {name}: missing field `travel`"))),
        };
        for (v, range, what) in [
            (Some(&a.max_velocity), ranges::VELOCITY, "max_velocity"),
            (
                Some(&a.max_acceleration),
                ranges::ACCELERATION,
                "max_acceleration",
            ),
            (a.max_jerk.as_ref(), ranges::JERK, "max_jerk"),
        ] {
            if let Some(v) = v {
                src.in_range(
                    v.span(),
                    range,
                    format_args!("axis {name}: {what}"),
                    *v.get_ref(),
                )?;
            }
        }
        axes.push(Axis {
            name: (*name).clone(),
            travel,
            max_velocity: *a.max_velocity.get_ref(),
            max_acceleration: *a.max_acceleration.get_ref(),
            max_jerk: a.max_jerk.as_ref().map(|j| *j.get_ref()),
            path,
        });
    }
    if profile == ProfileKind::SCurve && axes.iter().all(|a| a.max_jerk.is_none()) {
        return Err(src.err(
            m.profile.span(),
            "profile = \"scurve\" needs max_jerk on at least one axis",
        ));
    }
    let axis_index = |n: &str| axes.iter().position(|a| a.name == n);

    // Joints: the kinematics replaces x and y; every other axis is its own joint.
    let xy = if kinematics.joints().is_empty() {
        None
    } else {
        match (axis_index("x"), axis_index("y")) {
            (Some(x), Some(y)) => Some((x, y)),
            _ => {
                return Err(src.err(
                    m.kinematics.span(),
                    format!("{} kinematics needs axes named x and y", kinematics.name()),
                ))
            }
        }
    };
    let mut joints = Vec::new();
    // Where each joint comes from, for "no actuator" errors.
    let mut joint_spans = Vec::new();
    if let Some((x, y)) = xy {
        for (j, spec) in kinematics.joints().iter().enumerate() {
            joint_spans.push(m.kinematics.span());
            let angle = spec.angle;
            joints.push(Joint {
                name: spec.name.to_string(),
                map: kinematics.joint_map(j, x, y),
                unit: if angle {
                    Unit::Degree
                } else {
                    Unit::Millimetre
                },
                max_velocity: None,
                max_acceleration: None,
            });
        }
    }
    for (i, a) in axes.iter().enumerate() {
        if xy.is_some_and(|(x, y)| i == x || i == y) {
            continue;
        }
        joint_spans.push(raw.axes[&a.name].span());
        joints.push(Joint {
            name: a.name.clone(),
            map: JointMap::axis(i),
            unit: Unit::Millimetre,
            max_velocity: None,
            max_acceleration: None,
        });
    }
    let joint_names = joints
        .iter()
        .map(|j| j.name.as_str())
        .collect::<Vec<_>>()
        .join(", ");

    // Actuators and their element chains.
    let mut actuators = Vec::new();
    let mut actuator_spans: Vec<Range<usize>> = Vec::new();
    let mut driven = vec![false; joints.len()];
    for (name, a) in &raw.actuators {
        let a = a.get_ref();
        let joint = joints
            .iter()
            .position(|j| j.name == *a.joint.get_ref())
            .ok_or_else(|| {
                src.err(
                    a.joint.span(),
                    format!(
                        "actuator {name}: unknown joint `{}`; this machine's joints are {}",
                        a.joint.get_ref(),
                        joint_names
                    ),
                )
            })?;
        driven[joint] = true;
        let mut elements = Vec::new();
        for e in a.chain.get_ref() {
            check_element(src, name, e)?;
            let el = match e.get_ref() {
                ElementFile::Pulley(p) => {
                    let circumference = match (p.pitch_diameter, p.teeth, p.belt_pitch) {
                        (Some(d), None, None) => std::f64::consts::PI * d,
                        (None, Some(t), Some(pitch)) => t as f64 * pitch,
                        _ => {
                            return Err(src.err(
                                e.span(),
                                format!("actuator {name}: a pulley needs either pitch_diameter, or teeth and belt_pitch"),
                            ))
                        }
                    };
                    Element::Pulley { circumference }
                }
                ElementFile::Leadscrew { lead } => Element::Leadscrew { lead: *lead },
                ElementFile::Gear { ratio } => Element::Gear { ratio: *ratio },
                ElementFile::Stepper { step_angle } => Element::Stepper {
                    step_angle: *step_angle,
                },
                ElementFile::Microstep(n) => Element::Microstep { divisions: *n },
                ElementFile::Invert => Element::Invert,
            };
            elements.push(el);
        }
        let chain = ElementChain::new(joints[joint].unit, &elements).map_err(|e| {
            let span = a
                .chain
                .get_ref()
                .get(e.index)
                .map_or(a.chain.span(), |x| x.span());
            src.err(
                span,
                format!("actuator {name}: impossible element chain: {e}"),
            )
        })?;
        // Each element is in its range, yet together they can still give
        // more steps than a node follows, or fewer than make sense.
        src.in_range(
            a.chain.span(),
            ranges::STEPS_PER_UNIT,
            format_args!("actuator {name}: the chain's steps per unit of its joint"),
            chain.steps_per_unit.abs(),
        )?;
        for (v, range, what) in [
            (&a.max_velocity, ranges::VELOCITY, "max_velocity"),
            (
                &a.max_acceleration,
                ranges::ACCELERATION,
                "max_acceleration",
            ),
        ] {
            if let Some(v) = v {
                src.in_range(
                    v.span(),
                    range,
                    format_args!("actuator {name}: {what}"),
                    *v.get_ref(),
                )?;
            }
        }
        if let Some(v) = a.max_velocity.as_ref().map(|v| *v.get_ref()) {
            let j = &mut joints[joint];
            j.max_velocity = Some(j.max_velocity.map_or(v, |w| w.min(v)));
        }
        if let Some(v) = a.max_acceleration.as_ref().map(|v| *v.get_ref()) {
            let j = &mut joints[joint];
            j.max_acceleration = Some(j.max_acceleration.map_or(v, |w| w.min(v)));
        }
        let timing = |key: &Option<toml::Spanned<f64>>,
                      default: f32,
                      range: std::ops::RangeInclusive<f32>,
                      what: &str|
         -> Result<f32, MachineError> {
            let Some(v) = key else {
                return Ok(default);
            };
            let x = *v.get_ref();
            if !(x.is_finite() && range.contains(&(x as f32))) {
                return Err(src.err(
                    v.span(),
                    format!(
                        "actuator {name}: {what} must be from {} to {} µs",
                        range.start(),
                        range.end()
                    ),
                ));
            }
            Ok(x as f32)
        };
        let pulse_us = timing(
            &a.pulse_us,
            motet_wire::message::DEFAULT_PULSE_US,
            motet_wire::message::PULSE_US,
            "pulse_us",
        )?;
        let dir_setup_us = timing(
            &a.dir_setup_us,
            motet_wire::message::DEFAULT_DIR_SETUP_US,
            motet_wire::message::DIR_SETUP_US,
            "dir_setup_us",
        )?;
        actuator_spans.push(a.pulse_us.as_ref().map_or(a.joint.span(), |p| p.span()));
        actuators.push(Actuator {
            name: name.clone(),
            joint,
            steps_per_unit: chain.steps_per_unit,
            pulse_us,
            dir_setup_us,
            max_step_hz: None,
        });
    }
    // A step output high for `pulse_us` and low as long between pulses
    // steps at most 1 / (2 · pulse_us): a faster actuator would fall behind.
    for (a, span) in actuators.iter_mut().zip(&actuator_spans) {
        a.max_step_hz =
            joint_speed_bound(&joints[a.joint], &axes).map(|v| v * a.steps_per_unit.abs());
        let reach = 1e6 / (2.0 * a.pulse_us as f64);
        if let Some(hz) = a.max_step_hz.filter(|&hz| hz > reach) {
            return Err(src.err(
                span.clone(),
                format!(
                    "actuator {}: at its joint's top speed it steps {hz:.0} times a second, but a {} µs pulse (and as long low) allows {reach:.0}: shorten pulse_us or lower max_velocity",
                    a.name, a.pulse_us
                ),
            ));
        }
    }
    if let Some(j) = driven.iter().position(|d| !d) {
        return Err(src.err(
            joint_spans[j].clone(),
            format!(
                "joint `{}` has no actuator; add an [actuators.NAME] with joint = \"{}\"",
                joints[j].name, joints[j].name
            ),
        ));
    }

    // Tools.
    let mut tools = Vec::new();
    for (name, t) in &raw.tools {
        let t = t.get_ref();
        let kind = match t.kind.get_ref().as_str() {
            "pen" => ToolKind::Pen,
            "laser" => ToolKind::Laser,
            "spindle" => ToolKind::Spindle,
            other => {
                return Err(src.err(
                    t.kind.span(),
                    format!("tool {name}: unknown kind `{other}`; expected pen, laser or spindle"),
                ))
            }
        };
        let default_settle = match kind {
            ToolKind::Pen => 0.15,
            ToolKind::Spindle => 1.0,
            ToolKind::Laser => 0.0,
        };
        let settle = match &t.settle {
            Some(s) => src.in_range(
                s.span(),
                ranges::SETTLE_S,
                format_args!("tool {name}: settle"),
                *s.get_ref(),
            )?,
            None => default_settle,
        };
        let on_value = t.on_value.as_ref().map_or(1.0, |v| *v.get_ref());
        if on_value.is_nan() {
            let span = t.on_value.as_ref().map_or(t.kind.span(), |v| v.span());
            return Err(src.err(
                span,
                format!("tool {name}: on_value must be a number from 0 to 1"),
            ));
        }
        tools.push(Tool {
            name: name.clone(),
            kind,
            settle,
            on_value: on_value.clamp(0.0, 1.0),
        });
    }

    // Nodes: each actuator on exactly one node, each tool on at most one.
    let mut nodes = Vec::new();
    let mut owner: Vec<Option<String>> = vec![None; actuators.len()];
    let mut tool_owner: Vec<Option<String>> = vec![None; tools.len()];
    for (name, n) in &raw.nodes {
        let node_span = n.span();
        let n = n.get_ref();
        let queue = match &n.queue {
            Some(q) => ranges::NODE_QUEUE
                .check_count(format_args!("node {name}: queue"), *q.get_ref())
                .map_err(|e| src.err(q.span(), e.to_string()))?,
            None => 64,
        };
        let frame_us = match &n.frame_us {
            Some(f) => src.in_range(
                f.span(),
                ranges::FRAME_US,
                format_args!("node {name}: frame_us"),
                *f.get_ref(),
            )?,
            None => 40.0,
        };
        let mut spec = NodeSpec {
            name: name.clone(),
            actuators: vec![],
            tools: vec![],
            queue,
            frame_us,
        };
        for a in &n.actuators {
            let i = actuators
                .iter()
                .position(|x| x.name == *a.get_ref())
                .ok_or_else(|| {
                    src.err(
                        a.span(),
                        format!("node {name}: unknown actuator `{}`", a.get_ref()),
                    )
                })?;
            if let Some(other) = &owner[i] {
                return Err(src.err(
                    a.span(),
                    format!("actuator `{}` is already on node {other}", a.get_ref()),
                ));
            }
            owner[i] = Some(name.clone());
            spec.actuators.push(i);
        }
        for t in &n.tools {
            let i = tools
                .iter()
                .position(|x| x.name == *t.get_ref())
                .ok_or_else(|| {
                    src.err(
                        t.span(),
                        format!("node {name}: unknown tool `{}`", t.get_ref()),
                    )
                })?;
            if let Some(other) = &tool_owner[i] {
                return Err(src.err(
                    t.span(),
                    format!("tool `{}` is already on node {other}", t.get_ref()),
                ));
            }
            tool_owner[i] = Some(name.clone());
            spec.tools.push(i);
        }
        if spec.actuators.len() > 8 || spec.tools.len() > 4 {
            return Err(src.err(
                node_span,
                format!("node {name}: at most 8 actuators and 4 tools per node"),
            ));
        }
        nodes.push(spec);
    }
    if raw.nodes.is_empty() {
        // One node drives everything: the default that works.
        nodes.push(NodeSpec {
            name: "main".into(),
            actuators: (0..actuators.len()).collect(),
            tools: (0..tools.len()).collect(),
            queue: 64,
            frame_us: 40.0,
        });
        if actuators.len() > 8 || tools.len() > 4 {
            // Point at the first actuator or tool that does not fit.
            let span = match raw.actuators.values().nth(8) {
                Some(a) => a.span(),
                None => raw.tools.values().nth(4).map_or(0..0, |t| t.span()),
            };
            return Err(src.err(
                span,
                "more than 8 actuators or 4 tools: split them over [nodes.NAME] tables",
            ));
        }
    } else if let Some(i) = owner.iter().position(|o| o.is_none()) {
        let span = raw.actuators[&actuators[i].name].span();
        return Err(src.err(
            span,
            format!("actuator `{}` is on no node", actuators[i].name),
        ));
    }

    // Start position.
    let mut start = [0.0; MAX_AXES];
    for (i, a) in axes.iter().enumerate() {
        if a.travel[0] > 0.0 || a.travel[1] < 0.0 {
            start[i] = a.travel[0];
        }
    }
    for (name, v) in m.start.get_ref() {
        let i = axis_index(name).ok_or_else(|| {
            src.err(
                m.start.span(),
                format!("[motion] start: unknown axis `{name}`"),
            )
        })?;
        if !(v.is_finite() && *v >= axes[i].travel[0] && *v <= axes[i].travel[1]) {
            return Err(src.err(
                m.start.span(),
                format!("[motion] start: {name} = {v} is outside the axis's travel"),
            ));
        }
        start[i] = *v;
    }
    if let Some((x, y)) = xy {
        if let Err(why) = kinematics.reach(start[x], start[y]) {
            return Err(src.err(
                m.start.span(),
                format!(
                    "[motion] start ({}, {}) is {why} of the {} kinematics; set [motion] start = {{ x = …, y = … }}",
                    start[x],
                    start[y],
                    kinematics.name()
                ),
            ));
        }
    }
    if let (KinematicsKind::Polar(_), Some((x, y))) = (kinematics, xy) {
        if start[x].hypot(start[y]) < *m.min_radius.get_ref() {
            return Err(src.err(
                m.kinematics.span(),
                format!(
                    "a polar machine cannot start within min_radius = {} mm of the centre; set [motion] start = {{ x = …, y = … }}",
                    m.min_radius.get_ref()
                ),
            ));
        }
    }
    let slowest = axes
        .iter()
        .filter(|a| a.path)
        .map(|a| a.max_velocity)
        .fold(f64::INFINITY, f64::min);
    let draw_feed = m.draw_feed.as_ref().map_or(
        if slowest.is_finite() {
            0.5 * slowest
        } else {
            10.0
        },
        |d| *d.get_ref(),
    );
    let span = m.draw_feed.as_ref().map_or(0..0, |d| d.span());
    src.in_range(span, ranges::VELOCITY, "[motion] draw_feed", draw_feed)?;

    // A node holding the horizon's segments can always be given a window it
    // can stop inside; a longer horizon than the smallest queue cannot be.
    let smallest_queue = nodes.iter().map(|n| n.queue).min().unwrap_or(64);
    let horizon = *m.stop_horizon.get_ref();
    if !(0..=smallest_queue as i64).contains(&horizon) {
        return Err(src.err(
            m.stop_horizon.span(),
            format!(
                "[motion] stop_horizon must be 0 (off) to {smallest_queue} (the smallest node queue), got {horizon}"
            ),
        ));
    }
    let stop_horizon = horizon as usize;

    Ok(Machine {
        name: raw.name,
        description: raw.description,
        file: file.to_path_buf(),
        axes,
        kinematics,
        xy,
        joints,
        actuators,
        tools,
        nodes,
        junction_deviation: *m.junction_deviation.get_ref(),
        profile,
        tolerance: *m.tolerance.get_ref(),
        draw_feed,
        start,
        min_radius: *m.min_radius.get_ref(),
        lookahead,
        stop_horizon,
    })
}

/// The values of one chain element, each in its range.
fn check_element(
    src: &Source,
    actuator: &str,
    e: &toml::Spanned<ElementFile>,
) -> Result<(), MachineError> {
    let span = e.span();
    let check = |range: ValueRange, what: &str, v: f64| {
        src.in_range(
            span.clone(),
            range,
            format_args!("actuator {actuator}: {what}"),
            v,
        )
        .map(|_| ())
    };
    match e.get_ref() {
        ElementFile::Pulley(p) => {
            if let Some(d) = p.pitch_diameter {
                check(ranges::ELEMENT_MM, "pulley pitch_diameter", d)?;
            }
            if let Some(t) = p.teeth {
                check(ranges::TEETH, "pulley teeth", f64::from(t))?;
            }
            if let Some(b) = p.belt_pitch {
                check(ranges::ELEMENT_MM, "pulley belt_pitch", b)?;
            }
            Ok(())
        }
        ElementFile::Leadscrew { lead } => check(ranges::ELEMENT_MM, "leadscrew lead", *lead),
        ElementFile::Gear { ratio } => check(ranges::GEAR_RATIO, "gear ratio", *ratio),
        ElementFile::Stepper { step_angle } => {
            check(ranges::STEP_ANGLE_DEG, "stepper step_angle", *step_angle)
        }
        ElementFile::Microstep(n) => check(ranges::MICROSTEPS, "microstep", f64::from(*n)),
        ElementFile::Invert => Ok(()),
    }
}
