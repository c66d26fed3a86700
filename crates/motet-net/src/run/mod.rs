//! A job streamed to networked nodes: connect, synchronise clocks, configure,
//! stream the trajectory in sealed windows, and finish or stop safely.
//!
//! Safety rests on the nodes, not on the host: every node runs only committed
//! (sealed) segments and computes, with the same code as the host, a
//! contingency tail that brings the machine to rest exactly at the end of the
//! committed window. The host keeps the next seal arriving before that tail
//! would start (minimal buffering: at least 2 segments and 2×RTT ahead, at most
//! the node's queue). If the host stops sealing, for any reason (it dies, a
//! link is cut, a node stops answering, a node refuses a message), every node
//! runs its tail from the same boundary and all come to rest together on the
//! path, where the journal says.

mod clocks;
mod figures;
mod group;
mod heaters;
mod loops;
mod pace;
mod stop;
mod window;

pub use figures::{PeerFigures, Tally};
pub use pace::PaceFigures;
pub use stop::{LostNode, StopInfo};

use crate::digest::Digest;
use crate::journal::{JournalHeader, JournalWriter};
use crate::node_clock::EXCHANGE_AT;
use crate::peer::{Incoming, Peer};
use crate::plan_feed::{run_limits, CommandSource, PlanFeed};
use clocks::{clock_target, path_limit};
use motet_host::{Distributor, Machine};
use motet_planner::{Command, Located, PlanError, SourceLoc};
use motet_trajectory::{Point, Segment};
use motet_wire::link::State;
use motet_wire::{HostMessage, NodeMessage, Refusal};
use std::collections::VecDeque;
use window::Committed;

/// Service replies kept for [`NetRun::take_service_replies`].
const SERVICE_REPLIES: usize = 256;
/// Nothing moves before every node's clock bound stays within its target
/// this long with no exchange more, µs.
const START_HORIZON_US: f64 = 1_000_000.0;

/// Settings of a networked run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NetConfig {
    /// Least time the committed window reaches ahead of now, µs (the run uses
    /// at least 2×RTT + 4×RTTVAR of the slowest link).
    pub lead_min_us: u64,
    /// A node silent this long is lost, µs.
    pub node_timeout_us: u64,
    /// Status requests to each node while the machine finishes, µs apart
    /// (while windows stream, a seal's acknowledgement tells the host what
    /// it needs, and a status is asked only when a queue looks full).
    pub status_interval_us: u64,
    /// Longest time between clock exchanges with a node, µs: they are as
    /// rare as the node's error bound allows, and no rarer than this (they
    /// are also what a quiet node answers, so the host hears it).
    pub sync_interval_us: u64,
    /// The clock target, µs: nothing moves until every node's clock error
    /// bound is within it, and the exchanges and models keep it there.
    pub clock_bound_us: f64,
    /// How long a start waits for every clock to reach its target, µs
    /// (a busy computer makes the exchanges that tell the most rare); past
    /// it the run waits as long again while every node's bound is within
    /// what the machine's path allows, and gives up when one is not, or
    /// after twice as long, naming the clock.
    pub connect_timeout_us: u64,
    /// Past `connect_timeout_us`, start once every link is up and every
    /// node's bound is within what the machine's path allows, short of its
    /// target, saying which clocks fell short (`motet run
    /// --start-late-clocks`: a computer too busy for the target). Off by
    /// default: nothing moves on a clock above its target, but for the
    /// machine's only node that moves or drives a tool, which starts so
    /// unasked (its clock sets no two nodes apart).
    pub start_late_clocks: bool,
    /// How far past the lead a new window reaches, µs: longer windows mean
    /// fewer seals on the wire, shorter ones keep more of the trajectory
    /// editable.
    pub window_us: u64,
    /// Longest a planned move should take, µs (0: no limit): longer moves
    /// are planned as pieces, so a stop brakes soon after it is asked
    /// ([`motet_planner::Limits::max_move_s`]). Not journaled: a run that
    /// may be resumed from its journal leaves it at 0.
    pub max_move_us: u64,
    /// On a shared medium, one clock exchange to every node in one frame:
    /// where the host hears its own frame when every node does (a CAN
    /// bus), each answer is an exact sample (reference broadcast). Off:
    /// one exchange per node, as on separate links.
    pub sync_to_all: bool,
    /// Longest lead the run raises to when the host falls behind, µs
    /// ([`NetRun::take_notes`] says when it does): a longer lead rides out
    /// longer stalls of a busy host, and brakes that much later on a stop.
    pub lead_max_us: u64,
}

