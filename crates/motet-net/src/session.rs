//! The nodes of one run: started here (`spawn`), found through the pairing
//! file (`paired`), or named directly (`attach`, for `motet resume`), each
//! checked against the machine before any motion is sent.

use crate::admin::{Admin, AdminError};
use crate::clock::{Clock, SharedClock};
use crate::pairing_file::{format_uid, parse_uid, PairingFile};
use crate::peer::{Incoming, Peer};
use crate::registry;
use crate::resume::NodePosition;
use crate::spawn::{spawn_sim_node, SpawnError, SpawnedNode};
use motet_host::Machine;
use motet_wire::link::State;
use motet_wire::service::Info;
use motet_wire::HostMessage;
use std::path::Path;
use std::time::Duration;

/// Why the run's nodes could not be brought together; each names the
/// machine node it is about. No motion has been sent when it is returned.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// A simulated node process could not be started.
    #[error("node {node}: {source}")]
    Spawn {
        /// The node's name in the machine file.
        node: String,
        /// Why the process did not start or announce itself.
        source: SpawnError,
    },
    /// The node's link could not be opened.
    #[error("node {node}: cannot open {link}: {message}")]
    Open {
        /// The node's name in the machine file.
        node: String,
        /// The link spec.
        link: String,
        /// Why it could not be opened.
        message: String,
    },
    /// Pairing or asking the node what it is failed.
    #[error("node {node}: {source}")]
    Admin {
        /// The node's name in the machine file.
        node: String,
        /// The request that failed, and why.
        source: AdminError,
    },
    /// The node is not paired, or another device answers at its address.
    #[error("node {node}: {message}")]
    Node {
        /// The node's name in the machine file.
        node: String,
        /// What is wrong and how to put it right.
        message: String,
    },
    /// The device is not what the machine file says the node is (kind,
    /// channels, tools, protocol).
    #[error("node {node}: {source}")]
    Mismatch {
        /// The node's name in the machine file.
        node: String,
        /// How it differs.
        source: registry::Mismatch,
    },
}

/// Where a node of the run is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeAddr {
    /// Its name in the machine file.
    pub name: String,
    /// The link spec it is reached on.
    pub link: String,
    /// Its address on that link.
    pub address: u16,
}

/// The machine's nodes, reached and checked, ready for a run: one peer per
/// machine node, in the machine file's order.
pub struct Session {
    /// The link to each node (connected by the run, not yet here).
    pub peers: Vec<Peer>,
    /// Where each node is.
    pub nodes: Vec<NodeAddr>,
    /// What each node said it is when the session began.
    pub infos: Vec<Info>,
    /// Node processes this session started; they stop with it.
    pub spawned: Vec<SpawnedNode>,
}

fn isn(k: usize) -> u16 {
    // Differs across host runs, so a node sees a new session: the calendar
    // time serves as a seed here, not as a clock.
    let t = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_micros() as u64)
        .unwrap_or(0);
    (t as u16) ^ ((k as u16) << 12)
}

fn open(node: &str, link: &str, clock: &SharedClock) -> Result<Admin, SessionError> {
    let t = motet_link::open(link).map_err(|e| SessionError::Open {
        node: node.into(),
        link: link.into(),
        message: e.to_string(),
    })?;
    Ok(Admin::with_clock(t, link, clock.clone()))
}

impl Session {
    /// Starts one simulated node process per machine node (`exe node --sim
    /// …` plus `extra`) and pairs each (alone on its link). Requests wait
    /// on `clock`.
    pub fn spawn(
        machine: &Machine,
        exe: &Path,
        extra: &[String],
        clock: &SharedClock,
    ) -> Result<Session, SessionError> {
        let each = vec![extra.to_vec(); machine.nodes.len()];
        Session::spawn_each(machine, exe, &each, clock)
    }

