//! The machine file a composition makes, written for a person to read and
//! edit: the chain in a comment, then the ordinary sections (`[motion]`,
//! `[axes]`, `[actuators]`, `[tools]`, `[heaters]`, `[nodes]`), one node
//! per module, and each module's identity and description under
//! `[modules.NAME]`.
//!
//! A servo module's actuator gets the `servo` table and an `encoder`
//! element, a heater module a `[heaters.NAME]` listed on its node: the keys
//! of the closed-loop machine file.

use super::compose::{joint_channels, Composed, Composition, Role};
use super::viability::machine_travel;
use super::write_description::{description_toml, toml_num, toml_str};
use motet_planner::ranges::rounded;
use motet_wire::describe::{ChannelSpec, HeaterChannel, ModuleKind};
use std::fmt::Write;

/// A node's name, actuators, tools and heaters.
type NodeLines = (String, Vec<String>, Vec<String>, Vec<String>);

/// The node names of a composition's modules: each module's name.
fn node_name(m: &Composed) -> &str {
    m.name()
}

/// The machine file for a viable composition named `name`.
pub fn machine_toml(c: &Composition, name: &str) -> String {
    let mut s = String::new();
    write_header(&mut s, c, name);

    let axes = c.axes();
    let _ = writeln!(s, "[motion]\nkinematics = \"cartesian\"");
    let start: Vec<String> = axes
        .iter()
        .map(|(a, m)| {
            let home = f64::from(m.module.description.limits.home);
            let v = match m.role {
                Role::Axis { inverted: true, .. } => -home,
                _ => home,
            };
            format!("{a} = {}", rounded(v + 0.0))
        })
        .collect();
    let _ = writeln!(s, "start = {{ {} }}", start.join(", "));

    for (a, m) in &axes {
        let l = &m.module.description.limits;
        let [lo, hi] = machine_travel(m);
        let _ = writeln!(
            s,
            "\n[axes.{a}]                       # module {}",
            m.name()
        );
        let _ = writeln!(s, "travel = [{}, {}]", rounded(lo + 0.0), rounded(hi + 0.0));
        let _ = writeln!(s, "max_velocity = {}", toml_num(l.max_velocity));
        let _ = writeln!(s, "max_acceleration = {}", toml_num(l.max_acceleration));
    }

    let mut node_lines: Vec<NodeLines> = Vec::new();
    for m in &c.modules {
        let mut actuators = Vec::new();
        let mut tools = Vec::new();
        let mut heaters = Vec::new();
        if let Role::Axis { axis, inverted } = m.role {
            let d = &m.module.description;
            let n = joint_channels(d).count();
            for (k, spec) in joint_channels(d).enumerate() {
                let act = if n == 1 {
                    m.name().to_string()
                } else {
                    format!("{}_{}", m.name(), k + 1)
                };
                let _ = writeln!(s, "\n[actuators.{act}]");
                let _ = writeln!(s, "joint = \"{axis}\"");
                let _ = writeln!(s, "chain = [{}]", chain(d.kind, spec, inverted).join(", "));
                if let ChannelSpec::Servo { gains, .. } = spec {
                    write_servo(&mut s, &act, gains);
                }
                actuators.push(act);
            }
        }
        for ch in &m.module.description.channels {
            match &ch.spec {
                ChannelSpec::Tool { tool, settle, .. } => {
                    let _ = writeln!(s, "\n[tools.{}]", m.name());
                    let _ = writeln!(s, "kind = {}", toml_str(tool.name()));
                    let _ = writeln!(s, "settle = {}", toml_num(*settle));
                    tools.push(m.name().to_string());
                }
                ChannelSpec::Heater {
                    channel,
                    max_c,
                    time_constant,
                } => {
                    let _ = writeln!(s, "\n[heaters.{}]", m.name());
                    match channel {
                        HeaterChannel::Hotend(i) => {
                            let _ = writeln!(s, "channel = \"hotend\"\nindex = {i}");
                        }
                        HeaterChannel::Bed => {
                            let _ = writeln!(s, "channel = \"bed\"");
                        }
                        HeaterChannel::Chamber => {
                            let _ = writeln!(s, "channel = \"chamber\"");
                        }
                    }
                    let _ = writeln!(s, "max = {}", toml_num(*max_c));
                    let _ = writeln!(s, "time_constant = {}", toml_num(*time_constant));
                    heaters.push(m.name().to_string());
                }
                _ => {}
            }
        }
        node_lines.push((node_name(m).to_string(), actuators, tools, heaters));
    }
    let list = |v: &[String]| v.iter().map(|x| toml_str(x)).collect::<Vec<_>>().join(", ");
    for (node, actuators, tools, heaters) in &node_lines {
        let _ = writeln!(s, "\n[nodes.{node}]");
        if !actuators.is_empty() {
            let _ = writeln!(s, "actuators = [{}]", list(actuators));
        }
        if !tools.is_empty() {
            let _ = writeln!(s, "tools = [{}]", list(tools));
        }
        if !heaters.is_empty() {
            let _ = writeln!(s, "heaters = [{}]", list(heaters));
        }
    }
    for m in &c.modules {
        let node = node_name(m);
        let _ = writeln!(s, "\n[modules.{node}]");
        let _ = writeln!(s, "order = {}", m.order);
        let _ = writeln!(s, "uid = \"{}\"", super::format_uid(m.module.uid));
        if let Some(f) = m.module.firmware {
            let _ = writeln!(s, "firmware = \"{f}\"");
        }
        let _ = writeln!(s, "digest = \"{:08x}\"", m.module.description.digest());
        s.push_str(&description_toml(
            &m.module.description,
            &format!("modules.{node}.description"),
        ));
    }
    s
}

