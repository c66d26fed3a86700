//! Pairing a machine's nodes: each machine node's device, found on the link
//! it is given, gets its own address, and the pairing file says which is
//! which. `motet nodes pair` and `motet serve` (its page's Pair button)
//! both pair through here.

use crate::admin::{free_address, Admin, AdminError};
use crate::pairing_file::{format_uid, PairedNode, PairingFile};
use crate::registry;
use motet_host::{Machine, NodeSpec};
use motet_wire::service::{Info, UNPAIRED};
use std::time::Duration;

/// How long a link is listened to for the nodes on it.
const SCAN: Duration = Duration::from_millis(600);

/// Why pairing stopped, naming the machine node it is about.
#[derive(Debug, thiserror::Error)]
pub enum PairError {
    /// The link could not be opened.
    #[error("{node}: cannot open link {link}: {message}")]
    Open {
        /// The machine node.
        node: String,
        /// The link spec.
        link: String,
        /// Why.
        message: String,
    },
    /// A request to a node failed.
    #[error("{node}: {source}")]
    Admin {
        /// The machine node.
        node: String,
        /// The request that failed, and why.
        source: AdminError,
    },
    /// No node answered on the link.
    #[error("{node}: no node answered on {link}")]
    NoNode {
        /// The machine node.
        node: String,
        /// The link spec.
        link: String,
    },
    /// Several nodes answer on the link and no button may be asked for.
    #[error("{node}: {count} nodes answer on {link}: which one is `{node}` takes its button; pair them with `motet nodes pair MACHINE --link {node}={link}`")]
    Several {
        /// The machine node.
        node: String,
        /// The link spec.
        link: String,
        /// How many answered.
        count: usize,
    },
    /// Two machine nodes would be one device.
    #[error("machine nodes `{first}` and `{second}` would both be the device uid {uid} {on}: each machine node needs its own device; nothing was written")]
    SameDevice {
        /// The machine node paired first.
        first: String,
        /// The machine node paired second.
        second: String,
        /// The device's uid.
        uid: String,
        /// Where it answered.
        on: String,
    },
    /// The node's new address answered as another device.
    #[error("{node}: address {address} answered as uid {got}, expected {want}")]
    Answered {
        /// The machine node.
        node: String,
        /// The address given.
        address: u16,
        /// The uid that answered.
        got: String,
        /// The uid paired.
        want: String,
    },
    /// The device is not what the machine file says the node is.
    #[error("{node}: {source}")]
    Mismatch {
        /// The machine node.
        node: String,
        /// How it differs.
        source: registry::Mismatch,
    },
    /// A machine node with no link to find it on.
    #[error("no link for machine node `{0}`")]
    NoLink(String),
}

/// How a device is picked when it is not alone on its link.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ask {
    /// A device alone on its link is paired; where several answer, the one
    /// whose button is pressed within the wait.
    AloneOrButton(Duration),
    /// Always by its button, within the wait.
    Button(Duration),
    /// Only devices alone on their links: every link is looked at first,
    /// and any link with none or several, a device running a job or of the
    /// wrong kind is refused before any address changes.
    Alone,
}

/// A device paired in this run.
struct Device {
    /// The machine node it became.
    node: String,
    uid: u64,
    /// The link it answered on.
    link: String,
}

fn open(node: &str, link: &str) -> Result<Admin, PairError> {
    let t = motet_link::open(link).map_err(|e| PairError::Open {
        node: node.into(),
        link: link.into(),
        message: e.to_string(),
    })?;
    Ok(Admin::new(t, link))
}

fn admin_err(node: &str) -> impl Fn(AdminError) -> PairError + '_ {
    move |source| PairError::Admin {
        node: node.into(),
        source,
    }
}

/// Pairs every node of `machine`, each found on its link in `links`
/// (machine node, link spec), picked as `ask` says; `say` hears what is
/// done, as it is done (and when to press a button). Returns the pairing
/// file to write (the caller writes it: a refusal writes nothing).
pub fn pair_machine(
    machine: &Machine,
    links: &[(String, String)],
    ask: Ask,
    say: &mut dyn FnMut(String),
) -> Result<PairingFile, PairError> {
    let link_of = |name: &str| {
        links
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, l)| l.clone())
            .ok_or_else(|| PairError::NoLink(name.into()))
    };
    if ask == Ask::Alone {
        let mut devices = Vec::new();
        for spec in &machine.nodes {
            let link = link_of(&spec.name)?;
            devices.push(survey(machine, spec, &link, &devices)?);
        }
    }
    let mut file = PairingFile::default();
    let mut taken = Vec::new();
    let mut devices: Vec<Device> = Vec::new();
    for spec in &machine.nodes {
        let link = link_of(&spec.name)?;
        let (address, uid, info) = pair_node(machine, spec, &link, &taken, &devices, ask, say)?;
        taken.push(address);
        devices.push(Device {
            node: spec.name.clone(),
            uid,
            link: link.clone(),
        });
        file.nodes.insert(
            spec.name.clone(),
            PairedNode {
                link,
                address,
                uid: format_uid(uid),
                kind: info.kind.to_string(),
                firmware: info.firmware.to_string(),
            },
        );
    }
    Ok(file)
}

