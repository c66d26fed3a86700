//! Description files: what a module says of itself, as TOML a person
//! writes (`motet node --sim --describe FILE` serves one, and a machine
//! file composed from modules keeps each module's as
//! `[modules.NAME.description]`).
//!
//! ```toml
//! kind = "stepper-axis"        # stepper-axis | servo-axis | rotary | tool | heater | sensor | input
//! name = "x"                   # what a person orders it by; its node's name
//! model = "MRMT base module"
//! [placement]                  # from this module's frame to the next one's, towards the workpiece
//! joint = "x"                  # the axis of its own frame it moves along (turns about); "-x" the other way
//! htm = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -111], [0, 0, 0, 1]]
//! [limits]                     # axis modules: mm (degrees for a rotary one)
//! travel = [0, 300]
//! max_velocity = 40
//! max_acceleration = 400
//! resolution = 0.01
//! accuracy = 0.05
//! [[channels]]
//! drives = "joint"
//! step = { lead = 5, step_angle = 1.8, microstep = 16 }
//! ```
//!
//! Every error is at its place (`file:line:column`), naming the module and
//! the field.

use super::check::{problems, step_length, valid_name};
use crate::machine_build::Source;
use motet_wire::describe::{
    Channel, ChannelSpec, Description, HeaterChannel, Identity, JointAxis, Label, Limits,
    ModuleKind, Placement, ServoGains, ToolKind, IDENTITY_HTM,
};
use serde::Deserialize;
use std::ops::Range;
use std::path::Path;
use toml::Spanned;

/// A problem in a description, at its place.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}: {}{message}", place(.file, *.line, *.column), about(.module, .field))]
pub struct DescriptionError {
    /// The file, as given.
    pub file: String,
    /// Line, from 1 (0: the file could not be read).
    pub line: usize,
    /// Column in characters, from 1.
    pub column: usize,
    /// The module's name (`?` before it is known).
    pub module: String,
    /// The field (`limits.travel`, `channels[1].step.lead`).
    pub field: String,
    /// What is wrong.
    pub message: String,
}

/// `module x: limits.travel: `, or nothing before the module is known
/// (the file does not read as TOML).
fn about(module: &str, field: &str) -> String {
    if module == "?" {
        String::new()
    } else {
        format!("module {module}: {field}: ")
    }
}

fn place(file: &str, line: usize, column: usize) -> String {
    match line {
        0 => file.to_string(),
        _ => format!("{file}:{line}:{column}"),
    }
}

