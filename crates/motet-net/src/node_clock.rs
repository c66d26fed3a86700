//! One node's clock as the host knows it: the estimate from the exchanges
//! (`motet_wire::sync`), the model the node runs (the last one sent), when
//! to exchange next, and when the node needs a new model.
//!
//! Two rules keep the node's time trustworthy:
//! - **Slew, never step.** A correction larger than a clock tick goes out as
//!   a model that agrees with the node's current one where the node will
//!   take it and reaches the estimate over a while, [`SLEW_RATE`] faster
//!   or slower (a correction larger than a second of that within about a
//!   second, at most [`MAX_SLEW_RATE`]); the exact model follows once it
//!   has. The node's time stays monotone and never jumps while it moves.
//! - **As few exchanges as the bound allows.** While the bound is above 70 %
//!   of the target the host exchanges every [`FAST_US`] (four round trips
//!   on a quicker link, at least [`FAST_MIN_US`]); then it exchanges
//!   when the slope's uncertainty would carry the bound there, at
//!   most [`crate::NetConfig::sync_interval_us`] apart. With a steady
//!   crystal the slope's uncertainty keeps falling, and so does the rate.

use motet_wire::sync::{ClockFault, ClockModel, ClockSync, Exchange, SyncConfig};
use std::collections::VecDeque;

/// The most a crystal is off, with its temperature and age: a node whose
/// clock runs further off the host's is refused.
pub const MAX_CRYSTAL: f64 = 500e-6;
/// The estimate's bound is kept within this share of the target: the rest
/// is for the model the node runs, replaced when off by a quarter, and a
/// margin, so the node's bound stays within the target.
pub const EXCHANGE_AT: f64 = 0.7;
/// Exchanges at most this far apart while the estimate is not yet good
/// enough, µs ...
pub const FAST_US: u64 = 10_000;
/// ... and this close on a quick link (four round trips apart): under
/// jitter a bound falls with the number of exchanges, so a fast link
/// starts sooner.
pub const FAST_MIN_US: u64 = 1_000;
/// How much faster or slower than its estimate a node's clock runs while a
/// correction is taken up: a drift's corrections are far below a step's
/// length.
pub const SLEW_RATE: f64 = 50e-6;
/// A correction is taken up within this long when [`SLEW_RATE`] would take
/// longer, µs: a node off by much (its rate changed) comes back soon, its
/// moves this much faster or slower meanwhile.
const MAX_SLEW_US: f64 = 1_000_000.0;
/// The fastest a node's clock is slewed: 0.1 % (a node found 2 ms off takes
/// 2 s).
pub const MAX_SLEW_RATE: f64 = 1e-3;
/// A correction this small is sent as it is: below a clock tick.
const STEP_US: f64 = 0.5;
/// The shortest slew, µs: a correction is spread over at least this long.
const MIN_SLEW_US: f64 = 20_000.0;
/// How far ahead the model the node runs is checked against the estimate,
/// µs: a model that will be off by then is replaced now.
const LOOKAHEAD_US: f64 = 100_000.0;

/// Models kept that a node may still run ([`NodeClock::error_bound`]):
/// far more than a link has in flight.
const MAYBE_KEPT: usize = 32;

/// A node's clock as the host knows it.
#[derive(Clone, Debug)]
pub struct NodeClock {
    est: ClockSync,
    /// The model the node runs (the last one sent), if any.
    sent: Option<ClockModel>,
    /// Models the node may still run instead, while the link has not yet
    /// acknowledged the later ones (oldest first): the last acknowledged
    /// and each one sent after it but the newest.
    maybe: VecDeque<ClockModel>,
    /// Models sent and not yet acknowledged.
    unacked: usize,
    /// Until when (host µs) the model sent is a slew, not the estimate.
    slewing_until: Option<f64>,
    fault: Option<ClockFault>,
    /// When to exchange next, host µs.
    next_exchange: u64,
    /// When the exchanges' own pace puts the next one, host µs (a probe of
    /// a quiet node may come sooner).
    planned: u64,
    /// When the last exchange went out, host µs.
    last_sent: Option<u64>,
    /// Models sent, and how many of them slewed.
    pub models_sent: (u64, u64),
    /// How far apart exchanges go while the bound is above its share of
    /// the target, µs ([`NodeClock::set_link_rtt`]).
    fast_us: u64,
    /// The last [`NodeClock::rate_step`], and the exchange counts it was
    /// computed at.
    rate_step_seen: std::cell::Cell<Option<RateStepSeen>>,
}

