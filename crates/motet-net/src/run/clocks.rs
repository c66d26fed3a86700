//! The run's clocks: exchanges with each node (or one sync frame for all
//! on a shared medium), the models sent, each node's clock target, and
//! the checks that hold a start (or stop a run) for a clock.

use super::{NetConfig, NetError, NetRun, Phase};
use crate::node_clock::{EXCHANGE_AT, MAX_CRYSTAL};
use crate::peer::Peer;
use motet_wire::link::State;
use motet_wire::service::MAX_SKEW;

impl NetRun {
    /// Clock exchanges (also the heartbeat of a quiet node) and models,
    /// in every phase; a node whose clock answered nonsense is refused.
    pub(super) fn keep_time(&mut self, now: u64) -> Result<(), NetError> {
        let at_rest = matches!(self.phase, Phase::Starting);
        // A node not heard for two thirds of its timeout is asked, and
        // asked again every tenth of that (see `NodeClock::probe_after`);
        // while windows flow, a seal asks first (`NetRun::quiet_node`).
        let quiet = self.quiet_us();
        let mut fault = None;
        // On a shared medium one sync frame serves every node.
        let shared = self.group.is_some() && self.cfg.sync_to_all;
        let mut to_all = false;
        for p in self.peers.iter_mut() {
            let target = clock_target(&self.cfg, p);
            p.sync.probe_after(p.last_heard, p.last_asked, quiet);
            // Exchanges under jitter need as many as the link carries;
            // reference samples do not (each is exact), and on a bus each
            // sync frame costs every node an answer.
            if p.references == 0 {
                p.sync.set_link_rtt(p.link().stats().min_rtt_us);
            }
            let hurry = at_rest && p.references == 0;
            if p.sync
                .exchange_due(now, target, self.cfg.sync_interval_us, hurry)
            {
                // A lost datagram is only a missing sample.
                if shared {
                    to_all = true;
                } else {
                    let _ = p.send_time_get(now);
                }
            }
            if let Some(f) = p.sync.fault() {
                fault.get_or_insert((p.name.clone(), f));
                continue;
            }
            if !matches!(p.link_state(), State::Established { .. }) {
                continue;
            }
            // The model reaches the node about half a round trip later.
            let delay = 0.5 * p.link().stats().srtt_us as f64;
            if let Some(m) = p
                .sync
                .model_due(now, model_tolerance(target, p), delay, at_rest)
            {
                p.send_clock_model(m);
            }
        }
        if to_all {
            self.sync_all(now);
        }
        if let Some((node, f)) = fault {
            let message = format!("its clock cannot be trusted: {f}; nothing moves on it");
            if at_rest {
                return Err(NetError::Node { node, message });
            }
            self.stop(&format!("node {node}: {message}"), now);
        }
        // A clock gone bad while the machine moves stops it, as it would
        // refuse the start.
        if matches!(self.phase, Phase::Streaming | Phase::Draining) {
            if let Err(NetError::Node { node, message }) = self.check_moving(now) {
                self.stop(&format!("node {node}: {message}"), now);
            }
        }
        Ok(())
    }

    /// The clocks of a moving machine, judged only on what the host knows
    /// surely: a rate out of a crystal's range, a rate that stepped further
    /// than a crystal drifts (hard limits both, which a host's or a node's
    /// late stamps only widen), or a node known to run far off the host's
    /// time. An estimate in doubt (an emulated board on a loaded computer
    /// wanders, a busy path delays) is said once, not stopped on: the
    /// machine may be right where it should be.
    fn check_moving(&mut self, now: u64) -> Result<(), NetError> {
        self.check_rates()?;
        let h = now as f64;
        for (k, p) in self.peers.iter().enumerate() {
            if self.lost.iter().any(|l| l.node == k) {
                continue;
            }
            let node = p.name.clone();
            if let Some(((blo, bhi), (alo, ahi))) = p.sync.rate_step() {
                let gap = (alo - bhi).max(blo - ahi);
                if gap > MAX_RATE_STEP {
                    let message = format!(
                        "its clock's rate jumped from {:+.0} to {:+.0} ppm off the host's (every exchange since allows {:+.0} to {:+.0}, at least {:.0} ppm from before); a crystal drifts but does not jump so: its clock source is failing, and nothing moves on it",
                        0.5 * (blo + bhi) * 1e6,
                        now_rate(p.sync.model().skew, (alo, ahi)) * 1e6,
                        alo * 1e6,
                        ahi * 1e6,
                        gap * 1e6
                    );
                    return Err(NetError::Node { node, message });
                }
            }
            let limit = path_limit(&self.cfg, p);
            if let Some((off, sure)) = p.sync.model_off(h) {
                if off > limit && sure < 0.25 * limit {
                    let message = format!(
                        "its clock ran {off:.0} µs off the host's time (known to ±{sure:.1} µs), beyond the {limit:.0} µs the machine's path allows; nothing moves on it"
                    );
                    return Err(NetError::Node { node, message });
                }
            }
        }
        // Doubt, said once a node.
        for k in 0..self.peers.len() {
            let p = &self.peers[k];
            let limit = path_limit(&self.cfg, p);
            let bound = p.sync.error_bound(h);
            if bound.is_finite() && bound > limit && !self.doubted.contains(&k) {
                let note = format!(
                    "node {}: its clock is known only to ±{bound:.0} µs (its exchanges are late or its rate wanders); the run goes on, as nothing says the node is off",
                    p.name
                );
                self.doubted.push(k);
                self.pace.note(note);
            }
        }
        Ok(())
    }
}

