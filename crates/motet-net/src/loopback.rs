//! A networked run in one process on a simulated clock: the host's [`NetRun`]
//! and simulated nodes ([`SimNode`], the node firmware's endpoint) joined by
//! any transports (in-memory pairs, optionally with faults injected), with
//! node crystals off by given ppm. Deterministic and faster than real time;
//! the tests of the network and `motet bench net` use it.

use crate::journal::JournalWriter;
use crate::medium::Medium;
use crate::peer::Peer;
use crate::run::{NetConfig, NetError, NetRun, Phase};
use crate::sim_node::{sim_config, SimNode};
use motet_host::Machine;
use motet_link::udp_group::{self, GroupTally, UdpGroup};
use motet_link::{BusTiming, CanBus, CanTransport, SimClock, Transport};
use motet_node::storage::{Persisted, RamStore};
use motet_planner::{Command, Located};
use motet_trajectory::Point;
use std::net::{Ipv4Addr, SocketAddrV4};
use std::sync::Arc;

/// One simulated node and its clock.
pub struct LoopbackNode {
    /// The node's endpoint, storing what it persists in RAM.
    pub node: SimNode<RamStore>,
    /// Crystal error, parts per million.
    pub ppm: f64,
    /// Local clock at host time 0, µs.
    pub offset_us: u64,
    /// A dead node is no longer stepped: it neither moves nor answers.
    pub alive: bool,
}

impl LoopbackNode {
    /// The node's clock against host time.
    pub fn crystal(&self) -> Crystal {
        Crystal {
            ppm: self.ppm,
            offset_us: self.offset_us,
        }
    }
    fn local(&self, host: u64) -> u64 {
        self.crystal().local(host as f64)
    }
    fn host(&self, local: u64) -> u64 {
        self.crystal().reference(local)
    }
}

/// A loopback node's crystal: its error and its clock's starting offset
/// against host time (the host's estimate of that clock is
/// [`crate::node_clock::NodeClock`]).
pub use motet_link::Crystal;

/// A whole networked run, host and nodes, stepped together on one simulated
/// clock.
pub struct Loopback {
    /// The host's side of the run.
    pub run: NetRun,
    /// One per machine node, in the machine's order.
    pub nodes: Vec<LoopbackNode>,
    /// Host time, µs.
    pub now: u64,
    /// A dead host is no longer polled (its process was killed).
    pub host_alive: bool,
    /// Longest step of simulated time, µs. Frames a fault wrapper holds are
    /// released at the first step after their time, so jittered links need
    /// short steps to keep their delays what the wrapper drew.
    pub max_step_us: u64,
    /// The bus every node and the host share, for a run on one medium
    /// ([`Loopback::on_bus`]).
    pub bus: Option<CanBus>,
    /// The host's end of the bus, for what comes from addresses the run
    /// does not know ([`Medium::take_strangers`]).
    pub medium: Option<Medium>,
    /// The UDP multicast group every node and the host joined, for a run on
    /// one medium over real sockets ([`Loopback::on_udp_group`]), and the
    /// tally that waits for every frame to reach every member.
    pub group: Option<(SocketAddrV4, Arc<GroupTally>)>,
    /// Hosts started on the bus so far (each takes its own identifier).
    hosts: u32,
    /// The bus's clock: host time.
    bus_clock: SimClock,
}

/// The CAN identifier of the first host on a loopback bus (a low one: the
/// host wins arbitration); later hosts take the next ones.
pub const BUS_HOST_ID: u32 = 0x010;
/// The CAN identifier of machine node `k` on a loopback bus is this plus `k`.
pub const BUS_NODE_ID: u32 = 0x100;
/// The multicast group of a loopback run on UDP ([`Loopback::on_udp_group`]),
/// on a port of its own.
pub const LOOPBACK_GROUP: Ipv4Addr = Ipv4Addr::new(239, 255, 77, 77);