    /// [`Session::spawn`] with arguments of its own for each machine node
    /// (`extra[k]`: a module's `--describe` and `--uid`, say).
    pub fn spawn_each(
        machine: &Machine,
        exe: &Path,
        extra: &[Vec<String>],
        clock: &SharedClock,
    ) -> Result<Session, SessionError> {
        let mut s = Session {
            peers: Vec::new(),
            nodes: Vec::new(),
            infos: Vec::new(),
            spawned: Vec::new(),
        };
        for (k, spec) in machine.nodes.iter().enumerate() {
            // A node with closed loops (servos, heaters) runs its
            // machine's simulated plant.
            let mut args = extra.get(k).cloned().unwrap_or_default();
            let servos = spec
                .actuators
                .iter()
                .any(|&a| machine.actuators[a].servo.is_some());
            if servos || !motet_host::heater_loop::on_node(machine, k).is_empty() {
                args.extend([
                    "--plant".to_string(),
                    machine.file.display().to_string(),
                    "--plant-node".to_string(),
                    spec.name.clone(),
                ]);
            }
            let node =
                spawn_sim_node(exe, "stepper", &args).map_err(|source| SessionError::Spawn {
                    node: spec.name.clone(),
                    source,
                })?;
            let address = 2 + k as u16;
            let mut a = open(&spec.name, &node.link, clock)?;
            let admin_err = |source| SessionError::Admin {
                node: spec.name.clone(),
                source,
            };
            a.set_address(node.uid, address).map_err(admin_err)?;
            let info = a.info(address).map_err(admin_err)?;
            registry::check(machine, spec, &info).map_err(|source| SessionError::Mismatch {
                node: spec.name.clone(),
                source,
            })?;
            s.nodes.push(NodeAddr {
                name: spec.name.clone(),
                link: node.link.clone(),
                address,
            });
            s.infos.push(info);
            s.peers
                .push(Peer::new(&spec.name, address, a.into_transport(), isn(k)));
            s.spawned.push(node);
        }
        Ok(s)
    }

    /// The nodes of the pairing file, each checked to be the device paired.
    pub fn paired(
        machine: &Machine,
        file: &PairingFile,
        path: &Path,
        clock: &SharedClock,
    ) -> Result<Session, SessionError> {
        let mut nodes = Vec::new();
        let mut uids = Vec::new();
        for spec in &machine.nodes {
            let p = file
                .nodes
                .get(&spec.name)
                .ok_or_else(|| SessionError::Node {
                    node: spec.name.clone(),
                    message: format!("not in {}: pair it with `motet nodes pair`", path.display()),
                })?;
            nodes.push(NodeAddr {
                name: spec.name.clone(),
                link: p.link.clone(),
                address: p.address,
            });
            uids.push(parse_uid(&p.uid));
        }
        Session::attach_checked(machine, &nodes, &uids, clock)
    }

    /// Nodes at known links and addresses.
    pub fn attach(
        machine: &Machine,
        nodes: &[NodeAddr],
        clock: &SharedClock,
    ) -> Result<Session, SessionError> {
        Session::attach_checked(machine, nodes, &vec![None; nodes.len()], clock)
    }

    fn attach_checked(
        machine: &Machine,
        nodes: &[NodeAddr],
        uids: &[Option<u64>],
        clock: &SharedClock,
    ) -> Result<Session, SessionError> {
        let mut s = Session {
            peers: Vec::new(),
            nodes: nodes.to_vec(),
            infos: Vec::new(),
            spawned: Vec::new(),
        };
        for (k, (spec, n)) in machine.nodes.iter().zip(nodes).enumerate() {
            let mut a = open(&spec.name, &n.link, clock)?;
            let info = a.info(n.address).map_err(|source| SessionError::Admin {
                node: spec.name.clone(),
                source,
            })?;
            if let Some(Some(uid)) = uids.get(k) {
                if info.uid != *uid {
                    return Err(SessionError::Node {
                        node: spec.name.clone(),
                        message: format!(
                            "the node at address {} on {} is uid {}, but uid {} was paired: pair again with `motet nodes pair`",
                            n.address,
                            n.link,
                            format_uid(info.uid),
                            format_uid(*uid)
                        ),
                    });
                }
            }
            registry::check(machine, spec, &info).map_err(|source| SessionError::Mismatch {
                node: spec.name.clone(),
                source,
            })?;
            s.infos.push(info);
            s.peers
                .push(Peer::new(&spec.name, n.address, a.into_transport(), isn(k)));
        }
        Ok(s)
    }
}

/// Connects every peer's link and asks each node where it is on its run
/// (`Where`). `None` for a node that did not answer within `timeout`.
pub fn locate(
    peers: &mut [Peer],
    clock: &dyn Clock,
    timeout: Duration,
) -> Vec<Option<NodePosition>> {
    let start = clock.now_us();
    let mut got: Vec<Option<NodePosition>> = vec![None; peers.len()];
    let mut asked = vec![false; peers.len()];
    while clock.now_us() < start + timeout.as_micros() as u64 {
        let now = clock.now_us();
        for (k, p) in peers.iter_mut().enumerate() {
            let _ = p.receive(now);
            while let Some(m) = p.take() {
                if let Incoming::Motion(m) = m {
                    if let Some(pos) = NodePosition::from_message(&m) {
                        got[k] = Some(pos);
                    }
                }
            }
            if !asked[k] && matches!(p.link_state(), State::Established { .. }) {
                p.send_motion(&HostMessage::Where);
                asked[k] = true;
            }
            let _ = p.flush(now);
        }
        if got.iter().all(|g| g.is_some()) {
            break;
        }
        clock.sleep_us(500);
    }
    got
}