impl Default for NetConfig {
    fn default() -> Self {
        NetConfig {
            lead_min_us: 100_000,
            node_timeout_us: 1_500_000,
            status_interval_us: 5_000_000,
            sync_interval_us: 10_000_000,
            clock_bound_us: 10.0,
            connect_timeout_us: 15_000_000,
            start_late_clocks: false,
            window_us: 1_000_000,
            max_move_us: 0,
            sync_to_all: true,
            lead_max_us: 2_000_000,
        }
    }
}

/// What identifies a run: a number the nodes keep while they hold its
/// trajectory, and the files it was made from. The journal starts with it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunIdentity {
    /// Never 0 (a node with no run reports 0).
    pub run: u32,
    /// SHA-256 of the machine file.
    pub machine: Digest,
    /// SHA-256 of the job file.
    pub job: Digest,
}

impl RunIdentity {
    /// A new run of these files, with a number unlikely to repeat.
    pub fn new(machine: Digest, job: Digest) -> RunIdentity {
        let t = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64);
        let mixed = Digest::of(&[&t.to_le_bytes()[..], &std::process::id().to_le_bytes()].concat());
        let run = u32::from_le_bytes([mixed.0[0], mixed.0[1], mixed.0[2], mixed.0[3]]).max(1);
        RunIdentity { run, machine, job }
    }
}

impl Default for RunIdentity {
    fn default() -> Self {
        RunIdentity {
            run: 1,
            machine: Digest::default(),
            job: Digest::default(),
        }
    }
}

