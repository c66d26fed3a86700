//! The run's clocks: exchanges with each node (or one sync frame for all
//! on a shared medium), the models sent, and each node's clock target.

use super::{NetConfig, NetError, NetRun, Phase};
use crate::peer::Peer;
use motet_wire::link::State;
use motet_wire::service::ServiceRequest;

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
            if p.sync.exchange_due(now, target, self.cfg.sync_interval_us) {
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
            if let Some(m) = p.sync.model_due(now, target, delay, at_rest) {
                p.send_service(&ServiceRequest::TimeSet {
                    offset: m.offset,
                    skew: m.skew,
                });
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
        // A crystal that leaves its range while the machine moves (a fault,
        // a clock source gone bad) stops it as it would refuse the start.
        // (Only a rate: a bound that grows, as an emulated board's does on
        // a loaded computer, is the estimate's doubt, not the node's fault.)
        if matches!(self.phase, Phase::Streaming | Phase::Draining) {
            if let Err(NetError::Node { node, message }) = self.check_rates() {
                self.stop(&format!("node {node}: {message}"), now);
            }
        }
        Ok(())
    }
}

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

/// The clock target of a node measured by reference samples, µs: its
/// model is replaced once a quarter of this off, so the node keeps within
/// about 2 µs of the host.
const REFERENCE_TARGET_US: f64 = 5.0;
