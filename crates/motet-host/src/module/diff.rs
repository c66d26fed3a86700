//! The modules on the bus against those a machine file records: every
//! difference named (missing, extra, replaced, swapped, moved, changed
//! field by field), the machine they make now, and whether that is still
//! the file's machine.
//!
//! A module is known by its uid and found at a place (its link and
//! address). Found elsewhere than recorded, it moved (two that traded
//! places are swapped); its chain position stays its own, since the
//! order is mechanical and the link only carries its messages. A
//! different uid where a recorded module was is a replacement, composed
//! at the old one's place in the chain. A module the file does not know
//! is composed at the workpiece end, where its own placement puts it.

use super::compose::{compose, Composition, ModuleAt};
use super::format_uid;
use super::record::ModuleRecord;
use super::viability::{check, NotViable};
use super::write_description::toml_num;
use motet_wire::describe::{ChannelSpec, Description};
use motet_wire::service::Version;

/// Where a module answers: its link and address.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Place {
    /// The link spec.
    pub link: String,
    /// Its address there.
    pub address: u16,
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "address {} on {}", self.address, self.link)
    }
}

/// A module found on the bus.
#[derive(Clone, Debug, PartialEq)]
pub struct FoundModule {
    /// Where it answered.
    pub place: Place,
    /// Its uid.
    pub uid: u64,
    /// Its firmware.
    pub firmware: Option<Version>,
    /// What it says of itself (or why that could not be read).
    pub description: Result<Description, String>,
}

/// A recorded module and where the pairing put it.
#[derive(Clone, Debug, PartialEq)]
pub struct Expected {
    /// The record.
    pub record: ModuleRecord,
    /// Where it was paired.
    pub place: Place,
}

/// One difference between the bus and the machine file.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Difference {
    /// A recorded module answers nowhere.
    #[error("{node} (uid {uid}) is missing: nothing answers as it, and nothing new at {place}")]
    Missing {
        /// The machine node.
        node: String,
        /// Its uid.
        uid: String,
        /// Where it was.
        place: Place,
    },
    /// A module the file does not record.
    #[error(
        "extra module {name} ({kind}, uid {uid}) at {place}: the machine file does not know it"
    )]
    Extra {
        /// Its name.
        name: String,
        /// Its kind.
        kind: String,
        /// Its uid.
        uid: String,
        /// Where.
        place: Place,
        /// A sensor or input (it moves nothing).
        passive: bool,
    },
    /// Another module where a recorded one was.
    #[error("{node} (uid {was}) was replaced by {name} (uid {now}) at {place}{}", if *.same { ", which describes itself the same" } else { "" })]
    Replaced {
        /// The machine node.
        node: String,
        /// The recorded uid.
        was: String,
        /// The new module's name.
        name: String,
        /// Its uid.
        now: String,
        /// Where.
        place: Place,
        /// Its description is the recorded one's.
        same: bool,
    },
    /// Two recorded modules traded places.
    #[error("{first} and {second} are swapped: {first} now answers at {first_now}, where {second} was, and {second} at {second_now}, where {first} was")]
    Swapped {
        /// One.
        first: String,
        /// The other.
        second: String,
        /// Where the first answers now.
        first_now: Place,
        /// Where the second answers now.
        second_now: Place,
    },
    /// A recorded module answers somewhere else.
    #[error("{node} moved from {from} to {to}")]
    Moved {
        /// The machine node.
        node: String,
        /// Where it was.
        from: Place,
        /// Where it is.
        to: Place,
    },
    /// A recorded module describes itself otherwise.
    #[error("{node}: {field} changed: {was} → {now}")]
    Changed {
        /// The machine node.
        node: String,
        /// The field.
        field: String,
        /// As recorded.
        was: String,
        /// As the module says now.
        now: String,
    },
    /// A module whose description could not be read.
    #[error("the module at {place} (uid {uid}) gives no description: {why}")]
    Unreadable {
        /// Its uid.
        uid: String,
        /// Where.
        place: Place,
        /// Why.
        why: String,
    },
}

/// The bus against the file.
#[derive(Clone, Debug)]
pub struct BusCheck {
    /// Every difference, in the file's order of modules.
    pub differences: Vec<Difference>,
    /// The machine the modules on the bus make, in the file's order.
    pub now: Composition,
    /// Whether that machine is viable.
    pub viability: Result<(), NotViable>,
    /// Whether it is the file's machine (every recorded module there,
    /// describing itself as recorded, nothing new that moves or works):
    /// then it may run, with each machine node where it answers now.
    pub same_machine: bool,
    /// Where each machine node answers now and which device it is
    /// (`None`: missing).
    pub places: Vec<(String, Option<(Place, u64)>)>,
}