/// Why a run could not go on. Once streaming has started, a node's trouble
/// stops the run safely instead ([`Phase::Stopping`]); these are what is
/// left: the run cannot start, the job does not plan, or the journal cannot
/// be written (then nothing more is sealed).
#[derive(Debug, thiserror::Error)]
pub enum NetError {
    /// The planner refused a job command.
    #[error("{loc}: {error}")]
    Plan {
        /// Where in the job.
        loc: SourceLoc,
        /// What it refused.
        error: PlanError,
    },
    /// The job could not be read further as the run went (its source
    /// failed, saying where). Only between a feed and its run: the run
    /// stops on the path instead ([`Phase::Stopping`]).
    #[error("{0}")]
    Source(String),
    /// A node refused, failed its link, or its clock could not be trusted
    /// while the run started; or a segment could not be routed to it.
    #[error("node {node}: {message}")]
    Node {
        /// The machine node's name.
        node: String,
        /// What went wrong.
        message: String,
    },
    /// The journal could not be written: without it nothing is sealed.
    #[error("journal: {0}")]
    Journal(#[from] crate::journal::JournalError),
    /// A node's transport failed while the run started.
    #[error("node {node}: link: {source}")]
    Io {
        /// The machine node's name.
        node: String,
        /// What the transport said.
        source: std::io::Error,
    },
}

/// Where a run is.
#[derive(Clone, Debug, PartialEq)]
pub enum Phase {
    /// Links handshaking, clocks being measured, nodes being configured.
    Starting,
    /// Windows streaming.
    Streaming,
    /// Everything sealed; waiting for the machine to finish.
    Draining,
    /// Finished: every node at rest at the job's end.
    Done,
    /// Sealing stopped; the nodes are running their tails.
    Stopping(StopInfo),
    /// Stopped on the path; `motet resume` continues from `info`.
    Stopped(StopInfo),
}

/// The host's side of a networked run: plans the job, streams it to the
/// nodes in sealed windows ahead of their clocks, keeps their clocks
/// synchronised, journals every seal before sending it, and stops safely
/// on its contingency tails when a node is lost. Driven by polling with the
/// time as an argument.
///
/// Of the trajectory it keeps only a window that does not grow with the
/// job: the segments sealed and not yet run (at most a node's queue) and
/// those that ended less than a second of host time ago, the record
/// [`NetRun::position_at`] answers from and a stop's tail is computed on.
/// The journal, on disk, keeps the whole run.
pub struct NetRun {
    machine: Machine,
    cfg: NetConfig,
    identity: RunIdentity,
    peers: Vec<Peer>,
    dist: Distributor,
    /// The rest of the job, read as the run goes, and its length; until
    /// streaming starts and the feed takes it.
    source: Option<(Box<dyn CommandSource>, usize)>,
    /// The job, until streaming starts and the feed takes it.
    commands: Vec<Located<Command>>,
    feed: Option<PlanFeed>,
    /// More commands may come ([`NetRun::keep_feed_open`]).
    feed_open: bool,
    /// Host time the feed's trajectory starts at, µs.
    feed_t0: f64,
    start_point: Point,
    /// Routed to the nodes but not sealed.
    pending: Vec<Committed>,
    pending_events: usize,
    committed: VecDeque<Committed>,
    /// The committed segments as run (tails included after a stop), for
    /// "where was the machine at time t": the same window as `committed`,
    /// forgotten with it.
    history: VecDeque<Segment>,
    /// End time of the last segment forgotten, µs: where the machine was
    /// before it is no longer known.
    forgotten_until: f64,
    /// Where the machine was before the oldest segment in `history`.
    before: Point,
    next_index: u32,
    /// End time of the last committed segment, µs.
    committed_end: f64,
    /// Tail start time of the committed window, µs.
    deadline: f64,
    tail_start: u32,
    journal: Option<JournalWriter>,
    /// Segments every node has reported finished, as last journaled.
    done: u32,
    /// Nodes lost, in the order the host noticed.
    lost: Vec<LostNode>,
    phase: Phase,
    started_at: Option<u64>,
    configured: bool,
    next_status: u64,
    /// When to ask the stopping nodes where they are next.
    next_where: u64,
    /// When the tallies were asked for, at the end.
    tally_asked: Option<u64>,
    /// Each node's answer: not yet, none kept, or its tally.
    tallies: Vec<Option<Option<Tally>>>,
    room_asked_at: Option<u64>,
    /// Windows sealed so far.
    pub windows: u64,
    /// Segments routed to the nodes so far (each once, whatever the number
    /// of nodes).
    pub segments_sent: u64,
    /// Pauses for the person (M0, M1) routed so far.
    pub pauses: u64,
    status: Vec<Option<NodeMessage>>,
    /// Seals and stops to every node in one frame (a shared medium).
    group: Option<group::Group>,
    /// How late the host runs, and the lead that covers it.
    pace: pace::Pace,
    /// Samples the nodes' loops sent, per source.
    samples: motet_host::samples::SampleStore,
    /// The sensors' planned acceleration, from the committed segments.
    sensor_plan: motet_host::sensor_plan::SensorPlan,
    /// Service replies the run does not act on (a module watch's), by node.
    service_replies: VecDeque<(usize, motet_wire::ServiceReply)>,
    /// The heaters its nodes drive: heard from, ready, tripped; a wait.
    heat: heaters::Heat,
    /// Nodes whose clock the host was in doubt of (said once).
    doubted: Vec<usize>,
}

impl NetRun {
    /// A run of `commands` on `machine` through `peers` (one per machine node,
    /// in the machine's order), starting at rest at `start`.
    pub fn new(
        machine: &Machine,
        commands: Vec<Located<Command>>,
        peers: Vec<Peer>,
        start: Point,
        cfg: NetConfig,
        journal: Option<JournalWriter>,
    ) -> NetRun {
        let n = peers.len();
        let mut peers = peers;
        for p in &mut peers {
            // A run starts at rest, and a node may have restarted since the
            // last: its first model goes out as it is.
            p.sync.forget_sent();
        }
        NetRun {
            machine: machine.clone(),
            cfg,
            identity: RunIdentity::default(),
            peers,
            dist: Distributor::new(machine),
            commands,
            source: None,
            feed: None,
            feed_open: false,
            feed_t0: f64::NEG_INFINITY,
            start_point: start,
            pending: Vec::new(),
            pending_events: 0,
            committed: VecDeque::new(),
            history: VecDeque::new(),
            forgotten_until: f64::NEG_INFINITY,
            before: start,
            next_index: 0,
            committed_end: f64::NEG_INFINITY,
            deadline: f64::NEG_INFINITY,
            tail_start: 0,
            journal,
            done: 0,
            lost: Vec::new(),
            phase: Phase::Starting,
            started_at: None,
            configured: false,
            next_status: 0,
            next_where: 0,
            tally_asked: None,
            tallies: vec![None; n],
            room_asked_at: None,
            windows: 0,
            segments_sent: 0,
            pauses: 0,
            status: vec![None; n],
            group: None,
            pace: pace::Pace::new(cfg.lead_max_us),
            samples: motet_host::samples::SampleStore::new(),
            sensor_plan: motet_host::sensor_plan::SensorPlan::new(machine),
            service_replies: VecDeque::new(),
            heat: heaters::Heat::default(),
            doubted: Vec::new(),
        }
    }