/// The file's head: the modules in order with their roles, where the tool
/// point is, and the machine's name.
fn write_header(s: &mut String, c: &Composition, name: &str) {
    let _ = writeln!(*s, "# Composed from modules, tool to workpiece:");
    for m in &c.modules {
        let role = match &m.role {
            Role::Axis { axis, inverted } => {
                format!("axis {axis}{}", if *inverted { " (inverted)" } else { "" })
            }
            Role::Tool => "tool".into(),
            Role::Heater => "heater".into(),
            Role::Passive => "passive".into(),
            Role::Unresolved(_) => "unresolved".into(),
        };
        let _ = writeln!(
            *s,
            "#   {}. {:<12} {:<13} -> {:<16} uid {}",
            m.order,
            m.name(),
            m.module.description.kind.name(),
            role,
            super::format_uid(m.module.uid)
        );
    }
    let p = c.tool_point();
    let _ = writeln!(
        *s,
        "# With every joint at 0 the tool point is at ({}, {}, {}) mm in the workpiece frame.",
        rounded(p[0]),
        rounded(p[1]),
        rounded(p[2])
    );
    let _ = writeln!(
        *s,
        "# Edit what you like; [modules] records what each module said of itself, and\n# `motet run --nodes paired` and `motet check --nodes paired` compare it with the bus."
    );
    let _ = writeln!(*s, "name = {}\n", toml_str(name));
}

/// A servo actuator's loop, `[actuators.ACT.servo]`.
fn write_servo(s: &mut String, act: &str, g: &motet_wire::describe::ServoGains) {
    let _ = writeln!(*s, "\n[actuators.{act}.servo]");
    let _ = writeln!(*s, "rate_hz = {}", g.rate_hz);
    for (k, v) in [
        ("kp", g.kp),
        ("ki", g.ki),
        ("kd", g.kd),
        ("kv", g.kv),
        ("ka", g.ka),
        ("integral_limit", g.integral_limit),
        ("output_limit", g.output_limit),
    ] {
        let _ = writeln!(*s, "{k} = {}", toml_num(v));
    }
    let _ = writeln!(*s, "following_limit = {}", g.following_limit);
}

/// The element chain of one joint channel: screw or gear, motor, its
/// microsteps (or encoder), `invert` when the joint runs against its axis
/// or the motor is wired the other way round.
fn chain(kind: ModuleKind, spec: &ChannelSpec, inverted: bool) -> Vec<String> {
    let mut out = Vec::new();
    let (lead, ratio, wired) = match spec {
        ChannelSpec::Step {
            lead,
            ratio,
            invert,
            ..
        }
        | ChannelSpec::Servo {
            lead,
            ratio,
            invert,
            ..
        } => (*lead, *ratio, *invert),
        _ => return out,
    };
    if kind != ModuleKind::Rotary {
        out.push(format!("{{ leadscrew = {{ lead = {} }} }}", toml_num(lead)));
    }
    if ratio != 1.0 || kind == ModuleKind::Rotary {
        out.push(format!("{{ gear = {{ ratio = {} }} }}", toml_num(ratio)));
    }
    match spec {
        ChannelSpec::Step {
            step_angle,
            microstep,
            ..
        } => {
            out.push(format!(
                "{{ stepper = {{ step_angle = {} }} }}",
                toml_num(*step_angle)
            ));
            out.push(format!("{{ microstep = {microstep} }}"));
        }
        ChannelSpec::Servo { encoder_lines, .. } => {
            out.push(format!("{{ encoder = {{ lines = {encoder_lines} }} }}"));
        }
        _ => {}
    }
    if inverted != wired {
        out.push("\"invert\"".into());
    }
    out
}
