//! What a description must hold, whichever way it came (a description
//! file, or the wire from a module on the bus): every field in its range,
//! the channels its kind needs, a rigid placement, and limits that agree
//! with each other and with the mechanics behind them. Each problem names
//! its field (`limits.travel`, `channels[0].step.lead`), so a file's error
//! points at the key and a module's names the field.

use motet_planner::ranges::{self, ValueRange};
use motet_wire::describe::{ChannelSpec, Description, ModuleKind, ToolKind, NAME_LEN};

/// One thing wrong with a description.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Problem {
    /// The field, as a path into the description file (`limits.home`).
    pub field: String,
    /// What is wrong with it.
    pub message: String,
}

fn problem(field: impl Into<String>, message: impl Into<String>) -> Problem {
    Problem {
        field: field.into(),
        message: message.into(),
    }
}

/// How far a placement's rotation may be from a rotation (`RᵀR = I`,
/// `det R = 1`): a description is read in `f32`, so a few ulps of a
/// rotation by an arbitrary angle, far below anything a machine would notice.
pub const RIGID_TOLERANCE: f64 = 1e-4;

/// Highest target a heater may take, °C (as `[heaters]` in a machine file).
const HEATER_C: ValueRange = ValueRange::new(30.0, 1000.0, "°C");
/// A heater's time constant, s.
const HEATER_TAU_S: ValueRange = ValueRange::new(0.1, 3600.0, "s");
/// Encoder lines per motor turn.
const ENCODER_LINES: ValueRange = ValueRange::new(1.0, 1e7, "lines");
/// A node's control loop rate or a sensor's sample rate, Hz.
const RATE_HZ: ValueRange = ValueRange::new(0.001, 1e6, "Hz");
/// A tool's full output (rpm, W, 1 for a pen).
const TOOL_MAX: ValueRange = ValueRange::new(0.0, 1e6, "");

/// Whether `name` can be a module's (and its node's) name: a lower-case
/// letter, then lower-case letters, digits and `_`.
pub fn valid_name(name: &str) -> bool {
    let mut c = name.chars();
    c.next().is_some_and(|f| f.is_ascii_lowercase())
        && c.all(|ch| ch.is_ascii_lowercase() || ch.is_ascii_digit() || ch == '_')
        && name.len() <= NAME_LEN
}

/// Every problem of `d`, in the order a reader meets the fields; empty when
/// the description holds.
pub fn problems(d: &Description) -> Vec<Problem> {
    let mut out = Vec::new();
    if !d.described {
        out.push(problem(
            "kind",
            "the module has not been described: it serves its board's default description, made from its channels alone (give it one: `motet node --sim --describe FILE`, or its firmware's)",
        ));
        return out;
    }
    let name = d.identity.name.as_str();
    if !valid_name(name) {
        out.push(problem(
            "name",
            format!("`{name}` must be a lower-case letter, then lower-case letters, digits or _, at most {NAME_LEN} bytes"),
        ));
    }
    placement(d, &mut out);
    limits(d, &mut out);
    channels(d, &mut out);
    out
}

