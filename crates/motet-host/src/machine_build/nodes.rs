//! `[nodes.*]`: which node drives which actuators and tools; one node for
//! everything when the file names none.

use super::Source;
use crate::machine::{Actuator, MachineError, NodeSpec, Tool};
use crate::machine_file::{MachineFile, NodeFile};
use crate::servo::SensorSpec;
use motet_planner::ranges;

/// A node's own settings (queue, frame period, fixed-point time), each in
/// its range, with no actuators or tools yet.
fn settings(src: &Source, name: &str, n: &NodeFile) -> Result<NodeSpec, MachineError> {
    let queue = match &n.queue {
        Some(q) => ranges::NODE_QUEUE
            .check_count(format_args!("node {name}: queue"), *q.get_ref())
            .map_err(|e| src.err(q.span(), e.to_string()))?,
        None => 64,
    };
    let frame_us = src.value_or(
        n.frame_us.as_ref(),
        ranges::FRAME_US,
        format_args!("node {name}: frame_us"),
        40.0,
    )?;
    let fixed_time_us = src.value_or(
        n.fixed_time_us.as_ref(),
        ranges::FIXED_TIME_US,
        format_args!("node {name}: fixed_time_us"),
        0.0,
    )?;
    let sample_budget = src.value_or(
        n.sample_budget.as_ref(),
        super::servo::SAMPLE_BUDGET,
        format_args!("node {name}: sample_budget"),
        super::servo::DEFAULT_SAMPLE_BUDGET,
    )?;
    Ok(NodeSpec {
        name: name.to_string(),
        actuators: vec![],
        tools: vec![],
        queue,
        frame_us,
        fixed_time_us,
        sensors: vec![],
        sample_budget,
    })
}

/// The machine's nodes: each actuator on exactly one, each tool on at most
/// one.
pub(super) fn nodes(
    src: &Source,
    raw: &MachineFile,
    actuators: &[Actuator],
    tools: &[Tool],
    sensors: &[SensorSpec],
) -> Result<Vec<NodeSpec>, MachineError> {
    let mut nodes = Vec::new();
    let mut owner: Vec<Option<String>> = vec![None; actuators.len()];
    let mut tool_owner: Vec<Option<String>> = vec![None; tools.len()];
    for (name, n) in &raw.nodes {
        let node_span = n.span();
        let n = n.get_ref();
        let mut spec = settings(src, name, n)?;
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
        for s in &n.sensors {
            let i = sensors
                .iter()
                .position(|x| x.name == *s.get_ref())
                .ok_or_else(|| {
                    src.err(
                        s.span(),
                        format!("node {name}: unknown sensor `{}`", s.get_ref()),
                    )
                })?;
            if !spec.actuators.contains(&sensors[i].actuator) {
                return Err(src.err(
                    s.span(),
                    format!(
                        "node {name}: sensor `{}` is on actuator {}, which another node drives",
                        s.get_ref(),
                        actuators[sensors[i].actuator].name
                    ),
                ));
            }
            spec.sensors.push(i);
        }
        check_loops(src, name, node_span.clone(), &spec, actuators)?;
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
            fixed_time_us: 0.0,
            sensors: (0..sensors.len()).collect(),
            sample_budget: super::servo::DEFAULT_SAMPLE_BUDGET,
        });
        check_loops(src, "main", 0..0, &nodes[0], actuators)?;
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

    Ok(nodes)
}

/// A node runs at most `MAX_SERVOS` servos and `MAX_SENSORS` sensors.
fn check_loops(
    src: &Source,
    name: &str,
    span: std::ops::Range<usize>,
    spec: &NodeSpec,
    actuators: &[Actuator],
) -> Result<(), MachineError> {
    use motet_node::control::{MAX_SENSORS, MAX_SERVOS};
    let servos = spec
        .actuators
        .iter()
        .filter(|&&a| actuators[a].servo.is_some())
        .count();
    if servos > MAX_SERVOS || spec.sensors.len() > MAX_SENSORS {
        return Err(src.err(
            span,
            format!("node {name}: at most {MAX_SERVOS} servo actuators and {MAX_SENSORS} sensors per node"),
        ));
    }
    Ok(())
}
