//! Where the machine's nodes are, for a server: every motion a server
//! starts (a job, its continuation after a hold, a jog) is one networked run
//! ([`NetRun`]) on the same nodes, so a hold, a cancel and an emergency stop
//! are the run's coordinated stop: every node brakes on its contingency tail
//! and rests on the path, where the host knows it is.

mod pair;

pub use pair::{PairOutcome, PairRefusal};

use motet_host::Machine;
use motet_net::loopback::{Crystal, Loopback};
use motet_net::run::PeerFigures;
use motet_net::{NetConfig, NetError, NetRun};
use motet_planner::{Command, Located};
use motet_trajectory::Point;

/// The nodes a server drives, each motion one [`NetRun`] on them, polled on
/// the server's clock (µs since it started).
///
/// To put a server on other nodes, implement this over their links: `begin`
/// makes a new run with the current run's peers
/// ([`NetRun::take_peers`]); `advance` polls it and the links.
pub trait Nodes: Send {
    /// Replaces the current run (which has finished or stopped) by a run of
    /// `commands` from rest at `start`, on the same links: the clock
    /// estimates carry over, so it starts at once.
    fn begin(&mut self, machine: &Machine, commands: Vec<Located<Command>>, start: Point);
    /// Polls the run and the nodes at `now`; returns when to poll next at
    /// the latest, µs.
    fn advance(&mut self, now: u64) -> Result<u64, NetError>;
    /// The current run.
    fn run(&self) -> &NetRun;
    /// The current run, to stop it.
    fn run_mut(&mut self) -> &mut NetRun;
    /// Each node's link figures (round trip, retransmits, clock error).
    fn figures(&self, now: u64) -> Vec<PeerFigures> {
        self.run().figures(now)
    }
    /// Where the nodes are, for the person: `sim` (in this process),
    /// `spawn` (node processes this server started) or `paired`.
    fn kind(&self) -> &'static str;
    /// Node `k`'s firmware version, `major.minor.patch`.
    fn firmware(&self, k: usize) -> String;
    /// The link node `k` is reached on (`memory` for in-process nodes).
    fn link(&self, k: usize) -> String;
    /// Whether node `k`'s identify LED is on at `now`, where the server
    /// can see it (in-process nodes); `None` elsewhere.
    fn identifying(&self, _k: usize, _now: u64) -> Option<bool> {
        None
    }
    /// Frames stamped as they arrive on `clock`, the server's (its origin
    /// when it started), where the links can tell (real transports).
    fn stamp_arrivals(&mut self, _clock: motet_link::WallClock) {}
    /// Pairs the devices on the nodes' links with the machine's nodes (each
    /// alone on its link), writes the pairing file and goes on with them;
    /// the machine rests at `at`. Only at rest.
    fn pair(&mut self, _machine: &Machine, _at: Point) -> Result<PairOutcome, PairRefusal> {
        Err(PairRefusal::Simulated)
    }
}

/// Settings of a server's runs: a short lead, short windows and moves
/// planned in pieces of at most about 20 ms, because a hold or a stop
/// brakes on the tail of the committed window and a person waits for it
/// (in-process nodes have no link delay to cover).
///
/// Its clock target is a millisecond: the clock thread reads the time once
/// per tick (up to 1 ms) and stamps the clock exchanges it sends and takes
/// with it, so its timestamps cannot tell a node's clock any finer.
pub fn serve_config() -> NetConfig {
    NetConfig {
        clock_bound_us: 1_000.0,
        lead_min_us: 10_000,
        // A busy computer may lengthen the lead, but a person waiting for a
        // hold to brake should not wait much longer.
        lead_max_us: 200_000,
        window_us: 20_000,
        max_move_us: 20_000,
        ..NetConfig::default()
    }
}

/// [`serve_config`] for nodes in other processes or on boards: a longer
/// lead (50 ms), since the committed window must outlast the host thread's
/// worst scheduling delay on a busy computer, not only the link's round
/// trip; a node that runs out of it brakes on its tail and the job stops in
/// alarm. A hold or stop brakes up to this much later.
pub fn linked_config() -> NetConfig {
    NetConfig {
        lead_min_us: 50_000,
        ..serve_config()
    }
}

/// The machine's nodes simulated in this process, stepped on the server's
/// clock: the node firmware's own code, joined to the host by in-memory
/// links.
pub struct SimNodes {
    net: Loopback,
    cfg: NetConfig,
}