/// Each field of a description as text, in a fixed order: what
/// [`Difference::Changed`] compares.
pub fn fields(d: &Description) -> Vec<(String, String)> {
    let mut out = vec![
        ("kind".to_string(), d.kind.name().to_string()),
        ("name".into(), d.identity.name.to_string()),
        ("model".into(), d.identity.model.to_string()),
        ("hardware".into(), d.identity.hardware.to_string()),
        ("placement.joint".into(), d.placement.joint.name().into()),
    ];
    for (r, row) in d.placement.htm.chunks(4).enumerate() {
        let row: Vec<String> = row.iter().map(|v| toml_num(*v)).collect();
        out.push((format!("placement.htm row {}", r + 1), row.join(" ")));
    }
    let l = &d.limits;
    out.push((
        "limits.travel".into(),
        format!("[{}, {}]", toml_num(l.travel[0]), toml_num(l.travel[1])),
    ));
    for (k, v) in [
        ("max_velocity", l.max_velocity),
        ("max_acceleration", l.max_acceleration),
        ("resolution", l.resolution),
        ("accuracy", l.accuracy),
        ("home", l.home),
    ] {
        out.push((format!("limits.{k}"), toml_num(v)));
    }
    out.push(("channels".into(), d.channels.len().to_string()));
    for (i, c) in d.channels.iter().enumerate() {
        out.push((format!("channels[{i}].drives"), c.drives.to_string()));
        for (k, v) in spec_fields(&c.spec) {
            out.push((format!("channels[{i}].{k}"), v));
        }
    }
    out
}

fn spec_fields(s: &ChannelSpec) -> Vec<(String, String)> {
    let n = |v: f32| toml_num(v);
    let f = |k: &str, v: String| (k.to_string(), v);
    match s {
        ChannelSpec::Step {
            lead,
            ratio,
            step_angle,
            microstep,
            invert,
            max_step_hz,
        } => vec![
            f("step.lead", n(*lead)),
            f("step.ratio", n(*ratio)),
            f("step.step_angle", n(*step_angle)),
            f("step.microstep", microstep.to_string()),
            f("step.invert", invert.to_string()),
            f("step.max_step_hz", max_step_hz.to_string()),
        ],
        ChannelSpec::Servo {
            lead,
            ratio,
            encoder_lines,
            invert,
            gains,
        } => vec![
            f("servo.lead", n(*lead)),
            f("servo.ratio", n(*ratio)),
            f("servo.encoder_lines", encoder_lines.to_string()),
            f("servo.invert", invert.to_string()),
            f("servo.gains", format!("{gains:?}")),
        ],
        ChannelSpec::Tool { tool, max, settle } => vec![
            f("tool.kind", tool.name().into()),
            f("tool.max", n(*max)),
            f("tool.settle", n(*settle)),
        ],
        ChannelSpec::Heater {
            channel,
            max_c,
            time_constant,
        } => vec![
            f("heater.channel", format!("{channel:?}")),
            f("heater.max", n(*max_c)),
            f("heater.time_constant", n(*time_constant)),
        ],
        ChannelSpec::Sensor {
            quantity,
            unit,
            rate_hz,
        } => vec![
            f("sensor.quantity", quantity.to_string()),
            f("sensor.unit", unit.to_string()),
            f("sensor.rate_hz", n(*rate_hz)),
        ],
        ChannelSpec::Input { input } => vec![f("input.kind", input.to_string())],
    }
}

/// Every field of `now` that differs from `was`.
pub fn changes(node: &str, was: &Description, now: &Description) -> Vec<Difference> {
    let (a, b) = (fields(was), fields(now));
    let mut out = Vec::new();
    for (k, v) in &a {
        let now_v = b.iter().find(|(bk, _)| bk == k).map(|(_, v)| v.as_str());
        if now_v != Some(v.as_str()) {
            out.push(Difference::Changed {
                node: node.to_string(),
                field: k.clone(),
                was: v.clone(),
                now: now_v.unwrap_or("(none)").to_string(),
            });
        }
    }
    for (k, v) in &b {
        if !a.iter().any(|(ak, _)| ak == k) {
            out.push(Difference::Changed {
                node: node.to_string(),
                field: k.clone(),
                was: "(none)".into(),
                now: v.clone(),
            });
        }
    }
    out
}

/// Whether one module now at `a_now` and another at `b_now` traded the
/// places `b_was` and `a_was`: their links, or on one shared link their
/// addresses (a module keeps its own address wherever it is plugged in).
fn traded(a_now: &Place, b_was: &Place, b_now: &Place, a_was: &Place) -> bool {
    let links = a_now.link == b_was.link && b_now.link == a_was.link;
    links
        && (a_was.link != b_was.link
            || (a_now.address == b_was.address && b_now.address == a_was.address))
}