impl Loopback {
    /// A run of `commands` on `machine` from `start`; `links[k]` joins the
    /// host (`.0`) to the node of machine node `k` (`.1`). Nodes are paired
    /// already (addresses 2, 3, …) and keep a trace of every step.
    pub fn new(
        machine: &Machine,
        commands: Vec<Located<Command>>,
        start: Point,
        links: Vec<(Box<dyn Transport + Send>, Box<dyn Transport + Send>)>,
        clocks: &[Crystal],
        cfg: NetConfig,
    ) -> Loopback {
        Loopback::with_journal(machine, commands, start, links, clocks, cfg, None)
    }

    /// [`Loopback::new`] writing the run's journal.
    pub fn with_journal(
        machine: &Machine,
        commands: Vec<Located<Command>>,
        start: Point,
        links: Vec<(Box<dyn Transport + Send>, Box<dyn Transport + Send>)>,
        clocks: &[Crystal],
        cfg: NetConfig,
        journal: Option<JournalWriter>,
    ) -> Loopback {
        let mut peers = Vec::new();
        let mut nodes = Vec::new();
        for (k, (host_end, node_end)) in links.into_iter().enumerate() {
            let address = 2 + k as u16;
            peers.push(Peer::new(
                &node_name(machine, k),
                address,
                host_end,
                0x1000 + k as u16,
            ));
            let mut node = loopback_node(k, node_end, clocks);
            node.node.board.heat = motet_host::thermal::NodeHeat::of_node(machine, k);
            nodes.push(node);
        }
        Loopback {
            run: NetRun::new(machine, commands, peers, start, cfg, journal),
            nodes,
            now: 0,
            host_alive: true,
            max_step_us: 1_000,
            bus: None,
            medium: None,
            group: None,
            hosts: 0,
            bus_clock: SimClock::new(),
        }
    }

    /// [`Loopback::with_journal`] with the host and every node on one
    /// simulated CAN-FD bus: the host reaches all nodes through one
    /// transport, seals and stops go to every node in one frame, and every
    /// node hears the others' heartbeats.
    pub fn on_bus(
        machine: &Machine,
        commands: Vec<Located<Command>>,
        start: Point,
        clocks: &[Crystal],
        cfg: NetConfig,
        journal: Option<JournalWriter>,
    ) -> Loopback {
        Loopback::on_bus_with(machine, commands, start, clocks, cfg, journal, &|t| t)
    }

    /// [`Loopback::on_bus`] with the host's transport to the bus passed
    /// through `wrap` (a tap that counts its frames).
    pub fn on_bus_with(
        machine: &Machine,
        commands: Vec<Located<Command>>,
        start: Point,
        clocks: &[Crystal],
        cfg: NetConfig,
        journal: Option<JournalWriter>,
        wrap: &dyn Fn(Box<dyn Transport + Send>) -> Box<dyn Transport + Send>,
    ) -> Loopback {
        let bus_clock = SimClock::new();
        let bus = CanBus::timed(BusTiming::FD_1M_5M, Arc::new(bus_clock.clone()));
        let nodes = (0..machine.nodes.len())
            .map(|k| {
                let id = BUS_NODE_ID + k as u32;
                let node = bus.attach(id, false).expect("one identifier per node");
                let crystal = clocks.get(k).copied().unwrap_or_default();
                let transport = CanTransport::with_clock(node, None, crystal);
                let mut node = loopback_node(k, Box::new(transport), clocks);
                node.node.board.heat = motet_host::thermal::NodeHeat::of_node(machine, k);
                node
            })
            .collect();
        let mut lb = Loopback {
            run: NetRun::new(machine, Vec::new(), Vec::new(), start, cfg, None),
            nodes,
            now: 0,
            host_alive: true,
            max_step_us: 1_000,
            bus: Some(bus),
            medium: None,
            group: None,
            hosts: 0,
            bus_clock,
        };
        let peers = lb
            .bus_peers(machine, 0x1000, wrap)
            .expect("a host identifier on a new bus");
        lb.run = NetRun::new(machine, commands, peers, start, cfg, journal);
        let _ = lb.run.on_shared_medium();
        lb
    }

