//! `motet nodes …`: find, pair, identify, inspect and update nodes.

use anyhow::{bail, Context, Result};
use motet_host::Machine;
use motet_net::admin::Admin;
use motet_net::pairing::{pair_machine, Ask};
use motet_net::pairing_file::{format_uid, pairing_path, PairedNode, PairingFile};
use motet_wire::service::{Version, UNPAIRED};
use std::path::Path;
use std::time::Duration;

pub fn admin(link: &str) -> Result<Admin> {
    let t = motet_link::open(link).with_context(|| format!("cannot open link {link}"))?;
    Ok(Admin::new(t, link))
}

/// `motet nodes scan --link SPEC…`
pub fn scan(links: &[String], wait: f64) -> Result<()> {
    if links.is_empty() {
        bail!("name at least one link to scan with --link (e.g. udp:127.0.0.1:47001 or serial:/dev/ttyACM0)");
    }
    let mut total = 0;
    for link in links {
        let mut a = admin(link)?;
        let found = a.scan(Duration::from_secs_f64(wait))?;
        if found.is_empty() {
            println!("{link}: no node answered");
        }
        for f in found {
            total += 1;
            let i = &f.info;
            let driver = motet_net::registry::driver(i.kind.as_str())
                .map_or("no driver on this host", |d| d.description);
            let board = if i.board.is_empty() {
                String::new()
            } else {
                format!(" on {}", i.board)
            };
            println!(
                "{link}: {}{board} uid {} firmware {} {} — {} channels, {} tools, queue {} ({driver})",
                i.kind,
                format_uid(i.uid),
                i.firmware,
                if i.address == UNPAIRED {
                    "unpaired".to_string()
                } else {
                    format!("address {}", i.address)
                },
                i.channels,
                i.tools,
                i.queue_capacity
            );
            // What the module says of itself.
            let bc = motet_wire::frame::BROADCAST;
            match motet_net::modules::describe(&mut a, bc, Some(i.uid)) {
                Ok(d) => {
                    for l in crate::modules::description_lines(&d) {
                        println!("    {l}");
                    }
                }
                Err(e) => println!("    no description: {e}"),
            }
        }
    }
    println!("{total} node(s)");
    Ok(())
}

/// `motet nodes pair MACHINE --link NAME=SPEC…`
pub fn pair(machine_path: &Path, links: &[String], button: bool, wait: f64) -> Result<()> {
    let machine = Machine::load(machine_path)?;
    let assigned = assign_links(&machine, links)?;
    let wait = Duration::from_secs_f64(wait);
    let ask = if button {
        Ask::Button(wait)
    } else {
        Ask::AloneOrButton(wait)
    };
    let file = pair_machine(&machine, &assigned, ask, &mut |line| println!("{line}"))?;
    let path = pairing_path(machine_path);
    file.save(&path)?;
    println!("wrote {}", path.display());
    Ok(())
}