/// Compares the modules `found` on the bus with those `expected`.
pub fn bus_check(expected: &[Expected], found: &[FoundModule]) -> BusCheck {
    let mut differences = Vec::new();
    let mut chain: Vec<ModuleAt> = Vec::new();
    let mut places = Vec::new();
    let mut used = vec![false; found.len()];
    let mut same_machine = true;
    let mut moved: Vec<(usize, Place)> = Vec::new();
    for f in found {
        if let Err(why) = &f.description {
            differences.push(Difference::Unreadable {
                uid: format_uid(f.uid),
                place: f.place.clone(),
                why: why.clone(),
            });
            same_machine = false;
        }
    }
    for (k, e) in expected.iter().enumerate() {
        let r = &e.record;
        let by_uid = found.iter().position(|f| f.uid == r.uid);
        let at_place = found
            .iter()
            .position(|f| f.place == e.place && !expected.iter().any(|o| o.record.uid == f.uid));
        let (i, module) = match (by_uid, at_place) {
            (Some(i), _) => {
                let f = &found[i];
                if f.place != e.place {
                    moved.push((k, f.place.clone()));
                }
                if let Ok(d) = &f.description {
                    let c = changes(&r.node, &r.description, d);
                    same_machine &= c.is_empty();
                    differences.extend(c);
                }
                (Some(i), Some(f))
            }
            (None, Some(i)) => {
                let f = &found[i];
                let same = f.description.as_ref().ok() == Some(&r.description);
                differences.push(Difference::Replaced {
                    node: r.node.clone(),
                    was: format_uid(r.uid),
                    name: f
                        .description
                        .as_ref()
                        .map_or("?".into(), |d| d.identity.name.to_string()),
                    now: format_uid(f.uid),
                    place: e.place.clone(),
                    same,
                });
                if let Ok(d) = &f.description {
                    if !same {
                        differences.extend(changes(&r.node, &r.description, d));
                    }
                }
                same_machine &= same;
                (Some(i), Some(f))
            }
            (None, None) => {
                differences.push(Difference::Missing {
                    node: r.node.clone(),
                    uid: format_uid(r.uid),
                    place: e.place.clone(),
                });
                same_machine = false;
                (None, None)
            }
        };
        if let Some(i) = i {
            used[i] = true;
        }
        places.push((r.node.clone(), module.map(|f| (f.place.clone(), f.uid))));
        if let Some(Ok(d)) = module.map(|f| &f.description) {
            chain.push(ModuleAt {
                uid: module.map_or(r.uid, |f| f.uid),
                firmware: module.and_then(|f| f.firmware),
                description: d.clone(),
            });
        }
    }
    differences.extend(moves(expected, &moved));
    for (i, f) in found.iter().enumerate() {
        if used[i] {
            continue;
        }
        let Ok(d) = &f.description else { continue };
        let passive = d.kind.is_passive();
        differences.push(Difference::Extra {
            name: d.identity.name.to_string(),
            kind: d.kind.name().into(),
            uid: format_uid(f.uid),
            place: f.place.clone(),
            passive,
        });
        // Something new that moves or works makes another machine; a
        // sensor or an input is noted and left out.
        same_machine &= passive;
        chain.push(ModuleAt {
            uid: f.uid,
            firmware: f.firmware,
            description: d.clone(),
        });
    }
    let now = compose(&chain);
    let viability = check(&now);
    same_machine &= viability.is_ok();
    BusCheck {
        differences,
        now,
        viability,
        same_machine,
        places,
    }
}

/// The modules found elsewhere than recorded (`moved`: which record, where
/// now): two that traded places are one swap, not two moves.
fn moves(expected: &[Expected], moved: &[(usize, Place)]) -> Vec<Difference> {
    let mut out = Vec::new();
    let mut taken = vec![false; moved.len()];
    for a in 0..moved.len() {
        if taken[a] {
            continue;
        }
        let (ka, ref to_a) = moved[a];
        let swap = (a + 1..moved.len()).find(|&b| {
            let (kb, ref to_b) = moved[b];
            !taken[b] && traded(to_a, &expected[kb].place, to_b, &expected[ka].place)
        });
        match swap {
            Some(b) => {
                taken[b] = true;
                let kb = moved[b].0;
                out.push(Difference::Swapped {
                    first: expected[ka].record.node.clone(),
                    second: expected[kb].record.node.clone(),
                    first_now: to_a.clone(),
                    second_now: moved[b].1.clone(),
                });
            }
            None => out.push(Difference::Moved {
                node: expected[ka].record.node.clone(),
                from: expected[ka].place.clone(),
                to: to_a.clone(),
            }),
        }
        taken[a] = true;
    }
    out
}