/// The device alone on `link` that would be machine node `spec`: one
/// answers, it is not running a job, it is of the kind the machine file
/// asks and no other machine node is it.
fn survey(
    machine: &Machine,
    spec: &NodeSpec,
    link: &str,
    devices: &[Device],
) -> Result<Device, PairError> {
    let mut a = open(&spec.name, link)?;
    let found = a.scan(SCAN).map_err(admin_err(&spec.name))?;
    let [one] = found.as_slice() else {
        return Err(if found.is_empty() {
            PairError::NoNode {
                node: spec.name.clone(),
                link: link.into(),
            }
        } else {
            PairError::Several {
                node: spec.name.clone(),
                link: link.into(),
                count: found.len(),
            }
        });
    };
    if one.info.address != UNPAIRED {
        a.at_rest(one.info.address, "pairing it again")
            .map_err(admin_err(&spec.name))?;
    }
    registry::check(machine, spec, &one.info).map_err(|source| PairError::Mismatch {
        node: spec.name.clone(),
        source,
    })?;
    own_device(devices, one.info.uid, &spec.name, link)?;
    Ok(Device {
        node: spec.name.clone(),
        uid: one.info.uid,
        link: link.into(),
    })
}

/// Pairs machine node `spec` on `link`: the node alone there (unless a
/// button press is asked for), else the one whose button is pressed, gets
/// the first address not `taken`; it must be a device not yet paired
/// (`devices`) and of the kind the machine file asks. Returns the address,
/// the device's uid and what it says of itself.
fn pair_node(
    machine: &Machine,
    spec: &NodeSpec,
    link: &str,
    taken: &[u16],
    devices: &[Device],
    ask: Ask,
    say: &mut dyn FnMut(String),
) -> Result<(u16, u64, Info), PairError> {
    let name = spec.name.as_str();
    let mut a = open(name, link)?;
    let address = free_address(taken);
    let found = a.scan(SCAN).map_err(admin_err(name))?;
    // A node paired before may be running a job: a new address would
    // cut it off mid-move.
    for f in found.iter().filter(|f| f.info.address != UNPAIRED) {
        a.at_rest(f.info.address, "pairing it again")
            .map_err(admin_err(name))?;
    }
    let wait = match ask {
        Ask::AloneOrButton(_) if found.len() == 1 => None,
        Ask::Alone if found.len() == 1 => None,
        Ask::AloneOrButton(w) | Ask::Button(w) => Some(w),
        Ask::Alone => {
            return Err(PairError::Several {
                node: name.into(),
                link: link.into(),
                count: found.len(),
            })
        }
    };
    let uid = match wait {
        None => {
            // Alone on its link: no button needed.
            let uid = found[0].info.uid;
            own_device(devices, uid, name, link)?;
            a.set_address(uid, address).map_err(admin_err(name))?;
            say(format!(
                "{name}: the only node on {link} (uid {}) is now address {address}",
                format_uid(uid)
            ));
            uid
        }
        Some(wait) => {
            if found.is_empty() {
                return Err(PairError::NoNode {
                    node: name.into(),
                    link: link.into(),
                });
            }
            say(format!(
                "{name}: {} node(s) on {link}; press the button of the one to be `{name}` (Enter in a simulated node's terminal)…",
                found.len(),
            ));
            let uid = a.pair_by_button(address, wait).map_err(admin_err(name))?;
            own_device(devices, uid, name, link)?;
            say(format!(
                "{name}: uid {} is now address {address}",
                format_uid(uid)
            ));
            uid
        }
    };
    let info = a.info(address).map_err(admin_err(name))?;
    if info.uid != uid {
        return Err(PairError::Answered {
            node: name.into(),
            address,
            got: format_uid(info.uid),
            want: format_uid(uid),
        });
    }
    registry::check(machine, spec, &info).map_err(|source| PairError::Mismatch {
        node: name.into(),
        source,
    })?;
    Ok((address, uid, info))
}

/// Two machine nodes on one device would each get the other's motion:
/// refused before the device's address is changed.
fn own_device(devices: &[Device], uid: u64, node: &str, link: &str) -> Result<(), PairError> {
    let Some(other) = devices.iter().find(|d| d.uid == uid) else {
        return Ok(());
    };
    let on = if other.link == link {
        format!("on {link}")
    } else {
        format!("on {} and on {link}", other.link)
    };
    Err(PairError::SameDevice {
        first: other.node.clone(),
        second: node.into(),
        uid: format_uid(uid),
        on,
    })
}