/// The `--link NODE=SPEC` flags as (machine node, link spec), one for each
/// of the machine's nodes, none twice, none for a node it does not have.
fn assign_links(machine: &Machine, links: &[String]) -> Result<Vec<(String, String)>> {
    let mut assigned: Vec<(String, String)> = Vec::new();
    for l in links {
        let (name, spec) = l.split_once('=').with_context(|| {
            format!("--link {l:?}: expected NODE=SPEC, e.g. mainboard=udp:127.0.0.1:47001")
        })?;
        if !machine.nodes.iter().any(|n| n.name == name) {
            bail!(
                "--link {l:?}: the machine has no node `{name}` (it has: {})",
                machine
                    .nodes
                    .iter()
                    .map(|n| n.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        if assigned.iter().any(|(a, _)| a == name) {
            bail!("--link {l:?}: machine node `{name}` has a --link already");
        }
        assigned.push((name.to_string(), spec.to_string()));
    }
    for n in &machine.nodes {
        if !assigned.iter().any(|(a, _)| *a == n.name) {
            bail!("no --link for machine node `{}`", n.name);
        }
    }
    Ok(assigned)
}

/// The machine's pairing file, or an error that says how to make it.
pub(crate) fn paired(machine_path: &Path) -> Result<PairingFile> {
    let path = pairing_path(machine_path);
    if !path.exists() {
        bail!(
            "{} does not exist: pair the nodes first with `motet nodes pair {} --link NODE=SPEC …`",
            path.display(),
            machine_path.display()
        );
    }
    Ok(PairingFile::load(&path)?)
}

fn node_entry<'a>(file: &'a PairingFile, machine: &Path, node: &str) -> Result<&'a PairedNode> {
    file.nodes.get(node).with_context(|| {
        format!(
            "{}: no paired node `{node}` (paired: {})",
            pairing_path(machine).display(),
            file.nodes.keys().cloned().collect::<Vec<_>>().join(", ")
        )
    })
}

/// `motet nodes status MACHINE`
pub fn status(machine_path: &Path) -> Result<()> {
    let file = paired(machine_path)?;
    // Every node is asked, even after one failed: the ones that answer are
    // shown, the others named at the end.
    let mut silent = Vec::new();
    for (name, p) in &file.nodes {
        let answer = admin(&p.link).and_then(|mut a| {
            let info = a.info(p.address)?;
            Ok((info, a.status(p.address)?))
        });
        match answer {
            Ok((i, s)) => println!(
                "{name}: {}{} uid {} firmware {} at {} on {} — {:?}, link {}, clock {}{}, up {:.1} s",
                i.kind,
                if i.board.is_empty() {
                    String::new()
                } else {
                    format!(" on {}", i.board)
                },
                format_uid(i.uid),
                i.firmware,
                p.address,
                p.link,
                s.state,
                if s.link_up { "up" } else { "down" },
                if s.synced { "synced" } else { "not synced" },
                s.drift.map_or(String::new(), |d| format!(
                    " (its own measure: {:+.1} ppm over {} s)",
                    d.ppb as f64 * 1e-3,
                    d.span_s
                )),
                s.uptime_us as f64 * 1e-6
            ),
            Err(e) => {
                eprintln!("{name}: {}", crate::error_text::error_text(&e));
                silent.push(name.as_str());
            }
        }
    }
    if !silent.is_empty() {
        bail!(
            "{} of {} paired nodes gave no status: {}",
            silent.len(),
            file.nodes.len(),
            silent.join(", ")
        );
    }
    Ok(())
}

/// `motet nodes identify MACHINE NODE`
pub fn identify(machine_path: &Path, node: &str, seconds: f64) -> Result<()> {
    let file = paired(machine_path)?;
    let p = node_entry(&file, machine_path, node)?;
    admin(&p.link)?.identify(p.address, (seconds * 1000.0) as u32)?;
    println!("{node}: blinking for {seconds} s");
    Ok(())
}

/// `motet nodes flash MACHINE NODE IMAGE`
pub fn flash(machine_path: &Path, node: &str, image: &Path) -> Result<()> {
    let file = paired(machine_path)?;
    let p = node_entry(&file, machine_path, node)?;
    let bytes = std::fs::read(image).with_context(|| format!("cannot read {}", image.display()))?;
    let mut a = admin(&p.link)?;
    let bar = indicatif::ProgressBar::new(bytes.len() as u64);
    let v = a
        .flash(p.address, &bytes, &mut |done, _| {
            bar.set_position(done as u64)
        })
        .with_context(|| format!("{node}: firmware {}", image.display()))?;
    bar.finish_and_clear();
    println!("{node}: firmware {v} verified and started");
    Ok(())
}

/// `motet nodes image --kind K [--board B] --version X.Y.Z PAYLOAD -o OUT`
pub fn image(
    kind: &str,
    board: Option<&str>,
    version: &str,
    payload: &Path,
    out: &Path,
) -> Result<()> {
    let mut parts = version.split('.').map(|p| p.parse::<u16>());
    let v = match (parts.next(), parts.next(), parts.next(), parts.next()) {
        (Some(Ok(major)), Some(Ok(minor)), Some(Ok(patch)), None) => Version {
            major,
            minor,
            patch,
        },
        _ => bail!("--version {version:?}: expected MAJOR.MINOR.PATCH"),
    };
    let file =
        std::fs::read(payload).with_context(|| format!("cannot read {}", payload.display()))?;
    let (data, from) = if file.starts_with(b"\x7fELF") {
        let (data, start) = crate::elf::flatten(&file)
            .with_context(|| format!("{}: not a firmware ELF file", payload.display()))?;
        (data, format!(" from ELF, loaded at {start:#010x}"))
    } else {
        (file, String::new())
    };
    let mut bytes = vec![0u8; motet_wire::image::MAX_HEADER_LEN + data.len()];
    let n = motet_wire::image::build(kind, board, v, &data, &mut bytes)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    bytes.truncate(n);
    std::fs::write(out, bytes).with_context(|| format!("cannot write {}", out.display()))?;
    println!(
        "wrote {} ({kind}{} {v}, {} payload bytes{from})",
        out.display(),
        board.map_or(String::new(), |b| format!(" for {b}")),
        data.len()
    );
    Ok(())
}