/// A number as the description gave it (`0.01`, not its `f64` expansion).
pub fn num(v: f32) -> String {
    if v.is_finite() && v != 0.0 && !(1e-4..1e7).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

fn in_range(out: &mut Vec<Problem>, field: &str, range: ValueRange, v: f32) -> bool {
    match range.check(field, f64::from(v)) {
        Ok(_) => true,
        Err(e) => {
            out.push(problem(
                field,
                format!("must be {}, got {}", e.range, num(v)),
            ));
            false
        }
    }
}

/// `RᵀR = I`, `det R = 1`, bottom row `0 0 0 1`, every number finite.
fn placement(d: &Description, out: &mut Vec<Problem>) {
    let m = super::math::from_wire(&d.placement.htm);
    let field = "placement.htm";
    if m.iter().flatten().any(|v| !v.is_finite()) {
        out.push(problem(field, "every number must be finite"));
        return;
    }
    if m[3] != [0.0, 0.0, 0.0, 1.0] {
        out.push(problem(
            field,
            format!(
                "the bottom row must be 0 0 0 1 (a homogeneous transform), got {}",
                m[3].map(ranges::rounded).join(" ")
            ),
        ));
    }
    let err = super::math::rigidity_error(&m);
    if err > RIGID_TOLERANCE {
        out.push(problem(
            field,
            format!(
                "not a rigid transform: its rotation part is off a rotation by {} (RᵀR must be I and det R 1, within {RIGID_TOLERANCE}); a module's placement cannot scale, shear or mirror",
                ranges::rounded(err)
            ),
        ));
    }
    for (i, t) in [m[0][3], m[1][3], m[2][3]].into_iter().enumerate() {
        if !ranges::COORDINATE.contains(t) {
            out.push(problem(
                field,
                format!(
                    "its translation's {} {} mm is beyond ±1 km",
                    ["x", "y", "z"][i],
                    ranges::rounded(t)
                ),
            ));
        }
    }
}

fn limits(d: &Description, out: &mut Vec<Problem>) {
    let l = &d.limits;
    if !d.kind.is_axis() {
        let zero = l.travel == [0.0, 0.0]
            && [
                l.max_velocity,
                l.max_acceleration,
                l.resolution,
                l.accuracy,
                l.home,
            ]
            .iter()
            .all(|v| *v == 0.0);
        if !zero {
            out.push(problem(
                "limits",
                format!(
                    "a {} module has no joint: limits are for axis modules",
                    d.kind.name()
                ),
            ));
        }
        return;
    }
    let unit = if d.kind == ModuleKind::Rotary {
        "°"
    } else {
        "mm"
    };
    let [lo, hi] = l.travel;
    let travel_ok = lo.is_finite() && hi.is_finite() && lo < hi;
    if !travel_ok {
        out.push(problem(
            "limits.travel",
            format!(
                "must be [min, max] with min < max, got [{}, {}]",
                num(lo),
                num(hi)
            ),
        ));
    } else {
        for v in [lo, hi] {
            if !ranges::COORDINATE.contains(f64::from(v)) {
                out.push(problem(
                    "limits.travel",
                    format!(
                        "{} {unit} is beyond ±1 km (the widest travel motet takes)",
                        num(v)
                    ),
                ));
            }
        }
    }
    in_range(out, "limits.max_velocity", ranges::VELOCITY, l.max_velocity);
    in_range(
        out,
        "limits.max_acceleration",
        ranges::ACCELERATION,
        l.max_acceleration,
    );
    let res_ok = l.resolution > 0.0 && l.resolution.is_finite();
    if !res_ok {
        out.push(problem(
            "limits.resolution",
            format!("must be a positive length, got {}", num(l.resolution)),
        ));
    } else if travel_ok && l.resolution > hi - lo {
        out.push(problem(
            "limits.resolution",
            format!(
                "{} {unit} is coarser than the whole travel [{}, {}]",
                num(l.resolution),
                num(lo),
                num(hi)
            ),
        ));
    }
    if !(l.accuracy.is_finite() && l.accuracy > 0.0) {
        out.push(problem(
            "limits.accuracy",
            format!("must be a positive length, got {}", num(l.accuracy)),
        ));
    } else if res_ok && l.accuracy < l.resolution {
        out.push(problem(
            "limits.accuracy",
            format!(
                "{} {unit} is finer than the module's resolution {} {unit}: it cannot place closer than it can move",
                num(l.accuracy),
                num(l.resolution)
            ),
        ));
    }
    if travel_ok && !(l.home >= lo && l.home <= hi) {
        out.push(problem(
            "limits.home",
            format!(
                "{} {unit} is beyond the travel [{}, {}]",
                num(l.home),
                num(lo),
                num(hi)
            ),
        ));
    }
}

/// The length one step (or encoder count) moves the joint, units, when
/// the channel's mechanics give one.
pub fn step_length(kind: ModuleKind, spec: &ChannelSpec) -> Option<f64> {
    // Rotary joints are in degrees: one output turn is 360 of them.
    let per_turn = |lead: f32| {
        if kind == ModuleKind::Rotary {
            360.0
        } else {
            f64::from(lead)
        }
    };
    match *spec {
        ChannelSpec::Step {
            lead,
            ratio,
            step_angle,
            microstep,
            ..
        } => {
            let steps = 360.0 / f64::from(step_angle) * f64::from(microstep) * f64::from(ratio);
            (steps > 0.0 && steps.is_finite()).then(|| per_turn(lead) / steps)
        }
        ChannelSpec::Servo {
            lead,
            ratio,
            encoder_lines,
            ..
        } => {
            let counts = 4.0 * f64::from(encoder_lines) * f64::from(ratio);
            (counts > 0.0).then(|| per_turn(lead) / counts)
        }
        _ => None,
    }
}

fn channels(d: &Description, out: &mut Vec<Problem>) {
    if d.channels.is_empty() {
        out.push(problem("channels", "a module needs at least one channel"));
        return;
    }
    let mut joint = 0;
    for (i, c) in d.channels.iter().enumerate() {
        let at = |f: &str| format!("channels[{i}].{f}");
        let drives_joint = c.drives.as_str() == "joint";
        let allowed = matches!(
            (&c.spec, d.kind),
            (ChannelSpec::Sensor { .. } | ChannelSpec::Input { .. }, _)
                | (
                    ChannelSpec::Step { .. },
                    ModuleKind::StepperAxis | ModuleKind::Rotary
                )
                | (
                    ChannelSpec::Servo { .. },
                    ModuleKind::ServoAxis | ModuleKind::Rotary
                )
                | (ChannelSpec::Tool { .. }, ModuleKind::Tool)
                | (ChannelSpec::Heater { .. }, ModuleKind::Heater)
        );
        if !allowed {
            out.push(problem(
                format!("channels[{i}]"),
                format!(
                    "a {} channel on a {} module: its channels are {}",
                    spec_name(&c.spec),
                    d.kind.name(),
                    kind_channels(d.kind)
                ),
            ));
            continue;
        }
        match c.spec {
            ChannelSpec::Step {
                lead,
                ratio,
                step_angle,
                microstep,
                max_step_hz,
                ..
            } => {
                lead_ratio(d.kind, &|f| at(&format!("step.{f}")), lead, ratio, out);
                in_range(
                    out,
                    &at("step.step_angle"),
                    ranges::STEP_ANGLE_DEG,
                    step_angle,
                );
                in_range(
                    out,
                    &at("step.microstep"),
                    ranges::MICROSTEPS,
                    f32::from(microstep),
                );
                if drives_joint {
                    joint += 1;
                    step_rate(d, &at("step.max_step_hz"), &c.spec, max_step_hz, out);
                }
            }
            ChannelSpec::Servo { .. } => {
                servo_channel(d.kind, &c.spec, &at, out);
                if drives_joint {
                    joint += 1;
                    step_rate(d, &at("servo"), &c.spec, 0, out);
                }
            }
            ChannelSpec::Tool { tool, max, settle } => {
                if tool == ToolKind::Output {
                    out.push(problem(
                        at("tool.kind"),
                        "an output of unknown use: a tool is a spindle, a laser or a pen",
                    ));
                }
                in_range(out, &at("tool.max"), TOOL_MAX, max);
                in_range(out, &at("tool.settle"), ranges::SETTLE_S, settle);
            }
            ChannelSpec::Heater {
                max_c,
                time_constant,
                ..
            } => {
                in_range(out, &at("heater.max"), HEATER_C, max_c);
                in_range(
                    out,
                    &at("heater.time_constant"),
                    HEATER_TAU_S,
                    time_constant,
                );
            }
            ChannelSpec::Sensor {
                ref quantity,
                rate_hz,
                ..
            } => {
                if quantity.is_empty() {
                    out.push(problem(at("sensor.quantity"), "say what it measures"));
                }
                in_range(out, &at("sensor.rate_hz"), RATE_HZ, rate_hz);
            }
            ChannelSpec::Input { ref input } => {
                if input.is_empty() {
                    out.push(problem(
                        at("input.kind"),
                        "say what it is (button, knob, pedal)",
                    ));
                }
            }
        }
    }
    channel_counts(d, joint, out);
}

/// A servo channel's own values: its mechanics, encoder, rate and gains.
fn servo_channel(
    kind: ModuleKind,
    spec: &ChannelSpec,
    at: &dyn Fn(&str) -> String,
    out: &mut Vec<Problem>,
) {
    let ChannelSpec::Servo {
        lead,
        ratio,
        encoder_lines,
        gains,
        ..
    } = *spec
    else {
        return;
    };
    lead_ratio(kind, &|f| at(&format!("servo.{f}")), lead, ratio, out);
    in_range(
        out,
        &at("servo.encoder_lines"),
        ENCODER_LINES,
        encoder_lines as f32,
    );
    in_range(out, &at("servo.rate_hz"), RATE_HZ, gains.rate_hz as f32);
    for (k, v) in [
        ("kp", gains.kp),
        ("ki", gains.ki),
        ("kd", gains.kd),
        ("kv", gains.kv),
        ("ka", gains.ka),
    ] {
        if !v.is_finite() {
            out.push(problem(at(&format!("servo.{k}")), "must be a finite gain"));
        }
    }
    let unit = ValueRange::new(0.0, 1.0, "");
    in_range(out, &at("servo.integral_limit"), unit, gains.integral_limit);
    in_range(
        out,
        &at("servo.output_limit"),
        ValueRange::new(1e-3, 1.0, ""),
        gains.output_limit,
    );
    if gains.following_limit == 0 {
        out.push(problem(
            at("servo.following_limit"),
            "must be at least 1 count",
        ));
    }
}

/// What a module of its kind needs among its channels: an axis a channel
/// that drives its joint, a tool or heater exactly one of its own, a
/// sensor or input at least one.
fn channel_counts(d: &Description, joint: usize, out: &mut Vec<Problem>) {
    let count = |f: fn(&ChannelSpec) -> bool| d.channels.iter().filter(|c| f(&c.spec)).count();
    match d.kind {
        k if k.is_axis() && joint == 0 => out.push(problem(
            "channels",
            "no channel drives the joint (`drives = \"joint\"`): nothing would move it",
        )),
        ModuleKind::Tool if count(|s| matches!(s, ChannelSpec::Tool { .. })) != 1 => out.push(
            problem("channels", "a tool module has exactly one tool channel"),
        ),
        ModuleKind::Heater if count(|s| matches!(s, ChannelSpec::Heater { .. })) != 1 => out.push(
            problem("channels", "a heater module has exactly one heater channel"),
        ),
        ModuleKind::Sensor if count(|s| matches!(s, ChannelSpec::Sensor { .. })) == 0 => out.push(
            problem("channels", "a sensor module needs a sensor channel"),
        ),
        ModuleKind::Input if count(|s| matches!(s, ChannelSpec::Input { .. })) == 0 => out.push(
            problem("channels", "an input module needs an input channel"),
        ),
        _ => {}
    }
}

fn lead_ratio(
    kind: ModuleKind,
    at: &dyn Fn(&str) -> String,
    lead: f32,
    ratio: f32,
    out: &mut Vec<Problem>,
) {
    if kind == ModuleKind::Rotary {
        if lead != 0.0 {
            out.push(problem(
                at("lead"),
                "a rotary module turns its output: give its gear `ratio`, not a lead",
            ));
        }
    } else {
        in_range(out, &at("lead"), ranges::ELEMENT_MM, lead);
    }
    in_range(out, &at("ratio"), ranges::GEAR_RATIO, ratio);
}

/// The resolution claimed is at least one step, and the top speed within
/// what the channel steps.
fn step_rate(
    d: &Description,
    field: &str,
    spec: &ChannelSpec,
    max_hz: u32,
    out: &mut Vec<Problem>,
) {
    let Some(step) = step_length(d.kind, spec) else {
        return;
    };
    let res = f64::from(d.limits.resolution);
    // A resolution a hair under a step is the same step written in f32.
    if res > 0.0 && res < step * (1.0 - 1e-4) {
        out.push(problem(
            "limits.resolution",
            format!(
                "{} is finer than one step of its mechanics ({}): it cannot move that little",
                num(d.limits.resolution),
                ranges::rounded(step)
            ),
        ));
    }
    let hz = f64::from(d.limits.max_velocity) / step;
    if max_hz > 0 && hz > f64::from(max_hz) {
        out.push(problem(
            field,
            format!(
                "its top speed {} needs {} steps/s, beyond the channel's {max_hz}",
                num(d.limits.max_velocity),
                ranges::rounded(hz)
            ),
        ));
    }
}

fn spec_name(s: &ChannelSpec) -> &'static str {
    match s {
        ChannelSpec::Step { .. } => "step",
        ChannelSpec::Servo { .. } => "servo",
        ChannelSpec::Tool { .. } => "tool",
        ChannelSpec::Heater { .. } => "heater",
        ChannelSpec::Sensor { .. } => "sensor",
        ChannelSpec::Input { .. } => "input",
    }
}

fn kind_channels(k: ModuleKind) -> &'static str {
    match k {
        ModuleKind::StepperAxis => "step channels (and sensors, inputs)",
        ModuleKind::ServoAxis => "servo channels (and sensors, inputs)",
        ModuleKind::Rotary => "step or servo channels (and sensors, inputs)",
        ModuleKind::Tool => "one tool channel (and sensors, inputs)",
        ModuleKind::Heater => "one heater channel (and sensors, inputs)",
        ModuleKind::Sensor => "sensor channels (and inputs)",
        ModuleKind::Input => "input channels (and sensors)",
    }
}
