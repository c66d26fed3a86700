//! Viability: whether modules make a machine motet can run, and whether a
//! job fits it. The seeds' open-architecture controller checks "kinematic
//! viability" without saying what it is; motet's rule (ARCHITECTURE.md,
//! "The viability rule"):
//!
//! 1. every module describes itself completely and consistently (its
//!    fields in range, the channels its kind needs, a rigid placement,
//!    limits that agree with each other and its mechanics);
//! 2. no two modules are one device (uid) or share a name;
//! 3. every axis module resolves to a machine axis: translational along
//!    x, y or z of the workpiece, rotary about x, y or z (a, b, c);
//! 4. no two modules drive one degree of freedom, and no two heaters
//!    answer one channel;
//! 5. something moves: at least one axis module.
//!
//! A job fits a viable machine when every axis it moves is driven by a
//! module and within that module's travel, every tool it turns on is a
//! tool module of that kind, and every heater it sets is a heater module.
//! Nothing moves on a machine or a job that fails: the reasons name the
//! module, the field, the axis or the job's line.

use super::check::{num, problems};
use super::compose::{Composed, Composition, Role};
use crate::Machine;
use motet_planner::ranges::rounded;
use motet_planner::{AuxChannel, Command, Located, SourceLoc};
use motet_wire::describe::{ChannelSpec, HeaterChannel, ToolKind};

/// Why modules do not make a machine, or a job does not fit it.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Reason {
    /// A description does not hold.
    #[error("module {module}: {field}: {message}")]
    Described {
        /// The module, with its uid.
        module: String,
        /// The field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// Two modules are one device.
    #[error(
        "modules {first} and {second} are one device (uid {uid}): a module is on the bus once"
    )]
    SameUid {
        /// The first.
        first: String,
        /// The second.
        second: String,
        /// Their uid.
        uid: String,
    },
    /// Two modules share a name.
    #[error("two modules are named {name} (uids {first} and {second}): order them by uid, and give one another name")]
    SameName {
        /// The name.
        name: String,
        /// The first's uid.
        first: String,
        /// The second's uid.
        second: String,
    },
    /// An axis module that is no machine axis.
    #[error("module {module}: {why}")]
    Unresolved {
        /// The module.
        module: String,
        /// Why.
        why: String,
    },
    /// Two modules drive one degree of freedom.
    #[error("modules {first} and {second} both drive {axis}: one degree of freedom, two modules")]
    SameAxis {
        /// The axis.
        axis: String,
        /// The module composed first.
        first: String,
        /// The other.
        second: String,
    },
    /// Two heaters answer one channel.
    #[error("heater modules {first} and {second} both answer the {channel} temperature commands")]
    SameHeater {
        /// The channel.
        channel: String,
        /// The module composed first.
        first: String,
        /// The other.
        second: String,
    },
    /// Nothing moves.
    #[error("no module moves anything: a machine needs at least one axis module")]
    NoAxis,
    /// The job moves an axis no module drives.
    #[error("job {loc}: moves {axis}, which no module drives (the machine's axes: {axes})")]
    AxisNotDriven {
        /// Where the job first moves it.
        loc: SourceLoc,
        /// The axis.
        axis: String,
        /// The axes the modules make.
        axes: String,
    },
    /// The job moves an axis beyond its module's travel.
    #[error("job {loc}: moves {axis} to {value}, beyond module {module}'s travel [{lo}, {hi}]")]
    BeyondTravel {
        /// Where.
        loc: SourceLoc,
        /// The axis.
        axis: String,
        /// The farthest coordinate.
        value: String,
        /// The module.
        module: String,
        /// Its travel, in machine coordinates.
        lo: String,
        /// Its travel's other end.
        hi: String,
    },
    /// The job turns on a tool the modules do not have.
    #[error("job {loc}: turns on the {kind} ({tool}), and no module of the machine is a {kind}")]
    NoTool {
        /// Where the job first turns it on.
        loc: SourceLoc,
        /// The tool's name in the machine file.
        tool: String,
        /// Its kind.
        kind: String,
    },
    /// The job heats a heater the modules do not have.
    #[error("job {loc}: sets the {channel} temperature, and no heater module answers it")]
    NoHeater {
        /// Where.
        loc: SourceLoc,
        /// The channel.
        channel: String,
    },
    /// The machine file and the modules it records disagree.
    #[error("{0}")]
    File(String),
}

/// Modules that make no machine, or a job that does not fit: every reason.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}", list(.reasons))]
pub struct NotViable {
    /// Each reason, in the order found.
    pub reasons: Vec<Reason>,
}

fn list(reasons: &[Reason]) -> String {
    let lines: Vec<String> = reasons.iter().map(|r| format!("  - {r}")).collect();
    format!("not viable:\n{}", lines.join("\n"))
}

fn result(reasons: Vec<Reason>) -> Result<(), NotViable> {
    if reasons.is_empty() {
        Ok(())
    } else {
        Err(NotViable { reasons })
    }
}