/// The rate a clock runs at now, for the person: the estimate's, when
/// the exchanges since the change allow it, else the middle of what they
/// allow.
fn now_rate(estimate: f64, (lo, hi): (f64, f64)) -> f64 {
    if (lo..=hi).contains(&estimate) {
        estimate
    } else {
        0.5 * (lo + hi)
    }
}

/// A rate step beyond this between the exchanges before a change and
/// those after, surely, is a clock source gone bad: a crystal's rate moves
/// by a few ppm with its temperature, a board swapped or a failing
/// oscillator by far more.
pub(super) const MAX_RATE_STEP: f64 = 100e-6;
/// A node known to run this many times its clock target off the host's
/// time stops the run ...
const OFF_TARGETS: f64 = 100.0;
/// ... and never for less than this, µs.
const OFF_MIN_US: f64 = 1_000.0;

impl NetRun {
    /// How long a node may stay silent before it is asked to speak, µs:
    /// two thirds of its timeout, which leaves time to ask again.
    pub(super) fn quiet_us(&self) -> u64 {
        self.cfg.node_timeout_us * 2 / 3
    }

    /// Some node that takes segments has been neither heard nor asked for
    /// nearly [`NetRun::quiet_us`]: sealing a window now asks it (its
    /// status comes back) before a clock exchange would, which costs frames
    /// of its own. (On a
    /// shared medium every member's heartbeat says it is there.)
    pub(super) fn quiet_node(&self, now: u64) -> bool {
        if self.group.is_some() {
            return false;
        }
        let quiet = self.quiet_us() * 9 / 10;
        self.peers.iter().enumerate().any(|(k, p)| {
            self.dist.next_seq(k).is_some()
                && p.last_heard
                    .max(p.last_asked)
                    .is_some_and(|t| now >= t + quiet)
        })
    }
}

/// A node's clock target, µs: the run's, or a quarter of the link's
/// least round trip on a slow link (a serial line's byte times bound
/// what its timestamps can tell). A node whose clock is measured by
/// reference samples (a sync frame on a bus) is held to
/// [`REFERENCE_TARGET_US`] at most: they can tell that much.
pub(super) fn clock_target(cfg: &NetConfig, p: &Peer) -> f64 {
    if p.references > 0 {
        return cfg.clock_bound_us.min(REFERENCE_TARGET_US);
    }
    let rtt = p.sync.min_rtt();
    let slow = if rtt.is_finite() { 0.25 * rtt } else { 0.0 };
    cfg.clock_bound_us.max(slow)
}

/// The clock target of a node measured by reference samples, µs: they
/// tell that much.
const REFERENCE_TARGET_US: f64 = 6.0;

/// How far the model a node runs may be from the estimate before a new
/// one goes out, µs: a quarter of its target, and at most
/// [`REFERENCE_MODEL_US`] for a node measured by reference samples.
fn model_tolerance(target: f64, p: &Peer) -> f64 {
    let quarter = 0.25 * target;
    if p.references > 0 {
        quarter.min(REFERENCE_MODEL_US)
    } else {
        quarter
    }
}

/// A node measured by reference samples runs a model within this of the
/// estimate, µs: their estimates are within about as much of the truth,
/// so any two such nodes keep within about 2 µs of each other.
const REFERENCE_MODEL_US: f64 = 0.5;

/// The most a node's clock may be off (or known to) while the machine
/// moves, µs: far beyond its target, and at least [`OFF_MIN_US`].
pub(super) fn path_limit(cfg: &NetConfig, p: &Peer) -> f64 {
    (OFF_TARGETS * clock_target(cfg, p)).max(OFF_MIN_US)
}

impl NetRun {
    /// Whether node `p` may start short of its clock target once the
    /// connect timeout passed (within what the machine's path allows):
    /// when asked to (`start_late_clocks`), or when it is the only node
    /// that moves or drives a tool. Its clock then sets no two nodes apart:
    /// an error far below the lead only shifts when the job happens, not
    /// the path. (On a serial line, or on a computer busy enough to delay
    /// exchanges, a bound stays near half the least round trip or more,
    /// above the quarter its target asks.)
    pub(super) fn may_start_late(&self, p: &Peer) -> bool {
        self.cfg.start_late_clocks || self.lone_mover(&p.name)
    }

    /// Whether the node named `name` is the machine's only node with
    /// actuators or tools.
    fn lone_mover(&self, name: &str) -> bool {
        let moves =
            |n: &motet_host::machine::NodeSpec| !n.actuators.is_empty() || !n.tools.is_empty();
        let mut movers = self.machine.nodes.iter().filter(|n| moves(n));
        matches!((movers.next(), movers.next()), (Some(n), None) if n.name == name)
    }

