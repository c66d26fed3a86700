//! Modules over datagrams, outside a run: a node's description read a
//! part at a time, every module on a link found with its description, and
//! the bus compared with a machine file's records through its pairing file.

use crate::admin::{Admin, AdminError};
use crate::pairing_file::{format_uid, PairingFile};
use motet_host::module::{bus_check, BusCheck, Expected, FoundModule, Place};
use motet_host::Machine;
use motet_wire::describe::{Assembler, DescribeError, DescribePart, Description};
use motet_wire::frame::BROADCAST;
use motet_wire::service::{Info, ServiceReply, ServiceRequest};
use std::time::Duration;

/// Why modules could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ModuleError {
    /// A request failed.
    #[error("{0}")]
    Admin(#[from] AdminError),
    /// The parts did not make a description.
    #[error("{link}: node uid {uid}: {error}")]
    Describe {
        /// The link.
        link: String,
        /// The node's uid.
        uid: String,
        /// What was wrong with the parts.
        error: DescribeError,
    },
    /// A reply that is no part of a description.
    #[error(
        "{link}: node uid {uid} answered {got} to a request for part {part} of its description"
    )]
    Unexpected {
        /// The link.
        link: String,
        /// The node's uid, or `any`.
        uid: String,
        /// The part asked for.
        part: u8,
        /// What came.
        got: String,
    },
    /// A link could not be opened.
    #[error("cannot open link {link}: {message}")]
    Open {
        /// The link spec.
        link: String,
        /// Why.
        message: String,
    },
}

/// Part `part` of the description of the node at `dst` (the broadcast
/// address and `uid` reach it wherever it is, paired or not).
fn part(
    admin: &mut Admin,
    dst: u16,
    uid: Option<u64>,
    part: u8,
) -> Result<DescribePart, ModuleError> {
    let req = ServiceRequest::Describe { uid, part };
    // A late answer to the part before is not this one: asked again.
    for _ in 0..admin.tries {
        match admin.request(dst, &req)? {
            ServiceReply::Description { part: p, data } if p == part => return Ok(data),
            ServiceReply::Description { .. } => continue,
            other => {
                return Err(ModuleError::Unexpected {
                    link: admin.link().to_string(),
                    uid: uid.map_or("any".into(), format_uid),
                    part,
                    got: format!("{other:?}"),
                })
            }
        }
    }
    Err(ModuleError::Admin(AdminError::NoAnswer {
        link: admin.link().to_string(),
        address: dst,
        tries: admin.tries,
    }))
}

/// The description of the node at `dst` (with `uid`: that node only).
pub fn describe(admin: &mut Admin, dst: u16, uid: Option<u64>) -> Result<Description, ModuleError> {
    let DescribePart::Head(head) = part(admin, dst, uid, 0)? else {
        return Err(ModuleError::Unexpected {
            link: admin.link().to_string(),
            uid: uid.map_or("any".into(), format_uid),
            part: 0,
            got: "another part".into(),
        });
    };
    let err = |error, link: &str| ModuleError::Describe {
        link: link.to_string(),
        uid: format_uid(head.uid),
        error,
    };
    let mut a = Assembler::new(head).map_err(|e| err(e, admin.link()))?;
    for i in 1..head.parts {
        let p = part(admin, dst, Some(head.uid), i)?;
        a.take(i, p).map_err(|e| err(e, admin.link()))?;
    }
    a.finish().map_err(|e| err(e, admin.link()))
}

/// A module found on a link: what `Info` said, and its description.
#[derive(Clone, Debug)]
pub struct Scanned {
    /// What the node said it is (kind, uid, firmware, address).
    pub info: Info,
    /// The module as the diff and composition take it.
    pub found: FoundModule,
}

/// Every node answering on `admin`'s link within `wait`, each with its
/// description (or why it could not be read).
pub fn scan_modules(admin: &mut Admin, wait: Duration) -> Result<Vec<Scanned>, ModuleError> {
    let nodes = admin.scan(wait)?;
    let mut out = Vec::new();
    for n in nodes {
        let description = describe(admin, BROADCAST, Some(n.info.uid)).map_err(|e| e.to_string());
        out.push(Scanned {
            found: FoundModule {
                place: Place {
                    link: admin.link().to_string(),
                    address: n.from,
                },
                uid: n.info.uid,
                firmware: Some(n.info.firmware),
                description,
            },
            info: n.info,
        });
    }
    Ok(out)
}

/// Scans every link in `links` (each once).
pub fn scan_links(links: &[String], wait: Duration) -> Result<Vec<Scanned>, ModuleError> {
    let mut seen: Vec<&String> = Vec::new();
    let mut out = Vec::new();
    for l in links {
        if seen.contains(&l) {
            continue;
        }
        seen.push(l);
        let t = motet_link::open(l).map_err(|e| ModuleError::Open {
            link: l.clone(),
            message: e.to_string(),
        })?;
        let mut admin = Admin::new(t, l);
        out.extend(scan_modules(&mut admin, wait)?);
    }
    Ok(out)
}

/// The modules `machine` records, each where `pairing` put it.
pub fn expected(machine: &Machine, pairing: &PairingFile) -> Vec<Expected> {
    machine
        .modules
        .iter()
        .map(|r| {
            let place = pairing.nodes.get(&r.node).map_or(
                Place {
                    link: "(not paired)".into(),
                    address: 0,
                },
                |p| Place {
                    link: p.link.clone(),
                    address: p.address,
                },
            );
            Expected {
                record: r.clone(),
                place,
            }
        })
        .collect()
}

/// The modules on the pairing file's links against the machine file's
/// records.
pub fn check_bus(
    machine: &Machine,
    pairing: &PairingFile,
    wait: Duration,
) -> Result<(BusCheck, Vec<Scanned>), ModuleError> {
    let links: Vec<String> = pairing.nodes.values().map(|p| p.link.clone()).collect();
    let scanned = scan_links(&links, wait)?;
    let found: Vec<FoundModule> = scanned.iter().map(|s| s.found.clone()).collect();
    Ok((bus_check(&expected(machine, pairing), &found), scanned))
}

/// The pairing file with each machine node where the bus check found it
/// (a module moved, swapped or replaced by an identical one), for a run
/// on the file's machine.
pub fn follow(pairing: &PairingFile, check: &BusCheck, scanned: &[Scanned]) -> PairingFile {
    let mut out = pairing.clone();
    for (node, at) in &check.places {
        let (Some((place, uid)), Some(p)) = (at, out.nodes.get_mut(node)) else {
            continue;
        };
        p.link = place.link.clone();
        p.address = place.address;
        p.uid = format_uid(*uid);
        if let Some(s) = scanned.iter().find(|s| s.info.uid == *uid) {
            p.kind = s.info.kind.to_string();
            p.firmware = s.info.firmware.to_string();
        }
    }
    out
}