/// `x (uid 0123…)`.
pub fn who(m: &Composed) -> String {
    format!(
        "{} (uid {})",
        m.name(),
        crate::module::format_uid(m.module.uid)
    )
}

/// Checks the viability rule on a composition.
pub fn check(c: &Composition) -> Result<(), NotViable> {
    let mut out = Vec::new();
    for m in &c.modules {
        for p in problems(&m.module.description) {
            out.push(Reason::Described {
                module: who(m),
                field: p.field,
                message: p.message,
            });
        }
    }
    for (i, a) in c.modules.iter().enumerate() {
        for b in &c.modules[i + 1..] {
            if a.module.uid == b.module.uid {
                out.push(Reason::SameUid {
                    first: a.name().into(),
                    second: b.name().into(),
                    uid: crate::module::format_uid(a.module.uid),
                });
            } else if a.name() == b.name() {
                out.push(Reason::SameName {
                    name: a.name().into(),
                    first: crate::module::format_uid(a.module.uid),
                    second: crate::module::format_uid(b.module.uid),
                });
            }
        }
    }
    let mut claimed: Vec<(&str, &Composed)> = Vec::new();
    let mut heaters: Vec<(HeaterChannel, &Composed)> = Vec::new();
    for m in &c.modules {
        match &m.role {
            Role::Unresolved(why) => out.push(Reason::Unresolved {
                module: who(m),
                why: why.clone(),
            }),
            Role::Axis { axis, .. } => match claimed.iter().find(|(a, _)| a == axis) {
                Some((_, first)) => out.push(Reason::SameAxis {
                    axis: axis.to_string(),
                    first: who(first),
                    second: who(m),
                }),
                None => claimed.push((axis, m)),
            },
            Role::Heater => {
                for ch in &m.module.description.channels {
                    if let ChannelSpec::Heater { channel, .. } = ch.spec {
                        match heaters.iter().find(|(h, _)| *h == channel) {
                            Some((_, first)) => out.push(Reason::SameHeater {
                                channel: heater_name(channel),
                                first: who(first),
                                second: who(m),
                            }),
                            None => heaters.push((channel, m)),
                        }
                    }
                }
            }
            Role::Tool | Role::Passive => {}
        }
    }
    if !c
        .modules
        .iter()
        .any(|m| m.module.description.kind.is_axis())
    {
        out.push(Reason::NoAxis);
    }
    result(out)
}

/// `hotend 0`, `bed`, `chamber`.
pub fn heater_name(c: HeaterChannel) -> String {
    match c {
        HeaterChannel::Hotend(i) => format!("hotend {i}"),
        HeaterChannel::Bed => "bed".into(),
        HeaterChannel::Chamber => "chamber".into(),
    }
}

/// The functions a viable composition offers, one line each: what a
/// person may ask of the machine.
pub fn offers(c: &Composition) -> Vec<String> {
    let mut out = Vec::new();
    let axes: Vec<&str> = c.axes().iter().map(|(a, _)| *a).collect();
    if !axes.is_empty() {
        out.push(format!(
            "motion on {} ({} {}; G0 G1 G2 G3 with {})",
            axes.join(" "),
            axes.len(),
            if axes.len() == 1 { "axis" } else { "axes" },
            axes.iter()
                .map(|a| a.to_uppercase())
                .collect::<Vec<_>>()
                .join(" ")
        ));
    }
    for m in &c.modules {
        for ch in &m.module.description.channels {
            match &ch.spec {
                ChannelSpec::Tool { tool, max, .. } => out.push(format!(
                    "{} {} (M3/M4 S, M5; full output {})",
                    tool.name(),
                    m.name(),
                    num(*max)
                )),
                ChannelSpec::Heater { channel, max_c, .. } => out.push(format!(
                    "heater {} ({}: up to {} °C)",
                    m.name(),
                    heater_name(*channel),
                    num(*max_c)
                )),
                ChannelSpec::Sensor { quantity, unit, .. } => {
                    out.push(format!("sensor {} ({quantity}, {unit})", m.name()))
                }
                ChannelSpec::Input { input } => out.push(format!("input {} ({input})", m.name())),
                _ => {}
            }
        }
    }
    out
}

/// An axis a job moves: where first, and how far each way (with where).
#[derive(Clone, Debug, PartialEq)]
pub struct AxisUse {
    /// The axis's name.
    pub axis: String,
    /// Where the job first moves it.
    pub first: SourceLoc,
    /// The lowest coordinate it reaches, and where.
    pub min: (f64, SourceLoc),
    /// The highest, and where.
    pub max: (f64, SourceLoc),
}