    /// [`Loopback::on_bus`] with the host and every node members of one UDP
    /// multicast group on this computer's loopback (a port of its own, so
    /// runs side by side do not meet), over real sockets; the run waits
    /// for every frame to reach every member before time moves on, and
    /// each stamps it then, so the host's own sync frames heard back are
    /// reference samples as on the bus. `wrap` as for
    /// [`Loopback::on_bus_with`].
    pub fn on_udp_group(
        machine: &Machine,
        commands: Vec<Located<Command>>,
        start: Point,
        clocks: &[Crystal],
        cfg: NetConfig,
        journal: Option<JournalWriter>,
        wrap: &dyn Fn(Box<dyn Transport + Send>) -> Box<dyn Transport + Send>,
    ) -> std::io::Result<Loopback> {
        let bus_clock = SimClock::new();
        let group = SocketAddrV4::new(LOOPBACK_GROUP, udp_group::free_port()?);
        let tally = GroupTally::new();
        let clock: Arc<dyn motet_link::Clock + Send + Sync> = Arc::new(bus_clock.clone());
        let mut nodes = Vec::new();
        for k in 0..machine.nodes.len() {
            let crystal = clocks.get(k).copied().unwrap_or_default();
            let t = UdpGroup::join(group, Ipv4Addr::LOCALHOST)?
                .stamping(clock.clone(), crystal)
                .counted(&tally);
            nodes.push(loopback_node(k, Box::new(t), clocks));
        }
        let mut lb = Loopback {
            run: NetRun::new(machine, Vec::new(), Vec::new(), start, cfg, None),
            nodes,
            now: 0,
            host_alive: true,
            max_step_us: 1_000,
            bus: None,
            medium: None,
            group: Some((group, tally)),
            hosts: 0,
            bus_clock,
        };
        let peers = lb
            .bus_peers(machine, 0x1000, wrap)
            .ok_or_else(|| std::io::Error::other("the host could not join the group"))?;
        lb.run = NetRun::new(machine, commands, peers, start, cfg, journal);
        let _ = lb.run.on_shared_medium();
        Ok(lb)
    }

    /// The host's transport onto the shared medium: it hears its own
    /// frames at the instant every node heard them (reference broadcast).
    fn host_on_medium(&mut self) -> Option<Box<dyn Transport + Send>> {
        if let Some(bus) = self.bus.as_ref() {
            let host = bus
                .attach_hearing_own(BUS_HOST_ID + self.hosts, false)
                .ok()?;
            self.hosts += 1;
            return Some(Box::new(CanTransport::new(host, None)));
        }
        let (group, tally) = self.group.as_ref()?;
        let clock: Arc<dyn motet_link::Clock + Send + Sync> = Arc::new(self.bus_clock.clone());
        let host = UdpGroup::join(*group, Ipv4Addr::LOCALHOST)
            .ok()?
            .stamping(clock, Crystal::default())
            .hearing_own()
            .counted(tally);
        Some(Box::new(host))
    }

    /// A new host on the shared medium (under the next host identifier on
    /// a bus): one peer per node, all through one transport.
    fn bus_peers(
        &mut self,
        machine: &Machine,
        isn: u16,
        wrap: &dyn Fn(Box<dyn Transport + Send>) -> Box<dyn Transport + Send>,
    ) -> Option<Vec<Peer>> {
        let host = self.host_on_medium()?;
        let medium = Medium::new(wrap(host));
        self.medium = Some(medium.clone());
        let peers = (0..self.nodes.len())
            .map(|k| {
                let address = 2 + k as u16;
                let port = Box::new(medium.port(address));
                Peer::new(&node_name(machine, k), address, port, isn + k as u16)
            })
            .collect();
        Some(peers)
    }