    /// The run's identity (its number goes to the nodes, its files'
    /// digests into the journal). Before the first poll.
    pub fn with_identity(mut self, identity: RunIdentity) -> NetRun {
        self.set_identity(identity);
        self
    }

    /// [`NetRun::with_identity`] in place.
    pub fn set_identity(&mut self, identity: RunIdentity) {
        self.identity = identity;
    }

    /// The run's number and files.
    pub fn identity(&self) -> &RunIdentity {
        &self.identity
    }

    /// Where the run is.
    pub fn phase(&self) -> &Phase {
        &self.phase
    }

    /// The links to the nodes, in the machine's order.
    pub fn peers(&self) -> &[Peer] {
        &self.peers
    }

    /// Service replies the nodes sent that the run does not act on (what a
    /// module watch asked), each with its node's index, oldest first.
    pub fn take_service_replies(&mut self) -> Vec<(usize, motet_wire::ServiceReply)> {
        self.service_replies.drain(..).collect()
    }

    /// The link to machine node `k`, to send it a service request (identify)
    /// between the run's own messages.
    pub fn peer_mut(&mut self, k: usize) -> Option<&mut Peer> {
        self.peers.get_mut(k)
    }

    /// Takes the links to the nodes, for the next run on the same nodes
    /// (their clock estimates carry over, so it starts at once); this run
    /// is left with none and must not be polled again.
    pub fn take_peers(&mut self) -> Vec<Peer> {
        std::mem::take(&mut self.peers)
    }

    /// Has every node's transport stamp frames as they arrive, on `clock`:
    /// the clock this run's `now` is read from ([`Peer::stamp_arrivals`]).
    pub fn stamp_arrivals(&mut self, clock: motet_link::WallClock) {
        for p in &mut self.peers {
            p.stamp_arrivals(clock);
        }
    }

    /// How far apart the host's and a node's stamps of one sync frame may
    /// lie, host µs ([`Peer::reference_slack_us`]): processes whose system
    /// stamps datagrams.
    pub fn reference_slack_us(&mut self, us: u64) {
        for p in &mut self.peers {
            p.reference_slack_us(us);
        }
    }

    /// Reads the job's commands after those it was given from `source`,
    /// `total` in all (for progress), as the run plans them: the run then
    /// holds a bounded window of the job, however long it is.
    /// Before the first poll.
    pub fn reading(&mut self, source: Box<dyn CommandSource>, total: usize) {
        self.source = Some((source, total));
    }

    /// Keeps the run open for more commands ([`NetRun::push_commands`]),
    /// as a sender streams them: before the first poll. While no command is
    /// waiting to be planned when the committed window needs more, the run
    /// plans what it holds to rest and takes no more (its feed closes), so
    /// the nodes never reach their tails while the host waits for input;
    /// the run then ends as any run does ([`Phase::Done`]).
    pub fn keep_feed_open(&mut self) {
        self.feed_open = true;
    }

