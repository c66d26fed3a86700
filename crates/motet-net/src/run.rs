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

use crate::digest::Digest;
use crate::journal::{JournalHeader, JournalSeal, JournalSegment, JournalStop, JournalWriter};
use crate::peer::{Incoming, Peer};
use crate::plan_feed::{run_limits, PlanFeed};
use crate::source::Sourced;
use motet_host::{Distributor, Machine};
use motet_planner::{Command, Located, PlanError, Planned, SourceLoc};
use motet_trajectory::{Point, Segment};
use motet_wire::link::State;
use motet_wire::service::{ServiceRequest, MAX_SKEW};
use motet_wire::{HostMessage, NodeMessage, Refusal};
use std::collections::VecDeque;

/// Clock exchanges µs apart until every node's clock is settled.
const SYNC_START_US: u64 = 20_000;

/// How long after a segment's end a node may still hold it, µs.
const RETIRE_SLACK_US: f64 = 50_000.0;

/// Stopping nodes are asked where they are µs apart.
const WHERE_INTERVAL_US: u64 = 100_000;

/// Settings of a networked run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NetConfig {
    /// Least time the committed window reaches ahead of now, µs (the run uses
    /// at least 2×RTT + 4×RTTVAR of the slowest link).
    pub lead_min_us: u64,
    /// A node silent this long is lost, µs.
    pub node_timeout_us: u64,
    /// Status requests to each node, µs apart.
    pub status_interval_us: u64,
    /// Clock exchanges with each node, µs apart.
    pub sync_interval_us: u64,
    /// Clock model updates sent to each node, µs apart.
    pub model_interval_us: u64,
    /// Give up connecting after this long, µs.
    pub connect_timeout_us: u64,
    /// How far past the lead a new window reaches, µs: longer windows mean
    /// fewer seals on the wire, shorter ones keep more of the trajectory
    /// editable.
    pub window_us: u64,
}

impl Default for NetConfig {
    fn default() -> Self {
        NetConfig {
            lead_min_us: 100_000,
            node_timeout_us: 1_500_000,
            status_interval_us: 5_000_000,
            sync_interval_us: 400_000,
            model_interval_us: 5_000_000,
            connect_timeout_us: 15_000_000,
            window_us: 1_000_000,
        }
    }
}

/// What identifies a run: a number the nodes keep while they hold its
/// trajectory, and the files it was made from. The journal starts with it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunIdentity {
    /// Never 0 (a node with no run reports 0).
    pub run: u32,
    pub machine: Digest,
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

