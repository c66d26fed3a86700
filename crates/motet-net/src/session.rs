//! The nodes of one run: started here (`spawn`), found through the pairing
//! file (`paired`), or named directly (`attach`, for `motet resume`), each
//! checked against the machine before any motion is sent.

use crate::admin::{Admin, AdminError};
use crate::clock::{Clock, SharedClock};
use crate::medium::Medium;
use crate::pairing_file::{format_uid, parse_uid, PairingFile};
use crate::peer::{Incoming, Peer};
use crate::registry;
use crate::resume::NodePosition;
use crate::spawn::{spawn_sim_node_logged, SpawnError, SpawnedNode};
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

/// How [`Session::spawn_with`] starts the node processes.
#[derive(Clone, Copy, Debug, Default)]
pub struct Spawning<'a> {
    /// Every node a member of this multicast group
    /// (`udp-group:GROUP:PORT[@IFACE]`), as on a bus; else each on a UDP
    /// port of its own.
    pub group: Option<&'a str>,
    /// A folder for each node's log (`node-NAME.log`, what it says on
    /// stderr); else the nodes write to this process's stderr.
    pub logs: Option<&'a Path>,
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
    /// Every node is on one shared medium (a bus, a multicast group),
    /// reached through one transport: the run seals and stops them all in
    /// one frame ([`crate::run::NetRun::on_shared_medium`]).
    pub shared_medium: bool,
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

/// Whether the nodes on `link` share it: a multicast group, or a link
/// (a CAN adapter) that several machine nodes name.
pub fn is_shared(link: &str, nodes: &[NodeAddr]) -> bool {
    link.starts_with("udp-group:") || nodes.iter().filter(|n| n.link == link).count() > 1
}

/// The host's end of the shared medium `link`: a group member that hears
/// its own frames back (stamped, the reference for broadcast sync).
fn open_medium(node: &str, link: &str) -> Result<Medium, SessionError> {
    let err = |message: String| SessionError::Open {
        node: node.into(),
        link: link.into(),
        message,
    };
    let t: Box<dyn motet_link::Transport + Send> =
        match motet_link::LinkSpec::parse(link).map_err(|e| err(e.to_string()))? {
            motet_link::LinkSpec::UdpGroup { group, port, iface } => Box::new(
                motet_link::UdpGroup::join(std::net::SocketAddrV4::new(group, port), iface)
                    .map_err(|e| err(e.to_string()))?
                    .hearing_own(),
            ),
            spec => spec.open().map_err(|e| err(e.to_string()))?,
        };
    Ok(Medium::new(t))
}

/// Arguments of machine node `k`'s simulated process beyond `extra`: a
/// node with closed loops (servos, heaters) runs its machine's plant.
fn plant_args(machine: &Machine, k: usize, extra: &[String]) -> Vec<String> {
    let spec = &machine.nodes[k];
    let mut args = extra.to_vec();
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
    args
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
        Session::spawn_with(machine, exe, extra, clock, Spawning::default())
    }

    /// [`Session::spawn_each`] as `how` says: every node on one multicast
    /// group (the host too, one shared medium, each node given its address
    /// by uid) or each alone on a UDP port of its own, and where the
    /// nodes' logs go.
    pub fn spawn_with(
        machine: &Machine,
        exe: &Path,
        extra: &[Vec<String>],
        clock: &SharedClock,
        how: Spawning,
    ) -> Result<Session, SessionError> {
        let mut spawned = Vec::new();
        for (k, spec) in machine.nodes.iter().enumerate() {
            let args = plant_args(machine, k, extra.get(k).map_or(&[], |e| e.as_slice()));
            let log = how.logs.map(|d| d.join(format!("node-{}.log", spec.name)));
            let listen = how.group.unwrap_or("udp:127.0.0.1:0");
            let node = spawn_sim_node_logged(exe, "stepper", listen, &args, log.as_deref())
                .map_err(|source| SessionError::Spawn {
                    node: spec.name.clone(),
                    source,
                })?;
            spawned.push(node);
        }
        let nodes: Vec<NodeAddr> = machine
            .nodes
            .iter()
            .zip(&spawned)
            .enumerate()
            .map(|(k, (spec, node))| NodeAddr {
                name: spec.name.clone(),
                link: node.link.clone(),
                address: 2 + k as u16,
            })
            .collect();
        // Each node takes its address from a request naming its uid: alone
        // on its link, or heard by every node on the group.
        // One request channel for each link (all of them on a group).
        let mut admin: Option<Admin> = None;
        for (spec, (n, node)) in machine.nodes.iter().zip(nodes.iter().zip(&spawned)) {
            if admin.as_ref().is_none_or(|a| a.link() != n.link) {
                admin = Some(open(&spec.name, &n.link, clock)?);
            }
            let a = admin.as_mut().expect("opened above");
            a.set_address(node.uid, n.address)
                .map_err(|source| SessionError::Admin {
                    node: spec.name.clone(),
                    source,
                })?;
        }
        let uids: Vec<Option<u64>> = spawned.iter().map(|n| Some(n.uid)).collect();
        let mut s = Session::attach_checked(machine, &nodes, &uids, clock)?;
        s.spawned = spawned;
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

    /// [`Session::attach`] checking that each node is the device of
    /// `uids[k]` (the pairing file's, a run record's). On a shared medium
    /// a device that answers no more at its address (restarted without
    /// its state) is given it again by that uid.
    pub fn attach_checked(
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
            shared_medium: false,
        };
        // One transport for each shared medium, its nodes' ports on it.
        let mut media: Vec<(String, Medium)> = Vec::new();
        for (k, (spec, n)) in machine.nodes.iter().zip(nodes).enumerate() {
            let shared = is_shared(&n.link, nodes);
            let mut a = if shared {
                let medium = match media.iter().find(|(l, _)| *l == n.link) {
                    Some((_, m)) => m.clone(),
                    None => {
                        let m = open_medium(&spec.name, &n.link)?;
                        media.push((n.link.clone(), m.clone()));
                        m
                    }
                };
                Admin::with_clock(Box::new(medium.port(n.address)), &n.link, clock.clone())
            } else {
                open(&spec.name, &n.link, clock)?
            };
            let admin_err = |source| SessionError::Admin {
                node: spec.name.clone(),
                source,
            };
            let uid = uids.get(k).copied().flatten();
            let info = match (a.info(n.address), uid) {
                (Err(AdminError::NoAnswer { .. }), Some(uid)) if shared => {
                    a.set_address(uid, n.address).map_err(admin_err)?;
                    a.info(n.address).map_err(admin_err)?
                }
                (r, _) => r.map_err(admin_err)?,
            };
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
        // Seals and stops in one frame only when that frame reaches every
        // node: all of them on one medium.
        s.shared_medium = media.len() == 1 && nodes.iter().all(|n| n.link == media[0].0);
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