impl SimNodes {
    /// One simulated node per machine node, connected and idle at `start`.
    pub fn new(machine: &Machine, start: Point, cfg: NetConfig) -> SimNodes {
        let links = (0..machine.nodes.len())
            .map(|k| {
                let (a, b) = motet_link::pair(&format!("host{k}"), &format!("node{k}"));
                (
                    Box::new(a) as Box<dyn motet_link::Transport + Send>,
                    Box::new(b) as Box<dyn motet_link::Transport + Send>,
                )
            })
            .collect();
        let clocks = vec![Crystal::default(); machine.nodes.len()];
        // A server runs for days: nothing may grow with its motion.
        let net = Loopback::new(machine, Vec::new(), start, links, &clocks, cfg).untraced();
        SimNodes { net, cfg }
    }
}

impl Nodes for SimNodes {
    fn begin(&mut self, machine: &Machine, commands: Vec<Located<Command>>, start: Point) {
        self.net.next_run(machine, commands, start, self.cfg);
    }

    fn advance(&mut self, now: u64) -> Result<u64, NetError> {
        self.net.advance_to(now)
    }

    fn run(&self) -> &NetRun {
        &self.net.run
    }

    fn run_mut(&mut self) -> &mut NetRun {
        &mut self.net.run
    }

    fn kind(&self) -> &'static str {
        "sim"
    }

    fn firmware(&self, k: usize) -> String {
        self.net.nodes.get(k).map_or_else(String::new, |n| {
            version(n.node.endpoint.services().info().firmware)
        })
    }

    fn link(&self, _k: usize) -> String {
        "memory".into()
    }

    fn identifying(&self, k: usize, now: u64) -> Option<bool> {
        // Loopback nodes' clocks equal the host's (no crystal error).
        let n = self.net.nodes.get(k)?;
        Some(n.node.endpoint.services().blinking(now))
    }
}

fn version(v: motet_wire::service::Version) -> String {
    format!("{}.{}.{}", v.major, v.minor, v.patch)
}

/// Nodes on real links (UDP, serial, CAN): node processes this server
/// started, or the machine's paired nodes. The links and what each node
/// said it is come from a [`motet_net::session::Session`]; the server's
/// clock is the runs' host clock.
pub struct LinkedNodes {
    run: NetRun,
    cfg: NetConfig,
    session: motet_net::session::Session,
    kind: &'static str,
    /// Where pairing writes the pairing file (beside the machine file).
    pairing: Option<std::path::PathBuf>,
    /// The server's clock, once it gave it: what arrivals are stamped on.
    pub(crate) clock: Option<motet_link::WallClock>,
}

impl LinkedNodes {
    /// The session's nodes, connecting and idle at `start`. `kind` says
    /// where they are (`spawn` or `paired`).
    pub fn new(
        machine: &Machine,
        mut session: motet_net::session::Session,
        start: Point,
        cfg: NetConfig,
        kind: &'static str,
    ) -> LinkedNodes {
        let peers = std::mem::take(&mut session.peers);
        LinkedNodes {
            run: NetRun::new(machine, Vec::new(), peers, start, cfg, None),
            cfg,
            session,
            kind,
            pairing: None,
            clock: None,
        }
    }

    /// Pairing from the server writes the pairing file at `path` (beside
    /// the machine file: `motet_net::pairing_file::pairing_path`).
    pub fn pairing_file(mut self, path: std::path::PathBuf) -> LinkedNodes {
        self.pairing = Some(path);
        self
    }
}

impl Nodes for LinkedNodes {
    fn begin(&mut self, machine: &Machine, commands: Vec<Located<Command>>, start: Point) {
        let peers = self.run.take_peers();
        self.run = NetRun::new(machine, commands, peers, start, self.cfg, None);
    }

    fn stamp_arrivals(&mut self, clock: motet_link::WallClock) {
        self.clock = Some(clock);
        self.run.stamp_arrivals(clock);
    }

    fn advance(&mut self, now: u64) -> Result<u64, NetError> {
        self.run.poll(now)?;
        Ok(self.run.next_wakeup(now))
    }

    fn run(&self) -> &NetRun {
        &self.run
    }

    fn run_mut(&mut self) -> &mut NetRun {
        &mut self.run
    }

    fn kind(&self) -> &'static str {
        self.kind
    }

    fn firmware(&self, k: usize) -> String {
        self.session
            .infos
            .get(k)
            .map_or_else(String::new, |i| version(i.firmware))
    }

    fn link(&self, k: usize) -> String {
        self.session
            .nodes
            .get(k)
            .map_or_else(String::new, |n| n.link.clone())
    }

    fn pair(&mut self, machine: &Machine, at: Point) -> Result<PairOutcome, PairRefusal> {
        self.pair_here(machine, at)
    }
}