/// The estimate's counts (taken, dropped; changes) and its rate step then.
type RateStepSeen = (((u64, u64), u32), Option<((f64, f64), (f64, f64))>);

impl Default for NodeClock {
    fn default() -> Self {
        NodeClock {
            est: ClockSync::new(SyncConfig::default()),
            sent: None,
            maybe: VecDeque::new(),
            unacked: 0,
            slewing_until: None,
            fault: None,
            next_exchange: 0,
            planned: 0,
            last_sent: None,
            rate_step_seen: std::cell::Cell::new(None),
            models_sent: (0, 0),
            fast_us: FAST_US,
        }
    }
}

impl NodeClock {
    /// Takes one clock exchange. An exchange no working clock produces is
    /// kept as the node's fault (see [`NodeClock::fault`]).
    pub fn add(&mut self, e: Exchange) {
        if self.fault.is_some() {
            return;
        }
        let changes = self.est.changes();
        if let Err(f) = self.est.add(e) {
            self.fault = Some(f);
        }
        if self.est.changes() > changes {
            // The node's rate changed: the estimate starts again, and its
            // exchanges are fast again at once, not at the rare time the
            // old estimate had planned.
            self.next_exchange = self.next_exchange.min(e.t4 + self.fast_us);
            self.planned = self.planned.min(self.next_exchange);
        }
    }

    /// The link's least round trip, µs (0: none measured yet): fast
    /// exchanges go four of them apart, within [`FAST_MIN_US`] and
    /// [`FAST_US`] (a jittered path's least round trip is what it can
    /// carry; its mean is the jitter).
    pub fn set_link_rtt(&mut self, min_rtt_us: u64) {
        self.fast_us = if min_rtt_us == 0 {
            FAST_US
        } else {
            (4 * min_rtt_us).clamp(FAST_MIN_US, FAST_US)
        };
    }

    /// The node answered an exchange no working clock produces: nothing may
    /// move on its clock.
    pub fn fault(&self) -> Option<ClockFault> {
        self.fault
    }

    /// The estimate rests on data.
    pub fn synced(&self) -> bool {
        self.est.synced()
    }

    /// The estimated model: `local = offset + (1 + skew) · host`.
    pub fn model(&self) -> ClockModel {
        self.est.model()
    }

    /// How far the estimate's skew may be off.
    pub fn skew_bound(&self) -> f64 {
        self.est.skew_bound()
    }

    /// Least round trip seen, µs.
    pub fn min_rtt(&self) -> f64 {
        self.est.min_rtt()
    }

    /// The skews every kept exchange allows (hard limits; see
    /// [`ClockSync::feasible_skew`]).
    pub fn feasible_skew(&self) -> Option<(f64, f64)> {
        self.est.feasible_skew()
    }

    /// A step of the node's rate at its last change (see
    /// [`ClockSync::rate_step`]).
    /// Computed again only when an exchange came since: it costs the square
    /// of the exchanges kept, and a moving run asks on every poll.
    pub fn rate_step(&self) -> Option<((f64, f64), (f64, f64))> {
        let key = (self.est.counts(), self.est.changes());
        if let Some((k, step)) = self.rate_step_seen.get() {
            if k == key {
                return step;
            }
        }
        let step = self.est.rate_step();
        self.rate_step_seen.set(Some((key, step)));
        step
    }

    /// How far the model the node runs is from the estimate at host time
    /// `host`, µs, and how sure the estimate is (its own bound): a large
    /// offset known surely is a node off the host's time, not a host in
    /// doubt.
    pub fn model_off(&self, host: f64) -> Option<(f64, f64)> {
        let m = self.sent?;
        let off = (m.local(host) - self.est.host_to_local(host)).abs();
        Some((off, self.est.error_bound(host)))
    }

    /// Exchanges the estimate rests on.
    pub fn points(&self) -> u32 {
        self.est.points()
    }

    /// Exchanges taken and those dropped as too slow.
    pub fn counts(&self) -> (u64, u64) {
        self.est.counts()
    }

    /// Changes of the node's rate the estimate found (each a fit started
    /// again).
    pub fn changes(&self) -> u32 {
        self.est.changes()
    }

    /// A bound on the node's own error at host time `host`: how far the
    /// model it runs is from the estimate, plus the estimate's bound, µs;
    /// infinite while it runs none or the host knows too little.
    /// Until the link acknowledged the last model sent, the node may run
    /// any since the last acknowledged one: the farthest counts.
    pub fn error_bound(&self, host: f64) -> f64 {
        match self.sent {
            Some(m) if self.fault.is_none() => {
                let est = self.est.host_to_local(host);
                let off = self.maybe.iter().fold((m.local(host) - est).abs(), |o, k| {
                    o.max((k.local(host) - est).abs())
                });
                off + self.est.error_bound(host)
            }
            _ => f64::INFINITY,
        }
    }