    /// A start past the timeout: each node whose clock is known less well
    /// than its target, said once.
    pub(super) fn note_late_clocks(&mut self, now: u64, started: u64) {
        let secs = now.saturating_sub(started) as f64 * 1e-6;
        for k in 0..self.peers.len() {
            let p = &self.peers[k];
            let target = clock_target(&self.cfg, p);
            let bound = p.sync.error_bound(now as f64);
            if bound > EXCHANGE_AT * target {
                let why = if self.cfg.start_late_clocks {
                    "the machine's path allows"
                } else {
                    "no other node moves with it, and the machine's path allows"
                };
                let note = format!(
                    "node {}: its clock is known to ±{bound:.1} µs after {secs:.1} s, short of its ±{target:.0} µs target (a busy computer or a slow link makes its exchanges late); the run starts, as {why} ±{:.0} µs",
                    p.name,
                    path_limit(&self.cfg, p)
                );
                self.doubted.push(k);
                self.pace.note(note);
            }
        }
    }

    /// Why the run could not start in time: the first node without a link,
    /// or whose clock is not yet known well enough.
    pub(super) fn not_ready(&self, now: u64) -> NetError {
        let secs = now.saturating_sub(self.started_at.unwrap_or(0)) as f64 * 1e-6;
        for p in &self.peers {
            let node = p.name.clone();
            if !matches!(p.link_state(), State::Established { .. }) {
                let message = format!("no connection after {secs:.1} s");
                return NetError::Node { node, message };
            }
            let bound = p.sync.error_bound(now as f64);
            let target = clock_target(&self.cfg, p);
            let skew = p.sync.model().skew;
            if p.sync.synced() && skew.abs() - p.sync.skew_bound() > MAX_CRYSTAL {
                let message = format!(
                    "its clock seems to run {:+.0} ppm off the host's, beyond a crystal's ±{:.0} ppm, but its exchanges after {secs:.1} s do not make that sure ({} kept, least round trip {:.0} µs); nothing moves on it",
                    skew * 1e6,
                    MAX_CRYSTAL * 1e6,
                    p.sync.points(),
                    p.sync.min_rtt(),
                );
                return NetError::Node { node, message };
            }
            // The start's own test: within its share of the target now,
            // and within the target a while on with no exchange more.
            let later = p.sync.error_bound(now as f64 + super::START_HORIZON_US);
            if bound > crate::node_clock::EXCHANGE_AT * target || later > target {
                let bound = bound.max(later);
                let (taken, dropped) = p.sync.counts();
                let message = format!(
                    "its clock is known to ±{bound:.1} µs after {secs:.1} s ({} exchanges kept of {taken}, {dropped} too slow, least round trip {:.0} µs, {} rate changes); nothing moves before it is within ±{:.0} µs (a computer too busy for that: `--start-late-clocks` starts within what the machine's path allows)",
                    p.sync.points(),
                    p.sync.min_rtt(),
                    p.sync.changes(),
                    target
                );
                return NetError::Node { node, message };
            }
        }
        NetError::Node {
            node: "?".into(),
            message: format!("not configured after {secs:.1} s"),
        }
    }

    /// Refuses a node whose clock runs at a rate no crystal has: started
    /// with another --time-scale, or broken. The estimate points at such a
    /// node (its rate beyond the range by more than its slope's bound), but
    /// that bound is a statistic a busy host's bursts of late exchanges can
    /// fool; a node is refused only when every rate its exchanges allow is
    /// out of range ([`ClockSync::feasible_skew`]: hard limits, which
    /// delays only widen). `Ok(false)`: some node looks out of range but is
    /// not surely so yet (a start waits for more exchanges).
    ///
    /// [`ClockSync::feasible_skew`]: motet_wire::sync::ClockSync::feasible_skew
    pub(super) fn check_rates(&self) -> Result<bool, NetError> {
        let mut clear = true;
        for p in &self.peers {
            if !p.sync.synced() {
                continue;
            }
            let skew = p.sync.model().skew;
            if skew.abs() - p.sync.skew_bound() <= MAX_CRYSTAL {
                continue;
            }
            // The least |rate| the exchanges allow.
            let surely = match p.sync.feasible_skew() {
                Some((lo, _)) if lo > 0.0 => lo,
                Some((_, hi)) if hi < 0.0 => -hi,
                _ => 0.0,
            };
            let node = p.name.clone();
            if surely >= MAX_SKEW {
                return Err(NetError::Node {
                    node,
                    message: format!(
                        "its clock runs {:.2}× as fast as the host's ({:+.0} ppm): were the host and the node started with the same --time-scale?",
                        1.0 + skew,
                        skew * 1e6,
                    ),
                });
            }
            if surely > MAX_CRYSTAL {
                return Err(NetError::Node {
                    node,
                    message: format!(
                        "its clock runs {:+.0} ppm off the host's (at least {:.0} ppm, by every exchange); a crystal is within ±{:.0} ppm, so nothing moves on it",
                        skew * 1e6,
                        surely * 1e6,
                        MAX_CRYSTAL * 1e6
                    ),
                });
            }
            clear = false;
        }
        Ok(clear)
    }
}