    /// Replaces the host (after it died or stopped) with a new run over new
    /// links; the nodes keep their state, as node processes would.
    pub fn restart_host(
        &mut self,
        machine: &Machine,
        commands: Vec<Located<Command>>,
        start: Point,
        cfg: NetConfig,
        journal: Option<JournalWriter>,
    ) {
        if self.bus.is_some() || self.group.is_some() {
            if let Some(peers) = self.bus_peers(machine, 0x2000, &|t| t) {
                self.run = NetRun::new(machine, commands, peers, start, cfg, journal);
                let _ = self.run.on_shared_medium();
                self.host_alive = true;
                return;
            }
        }
        let mut peers = Vec::new();
        for (k, n) in self.nodes.iter_mut().enumerate() {
            let (a, b) = motet_link::pair(&format!("host{k}'"), &format!("node{k}'"));
            n.node.transport = Box::new(b);
            let address = 2 + k as u16;
            let name = machine
                .nodes
                .get(k)
                .map_or_else(|| format!("node{k}"), |s| s.name.clone());
            // A new host session: a different initial sequence number.
            peers.push(Peer::new(&name, address, Box::new(a), 0x2000 + k as u16));
        }
        self.run = NetRun::new(machine, commands, peers, start, cfg, journal);
        self.host_alive = true;
    }

    /// Replaces a run that finished or stopped by the next on the same
    /// links and nodes, as a server does for each motion: the links and the
    /// clock estimates carry over.
    pub fn next_run(
        &mut self,
        machine: &Machine,
        commands: Vec<Located<Command>>,
        start: Point,
        cfg: NetConfig,
    ) {
        let peers = self.run.take_peers();
        let shared = self.run.shared_medium();
        self.run = NetRun::new(machine, commands, peers, start, cfg, None);
        if shared {
            let _ = self.run.on_shared_medium();
        }
    }

    /// Stops recording every step and tool change on the nodes (tests
    /// compare the executed path through them): a long run, or a server
    /// that runs for days, keeps nothing that grows with its motion.
    pub fn untraced(mut self) -> Self {
        for n in &mut self.nodes {
            n.node.board.trace = None;
            n.node.board.tool_trace = None;
        }
        self
    }

    /// Node `k` restarts (power cycled, or its process killed and started
    /// again from its store): same identity, nothing else kept.
    pub fn restart_node(&mut self, k: usize) {
        let n = &mut self.nodes[k];
        let store = n.node.endpoint.services().store().clone();
        let cfg = sim_config("stepper", store.record.map_or(0, |r| r.uid)).expect("a short kind");
        let transport = std::mem::replace(
            &mut n.node.transport,
            Box::new(motet_link::pair("gone", "gone").0),
        );
        let local = n.local(self.now);
        let mut node = SimNode::new(cfg, store, transport, local);
        node.board = std::mem::take(&mut n.node.board);
        n.node = node;
        n.alive = true;
    }

    /// What every node would answer to `Where`, as `motet resume` sees it.
    pub fn seen(&self) -> Vec<crate::resume::NodeSeen> {
        self.nodes
            .iter()
            .map(|n| {
                if !n.alive {
                    return crate::resume::NodeSeen::Silent;
                }
                let info = n.node.endpoint.services().info();
                crate::resume::NodeSeen::Answered {
                    uid: info.uid,
                    firmware: info.firmware,
                    position: crate::resume::NodePosition::from_message(
                        &n.node.endpoint.node().position(),
                    ),
                }
            })
            .collect()
    }

    /// One round of the host and every live node, then time moves on to the
    /// next thing any of them has to do (at least 10 µs, at most [`Loopback::max_step_us`]).
    pub fn step(&mut self) -> Result<(), NetError> {
        let next = self.round()?;
        self.now = next.clamp(self.now + 10, self.now + self.max_step_us);
        Ok(())
    }