    /// Appends commands to an open run; their indices follow the ones
    /// before. Returns false, taking nothing, once the feed has closed.
    pub fn push_commands(&mut self, commands: Vec<Located<Command>>) -> bool {
        if !self.feed_open {
            return false;
        }
        match self.feed.as_mut() {
            Some(f) => f.push(commands),
            None => {
                self.commands.extend(commands);
                true
            }
        }
    }

    /// No more commands come: the run plans what it holds to rest and ends.
    pub fn close_feed(&mut self) {
        self.feed_open = false;
        if let Some(f) = self.feed.as_mut() {
            f.close();
        }
    }

    /// Whether the run still takes commands.
    pub fn feed_open(&self) -> bool {
        self.feed_open
    }

    /// The commands not yet planned, with the index of the first, to
    /// adjust before they are (a feed override applied live). What is
    /// planned stays as planned.
    pub fn pending_commands_mut(&mut self) -> (usize, &mut [Located<Command>]) {
        match self.feed.as_mut() {
            Some(f) => {
                let from = f.progress().0;
                (from, f.pending_mut())
            }
            None => (0, &mut self.commands[..]),
        }
    }

    /// Commands planned so far and in all.
    pub fn progress(&self) -> (usize, usize) {
        let before = match &self.source {
            Some((_, total)) => *total,
            None => self.commands.len(),
        };
        self.feed.as_ref().map_or((0, before), |f| f.progress())
    }

    /// Commands the run holds (given or read, not yet planned): what a
    /// job costs it in memory.
    pub fn commands_held(&self) -> usize {
        self.feed.as_ref().map_or(self.commands.len(), |f| f.held())
    }

    /// When the committed trajectory ends, µs.
    pub fn committed_end(&self) -> f64 {
        self.committed_end
    }

    /// The lead kept: the least one ([`NetRun::base_lead_us`]), longer by
    /// twice the worst lateness of the host seen so far, at most
    /// [`NetConfig::lead_max_us`].
    pub fn lead_us(&self) -> u64 {
        self.pace.lead(self.base_lead_us())
    }

    /// Least lead: the configured minimum or 2×RTT + 4×RTTVAR of the slowest link.
    pub fn base_lead_us(&self) -> u64 {
        let rtt = self
            .peers
            .iter()
            .map(|p| {
                let s = p.link().stats();
                2 * s.srtt_us + 4 * s.rttvar_us
            })
            .max()
            .unwrap_or(0);
        rtt.max(self.cfg.lead_min_us)
    }

    /// One round: take what arrived, act, transmit. Returns the phase.
    pub fn poll(&mut self, now: u64) -> Result<&Phase, NetError> {
        if self.started_at.is_none() {
            self.started_at = Some(now);
        }
        if !matches!(self.phase, Phase::Done | Phase::Stopped(_)) {
            let base = self.base_lead_us();
            // Short stalls, however frequent, never hide a dead node.
            self.pace.turn(now, base, self.cfg.node_timeout_us / 4);
        }
        let mut failed = None;
        for (k, p) in self.peers.iter_mut().enumerate() {
            if self.lost.iter().any(|l| l.node == k) {
                continue;
            }
            if let Err(source) = p.receive(now) {
                failed = Some((k, source));
                break;
            }
        }
        if let Some((k, source)) = failed {
            // A node gone mid-job stops the others with it; before the job
            // starts it is an error.
            if matches!(self.phase, Phase::Starting) {
                let node = self.peers[k].name.clone();
                return Err(NetError::Io { node, source });
            }
            if !matches!(self.phase, Phase::Done | Phase::Stopped(_)) {
                self.lose(k, format!("link error: {source}"), now);
            }
        }
        // Before the replies: a node's refusal after its tail started says
        // less than the host's own lateness.
        self.check_behind(now);
        self.take_replies(now)?;
        self.keep_time(now)?;
        self.keep_group(now);
        match self.phase.clone() {
            Phase::Starting => self.start(now)?,
            Phase::Streaming => {
                self.watch(now);
                if matches!(self.phase, Phase::Streaming) {
                    self.fill(now)?;
                }
            }
            Phase::Draining => {
                self.watch(now);
                self.ask_status(now);
                if matches!(self.phase, Phase::Draining) && self.finished(now) {
                    self.collect_tallies(now);
                }
            }
            Phase::Stopping(_) => self.settle(now)?,
            Phase::Done | Phase::Stopped(_) => {}
        }
        for k in 0..self.peers.len() {
            if self.lost.iter().any(|l| l.node == k) {
                continue;
            }
            if let Err(source) = self.peers[k].flush(now) {
                match self.phase {
                    Phase::Starting => {
                        let node = self.peers[k].name.clone();
                        return Err(NetError::Io { node, source });
                    }
                    Phase::Streaming | Phase::Draining | Phase::Stopping(_) => {
                        self.lose(k, format!("link error: {source}"), now)
                    }
                    Phase::Done | Phase::Stopped(_) => {}
                }
                break;
            }
        }
        Ok(&self.phase)
    }

