//! `motet machine …`: machines from modules. `from-scan` composes the
//! modules on the bus, in the order a person gives, into a machine file
//! and its pairing file; `compose` does the same from description files
//! alone; `watch` follows the modules of a paired machine live.

use crate::modules::{chain_lines, description_lines, print_offers};
use anyhow::{bail, Context, Result};
use motet_host::module::{
    self, compose, format_uid, load_description, machine_toml, viability, Composition, ModuleAt,
};
use motet_host::Machine;
use motet_net::admin::Admin;
use motet_net::clock::{Clock, WallClock};
use motet_net::modules::{scan_links, IdleWatch, ModuleWatch, Scanned, WatchConfig};
use motet_net::pairing_file::{pairing_path, PairedNode, PairingFile};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// `motet machine`'s subcommands.
#[derive(clap::Subcommand)]
pub enum MachineCmd {
    /// Compose the modules on the bus into a machine: scan the links, take
    /// the modules in the order given (tool to workpiece), check that they
    /// make a viable machine, give each an address, and write the machine
    /// file and its pairing file.
    FromScan {
        /// Link to scan (repeatable).
        #[arg(long = "link", required = true)]
        links: Vec<String>,
        /// The modules from the tool to the workpiece, by name or uid,
        /// comma-separated (e.g. spindle,z,y,x,a).
        #[arg(long, required = true)]
        order: String,
        /// The machine file to write (its pairing file goes beside it).
        #[arg(long, short)]
        out: PathBuf,
        /// The machine's name [default: the file's stem].
        #[arg(long)]
        name: Option<String>,
        /// Seconds to wait for the modules on each link.
        #[arg(long, default_value_t = 1.0)]
        wait: f64,
    },
    /// Compose description files (tool to workpiece) into a machine file,
    /// without a bus: uids 1, 2, … stand in for the devices.
    Compose {
        /// Description files, tool first.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// The machine file to write [default: print it].
        #[arg(long, short)]
        out: Option<PathBuf>,
        /// The machine's name.
        #[arg(long, default_value = "machine from modules")]
        name: String,
    },
    /// Follow a paired machine's modules live: print each change (a module
    /// added, removed, replaced, changed) and whether the machine is still
    /// viable.
    Watch {
        machine: PathBuf,
        /// Stop after this many seconds [default: until interrupted].
        #[arg(long)]
        seconds: Option<f64>,
    },
}

/// Runs a `motet machine` subcommand.
pub fn machine_cmd(cmd: MachineCmd) -> Result<()> {
    match cmd {
        MachineCmd::FromScan {
            links,
            order,
            out,
            name,
            wait,
        } => from_scan(&links, &order, &out, name, wait),
        MachineCmd::Compose { files, out, name } => compose_files(&files, out.as_deref(), &name),
        MachineCmd::Watch { machine, seconds } => watch(&machine, seconds),
    }
}

/// The composition, checked: printed when viable, every reason when not.
fn composed(modules: &[ModuleAt]) -> Result<Composition> {
    let c = compose(modules);
    for l in chain_lines(&c) {
        println!("  {l}");
    }
    if let Err(e) = viability::check(&c) {
        bail!("these modules make no machine: {e}\nnothing was written");
    }
    print_offers(&c);
    Ok(c)
}

fn from_scan(
    links: &[String],
    order: &str,
    out: &Path,
    name: Option<String>,
    wait: f64,
) -> Result<()> {
    motet_planner::ranges::WAIT_S.check("--wait", wait)?;
    let scanned = scan_links(links, Duration::from_secs_f64(wait))?;
    println!("found {} module(s)", scanned.len());
    for s in &scanned {
        println!("  uid {} at {}", format_uid(s.info.uid), s.found.place);
        match &s.found.description {
            Ok(d) => description_lines(d)
                .iter()
                .for_each(|l| println!("    {l}")),
            Err(e) => println!("    no description: {e}"),
        }
    }
    let chosen = ordered(&scanned, order)?;
    for s in &scanned {
        if !chosen.iter().any(|c| c.info.uid == s.info.uid) {
            eprintln!(
                "warning: module uid {} at {} is not in --order: left out",
                format_uid(s.info.uid),
                s.found.place
            );
        }
    }
    let mut modules = Vec::new();
    for s in &chosen {
        let d = s
            .found
            .description
            .clone()
            .map_err(|e| anyhow::anyhow!("module uid {}: {e}", format_uid(s.info.uid)))?;
        modules.push(ModuleAt {
            uid: s.info.uid,
            firmware: Some(s.info.firmware),
            description: d,
        });
    }
    println!("composed:");
    let c = composed(&modules)?;
    let pairing = give_addresses(&scanned, &chosen)?;
    let name = name.unwrap_or_else(|| {
        out.file_stem()
            .map_or("machine".into(), |s| s.to_string_lossy().into_owned())
    });
    write(out, &machine_toml(&c, &name))?;
    let p = pairing_path(out);
    pairing.save(&p)?;
    // What was written must read back as it was meant.
    let m = Machine::load(out)?;
    module::check_file(&m).map_err(|e| anyhow::anyhow!("{}: {e}", out.display()))?;
    println!("wrote {} and {}", out.display(), p.display());
    Ok(())
}

/// Writes `text` to `path`, making its folder if need be.
fn write(path: &Path, text: &str) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