    /// One round at `now` (µs, never earlier than the last): how a host
    /// drives loopback nodes on the wall clock instead of a simulated one.
    /// Returns when any of them has something to do next.
    pub fn advance_to(&mut self, now: u64) -> Result<u64, NetError> {
        self.now = self.now.max(now);
        self.round()
    }

    /// The host, every live node, and the host again (replies are taken at
    /// once, as on a link without delay); returns the earliest wakeup.
    fn round(&mut self) -> Result<u64, NetError> {
        self.bus_clock.set(self.now);
        if self.host_alive {
            self.run.poll(self.now)?;
        }
        self.settle_group();
        let mut next = if self.host_alive {
            self.run.next_wakeup(self.now)
        } else {
            self.now + 1_000
        };
        for n in self.nodes.iter_mut().filter(|n| n.alive) {
            let local = n.local(self.now);
            n.node.step(local);
            if let Some(w) = n.node.endpoint.next_wakeup(local) {
                next = next.min(n.host(w));
            }
        }
        self.settle_group();
        if self.host_alive {
            self.run.poll(self.now)?;
            next = next.min(self.run.next_wakeup(self.now));
        }
        self.settle_group();
        if let Some(t) = self.bus.as_ref().and_then(CanBus::next_event_us) {
            next = next.min(t.max(self.now));
        }
        Ok(next)
    }

    /// On a UDP group: waits (real time) until every frame sent reaches
    /// every member, each stamping it now, as a bus delivers a frame to
    /// every node at its end.
    fn settle_group(&self) {
        if let Some((_, tally)) = &self.group {
            // On this computer's loopback a datagram arrives in µs; a
            // member that never gets one (its socket gone) holds no one up
            // for long.
            let _ = tally.settle(std::time::Duration::from_millis(200));
        }
    }

    /// Steps until the run is done or stopped, the host is dead and the nodes
    /// idle for a second, or `max_us` of simulated time passed.
    pub fn run_until_settled(&mut self, max_us: u64) -> Result<Phase, NetError> {
        let end = self.now + max_us;
        let mut dead_since = None;
        while self.now < end {
            self.step()?;
            if self.host_alive {
                if matches!(self.run.phase(), Phase::Done | Phase::Stopped(_)) {
                    break;
                }
            } else {
                // A node braking on its tail is still moving.
                let busy = self
                    .nodes
                    .iter()
                    .any(|n| n.alive && n.node.endpoint.node().moving());
                if busy {
                    dead_since = None;
                } else if dead_since.get_or_insert(self.now).saturating_add(1_000_000) < self.now {
                    break;
                }
            }
        }
        Ok(self.run.phase().clone())
    }
}

/// Machine node `k`'s name.
fn node_name(machine: &Machine, k: usize) -> String {
    machine
        .nodes
        .get(k)
        .map_or_else(|| format!("node{k}"), |n| n.name.clone())
}

/// The simulated node of machine node `k` on `transport` (address 2 + k,
/// paired already, tracing every step and tool change).
fn loopback_node(
    k: usize,
    transport: Box<dyn Transport + Send>,
    clocks: &[Crystal],
) -> LoopbackNode {
    let address = 2 + k as u16;
    let uid = 0x5157_0000 + k as u64;
    let cfg = sim_config("stepper", uid).expect("a short kind");
    let store = RamStore {
        record: Some(Persisted {
            uid,
            address,
            firmware: cfg.firmware,
        }),
        saves: 0,
    };
    let clock = clocks.get(k).copied().unwrap_or_default();
    let mut node = SimNode::new(cfg, store, transport, clock.offset_us);
    node.board.trace = Some(Vec::new());
    node.board.tool_trace = Some(Vec::new());
    LoopbackNode {
        node,
        ppm: clock.ppm,
        offset_us: clock.offset_us,
        alive: true,
    }
}