#[derive(Debug, thiserror::Error)]
pub enum NetError {
    #[error("{loc}: {error}")]
    Plan { loc: SourceLoc, error: PlanError },
    #[error("node {node}: {message}")]
    Node { node: String, message: String },
    #[error("journal: {0}")]
    Journal(#[from] crate::journal::JournalError),
    #[error("node {node}: link: {source}")]
    Io {
        node: String,
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

/// A coordinated stop.
#[derive(Clone, Debug, PartialEq)]
pub struct StopInfo {
    pub reason: String,
    /// Segments before this index were committed; every node that kept
    /// running rests at the end of the one before it.
    pub window_end: u32,
    /// First segment the contingency tail slowed down.
    pub tail_start: u32,
    /// Segments every node had reported finished.
    pub done: u32,
    /// Where the nodes that kept running come to rest.
    pub point: Point,
    /// Host time at which the machine is at rest, µs.
    pub rest_time: f64,
    /// Machine nodes (indices) that stopped answering: where they are is
    /// not known, only that they got no further than the committed window.
    pub lost: Vec<LostNode>,
    /// Machine nodes that reported themselves at rest, each with the end
    /// of its committed window (`window_end`, unless it missed the last seal).
    pub confirmed: Vec<(usize, u32)>,
}

/// What a node's outputs did in a run (`NodeMessage::Tally`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tally {
    pub steps: [u32; 8],
    pub tool_changes: u32,
    pub hash: u64,
}

impl From<&motet_node::StepTally> for Tally {
    fn from(t: &motet_node::StepTally) -> Tally {
        Tally {
            steps: t.steps,
            tool_changes: t.tool_changes,
            hash: t.hash,
        }
    }
}

/// A node the host lost during a run.
#[derive(Clone, Debug, PartialEq)]
pub struct LostNode {
    pub node: usize,
    pub name: String,
    pub why: String,
}

impl StopInfo {
    /// Whether every node is known to rest at `point`.
    pub fn all_at_rest(&self) -> bool {
        self.lost.is_empty() && self.confirmed.iter().all(|&(_, e)| e == self.window_end)
    }
}

/// A sealed segment the host keeps until the machine is past it.
#[derive(Clone, Copy, Debug)]
struct Committed {
    index: u32,
    seg: Segment,
}

/// Per-node figures for the report.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PeerFigures {
    pub name: String,
    pub rtt_us: u64,
    pub retransmits: u64,
    pub crc_errors: u64,
    pub bytes_out: u64,
    pub bytes_in: u64,
    pub frames_out: u64,
    pub frames_in: u64,
    pub sync_error_us: f64,
    pub skew_ppm: f64,
    pub underruns: u32,
}

pub struct NetRun {
    machine: Machine,
    cfg: NetConfig,
    identity: RunIdentity,
    peers: Vec<Peer>,
    dist: Distributor,
    /// The job, until streaming starts and the feed takes it.
    commands: Vec<Located<Command>>,
    feed: Option<PlanFeed>,
    start_point: Point,
    /// Routed to the nodes but not sealed.
    pending: Vec<(Committed, usize)>,
    pending_events: usize,
    committed: VecDeque<Committed>,
    /// Every committed segment as run (tails included after a stop), for
    /// "where was the machine at time t".
    history: Vec<Segment>,
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
    model_sent: Vec<Option<u64>>,
    /// A model from the settled estimate went to the node.
    settled_sent: Vec<bool>,
    next_sync: u64,
    next_status: u64,
    /// When to ask the stopping nodes where they are next.
    next_where: u64,
    /// When the tallies were asked for, at the end.
    tally_asked: Option<u64>,
    /// Each node's answer: not yet, none kept, or its tally.
    tallies: Vec<Option<Option<Tally>>>,
    room_asked_at: Option<u64>,
    pub windows: u64,
    pub segments_sent: u64,
    pub pauses: u64,
    status: Vec<Option<NodeMessage>>,
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
        NetRun {
            machine: machine.clone(),
            cfg,
            identity: RunIdentity::default(),
            peers,
            dist: Distributor::new(machine),
            commands,
            feed: None,
            start_point: start,
            pending: Vec::new(),
            pending_events: 0,
            committed: VecDeque::new(),
            history: Vec::new(),
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
            model_sent: vec![None; n],
            settled_sent: vec![false; n],
            next_sync: 0,
            next_status: 0,
            next_where: 0,
            tally_asked: None,
            tallies: vec![None; n],
            room_asked_at: None,
            windows: 0,
            segments_sent: 0,
            pauses: 0,
            status: vec![None; n],
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

    pub fn identity(&self) -> &RunIdentity {
        &self.identity
    }

    pub fn phase(&self) -> &Phase {
        &self.phase
    }

    pub fn peers(&self) -> &[Peer] {
        &self.peers
    }

    /// Commands planned so far and in all.
    pub fn progress(&self) -> (usize, usize) {
        self.feed
            .as_ref()
            .map_or((0, self.commands.len()), |f| f.progress())
    }

    /// When the committed trajectory ends, µs.
    pub fn committed_end(&self) -> f64 {
        self.committed_end
    }

    /// Stops sealing: the nodes run their tails. Safe to call at any time.
    pub fn stop(&mut self, reason: &str, now: u64) {
        if matches!(
            self.phase,
            Phase::Stopping(_) | Phase::Stopped(_) | Phase::Done
        ) {
            return;
        }
        for p in self.peers.iter_mut() {
            p.drop_unsealed();
        }
        self.pending.clear();
        self.pending_events = 0;
        let point = self
            .committed
            .back()
            .map(|c| c.seg.end)
            .unwrap_or(self.start_point);
        // From here the nodes run the tail: so does the record.
        let n = self.committed.len().min(self.history.len());
        let from = self.history.len() - n;
        if let Ok(c) = motet_trajectory::contingency::Contingency::of(self.history[from..].iter()) {
            let mut walk = c.walk();
            for s in self.history[from + c.start..].iter_mut() {
                *s = walk.next(s);
            }
        }
        let rest_time = crate::tail::rest_time(self.committed.iter().map(|c| &c.seg), now as f64)
            .max(self.committed_end.min(now as f64));
        self.update_done();
        self.phase = Phase::Stopping(StopInfo {
            reason: reason.to_string(),
            window_end: self.next_index_committed(),
            tail_start: self.tail_start,
            done: self.done,
            point,
            rest_time,
            lost: self.lost.clone(),
            confirmed: Vec::new(),
        });
        self.next_where = now;
    }

    /// Node `k` stopped answering or its link failed: the run stops, and
    /// where that node is, nobody knows.
    fn lose(&mut self, k: usize, why: String, now: u64) {
        if self.lost.iter().any(|l| l.node == k) {
            return;
        }
        let name = self.peers[k].name.clone();
        self.lost.push(LostNode {
            node: k,
            name: name.clone(),
            why: why.clone(),
        });
        self.stop(&format!("node {name}: {why}"), now);
        if let Phase::Stopping(info) = &mut self.phase {
            info.lost = self.lost.clone();
            info.confirmed.retain(|&(c, _)| c != k);
        }
    }

    /// Segments every node that takes segments has reported finished, as
    /// far as their last statuses tell (never less than before).
    fn update_done(&mut self) {
        let reported = (0..self.peers.len())
            .filter(|&k| self.dist.next_seq(k).is_some())
            .map(|k| match self.status[k] {
                Some(NodeMessage::Status {
                    segment_space,
                    next_seq,
                    ..
                }) => {
                    let held =
                        (motet_node::DEFAULT_QUEUE as u32).saturating_sub(segment_space as u32);
                    next_seq.saturating_sub(held)
                }
                _ => 0,
            })
            .min()
            .unwrap_or(0);
        self.done = self.done.max(reported.min(self.next_index_committed()));
    }

    fn next_index_committed(&self) -> u32 {
        self.committed.back().map_or(0, |c| c.index + 1)
    }

    /// Least lead: the configured minimum or 2×RTT + 4×RTTVAR of the slowest link.
    pub fn lead_us(&self) -> u64 {
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
        self.take_replies(now)?;
        self.keep_time(now);
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
        t.min(self.next_sync.max(now))
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
                        let message = format!("refused a message: {reason:?}");
                        if matches!(self.phase, Phase::Starting) {
                            return Err(NetError::Node { node, message });
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
                            if ours && queued == 0 && !info.confirmed.iter().any(|c| c.0 == k) {
                                info.confirmed.push((k, committed));
                            }
                        }
                    }
                    Incoming::Service(_) => {}
                }
            }
        }
        Ok(())
    }

    /// Clock exchanges and model updates, in every phase.
    fn keep_time(&mut self, now: u64) {
        if now >= self.next_sync {
            for p in self.peers.iter_mut() {
                // A lost datagram is only a missing sample.
                let _ = p.send_time_get(now);
            }
            // Quick exchanges until every node's clock is settled, so a job
            // starts within seconds; then few, as they are most of the
            // traffic of a slow job. The fine estimator starts from a
            // measured skew, so the change of spacing does not bias it.
            let settled = self.peers.iter().all(|p| p.sync.settled());
            self.next_sync = now
                + if settled {
                    self.cfg.sync_interval_us
                } else {
                    self.cfg.sync_interval_us.min(SYNC_START_US)
                };
        }
        for (k, p) in self.peers.iter_mut().enumerate() {
            if !p.sync.synced() {
                continue;
            }
            // The settled model goes out at once; later ones every interval.
            let first_settled = p.sync.settled() && !self.settled_sent[k];
            let due = first_settled
                || self.model_sent[k].is_none_or(|t| now >= t + self.cfg.model_interval_us);
            if due && matches!(p.link_state(), State::Established { .. }) {
                let m = p.sync.model();
                p.send_service(&ServiceRequest::TimeSet {
                    offset: m.offset,
                    skew: m.skew,
                });
                self.model_sent[k] = Some(now);
                self.settled_sent[k] |= p.sync.settled();
            }
        }
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
        if now > started + self.cfg.connect_timeout_us {
            let p = self
                .peers
                .iter()
                .find(|p| !matches!(p.link_state(), State::Established { .. }) || !p.sync.synced());
            return Err(NetError::Node {
                node: p.map_or_else(|| "?".into(), |p| p.name.clone()),
                message: format!(
                    "no connection and clock sync after {:.1} s",
                    self.cfg.connect_timeout_us as f64 * 1e-6
                ),
            });
        }
        if !all_up {
            return Ok(());
        }
        // A node whose clock runs at another rate than any crystal would
        // was started with another --time-scale (or is broken): its
        // trajectory would run at the wrong speed.
        for p in &self.peers {
            let skew = p.sync.model().skew;
            if p.sync.settled() && skew.abs() >= MAX_SKEW {
                return Err(NetError::Node {
                    node: p.name.clone(),
                    message: format!(
                        "its clock runs {:.2}× as fast as the host's ({:+.0} ppm; a crystal is off by at most {:.0}): were the host and the node started with the same --time-scale?",
                        1.0 + skew,
                        skew * 1e6,
                        MAX_SKEW * 1e6
                    ),
                });
            }
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
        let ready = self
            .peers
            .iter()
            .enumerate()
            .all(|(k, p)| self.settled_sent[k] && p.backlog() == 0);
        if ready {
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
            let limits = run_limits(&self.machine, min_move_s);
            self.feed = Some(PlanFeed::new(limits, self.start_point, t0, commands));
            self.phase = Phase::Streaming;
            self.fill(now)?;
        }
        Ok(())
    }

    /// Node loss: silence longer than the timeout, or a failed link.
    fn watch(&mut self, now: u64) {
        let mut lost = None;
        for (k, p) in self.peers.iter().enumerate() {
            if self.lost.iter().any(|l| l.node == k) {
                continue;
            }
            if let State::Failed(e) = p.link_state() {
                lost = Some((k, format!("link failed ({e:?})")));
                break;
            }
            let silent = now.saturating_sub(p.last_heard.unwrap_or(now));
            if silent > self.cfg.node_timeout_us {
                lost = Some((
                    k,
                    format!("stopped answering ({} ms without a frame)", silent / 1000),
                ));
                break;
            }
        }
        if let Some((k, why)) = lost {
            self.lose(k, why, now);
        }
        self.ask_status(now);
    }

    /// While the nodes run their tails: ask each where it is until it says
    /// it is at rest on this run; one that does not say so in time is lost.
    fn settle(&mut self, now: u64) -> Result<(), NetError> {
        self.watch(now);
        let Phase::Stopping(info) = self.phase.clone() else {
            return Ok(());
        };
        let open: Vec<usize> = (0..self.peers.len())
            .filter(|k| {
                !info.confirmed.iter().any(|c| c.0 == *k) && !info.lost.iter().any(|l| l.node == *k)
            })
            .collect();
        if open.is_empty() {
            return self.stopped(info, now);
        }
        if now as f64 > info.rest_time + self.cfg.node_timeout_us as f64 {
            for k in open {
                self.lose(k, "did not report itself at rest".into(), now);
            }
            let Phase::Stopping(info) = self.phase.clone() else {
                return Ok(());
            };
            return self.stopped(info, now);
        }
        // Asked from the start: the answers also show the node is alive.
        if now >= self.next_where {
            for k in open {
                if matches!(self.peers[k].link_state(), State::Established { .. }) {
                    self.peers[k].send_motion(&HostMessage::Where);
                }
            }
            self.next_where = now + WHERE_INTERVAL_US;
        }
        Ok(())
    }

    fn stopped(&mut self, info: StopInfo, now: u64) -> Result<(), NetError> {
        if let Some(j) = self.journal.as_mut() {
            j.stop(&JournalStop {
                seal: JournalSeal {
                    end: info.window_end,
                    tail: info.tail_start,
                    done: info.done,
                    time: now,
                },
                lost: info.lost.iter().map(|l| l.node).collect(),
            })?;
        }
        self.phase = Phase::Stopped(info);
        Ok(())
    }

    /// Asks every node that takes segments for its status, at most once per
    /// round trip.
    fn ask_room(&mut self, now: u64) {
        let rtt = self
            .peers
            .iter()
            .map(|p| p.link().stats().srtt_us)
            .max()
            .unwrap_or(0);
        if self.room_asked_at.is_some_and(|t| now < t + rtt.max(1_000)) {
            return;
        }
        self.room_asked_at = Some(now);
        for k in 0..self.peers.len() {
            if self.dist.next_seq(k).is_some() {
                self.peers[k].send_motion(&HostMessage::Status);
            }
        }
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

    /// At the end: what each node's outputs did, for the report; done once
    /// every node answered (or after the node timeout: a report without it).
    fn collect_tallies(&mut self, now: u64) {
        let asked = *self.tally_asked.get_or_insert_with(|| {
            for p in self.peers.iter_mut() {
                p.send_motion(&HostMessage::TallyGet);
            }
            now
        });
        if self.tallies.iter().all(Option::is_some) || now > asked + self.cfg.node_timeout_us {
            self.phase = Phase::Done;
        }
    }

    /// What each node's outputs did in the run, if it said (after `Done`).
    pub fn tallies(&self) -> Vec<Option<Tally>> {
        self.tallies.iter().map(|t| t.flatten()).collect()
    }

    /// Every node at rest after the trajectory's end.
    fn finished(&self, now: u64) -> bool {
        now as f64 > self.committed_end + 20_000.0 && self.peers.iter().all(|p| p.backlog() == 0)
    }

    /// Segments a node holds (committed and not yet run, and pending).
    fn queued_on_nodes(&self, now: u64) -> usize {
        // A place frees when the node retires a segment, a little after its
        // end on the host's clock (the node's clock and polling lag). The
        // node's own count (its status, sent with every seal's
        // acknowledgement) is exact but dated; the host's clock is current
        // but a guess. A segment is taken as retired when either says so,
        // the clock only well after the segment's end.
        let t = now as f64 - RETIRE_SLACK_US;
        let sent = self.next_index;
        let by_time = self
            .committed
            .iter()
            .find(|c| c.seg.t1() > t)
            .map_or(sent - self.pending.len() as u32, |c| c.index);
        let by_status = (0..self.peers.len())
            .filter(|&k| self.dist.next_seq(k).is_some())
            .filter_map(|k| match self.status[k] {
                Some(NodeMessage::Status {
                    segment_space,
                    next_seq,
                    ..
                }) => {
                    let held =
                        (motet_node::DEFAULT_QUEUE as u32).saturating_sub(segment_space as u32);
                    Some(next_seq.saturating_sub(held))
                }
                _ => None,
            })
            .min();
        let retired = by_status.map_or(by_time, |s| s.max(by_time)).min(sent);
        (sent - retired) as usize
    }

    fn capacity(&self) -> usize {
        self.machine
            .nodes
            .iter()
            .map(|n| n.queue)
            .min()
            .unwrap_or(64)
            .saturating_sub(2)
            .max(2)
    }

    /// Seals windows until the committed trajectory reaches far enough ahead.
    fn fill(&mut self, now: u64) -> Result<(), NetError> {
        let lead = self.lead_us() as f64;
        let t = now as f64;
        // Forget what the machine is well past.
        while self.committed.len() > 1 && self.committed[0].seg.t1() < t - 1e6 {
            self.committed.pop_front();
        }
        while self.deadline < t + lead {
            // One seal in flight at a time: a node that missed a seal can then
            // differ from the others by at most that one window.
            if self.peers.iter().any(|p| p.seal_in_flight()) {
                break;
            }
            let grew = self.grow(t + lead + self.cfg.window_us as f64, now)?;
            if self.pending.is_empty() && self.pending_events == 0 {
                if !grew && self.feed.as_ref().is_some_and(|f| f.exhausted()) {
                    self.phase = Phase::Draining;
                }
                break;
            }
            self.seal(now)?;
        }
        Ok(())
    }

    /// Routes planned items into the pending window until its tail would start
    /// at or after `target`, the queue is full, or the job is planned out.
    fn grow(&mut self, target: f64, now: u64) -> Result<bool, NetError> {
        let mut grew = false;
        loop {
            if self.queued_on_nodes(now) >= self.capacity() {
                // Full as far as the host knows: ask the nodes how full.
                self.ask_room(now);
                break;
            }
            let Some(item) = self.next_item()? else {
                break;
            };
            grew = true;
            match item.item {
                Planned::Segment(seg) => {
                    let c = Committed {
                        index: self.next_index,
                        seg,
                    };
                    self.next_index += 1;
                    self.route(&item.item)?;
                    self.pending.push((c, item.command));
                    self.segments_sent += 1;
                    let (start, _) = crate::tail::deadline(
                        self.committed
                            .iter()
                            .map(|c| &c.seg)
                            .chain(self.pending.iter().map(|(c, _)| &c.seg)),
                    );
                    if start >= target && self.pending.len() >= 2 {
                        break;
                    }
                }
                Planned::Event(_) => {
                    self.route(&item.item)?;
                    // Held on the nodes like segments until the seal.
                    self.pending_events += 1;
                }
                Planned::Pause { .. } => {
                    self.route(&item.item)?;
                    self.pauses += 1;
                }
                Planned::Aux(_) => self.route(&item.item)?,
            }
        }
        Ok(grew)
    }

    /// Sends `item` (quantized) to every node that reads it; segments go out
    /// in batches.
    fn route(&mut self, item: &Planned) -> Result<(), NetError> {
        for k in 0..self.peers.len() {
            let out = self
                .dist
                .route_batched(k, item)
                .map_err(|e| NetError::Node {
                    node: self.peers[k].name.clone(),
                    message: format!("segment stream: {e:?}"),
                })?;
            for o in out {
                self.peers[k].send_motion(&o.message);
            }
        }
        Ok(())
    }

    /// The next planned item, planning more commands as needed.
    fn next_item(&mut self) -> Result<Option<Sourced>, NetError> {
        let Some(feed) = self.feed.as_mut() else {
            return Ok(None);
        };
        feed.next(&mut self.dist)
            .map_err(|(loc, error)| NetError::Plan { loc, error })
    }

    /// Commits the pending window on every node.
    fn seal(&mut self, now: u64) -> Result<(), NetError> {
        let pending = std::mem::take(&mut self.pending);
        self.pending_events = 0;
        if let Some(j) = self.journal.as_mut() {
            for (c, command) in &pending {
                j.segment(&JournalSegment {
                    index: c.index,
                    command: *command,
                    t0: c.seg.t0,
                    t1: c.seg.t1(),
                    start: c.seg.start,
                    end: c.seg.end,
                })?;
            }
        }
        for (c, _) in &pending {
            self.committed.push_back(*c);
            self.history.push(c.seg);
            self.committed_end = c.seg.t1();
        }
        let segs: Vec<&Segment> = self.committed.iter().map(|c| &c.seg).collect();
        let (deadline, tail_pos) = crate::tail::deadline(segs.iter().copied());
        self.deadline = deadline;
        self.tail_start = self.committed.front().map_or(0, |c| c.index) + tail_pos as u32;
        let end = self.next_index_committed();
        self.update_done();
        if let Some(j) = self.journal.as_mut() {
            j.seal(JournalSeal {
                end,
                tail: self.tail_start,
                done: self.done,
                time: now,
            })?;
        }
        for k in 0..self.peers.len() {
            if let Some(o) = self.dist.flush(k) {
                self.peers[k].send_motion(&o.message);
            }
            if let Some(next_seq) = self.dist.next_seq(k) {
                self.peers[k].send_motion(&HostMessage::Seal { next_seq });
            }
        }
        self.windows += 1;
        Ok(())
    }

    /// Figures for the report.
    pub fn figures(&self, now: u64) -> Vec<PeerFigures> {
        self.peers
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let t = p.transport().stats();
                let l = p.link().stats();
                let underruns = match self.status[k] {
                    Some(NodeMessage::Status { underruns, .. }) => underruns,
                    _ => 0,
                };
                PeerFigures {
                    name: p.name.clone(),
                    rtt_us: l.srtt_us,
                    retransmits: l.retransmits,
                    crc_errors: l.crc_errors,
                    bytes_out: t.bytes_out,
                    bytes_in: t.bytes_in,
                    frames_out: t.frames_out,
                    frames_in: t.frames_in,
                    sync_error_us: p.sync.error_estimate(now as f64),
                    skew_ppm: p.sync.model().skew * 1e6,
                    underruns,
                }
            })
            .collect()
    }

    /// Where the machine was (or will be, within the committed window) at
    /// host time `t`, µs: on the committed trajectory, with the tail after a
    /// stop, at rest between segments and after the last.
    pub fn position_at(&self, t: f64) -> Point {
        let i = self.history.partition_point(|s| s.t0 <= t);
        match i.checked_sub(1).map(|i| &self.history[i]) {
            None => self.start_point,
            Some(s) if t < s.t1() => s.position_at(t),
            Some(s) => s.end,
        }
    }

    /// The committed segments the host still keeps, with their indices.
    pub fn committed(&self) -> impl Iterator<Item = (u32, &Segment)> {
        self.committed.iter().map(|c| (c.index, &c.seg))
    }

    /// The last status each node sent.
    pub fn node_status(&self, k: usize) -> Option<&NodeMessage> {
        self.status[k].as_ref()
    }
}