    /// When to poll again at the latest, µs.
    pub fn next_wakeup(&self, now: u64) -> u64 {
        let mut t = now + 1_000;
        for p in &self.peers {
            if let Some(d) = p.next_timeout() {
                t = t.min(d.max(now));
            }
        }
        for p in &self.peers {
            t = t.min(p.sync.next_exchange().max(now));
        }
        t
    }

    fn take_replies(&mut self, now: u64) -> Result<(), NetError> {
        for k in 0..self.peers.len() {
            while let Some(m) = self.peers[k].take() {
                match m {
                    // A node that keeps no tally says so; nothing is wrong.
                    Incoming::Motion(NodeMessage::Refused {
                        reason: Refusal::BadConfig,
                    }) if self.tally_asked.is_some() && self.tallies[k].is_none() => {
                        self.tallies[k] = Some(None);
                    }
                    Incoming::Motion(NodeMessage::Tally {
                        steps,
                        tool_changes,
                        hash,
                    }) => {
                        self.tallies[k] = Some(Some(Tally {
                            steps,
                            tool_changes,
                            hash,
                        }))
                    }
                    Incoming::Motion(NodeMessage::Refused { reason }) => {
                        let node = self.peers[k].name.clone();
                        let mut message = format!("refused a message: {reason}");
                        if matches!(self.phase, Phase::Starting) {
                            return Err(NetError::Node { node, message });
                        }
                        if matches!(reason, Refusal::Stopped | Refusal::TailStarted) {
                            message += &format!(" ({})", self.pace_context());
                        }
                        self.stop(&format!("node {node} {message}"), now);
                    }
                    Incoming::Motion(m @ NodeMessage::Status { .. }) => self.status[k] = Some(m),
                    Incoming::Motion(NodeMessage::Position {
                        run,
                        committed,
                        queued,
                        ..
                    }) => {
                        let ours = run == self.identity.run;
                        if let Phase::Stopping(info) = &mut self.phase {
                            if ours && queued == 0 {
                                info.at_rest(k, committed);
                            }
                        }
                    }
                    Incoming::Motion(
                        m @ (NodeMessage::Fault { .. }
                        | NodeMessage::Samples(_)
                        | NodeMessage::HeaterReady { .. }),
                    ) => self.on_loop_message(k, m, now),
                    Incoming::Service(r) => {
                        // Kept for whoever asked (a module watch), the
                        // newest few.
                        if self.service_replies.len() == SERVICE_REPLIES {
                            self.service_replies.pop_front();
                        }
                        self.service_replies.push_back((k, r));
                    }
                }
            }
        }
        Ok(())
    }

