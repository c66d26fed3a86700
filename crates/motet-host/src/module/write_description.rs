//! A description as its file's TOML, for a module's file, a simulated
//! module spawned for a run, and a machine file's `[modules.NAME]` record.
//! Parsing what this writes gives the same description back.

use motet_wire::describe::{ChannelSpec, Description, HeaterChannel, ModuleKind};
use std::fmt::Write;

/// A number as TOML (an `f32` written as short as it reads back).
pub(crate) fn toml_num(v: f32) -> String {
    if v.is_nan() {
        "nan".into()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{v}")
    }
}

/// A string as TOML (quoted and escaped).
pub(crate) fn toml_str(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

/// `d` as a description file; `table` is the table it is written under
/// (empty for a file of its own, `modules.x.description` in a machine
/// file).
pub fn description_toml(d: &Description, table: &str) -> String {
    let mut s = String::new();
    let sub = |name: &str| {
        if table.is_empty() {
            name.to_string()
        } else {
            format!("{table}.{name}")
        }
    };
    if !table.is_empty() {
        let _ = writeln!(s, "[{table}]");
    }
    let _ = writeln!(s, "kind = {}", toml_str(d.kind.name()));
    let _ = writeln!(s, "name = {}", toml_str(&d.identity.name));
    if !d.identity.model.is_empty() {
        let _ = writeln!(s, "model = {}", toml_str(&d.identity.model));
    }
    if !d.identity.hardware.is_empty() {
        let _ = writeln!(s, "hardware = {}", toml_str(&d.identity.hardware));
    }
    let _ = writeln!(s, "\n[{}]", sub("placement"));
    let _ = writeln!(s, "joint = {}", toml_str(d.placement.joint.name()));
    let rows: Vec<String> = d
        .placement
        .htm
        .chunks(4)
        .map(|r| {
            format!(
                "[{}]",
                r.iter()
                    .map(|v| toml_num(*v))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
        .collect();
    let _ = writeln!(s, "htm = [{}]", rows.join(", "));
    if d.kind.is_axis() || d.limits != Default::default() {
        let l = &d.limits;
        let _ = writeln!(s, "\n[{}]", sub("limits"));
        let _ = writeln!(
            s,
            "travel = [{}, {}]",
            toml_num(l.travel[0]),
            toml_num(l.travel[1])
        );
        for (k, v) in [
            ("max_velocity", l.max_velocity),
            ("max_acceleration", l.max_acceleration),
            ("resolution", l.resolution),
            ("accuracy", l.accuracy),
            ("home", l.home),
        ] {
            let _ = writeln!(s, "{k} = {}", toml_num(v));
        }
    }
    for c in &d.channels {
        let _ = writeln!(s, "\n[[{}]]", sub("channels"));
        let _ = writeln!(s, "drives = {}", toml_str(&c.drives));
        let _ = writeln!(s, "{}", spec_toml(d.kind, &c.spec));
    }
    s
}

fn spec_toml(kind: ModuleKind, spec: &ChannelSpec) -> String {
    let n = |v: f32| toml_num(v);
    match spec {
        ChannelSpec::Step {
            lead,
            ratio,
            step_angle,
            microstep,
            invert,
            max_step_hz,
        } => {
            let lead = if kind == ModuleKind::Rotary && *lead == 0.0 {
                String::new()
            } else {
                format!("lead = {}, ", n(*lead))
            };
            format!(
                "step = {{ {lead}ratio = {}, step_angle = {}, microstep = {microstep}, invert = {invert}, max_step_hz = {max_step_hz} }}",
                n(*ratio),
                n(*step_angle)
            )
        }
        ChannelSpec::Servo {
            lead,
            ratio,
            encoder_lines,
            invert,
            gains: g,
        } => {
            let lead = if kind == ModuleKind::Rotary && *lead == 0.0 {
                String::new()
            } else {
                format!("lead = {}, ", n(*lead))
            };
            format!(
                "servo = {{ {lead}ratio = {}, encoder_lines = {encoder_lines}, invert = {invert}, rate_hz = {}, kp = {}, ki = {}, kd = {}, kv = {}, ka = {}, integral_limit = {}, output_limit = {}, following_limit = {} }}",
                n(*ratio),
                g.rate_hz,
                n(g.kp),
                n(g.ki),
                n(g.kd),
                n(g.kv),
                n(g.ka),
                n(g.integral_limit),
                n(g.output_limit),
                g.following_limit
            )
        }
        ChannelSpec::Tool { tool, max, settle } => format!(
            "tool = {{ kind = {}, max = {}, settle = {} }}",
            toml_str(tool.name()),
            n(*max),
            n(*settle)
        ),
        ChannelSpec::Heater {
            channel,
            max_c,
            time_constant,
        } => {
            let (ch, index) = match channel {
                HeaterChannel::Hotend(i) => ("hotend", format!(", index = {i}")),
                HeaterChannel::Bed => ("bed", String::new()),
                HeaterChannel::Chamber => ("chamber", String::new()),
            };
            format!(
                "heater = {{ channel = \"{ch}\"{index}, max = {}, time_constant = {} }}",
                n(*max_c),
                n(*time_constant)
            )
        }
        ChannelSpec::Sensor {
            quantity,
            unit,
            rate_hz,
        } => format!(
            "sensor = {{ quantity = {}, unit = {}, rate_hz = {} }}",
            toml_str(quantity),
            toml_str(unit),
            n(*rate_hz)
        ),
        ChannelSpec::Input { input } => format!("input = {{ kind = {} }}", toml_str(input)),
    }
}