/// What a job asks of its machine: the axes it moves, the tools it turns
/// on and the heaters it sets, each with the place it first does. Taken a
/// command at a time, as the job is read.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JobNeeds {
    /// The axes moved.
    pub axes: Vec<AxisUse>,
    /// Tools turned on: name, kind, where first.
    pub tools: Vec<(String, ToolKind, SourceLoc)>,
    /// Heaters set above 0: channel and where first.
    pub heaters: Vec<(HeaterChannel, SourceLoc)>,
    at: Option<motet_trajectory::Point>,
}

impl JobNeeds {
    /// Takes the next command of a job read against `machine`.
    pub fn take(&mut self, machine: &Machine, c: &Located<Command>) {
        let from = *self.at.get_or_insert(machine.start);
        match c.item {
            Command::Move(m) => {
                for (i, a) in machine.axes.iter().enumerate() {
                    let v = m.target[i];
                    if v == from[i] {
                        continue;
                    }
                    match self.axes.iter_mut().find(|u| u.axis == a.name) {
                        Some(u) => {
                            if v < u.min.0 {
                                u.min = (v, c.loc);
                            }
                            if v > u.max.0 {
                                u.max = (v, c.loc);
                            }
                        }
                        None => self.axes.push(AxisUse {
                            axis: a.name.clone(),
                            first: c.loc,
                            min: (v.min(from[i]), c.loc),
                            max: (v.max(from[i]), c.loc),
                        }),
                    }
                }
                self.at = Some(m.target);
            }
            Command::Tool { tool, value } | Command::ToolPerSpeed { tool, value, .. }
                if value > 0.0 =>
            {
                if let Some(t) = machine.tools.get(usize::from(tool)) {
                    if !self.tools.iter().any(|(n, ..)| *n == t.name) {
                        let kind = match t.kind {
                            motet_planner::ToolKind::Pen => ToolKind::Pen,
                            motet_planner::ToolKind::Laser => ToolKind::Laser,
                            motet_planner::ToolKind::Spindle => ToolKind::Spindle,
                        };
                        self.tools.push((t.name.clone(), kind, c.loc));
                    }
                }
            }
            Command::Aux { channel, value, .. } if value > 0.0 => {
                let h = match channel {
                    AuxChannel::Hotend(i) => Some(HeaterChannel::Hotend(i)),
                    AuxChannel::Bed => Some(HeaterChannel::Bed),
                    AuxChannel::Chamber => Some(HeaterChannel::Chamber),
                    _ => None,
                };
                if let Some(h) = h {
                    if !self.heaters.iter().any(|(x, _)| *x == h) {
                        self.heaters.push((h, c.loc));
                    }
                }
            }
            _ => {}
        }
    }
}

/// The travel of `m`'s joint in machine coordinates (reversed when it is
/// inverted).
pub fn machine_travel(m: &Composed) -> [f64; 2] {
    let [lo, hi] = m.module.description.limits.travel.map(f64::from);
    match m.role {
        Role::Axis { inverted: true, .. } => [-hi, -lo],
        _ => [lo, hi],
    }
}

/// Whether a job that needs `needs` fits the machine `c` composes.
pub fn fits(c: &Composition, needs: &JobNeeds) -> Result<(), NotViable> {
    let mut out = Vec::new();
    let axes = c.axes();
    let names: Vec<&str> = axes.iter().map(|(a, _)| *a).collect();
    for u in &needs.axes {
        let Some((_, m)) = axes.iter().find(|(a, _)| *a == u.axis) else {
            out.push(Reason::AxisNotDriven {
                loc: u.first,
                axis: u.axis.clone(),
                axes: if names.is_empty() {
                    "none".into()
                } else {
                    names.join(", ")
                },
            });
            continue;
        };
        let [lo, hi] = machine_travel(m);
        // Within a hair: the machine file's travel is the module's,
        // written in f32 and read back in f64.
        let slack = 1e-6 * (hi - lo).abs().max(1.0);
        for (v, loc) in [u.min, u.max] {
            if v < lo - slack || v > hi + slack {
                out.push(Reason::BeyondTravel {
                    loc,
                    axis: u.axis.clone(),
                    value: rounded(v),
                    module: who(m),
                    lo: rounded(lo),
                    hi: rounded(hi),
                });
            }
        }
    }
    for (name, kind, loc) in &needs.tools {
        let has =
            c.modules.iter().any(|m| {
                m.role == Role::Tool
                    && m.module.description.channels.iter().any(
                        |ch| matches!(ch.spec, ChannelSpec::Tool { tool, .. } if tool == *kind),
                    )
            });
        if !has {
            out.push(Reason::NoTool {
                loc: *loc,
                tool: name.clone(),
                kind: kind.name().into(),
            });
        }
    }
    for (channel, loc) in &needs.heaters {
        let has = c.modules.iter().any(|m| {
            m.module.description.channels.iter().any(
                |ch| matches!(ch.spec, ChannelSpec::Heater { channel: h, .. } if h == *channel),
            )
        });
        if !has {
            out.push(Reason::NoHeater {
                loc: *loc,
                channel: heater_name(*channel),
            });
        }
    }
    result(out)
}