/// The modules `order` names, each once.
fn ordered<'a>(scanned: &'a [Scanned], order: &str) -> Result<Vec<&'a Scanned>> {
    let mut out: Vec<&Scanned> = Vec::new();
    let names: Vec<String> = scanned
        .iter()
        .map(|s| {
            s.found
                .description
                .as_ref()
                .map_or(format!("uid {}", format_uid(s.info.uid)), |d| {
                    d.identity.name.to_string()
                })
        })
        .collect();
    for token in order.split(',').map(str::trim).filter(|t| !t.is_empty()) {
        let by_name: Vec<&Scanned> = scanned
            .iter()
            .filter(|s| {
                s.found
                    .description
                    .as_ref()
                    .is_ok_and(|d| d.identity.name.as_str() == token)
            })
            .collect();
        let m = match (by_name.as_slice(), module::parse_uid(token)) {
            ([one], _) => *one,
            ([], Some(uid)) => match scanned.iter().find(|s| s.info.uid == uid) {
                Some(s) => s,
                None => bail!(
                    "--order: no module on the bus is named or has uid `{token}` (found: {})",
                    names.join(", ")
                ),
            },
            ([], None) => bail!(
                "--order: no module on the bus is named `{token}` (found: {})",
                names.join(", ")
            ),
            (several, _) => bail!(
                "--order: {} modules are named `{token}` (uids {}): order them by uid",
                several.len(),
                several
                    .iter()
                    .map(|s| format_uid(s.info.uid))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        };
        if out.iter().any(|o| o.info.uid == m.info.uid) {
            bail!("--order names module `{token}` twice: a module has one place in the chain");
        }
        out.push(m);
    }
    if out.is_empty() {
        bail!("--order names no module");
    }
    Ok(out)
}

/// Gives each chosen module its own address (2, 3, … in chain order,
/// skipping those modules left out hold on the same link), by its uid,
/// and the pairing file that says where each is.
fn give_addresses(scanned: &[Scanned], chosen: &[&Scanned]) -> Result<PairingFile> {
    let mut pairing = PairingFile::default();
    let mut admins: Vec<(String, Admin)> = Vec::new();
    let mut next = motet_wire::service::FIRST_NODE_ADDRESS;
    for s in chosen {
        let link = &s.found.place.link;
        let taken = |a: u16| {
            scanned.iter().any(|o| {
                o.found.place.link == *link
                    && o.found.place.address == a
                    && !chosen.iter().any(|c| c.info.uid == o.info.uid)
            })
        };
        while taken(next) {
            next += 1;
        }
        let address = next;
        next += 1;
        if s.found.place.address != address {
            let i = match admins.iter().position(|(l, _)| l == link) {
                Some(i) => i,
                None => {
                    admins.push((link.clone(), crate::nodes::admin(link)?));
                    admins.len() - 1
                }
            };
            admins[i]
                .1
                .set_address(s.info.uid, address)
                .with_context(|| {
                    format!("giving module uid {} an address", format_uid(s.info.uid))
                })?;
        }
        let d = s.found.description.as_ref().ok();
        let name = d.map_or(format_uid(s.info.uid), |d| d.identity.name.to_string());
        println!("  {name}: address {address} on {link}");
        pairing.nodes.insert(
            name,
            PairedNode {
                link: link.clone(),
                address,
                uid: format_uid(s.info.uid),
                kind: s.info.kind.to_string(),
                firmware: s.info.firmware.to_string(),
            },
        );
    }
    Ok(pairing)
}

fn compose_files(files: &[PathBuf], out: Option<&Path>, name: &str) -> Result<()> {
    let mut modules = Vec::new();
    for (k, f) in files.iter().enumerate() {
        modules.push(ModuleAt {
            uid: k as u64 + 1,
            firmware: None,
            description: load_description(f)?,
        });
    }
    let say = out.is_some();
    if say {
        println!("composed:");
    }
    let c = compose(&modules);
    if let Err(e) = viability::check(&c) {
        bail!("these modules make no machine: {e}");
    }
    let text = machine_toml(&c, name);
    match out {
        Some(p) => {
            for l in chain_lines(&c) {
                println!("  {l}");
            }
            print_offers(&c);
            write(p, &text)?;
            println!("wrote {}", p.display());
        }
        None => print!("{text}"),
    }
    Ok(())
}

fn watch(machine_path: &Path, seconds: Option<f64>) -> Result<()> {
    let machine = Machine::load(machine_path)?;
    if machine.modules.is_empty() {
        bail!(
            "{} has no [modules]: only a machine composed from modules can be watched",
            machine_path.display()
        );
    }
    let pairing = crate::nodes::paired(machine_path)?;
    let expected = motet_net::modules::scan::expected(&machine, &pairing);
    let watch = ModuleWatch::new(expected, None, WatchConfig::default());
    let mut transports = Vec::new();
    for l in watch.links() {
        let t = motet_link::open(l).with_context(|| format!("cannot open link {l}"))?;
        transports.push((l.clone(), t));
    }
    let mut idle = IdleWatch::new(watch, transports);
    let clock = WallClock::with(1.0, 0.0, 0);
    let start = clock.now_us();
    let end = seconds.map(|s| start + (s * 1e6) as u64);
    println!(
        "watching {} module(s) of {} (Ctrl-C stops)",
        machine.modules.len(),
        machine_path.display()
    );
    loop {
        let now = clock.now_us();
        if end.is_some_and(|e| now >= e) {
            return Ok(());
        }
        if let Some(r) = idle.turn(now)? {
            println!("{:.3} s: {}", (now - start) as f64 * 1e-6, r.text());
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}