    /// Models sent that the link has not yet acknowledged.
    pub fn models_unacknowledged(&self) -> usize {
        self.unacked
    }

    /// The link acknowledged the oldest model not yet acknowledged: the
    /// node runs it or a later one.
    pub fn model_delivered(&mut self) {
        if self.unacked == 0 {
            return;
        }
        if self.maybe.len() == self.unacked {
            self.maybe.pop_front();
        }
        self.unacked -= 1;
    }

    /// Whether an exchange is due at host time `now`; if so, plans the next
    /// one: fast while the estimate's bound is above 70 % of `target_us`, then
    /// as late as the slope's uncertainty allows, at most `max_us` later.
    pub fn exchange_due(&mut self, now: u64, target_us: f64, max_us: u64, hurry: bool) -> bool {
        if now < self.next_exchange {
            return false;
        }
        self.exchanged(now, target_us, max_us, hurry);
        true
    }

    /// An exchange went out at `now` (one this clock asked for, or a sync
    /// frame to every node): plans the next as [`NodeClock::exchange_due`]
    /// does; `hurry` (a run that has not started: nothing moves, and the
    /// sooner the bound is small the sooner it starts) plans it fast.
    pub fn exchanged(&mut self, now: u64, target_us: f64, max_us: u64, hurry: bool) {
        let h = now as f64;
        let limit = EXCHANGE_AT * target_us;
        let bound = self.est.error_bound(h);
        let fast = self.fast_us;
        let interval = if hurry || !self.est.synced() || bound > limit {
            fast
        } else {
            let grow = self.est.skew_bound().max(1e-12);
            (((limit - bound) / grow) as u64).clamp(fast, max_us.max(fast))
        };
        self.next_exchange = now + interval;
        self.planned = self.next_exchange;
        self.last_sent = Some(now);
    }

    /// When the next exchange is due, host µs.
    pub fn next_exchange(&self) -> u64 {
        self.next_exchange
    }

    /// Brings the next exchange forward to `quiet_us` after the later of
    /// the last frame heard (`heard`) and the last request: an exchange is
    /// also the heartbeat of a node that has nothing else to say. Other
    /// requests the node answers (`asked`: a seal) count as asking. One not
    /// answered (nothing heard since) is followed by an exchange after a
    /// tenth of that, or four least round trips if longer: a quiet node is
    /// asked several times within its timeout, so a few frames lost in a
    /// row do not make it look gone.
    pub fn probe_after(&mut self, heard: Option<u64>, asked: Option<u64>, quiet_us: u64) {
        let last = self.last_sent.max(asked);
        let next = match (heard, last) {
            (h, Some(sent)) if h.is_none_or(|h| h < sent) => {
                let rtt = self.est.min_rtt();
                let rtt = if rtt.is_finite() { 4.0 * rtt } else { 0.0 };
                sent + (quiet_us / 10).max(rtt as u64)
            }
            (h, sent) => h.max(sent).unwrap_or(0) + quiet_us,
        };
        // From the planned time each round: a repeat planned while an
        // answer was on its way is dropped once it came.
        self.next_exchange = self.planned.min(next);
    }

    /// The model to send at host time `now`, if the node needs one: its
    /// first, a slew toward the estimate when the model it runs is or will
    /// soon be off by more than `tolerance_us`, or the estimate itself once
    /// a slew has reached it. `delay_us` is how long the model takes to
    /// reach the node. The host takes the model as the node's once
    /// returned.
    /// A node `at_rest` takes the estimate at once, however far off.
    pub fn model_due(
        &mut self,
        now: u64,
        tolerance_us: f64,
        delay_us: f64,
        at_rest: bool,
    ) -> Option<ClockModel> {
        if self.fault.is_some() || !self.est.synced() {
            return None;
        }
        let est = self.est.model();
        let Some(sent) = self.sent else {
            // The node runs nothing yet (it is not moving): the estimate as
            // it is.
            return Some(self.take(est, None));
        };
        // Where the node will be when the model arrives.
        let at = now as f64 + delay_us;
        let off = |h: f64| est.local(h) - sent.local(h);
        let quarter = tolerance_us;
        match self.slewing_until {
            // A slew runs to its end before anything else is sent.
            Some(until) if at < until => return None,
            Some(_) => {}
            None if off(at).abs() <= quarter && off(at + LOOKAHEAD_US).abs() <= quarter => {
                return None
            }
            None => {}
        }
        let delta = off(at);
        if delta.abs() <= STEP_US || at_rest {
            return Some(self.take(est, None));
        }
        // A line through the node's current time at `at` that meets the
        // estimate `span` later.
        let span = (delta.abs() / SLEW_RATE)
            .min(MAX_SLEW_US)
            .max(delta.abs() / MAX_SLEW_RATE)
            .max(MIN_SLEW_US);
        let slope = (1.0 + est.skew) + delta / span;
        let m = ClockModel {
            offset: sent.local(at) - slope * at,
            skew: slope - 1.0,
        };
        Some(self.take(m, Some(at + span)))
    }