/// A description file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DescriptionFile {
    kind: Spanned<String>,
    name: Spanned<String>,
    #[serde(default)]
    model: Option<Spanned<String>>,
    #[serde(default)]
    hardware: Option<Spanned<String>>,
    #[serde(default)]
    placement: Option<Spanned<PlacementFile>>,
    #[serde(default)]
    limits: Option<Spanned<LimitsFile>>,
    #[serde(default)]
    channels: Vec<Spanned<ChannelFile>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlacementFile {
    #[serde(default)]
    joint: Option<Spanned<String>>,
    #[serde(default)]
    htm: Option<Spanned<Vec<Spanned<Vec<f64>>>>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LimitsFile {
    travel: Spanned<Vec<f64>>,
    max_velocity: Spanned<f64>,
    max_acceleration: Spanned<f64>,
    #[serde(default)]
    resolution: Option<Spanned<f64>>,
    #[serde(default)]
    accuracy: Option<Spanned<f64>>,
    #[serde(default)]
    home: Option<Spanned<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ChannelFile {
    drives: Spanned<String>,
    #[serde(default)]
    step: Option<Spanned<StepFile>>,
    #[serde(default)]
    servo: Option<Spanned<ServoFile>>,
    #[serde(default)]
    tool: Option<Spanned<ToolFile>>,
    #[serde(default)]
    heater: Option<Spanned<HeaterFile>>,
    #[serde(default)]
    sensor: Option<Spanned<SensorFile>>,
    #[serde(default)]
    input: Option<Spanned<InputFile>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct StepFile {
    #[serde(default)]
    lead: Option<Spanned<f64>>,
    #[serde(default)]
    ratio: Option<Spanned<f64>>,
    #[serde(default)]
    step_angle: Option<Spanned<f64>>,
    microstep: Spanned<i64>,
    #[serde(default)]
    invert: bool,
    #[serde(default)]
    max_step_hz: Option<Spanned<i64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ServoFile {
    #[serde(default)]
    lead: Option<Spanned<f64>>,
    #[serde(default)]
    ratio: Option<Spanned<f64>>,
    encoder_lines: Spanned<i64>,
    #[serde(default)]
    invert: bool,
    #[serde(default)]
    rate_hz: Option<Spanned<i64>>,
    #[serde(default)]
    kp: f64,
    #[serde(default)]
    ki: f64,
    #[serde(default)]
    kd: f64,
    #[serde(default)]
    kv: f64,
    #[serde(default)]
    ka: f64,
    #[serde(default)]
    integral_limit: Option<f64>,
    #[serde(default)]
    output_limit: Option<f64>,
    #[serde(default)]
    following_limit: Option<Spanned<i64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ToolFile {
    kind: Spanned<String>,
    #[serde(default)]
    max: Option<f64>,
    #[serde(default)]
    settle: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct HeaterFile {
    channel: Spanned<String>,
    #[serde(default)]
    index: Option<Spanned<i64>>,
    max: f64,
    time_constant: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SensorFile {
    quantity: Spanned<String>,
    #[serde(default)]
    unit: Option<Spanned<String>>,
    rate_hz: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct InputFile {
    kind: Spanned<String>,
}

/// Reads a description file.
pub fn load_description(path: &Path) -> Result<Description, DescriptionError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| DescriptionError {
        file: file.clone(),
        line: 0,
        column: 0,
        module: "?".into(),
        field: "file".into(),
        message: format!("cannot read the description: {e}"),
    })?;
    parse_description(&text, &file)
}

/// Parses and checks description file text (`file` names it in errors).
pub fn parse_description(text: &str, file: &str) -> Result<Description, DescriptionError> {
    let src = Source {
        file: file.to_string(),
        text,
    };
    let raw: DescriptionFile = toml::from_str(text).map_err(|e| {
        let err = src.err(e.span().unwrap_or(0..0), e.message().to_string());
        DescriptionError {
            file: err.file,
            line: err.line,
            column: err.column,
            module: "?".into(),
            field: "file".into(),
            message: err.message,
        }
    })?;
    from_file(&src, &raw, 0)
}

/// A description as a machine file or a description file holds it, its
/// spans offset by `base` in `src` (a description is checked as part of the
/// file it is in).
pub(crate) fn from_file(
    src: &Source,
    raw: &DescriptionFile,
    base: usize,
) -> Result<Description, DescriptionError> {
    let mut b = Builder {
        src,
        base,
        module: raw.name.get_ref().clone(),
        spans: vec![(String::new(), 0..0)],
    };
    let d = b.build(raw)?;
    // The first problem, at the place of the longest field path that was
    // written (the field itself, or the table it is missing from).
    if let Some(p) = problems(&d).into_iter().next() {
        let span = b
            .spans
            .iter()
            .filter(|(f, _)| p.field.starts_with(f.as_str()))
            .max_by_key(|(f, _)| f.len())
            .map(|(_, s)| s.clone())
            .unwrap_or(0..0);
        return Err(b.error(span, &p.field, p.message));
    }
    Ok(d)
}

struct Builder<'a> {
    src: &'a Source<'a>,
    base: usize,
    module: String,
    /// Where each field was written.
    spans: Vec<(String, Range<usize>)>,
}

impl Builder<'_> {
    fn error(
        &self,
        span: Range<usize>,
        field: &str,
        message: impl Into<String>,
    ) -> DescriptionError {
        let span = span.start + self.base..span.end + self.base;
        let e = self.src.err(span, message);
        DescriptionError {
            file: e.file,
            line: e.line,
            column: e.column,
            module: self.module.clone(),
            field: field.to_string(),
            message: e.message,
        }
    }

    fn at(&mut self, field: impl Into<String>, span: Range<usize>) {
        self.spans.push((field.into(), span));
    }

    fn text<const N: usize>(
        &mut self,
        field: &str,
        v: &Spanned<String>,
    ) -> Result<heapless::String<N>, DescriptionError> {
        self.at(field, v.span());
        heapless::String::try_from(v.get_ref().as_str())
            .map_err(|_| self.error(v.span(), field, format!("at most {N} bytes")))
    }

    fn build(&mut self, raw: &DescriptionFile) -> Result<Description, DescriptionError> {
        let kind = ModuleKind::parse(raw.kind.get_ref()).ok_or_else(|| {
            let known: Vec<&str> = ModuleKind::ALL.iter().map(|k| k.name()).collect();
            self.error(
                raw.kind.span(),
                "kind",
                format!(
                    "unknown module kind `{}`; expected {}",
                    raw.kind.get_ref(),
                    known.join(", ")
                ),
            )
        })?;
        self.at("kind", raw.kind.span());
        if !valid_name(raw.name.get_ref()) {
            return Err(self.error(
                raw.name.span(),
                "name",
                "must be a lower-case letter, then lower-case letters, digits or _, at most 16 bytes",
            ));
        }
        let name = self.text("name", &raw.name)?;
        let model = match &raw.model {
            Some(m) => self.text("model", m)?,
            None => heapless::String::new(),
        };
        let hardware = match &raw.hardware {
            Some(h) => self.text("hardware", h)?,
            None => Label::new(),
        };
        let placement = self.placement(kind, raw)?;
        let mut channels = heapless::Vec::new();
        for (i, c) in raw.channels.iter().enumerate() {
            let ch = self.channel(kind, i, c)?;
            if channels.push(ch).is_err() {
                return Err(self.error(
                    c.span(),
                    "channels",
                    format!(
                        "at most {} channels",
                        motet_wire::describe::MAX_MODULE_CHANNELS
                    ),
                ));
            }
        }
        self.at("channels", raw.channels.first().map_or(0..0, |c| c.span()));
        let limits = self.limits(kind, raw, &channels)?;
        Ok(Description {
            kind,
            described: true,
            identity: Identity {
                name,
                model,
                hardware,
            },
            placement,
            limits,
            channels,
        })
    }

    fn placement(
        &mut self,
        kind: ModuleKind,
        raw: &DescriptionFile,
    ) -> Result<Placement, DescriptionError> {
        let Some(p) = &raw.placement else {
            if kind.is_axis() {
                return Err(self.error(
                    0..0,
                    "placement",
                    "an axis module needs [placement]: the joint's axis and where the module sits",
                ));
            }
            return Ok(Placement {
                htm: IDENTITY_HTM,
                joint: JointAxis::X,
            });
        };
        self.at("placement", p.span());
        let p = p.get_ref();
        let joint = match &p.joint {
            Some(j) => {
                self.at("placement.joint", j.span());
                JointAxis::parse(j.get_ref()).ok_or_else(|| {
                    self.error(
                        j.span(),
                        "placement.joint",
                        format!(
                            "unknown axis `{}`; expected x, y, z, -x, -y or -z",
                            j.get_ref()
                        ),
                    )
                })?
            }
            None if kind.is_axis() => {
                return Err(self.error(
                    raw.placement.as_ref().map_or(0..0, |p| p.span()),
                    "placement.joint",
                    "an axis module names the axis its joint moves along or turns about",
                ))
            }
            None => JointAxis::X,
        };
        let mut htm = IDENTITY_HTM;
        if let Some(m) = &p.htm {
            self.at("placement.htm", m.span());
            let rows = m.get_ref();
            if rows.len() != 4 || rows.iter().any(|r| r.get_ref().len() != 4) {
                let span = rows
                    .iter()
                    .find(|r| r.get_ref().len() != 4)
                    .map_or(m.span(), |r| r.span());
                return Err(self.error(
                    span,
                    "placement.htm",
                    "must be 4 rows of 4 numbers (a 4×4 homogeneous transform)",
                ));
            }
            for (r, row) in rows.iter().enumerate() {
                for (c, v) in row.get_ref().iter().enumerate() {
                    htm[r * 4 + c] = *v as f32;
                }
            }
        }
        Ok(Placement { htm, joint })
    }

    fn limits(
        &mut self,
        kind: ModuleKind,
        raw: &DescriptionFile,
        channels: &[Channel],
    ) -> Result<Limits, DescriptionError> {
        let Some(l) = &raw.limits else {
            if kind.is_axis() {
                return Err(self.error(
                    0..0,
                    "limits",
                    "an axis module needs [limits]: travel, max_velocity, max_acceleration",
                ));
            }
            return Ok(Limits::default());
        };
        self.at("limits", l.span());
        let l = l.get_ref();
        self.at("limits.travel", l.travel.span());
        let travel = match l.travel.get_ref()[..] {
            [lo, hi] => [lo as f32, hi as f32],
            _ => return Err(self.error(l.travel.span(), "limits.travel", "must be [min, max]")),
        };
        let mut f = |name: &str, v: &Option<Spanned<f64>>| {
            v.as_ref().map(|v| {
                self.at(format!("limits.{name}"), v.span());
                *v.get_ref() as f32
            })
        };
        let resolution = f("resolution", &l.resolution);
        let accuracy = f("accuracy", &l.accuracy);
        let home = f("home", &l.home);
        self.at("limits.max_velocity", l.max_velocity.span());
        self.at("limits.max_acceleration", l.max_acceleration.span());
        // Unsaid: a step of its joint's channel, as accurate, home at 0
        // (or the travel's low end when 0 is outside it).
        let step = channels
            .iter()
            .filter(|c| c.drives.as_str() == "joint")
            .find_map(|c| step_length(kind, &c.spec))
            .unwrap_or(0.0) as f32;
        let resolution = resolution.unwrap_or(step);
        let [lo, hi] = travel;
        Ok(Limits {
            max_velocity: *l.max_velocity.get_ref() as f32,
            max_acceleration: *l.max_acceleration.get_ref() as f32,
            travel,
            resolution,
            accuracy: accuracy.unwrap_or(resolution),
            home: home.unwrap_or(if lo <= 0.0 && 0.0 <= hi { 0.0 } else { lo }),
        })
    }

    fn channel(
        &mut self,
        kind: ModuleKind,
        i: usize,
        c: &Spanned<ChannelFile>,
    ) -> Result<Channel, DescriptionError> {
        let field = format!("channels[{i}]");
        self.at(field.clone(), c.span());
        let raw = c.get_ref();
        let drives: Label = self.text(&format!("{field}.drives"), &raw.drives)?;
        let given = [
            raw.step.as_ref().map(|s| s.span()),
            raw.servo.as_ref().map(|s| s.span()),
            raw.tool.as_ref().map(|s| s.span()),
            raw.heater.as_ref().map(|s| s.span()),
            raw.sensor.as_ref().map(|s| s.span()),
            raw.input.as_ref().map(|s| s.span()),
        ];
        let n = given.iter().flatten().count();
        if n != 1 {
            return Err(self.error(
                c.span(),
                &field,
                format!("a channel is one of step, servo, tool, heater, sensor or input; this one gives {n}"),
            ));
        }
        let spec = if let Some(s) = &raw.step {
            self.at(format!("{field}.step"), s.span());
            let s = s.get_ref();
            let (lead, ratio) =
                self.lead_ratio(kind, &format!("{field}.step"), &s.lead, &s.ratio)?;
            ChannelSpec::Step {
                lead,
                ratio,
                step_angle: s.step_angle.as_ref().map_or(1.8, |v| *v.get_ref() as f32),
                microstep: self.count(&format!("{field}.step.microstep"), &s.microstep, 1, 256)?
                    as u16,
                invert: s.invert,
                max_step_hz: match &s.max_step_hz {
                    Some(h) => {
                        self.count(&format!("{field}.step.max_step_hz"), h, 0, 100_000_000)?
                    }
                    None => 0,
                },
            }
        } else if let Some(s) = &raw.servo {
            self.servo_spec(kind, &field, s)?
        } else if let Some(t) = &raw.tool {
            self.at(format!("{field}.tool"), t.span());
            let t = t.get_ref();
            let tool = ToolKind::parse(t.kind.get_ref())
                .filter(|k| *k != ToolKind::Output)
                .ok_or_else(|| {
                    self.error(
                        t.kind.span(),
                        &format!("{field}.tool.kind"),
                        format!(
                            "unknown tool `{}`; expected spindle, laser or pen",
                            t.kind.get_ref()
                        ),
                    )
                })?;
            let settle = match tool {
                ToolKind::Pen => 0.15,
                ToolKind::Spindle => 1.0,
                _ => 0.0,
            };
            ChannelSpec::Tool {
                tool,
                max: t.max.unwrap_or(1.0) as f32,
                settle: t.settle.unwrap_or(settle) as f32,
            }
        } else if let Some(h) = &raw.heater {
            self.heater_spec(&field, h)?
        } else if let Some(s) = &raw.sensor {
            self.at(format!("{field}.sensor"), s.span());
            let s = s.get_ref();
            ChannelSpec::Sensor {
                quantity: self.text(&format!("{field}.sensor.quantity"), &s.quantity)?,
                unit: match &s.unit {
                    Some(u) => self.text(&format!("{field}.sensor.unit"), u)?,
                    None => heapless::String::new(),
                },
                rate_hz: s.rate_hz as f32,
            }
        } else if let Some(s) = &raw.input {
            self.at(format!("{field}.input"), s.span());
            ChannelSpec::Input {
                input: self.text(&format!("{field}.input.kind"), &s.get_ref().kind)?,
            }
        } else {
            unreachable!("exactly one form was given")
        };
        Ok(Channel { drives, spec })
    }

    /// A servo channel's `[channels.servo]`, at `field`.
    fn servo_spec(
        &mut self,
        kind: ModuleKind,
        field: &str,
        s: &Spanned<ServoFile>,
    ) -> Result<ChannelSpec, DescriptionError> {
        self.at(format!("{field}.servo"), s.span());
        let s = s.get_ref();
        let (lead, ratio) = self.lead_ratio(kind, &format!("{field}.servo"), &s.lead, &s.ratio)?;
        Ok(ChannelSpec::Servo {
            lead,
            ratio,
            encoder_lines: self.count(
                &format!("{field}.servo.encoder_lines"),
                &s.encoder_lines,
                1,
                10_000_000,
            )?,
            invert: s.invert,
            gains: ServoGains {
                rate_hz: match &s.rate_hz {
                    Some(r) => self.count(&format!("{field}.servo.rate_hz"), r, 1, 1_000_000)?,
                    None => 10_000,
                },
                kp: s.kp as f32,
                ki: s.ki as f32,
                kd: s.kd as f32,
                kv: s.kv as f32,
                ka: s.ka as f32,
                integral_limit: s.integral_limit.unwrap_or(0.3) as f32,
                output_limit: s.output_limit.unwrap_or(1.0) as f32,
                following_limit: match &s.following_limit {
                    Some(f) => self.count(
                        &format!("{field}.servo.following_limit"),
                        f,
                        1,
                        1_000_000_000,
                    )?,
                    None => 40,
                },
            },
        })
    }

    /// A heater channel's `[channels.heater]`, at `field`.
    fn heater_spec(
        &mut self,
        field: &str,
        h: &Spanned<HeaterFile>,
    ) -> Result<ChannelSpec, DescriptionError> {
        self.at(format!("{field}.heater"), h.span());
        let h = h.get_ref();
        let index = match &h.index {
            Some(i) => self.count(&format!("{field}.heater.index"), i, 0, 255)? as u8,
            None => 0,
        };
        let channel = match h.channel.get_ref().as_str() {
            "hotend" => HeaterChannel::Hotend(index),
            "bed" => HeaterChannel::Bed,
            "chamber" => HeaterChannel::Chamber,
            other => {
                return Err(self.error(
                    h.channel.span(),
                    &format!("{field}.heater.channel"),
                    format!("unknown heater channel `{other}`; expected hotend, bed or chamber"),
                ))
            }
        };
        Ok(ChannelSpec::Heater {
            channel,
            max_c: h.max as f32,
            time_constant: h.time_constant as f32,
        })
    }

    fn lead_ratio(
        &mut self,
        kind: ModuleKind,
        field: &str,
        lead: &Option<Spanned<f64>>,
        ratio: &Option<Spanned<f64>>,
    ) -> Result<(f32, f32), DescriptionError> {
        if let Some(l) = lead {
            self.at(format!("{field}.lead"), l.span());
        }
        if let Some(r) = ratio {
            self.at(format!("{field}.ratio"), r.span());
        }
        let lead = match (lead, kind) {
            (None, ModuleKind::StepperAxis | ModuleKind::ServoAxis) => {
                let span = self
                    .spans
                    .iter()
                    .rev()
                    .find(|(f, _)| f == field)
                    .map_or(0..0, |s| s.1.clone());
                return Err(self.error(
                    span,
                    &format!("{field}.lead"),
                    "a translational module needs its lead (mm of travel per turn of its screw or pulley)",
                ));
            }
            (l, _) => l.as_ref().map_or(0.0, |l| *l.get_ref() as f32),
        };
        Ok((lead, ratio.as_ref().map_or(1.0, |r| *r.get_ref() as f32)))
    }

    fn count(
        &mut self,
        field: &str,
        v: &Spanned<i64>,
        lo: i64,
        hi: i64,
    ) -> Result<u32, DescriptionError> {
        self.at(field, v.span());
        let n = *v.get_ref();
        if n < lo || n > hi {
            return Err(self.error(
                v.span(),
                field,
                format!("must be from {lo} to {hi}, got {n}"),
            ));
        }
        Ok(n as u32)
    }
}
