//! What `motet` says about modules: a module's description in a few lines,
//! a composed machine and what it offers, and the bus against a machine
//! file, as `motet nodes scan`, `motet machine`, `motet check` and `motet
//! run` print them.

use anyhow::{bail, Context, Result};
use motet_host::module::{
    self, check::num, offers, BusCheck, Composition, JobNeeds, NotViable, Role,
};
use motet_host::module::{Expected, Place};
use motet_host::Machine;
use motet_net::modules::{check_bus, follow, ModuleWatch, Scanned, WatchConfig};
use motet_net::pairing_file::{pairing_path, PairingFile};
use motet_net::session::Session;
use motet_planner::ranges::rounded;
use motet_wire::describe::{ChannelSpec, Description, HeaterChannel, ModuleKind};
use std::path::Path;
use std::time::Duration;

/// The machine a machine file's records make, in messages.
pub const MODULES: &str = "the machine its modules make";
/// The machine the modules found on the bus make, in messages.
pub const BUS: &str = "the machine the modules on the bus make";

/// How long a bus check listens on each link for its modules.
pub const SCAN_WAIT: Duration = Duration::from_millis(600);

/// A description in a few lines, indented.
pub fn description_lines(d: &Description) -> Vec<String> {
    if !d.described {
        return vec![format!(
            "not described: its board's default ({} channels)",
            d.channels.len()
        )];
    }
    let mut out = Vec::new();
    let model = if d.identity.model.is_empty() {
        String::new()
    } else {
        format!(" \"{}\"", d.identity.model)
    };
    out.push(format!(
        "module {} ({}{model})",
        d.identity.name,
        d.kind.name()
    ));
    let h = &d.placement.htm;
    let t = format!("({}, {}, {}) mm", num(h[3]), num(h[7]), num(h[11]));
    let turned = [h[0], h[1], h[2], h[4], h[5], h[6], h[8], h[9], h[10]]
        != [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    let placement = format!("placed at {t}{}", if turned { ", turned" } else { "" });
    if d.kind.is_axis() {
        let l = &d.limits;
        let unit = if d.kind == ModuleKind::Rotary {
            "°"
        } else {
            "mm"
        };
        out.push(format!(
            "joint {} {}, travel [{}, {}] {unit}, {} {unit}/s, {} {unit}/s², resolution {}, accuracy {}; {placement}",
            if d.kind == ModuleKind::Rotary { "about" } else { "along" },
            d.placement.joint.name(),
            num(l.travel[0]),
            num(l.travel[1]),
            num(l.max_velocity),
            num(l.max_acceleration),
            num(l.resolution),
            num(l.accuracy),
        ));
    } else {
        out.push(placement);
    }
    for c in &d.channels {
        out.push(format!("channel {}: {}", c.drives, channel(&c.spec)));
    }
    out
}

fn channel(s: &ChannelSpec) -> String {
    match s {
        ChannelSpec::Step {
            lead,
            ratio,
            step_angle,
            microstep,
            ..
        } => {
            let lead = if *lead > 0.0 {
                format!("lead {} mm, ", num(*lead))
            } else {
                String::new()
            };
            format!(
                "step ({lead}gear {}:1, {}°, {microstep} microsteps)",
                num(*ratio),
                num(*step_angle)
            )
        }
        ChannelSpec::Servo {
            lead,
            encoder_lines,
            gains,
            ..
        } => format!(
            "servo (lead {} mm, {encoder_lines}-line encoder, {} Hz loop)",
            num(*lead),
            gains.rate_hz
        ),
        ChannelSpec::Tool { tool, max, .. } => {
            format!("{} (full output {})", tool.name(), num(*max))
        }
        ChannelSpec::Heater { channel, max_c, .. } => format!(
            "heater ({}, up to {} °C)",
            match channel {
                HeaterChannel::Hotend(i) => format!("hotend {i}"),
                HeaterChannel::Bed => "bed".into(),
                HeaterChannel::Chamber => "chamber".into(),
            },
            num(*max_c)
        ),
        ChannelSpec::Sensor {
            quantity,
            unit,
            rate_hz,
        } => {
            format!("sensor ({quantity}, {unit}, {} Hz)", num(*rate_hz))
        }
        ChannelSpec::Input { input } => format!("input ({input})"),
    }
}

/// One line per module of the chain, and the tool point.
pub fn chain_lines(c: &Composition) -> Vec<String> {
    let parts: Vec<String> = c
        .modules
        .iter()
        .map(|m| {
            let role = match &m.role {
                Role::Axis { axis, inverted } => {
                    format!("axis {axis}{}", if *inverted { ", inverted" } else { "" })
                }
                Role::Tool => "tool".into(),
                Role::Heater => "heater".into(),
                Role::Passive => "passive".into(),
                Role::Unresolved(_) => "unresolved".into(),
            };
            format!("{} ({role})", m.name())
        })
        .collect();
    let p = c.tool_point();
    vec![
        format!("tool to workpiece: {}", parts.join(" → ")),
        format!(
            "tool point with every joint at 0: ({}, {}, {}) mm in the workpiece frame",
            rounded(p[0]),
            rounded(p[1]),
            rounded(p[2])
        ),
    ]
}

/// What a viable composition offers, indented.
pub fn print_offers(c: &Composition) {
    println!("  viable; it offers:");
    for o in offers(c) {
        println!("    {o}");
    }
}

/// For a machine file composed from modules: its records checked (the
/// chain, the viability rule, the file against them) and printed. `None`
/// for a machine written by hand.
pub fn check_machine(machine: &Machine, say: bool) -> Result<Option<Composition>> {
    match module::check_file(machine) {
        Ok(None) => Ok(None),
        Ok(Some(c)) => {
            if say {
                println!(
                    "  composed from {} modules, {}",
                    c.modules.len(),
                    chain_lines(&c)[0]
                );
                print_offers(&c);
            }
            Ok(Some(c))
        }
        Err(e) => bail!(
            "{}: the machine its modules make {e}\nnothing can run on it: compose it again (`motet machine from-scan`) or put the file right",
            machine.file.display()
        ),
    }
}

/// Whether a job with `needs` fits composition `c`.
/// `what` names the machine (`the machine its modules make`).
pub fn check_fit(c: &Composition, needs: &JobNeeds, job: &Path, what: &str) -> Result<()> {
    module::fits(c, needs).map_err(|e: NotViable| {
        anyhow::anyhow!(
            "{}: the job does not fit {what}, {e}\nnothing moved",
            job.display()
        )
    })
}

/// The modules on the bus against the machine file's records, printed:
/// every difference, and whether they make the file's machine; with the
/// pairing to run with (each node where it answers now).
pub fn scan_the_bus(machine: &Machine, machine_path: &Path) -> Result<(BusCheck, PairingFile)> {
    let pairing = crate::nodes::paired(machine_path)?;
    let (check, scanned) = check_bus(machine, &pairing, SCAN_WAIT)?;
    print_bus(&check, &scanned);
    let followed = follow(&pairing, &check, &scanned);
    if check.same_machine && followed != pairing {
        println!(
            "  the modules answer where they are now; {} is left as it is",
            pairing_path(machine_path).display()
        );
    }
    Ok((check, followed))
}

/// [`scan_the_bus`], refusing a bus whose modules are not the file's
/// machine (or one that has no address) with every reason.
pub fn check_the_bus(machine: &Machine, machine_path: &Path) -> Result<(BusCheck, PairingFile)> {
    let (check, followed) = scan_the_bus(machine, machine_path)?;
    require_same(&check, machine_path)?;
    Ok((check, followed))
}

/// Refuses a bus check that did not find the file's machine.
pub fn require_same(check: &BusCheck, machine_path: &Path) -> Result<()> {
    if !check.same_machine {
        let mut why = String::new();
        if let Err(e) = &check.viability {
            why = format!("\nthe machine the modules on the bus make is {e}");
        }
        bail!(
            "the modules on the bus are not those {} was composed from{why}\nnothing moved: put the modules back, or compose the machine again (`motet machine from-scan --order …`)",
            machine_path.display()
        );
    }
    let mut at = check.places.iter().filter_map(|(_, p)| p.as_ref());
    if let Some((p, uid)) = at.find(|(p, _)| p.address == motet_wire::service::UNPAIRED) {
        bail!(
            "the module uid {} at {} has no address: compose the machine again (`motet machine from-scan`) to give it one",
            module::format_uid(*uid),
            p.link
        );
    }
    Ok(())
}

fn print_bus(check: &BusCheck, scanned: &[Scanned]) {
    let links: std::collections::BTreeSet<&str> = scanned
        .iter()
        .map(|s| s.found.place.link.as_str())
        .collect();
    println!(
        "bus: {} module(s) answer on {} link(s)",
        scanned.len(),
        links.len()
    );
    if check.differences.is_empty() {
        println!("  every module is the one the machine file records");
    }
    for d in &check.differences {
        println!("  - {d}");
    }
    if check.same_machine {
        println!("  they make the machine file's machine");
    }
}

/// The arguments of each spawned node process: `extra`, and for a machine
/// composed from modules, each module's description (written under
/// `out/modules/`) and uid, so the spawned nodes are the modules the file
/// records.
pub fn spawn_args(machine: &Machine, out: &Path, extra: &[String]) -> Result<Vec<Vec<String>>> {
    let mut each = vec![extra.to_vec(); machine.nodes.len()];
    if machine.modules.is_empty() {
        return Ok(each);
    }
    let dir = out.join("modules");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    for (k, n) in machine.nodes.iter().enumerate() {
        let Some(r) = machine.modules.iter().find(|r| r.node == n.name) else {
            continue;
        };
        let path = dir.join(format!("{}.toml", n.name));
        std::fs::write(&path, module::description_toml(&r.description, ""))
            .with_context(|| format!("cannot write {}", path.display()))?;
        each[k].extend([
            "--describe".to_string(),
            path.display().to_string(),
            "--uid".to_string(),
            module::format_uid(r.uid),
        ]);
    }
    Ok(each)
}

/// The live watch over a run's modules (a machine composed from them),
/// each where the session reached it, checking the job's `needs`; with the
/// link of each of the run's nodes.
pub fn run_watch(
    machine: &Machine,
    session: &Session,
    needs: JobNeeds,
) -> Option<(ModuleWatch, Vec<String>)> {
    if machine.modules.is_empty() {
        return None;
    }
    let expected = machine
        .modules
        .iter()
        .filter_map(|r| {
            let k = machine.nodes.iter().position(|n| n.name == r.node)?;
            let n = session.nodes.get(k)?;
            let mut record = r.clone();
            // A spare that describes itself the same took the recorded
            // one's place: the watch follows the device the run drives.
            if let Some(i) = session.infos.get(k) {
                record.uid = i.uid;
            }
            Some(Expected {
                record,
                place: Place {
                    link: n.link.clone(),
                    address: n.address,
                },
            })
        })
        .collect();
    let links = session.nodes.iter().map(|n| n.link.clone()).collect();
    Some((
        ModuleWatch::new(expected, Some(needs), WatchConfig::default()),
        links,
    ))
}