    fn take(&mut self, m: ClockModel, slewing_until: Option<f64>) -> ClockModel {
        if let Some(before) = self.sent {
            if self.maybe.len() == MAYBE_KEPT {
                self.maybe.pop_front();
            }
            self.maybe.push_back(before);
        }
        self.unacked += 1;
        self.sent = Some(m);
        self.slewing_until = slewing_until;
        self.models_sent.0 += 1;
        self.models_sent.1 += slewing_until.is_some() as u64;
        m
    }

    /// The node lost the model it ran (it restarted): the next one goes out
    /// as it is.
    pub fn forget_sent(&mut self) {
        self.sent = None;
        self.maybe.clear();
        self.unacked = 0;
        self.slewing_until = None;
    }

    /// The model the node runs, as last sent.
    pub fn sent(&self) -> Option<ClockModel> {
        self.sent
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A node whose clock runs 100 ppm fast, exchanges with a 200 µs round
    /// trip and no jitter.
    fn exchange(h: u64) -> Exchange {
        let local = |h: f64| (7_000_000.0 + h * (1.0 + 100e-6)) as u64;
        Exchange {
            t1: h,
            t2: local(h as f64 + 100.0),
            t3: local(h as f64 + 110.0),
            t4: h + 210,
        }
    }

    /// Until the link acknowledges a model, the node may still run the one
    /// before: the bound counts the farther of the two.
    #[test]
    fn a_model_in_flight_counts_the_one_before_until_acknowledged() {
        let mut c = NodeClock::default();
        let mut h = 1_000u64;
        while !c.synced() {
            c.add(exchange(h));
            h += 10_000;
        }
        let at = h as f64;
        let est = c.model();
        let alone = c.est.error_bound(at);
        // The node runs a model 30 µs off the estimate...
        c.take(
            ClockModel {
                offset: est.offset + 30.0,
                ..est
            },
            None,
        );
        c.model_delivered();
        assert!((c.error_bound(at) - (alone + 30.0)).abs() < 1e-6);
        // ... and is sent the estimate: until the link acknowledges it, the
        // 30 µs still count; then only the estimate's own bound.
        c.take(est, None);
        assert!((c.error_bound(at) - (alone + 30.0)).abs() < 1e-6);
        c.model_delivered();
        assert!((c.error_bound(at) - alone).abs() < 1e-6);
        // An acknowledgement of nothing changes nothing.
        c.model_delivered();
        assert!((c.error_bound(at) - alone).abs() < 1e-6);
    }

    #[test]
    fn corrections_are_slewed_and_time_stays_monotone() {
        let mut c = NodeClock::default();
        let mut h = 1_000u64;
        while !c.synced() {
            c.add(exchange(h));
            h += 10_000;
        }
        let first = c.model_due(h, 2.5, 100.0, false).expect("a first model");
        c.model_delivered();
        // A model 30 µs off: what a node restarted on an old estimate runs.
        c.sent = Some(ClockModel {
            offset: first.offset + 30.0,
            ..first
        });
        let mut models = vec![(h as f64, c.sent.unwrap())];
        for _ in 0..400 {
            h += 10_000;
            c.add(exchange(h));
            if let Some(m) = c.model_due(h, 2.5, 100.0, false) {
                models.push((h as f64 + 100.0, m));
                // The link acknowledges it, as a node's ack would.
                c.model_delivered();
            }
        }
        assert!(c.models_sent.1 >= 1, "the correction was slewed");
        // Where one model hands over to the next, the node's time moves by
        // less than a tick, and never backwards.
        for w in models.windows(2) {
            let (at, m) = w[1];
            let jump = m.local(at) - w[0].1.local(at);
            assert!(jump.abs() <= STEP_US + 1e-6, "jump {jump} at {at}");
        }
        // And in the end the node runs the estimate.
        assert!(
            c.error_bound(h as f64) < 10.0,
            "{}",
            c.error_bound(h as f64)
        );
    }
}