    fn start(&mut self, now: u64) -> Result<(), NetError> {
        let started = self.started_at.unwrap_or(now);
        for p in &self.peers {
            if let State::Failed(e) = p.link_state() {
                return Err(NetError::Node {
                    node: p.name.clone(),
                    message: format!("link failed: {e:?}"),
                });
            }
        }
        let all_up = self
            .peers
            .iter()
            .all(|p| matches!(p.link_state(), State::Established { .. }));
        let timeout = self.cfg.connect_timeout_us;
        // Past the timeout, a start waits as long again while every bound
        // is within what the machine's path allows (`path_limit`, the limit
        // a moving run holds too); asked to (`start_late_clocks`), it starts
        // then, short of a target a busy computer keeps out of reach, and
        // says so.
        let overdue = now > started + timeout;
        if overdue {
            let within = all_up
                && self.peers.iter().all(|p| {
                    p.sync.error_bound(now as f64 + START_HORIZON_US) <= path_limit(&self.cfg, p)
                });
            if !within || now > started + 2 * timeout {
                return Err(self.not_ready(now));
            }
        }
        if !all_up {
            return Ok(());
        }
        if !self.check_rates()? {
            // A rate that looks out of range is measured further before
            // anything is configured (or refused by name).
            return Ok(());
        }
        if !self.configured {
            let setups = self.dist.stream_setup(&self.machine, &self.start_point);
            for (k, mut msgs) in setups.into_iter().enumerate() {
                msgs.push(HostMessage::Windowed {
                    run: self.identity.run,
                });
                for m in msgs {
                    self.peers[k].send_motion(&m);
                }
            }
            self.configured = true;
        }
        // Within the share of the target the exchanges keep while
        // streaming (the rest is for the model and a margin), and within
        // the target a while on with no exchange more: a slope still
        // unsure would carry the bound past it.
        let ready = self.peers.iter().all(|p| {
            let target = clock_target(&self.cfg, p);
            let later = p.sync.error_bound(now as f64 + START_HORIZON_US);
            let on_target =
                p.sync.error_bound(now as f64) <= EXCHANGE_AT * target && later <= target;
            let late_ok = overdue && self.may_start_late(p);
            (on_target || (late_ok && later <= path_limit(&self.cfg, p))) && p.backlog() == 0
        });
        // Nothing moves before every heater a node drives has reported.
        if ready && self.heaters_heard()? {
            if overdue {
                self.note_late_clocks(now, started);
            }
            let lead = self.lead_us();
            let t0 = now as f64 + 2.0 * lead as f64;
            // The stop horizon keeps a window's tail inside the node's queue;
            // this keeps the queue's segments long enough that the next seal,
            // a lead ahead, arrives before the tail would start, however
            // tiny the moves.
            let horizon = self.machine.limits().stop_horizon;
            let usable = self.capacity().saturating_sub(horizon).max(1);
            let min_move_s = lead as f64 * 1e-6 / usable as f64;
            if let Some(j) = self.journal.as_mut() {
                j.header(&JournalHeader {
                    run: self.identity.run,
                    machine: self.identity.machine,
                    job: self.identity.job,
                    t0,
                    min_move_s,
                    start: self.start_point,
                })?;
            }
            let commands = std::mem::take(&mut self.commands);
            let mut limits = run_limits(&self.machine, min_move_s);
            limits.max_move_s = self.cfg.max_move_us as f64 * 1e-6;
            let mut feed = PlanFeed::new(limits, self.start_point, t0, commands);
            if let Some((source, total)) = self.source.take() {
                feed = feed.reading(source, total);
            }
            if self.feed_open {
                feed.keep_open();
            }
            self.feed = Some(feed);
            self.feed_t0 = t0;
            self.phase = Phase::Streaming;
            self.fill(now)?;
        }
        Ok(())
    }

    fn ask_status(&mut self, now: u64) {
        if now >= self.next_status {
            for p in self.peers.iter_mut() {
                if matches!(p.link_state(), State::Established { .. }) && p.backlog() < 4 {
                    p.send_motion(&HostMessage::Status);
                }
            }
            self.next_status = now + self.cfg.status_interval_us;
        }
    }

    /// Every node at rest after the trajectory's end.
    fn finished(&self, now: u64) -> bool {
        now as f64 > self.committed_end + 20_000.0 && self.peers.iter().all(|p| p.backlog() == 0)
    }
}
