//! Machines from modules: what a module says of itself (its
//! [description](motet_wire::describe)), how modules ordered from the tool
//! to the workpiece compose into a machine, whether that machine is viable
//! and a job fits it, and how the modules on the bus differ from those a
//! machine file records.
//!
//! - [`description`]: description files (TOML, located errors);
//!   [`write_description`] writes one back.
//! - [`check`]: what every description must hold, from a file or the wire.
//! - [`mod@compose`]: the placement chain into axes, tools and heaters.
//! - [`viability`]: the viability rule, what a composition offers, and
//!   what a job needs of it.
//! - [`write_machine`]: the machine file a composition makes.
//! - [`record`]: a machine file's `[modules.NAME]` records.
//! - [`diff`]: the bus against the records.

pub mod check;
pub mod compose;
pub mod description;
pub mod diff;
pub mod math;
pub mod record;
pub mod viability;
pub mod write_description;
pub mod write_machine;

pub use compose::{compose, Composed, Composition, ModuleAt, Role};
pub use description::{load_description, parse_description, DescriptionError};
pub use diff::{bus_check, BusCheck, Difference, Expected, FoundModule, Place};
pub use record::ModuleRecord;
pub use viability::{fits, offers, JobNeeds, NotViable, Reason};
pub use write_description::description_toml;
pub use write_machine::machine_toml;

use crate::Machine;
use motet_wire::service::Version;

/// A uid as files and messages write it: 16 hex digits.
pub fn format_uid(uid: u64) -> String {
    format!("{uid:016x}")
}

/// A uid written in hex (with or without `0x`).
pub fn parse_uid(s: &str) -> Option<u64> {
    u64::from_str_radix(s.trim_start_matches("0x"), 16).ok()
}

/// `0.1.0` as a version.
pub fn parse_version(s: &str) -> Option<Version> {
    let mut p = s.split('.').map(|x| x.parse::<u16>());
    match (p.next(), p.next(), p.next(), p.next()) {
        (Some(Ok(major)), Some(Ok(minor)), Some(Ok(patch)), None) => Some(Version {
            major,
            minor,
            patch,
        }),
        _ => None,
    }
}

/// The modules a machine file records, in their order, as composition
/// takes them.
pub fn recorded(machine: &Machine) -> Vec<ModuleAt> {
    machine
        .modules
        .iter()
        .map(|r| ModuleAt {
            uid: r.uid,
            firmware: r.firmware.as_deref().and_then(parse_version),
            description: r.description.clone(),
        })
        .collect()
}

/// For a machine file composed from modules: the composition its records
/// make, checked against the viability rule and against the file (every
/// axis driven by its module's node, within that module's limits; every
/// tool its module's; no axis or node without a module). `None` for a
/// machine written by hand (no `[modules]`).
pub fn check_file(machine: &Machine) -> Result<Option<Composition>, NotViable> {
    if machine.modules.is_empty() {
        return Ok(None);
    }
    let c = compose(&recorded(machine));
    let mut reasons = viability::check(&c).err().map_or(Vec::new(), |e| e.reasons);
    let file = |s: String| Reason::File(s);
    for (m, r) in c.modules.iter().zip(&machine.modules) {
        let node = machine.nodes.iter().find(|n| n.name == r.node);
        match &m.role {
            Role::Axis { axis, .. } => {
                let Some(i) = machine.axis(axis) else {
                    reasons.push(file(format!(
                        "module {} makes axis {axis}, and the machine file has no [axes.{axis}]",
                        m.name()
                    )));
                    continue;
                };
                let drives = node.is_some_and(|n| {
                    n.actuators
                        .iter()
                        .any(|&a| machine.joints[machine.actuators[a].joint].name == *axis)
                });
                if !drives {
                    reasons.push(file(format!(
                        "axis {axis}: node {} (module {}) drives none of its actuators",
                        r.node,
                        m.name()
                    )));
                }
                let a = &machine.axes[i];
                let l = &m.module.description.limits;
                let over = |file: f64, module: f32| file > f64::from(module) * (1.0 + 1e-6);
                for (key, file_v, module_v) in [
                    ("max_velocity", a.max_velocity, l.max_velocity),
                    ("max_acceleration", a.max_acceleration, l.max_acceleration),
                ] {
                    if over(file_v, module_v) {
                        reasons.push(file(format!(
                            "axis {axis}: {key} {} in the machine file, beyond module {}'s {}",
                            motet_planner::ranges::rounded(file_v),
                            m.name(),
                            check::num(module_v)
                        )));
                    }
                }
                let [lo, hi] = viability::machine_travel(m);
                let slack = 1e-6 * (hi - lo).abs().max(1.0);
                if a.travel[0] < lo - slack || a.travel[1] > hi + slack {
                    let n = motet_planner::ranges::rounded;
                    reasons.push(file(format!(
                        "axis {axis}: travel [{}, {}] in the machine file goes beyond module {}'s [{}, {}]",
                        n(a.travel[0]),
                        n(a.travel[1]),
                        m.name(),
                        n(lo),
                        n(hi)
                    )));
                }
            }
            Role::Tool => {
                let has = node
                    .is_some_and(|n| n.tools.iter().any(|&t| machine.tools[t].name == m.name()));
                if !has {
                    reasons.push(file(format!(
                        "module {} is a tool, and node {} has no tool {} in the machine file",
                        m.name(),
                        r.node,
                        m.name()
                    )));
                }
            }
            _ => {}
        }
    }
    let made: Vec<&str> = c.axes().iter().map(|(a, _)| *a).collect();
    for a in &machine.axes {
        if !made.contains(&a.name.as_str()) {
            reasons.push(file(format!(
                "axis {}: no module drives it (the recorded modules make {})",
                a.name,
                if made.is_empty() {
                    "none".into()
                } else {
                    made.join(", ")
                }
            )));
        }
    }
    for n in &machine.nodes {
        if !machine.modules.iter().any(|r| r.node == n.name) {
            reasons.push(file(format!(
                "node {} has no [modules.{}] record: in a machine composed from modules every node is a module",
                n.name, n.name
            )));
        }
    }
    if reasons.is_empty() {
        Ok(Some(c))
    } else {
        Err(NotViable { reasons })
    }
}
