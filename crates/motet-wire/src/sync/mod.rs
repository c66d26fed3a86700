//! Clock synchronisation: a node's clock as a function of the host's.
//!
//! Model: `local = offset + (1 + skew) · host`, both clocks in µs. It is
//! estimated from NTP-style exchanges: the host stamps a request when it leaves
//! (`t1`, host clock), the node when it arrives (`t2`, node clock) and when its
//! answer leaves (`t3`, node clock), the host when the answer arrives (`t4`,
//! host clock). The estimator is plain arithmetic over a fixed array (no clock
//! reads, no allocation) and runs on either side.
//!
//! With θ(h) = local − host at host time h, one exchange gives two one-sided
//! observations:
//! - forward `f = t2 − t1 = θ(t1) + d→ + j→ ≥ θ(t1) + d→`,
//! - reverse `r = t3 − t4 = θ(t4) − d← − j← ≤ θ(t4) − d←`,
//!
//! with d the fixed one-way delays and j ≥ 0 the queueing jitter. Jitter only
//! ever adds delay, so the information is in the *edges* of the two point
//! clouds, not in their means:
//!
//! 1. **Envelopes.** For a slope b, the forward points lie on or above the
//!    line `c_f(b) + b·h` with `c_f(b) = min (f − b·h)`, the reverse points on
//!    or below `c_r(b) + b·h` with `c_r(b) = max (r − b·h)`. The estimate is
//!    the slope that leaves the widest band between the two clouds (the gap
//!    `c_f − c_r` is concave in b: a golden-section search over the lower
//!    convex hull of the forward points and the upper hull of the reverse
//!    ones), and θ is the band's middle line. Every exchange counts, whenever
//!    it was lucky, in each direction separately; the error falls as 1/n in
//!    the number of exchanges (against 1/√n for an average), and a delayed,
//!    duplicated or retransmitted exchange costs nothing but its slot.
//!    (A constant asymmetry (d→ − d←)/2 is a bias no two-way method can see.)
//! 2. **Memory.** [`CAPACITY`] exchanges are kept. When full, the one
//!    farthest from both envelopes is dropped (never one of the newest
//!    [`RECENT`]), so the kept exchanges stretch over a long time and the
//!    slope rests on a long base; none older than [`SyncConfig::max_age_us`].
//! 3. **Change.** More data can only narrow the band by about the envelopes'
//!    own uncertainty; when a new exchange narrows it by far more, the node's
//!    rate changed (a crystal warming up) or the path got faster: the fit
//!    starts again from the newest exchanges and the old fit's band where they begin, from the
//!    last slope.
//! 4. **Error bound.** Near the envelopes the density of lucky exchanges is
//!    measured by the k-th least residual of each direction: with k
//!    residuals within x of the edge, an edge is known to about x/k. The
//!    bound at host time h is a timestamp tick, [`SyncConfig::confidence`] times that, plus the
//!    slope's uncertainty (the two edges' over the span) times the distance
//!    from the exchanges' centre.
//!
//! Exchanges that no clock can produce (the node's time running backwards
//! within an exchange or between two, a turnaround longer than the round
//! trip) are refused with a [`ClockFault`].

mod geometry;

use geometry::{golden_max, hull, kth_smallest};

/// Four timestamps of one exchange, µs: `t1`, `t4` on the host clock, `t2`,
/// `t3` on the node clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Exchange {
    /// Host clock when the request left.
    pub t1: u64,
    /// Node clock when the request arrived.
    pub t2: u64,
    /// Node clock when the reply left.
    pub t3: u64,
    /// Host clock when the reply arrived.
    pub t4: u64,
}

/// Exchanges kept for the fit.
pub const CAPACITY: usize = 256;
/// The newest exchanges are never dropped to make room: a change of rate
/// shows first in them, and the fit restarts from them.
pub const RECENT: usize = 12;
/// Exchanges before the slope is taken from the data rather than the prior.
const MIN_SAMPLES: usize = 8;
/// A slope known no better than this (2 %, far beyond any crystal) is no
/// slope yet: the bound with no prior, and the most a prior may be off.
const B_RANGE: f64 = 0.02;
/// The slopes searched: any clock that runs forward, up to 11 times the
/// host's, so a node started with another time scale is measured and
/// refused by name rather than never fitted.
const B_MIN: f64 = -0.9;
const B_MAX: f64 = 10.0;
/// The timestamps' resolution, µs.
const TICK_US: f64 = 1.0;
/// How far a crystal's rate may move at once (a board warming up, a
/// crystal swapped): after a change, the last slope is trusted this far
/// until the new exchanges are surer.
const CHANGE_BOUND: f64 = 300e-6;

/// Estimator settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SyncConfig {
    /// Exchanges whose round trip exceeds the least seen by more than this
    /// are not kept (retransmissions, stalls), µs.
    pub rtt_gate_us: f64,
    /// Exchanges older than this are dropped, µs: the longest time over which
    /// a crystal's rate is taken as constant.
    pub max_age_us: f64,
    /// The error bound in units of the measured edge uncertainty.
    pub confidence: f64,
}

impl Default for SyncConfig {
    /// Gate 10 ms, 10 minutes of memory, bound at 2 edge uncertainties.
    fn default() -> Self {
        SyncConfig {
            rtt_gate_us: 10_000.0,
            max_age_us: 600e6,
            confidence: 2.0,
        }
    }
}

/// A node clock model: `local = offset + (1 + skew) · host`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClockModel {
    /// Node clock at host time 0, µs.
    pub offset: f64,
    /// Node clock rate minus 1: how many µs the node's clock gains per host µs (within
    /// ±[`MAX_SKEW`](crate::service::MAX_SKEW)).
    pub skew: f64,
}

impl ClockModel {
    /// Node time at host time `host`, µs.
    pub fn local(&self, host: f64) -> f64 {
        self.offset + (1.0 + self.skew) * host
    }

    /// Host time at node time `local`, µs.
    pub fn host(&self, local: f64) -> f64 {
        (local - self.offset) / (1.0 + self.skew)
    }
}

/// An exchange no working clock produces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockFault {
    /// The node's reply left before its request arrived (`t3 < t2`).
    ReplyBeforeRequest,
    /// The node's clock read less than in an exchange that had ended before
    /// this one began.
    Backwards,
    /// The node spent longer between request and reply than the whole round
    /// trip took on the host: its clock runs far too fast.
    Turnaround,
}

impl core::fmt::Display for ClockFault {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ClockFault::ReplyBeforeRequest => "its clock answered before it was asked (t3 < t2)",
            ClockFault::Backwards => "its clock went backwards between two exchanges",
            ClockFault::Turnaround => "its clock counted more time between request and reply than the whole round trip took",
        })
    }
}

/// One exchange kept, relative to the estimator's origin.
#[derive(Clone, Copy, Debug, Default)]
struct Sample {
    /// Host time the request left.
    xf: f64,
    /// Forward observation `t2 − t1`.
    f: f64,
    /// Host time the reply arrived.
    xr: f64,
    /// Reverse observation `t3 − t4`.
    r: f64,
}

/// The fit: band edges at slope `b`, relative to the origin.
#[derive(Clone, Copy, Debug, Default)]
struct Fit {
    b: f64,
    c_f: f64,
    c_r: f64,
    /// The earlier and the later half of the kept exchanges.
    halves: [Half; 2],
    /// How far the slope may be off: the data's own bound, or the prior's.
    skew_bound: f64,
}

impl Fit {
    fn theta(&self, x: f64) -> f64 {
        0.5 * (self.c_f + self.c_r) + self.b * x
    }
    fn gap(&self) -> f64 {
        self.c_f - self.c_r
    }
}

/// Half of the kept exchanges, by host time.
#[derive(Clone, Copy, Debug, Default)]
struct Half {
    n: usize,
    /// Mean host time, relative to the origin.
    centre: f64,
    /// The forward and the reverse edge's uncertainties added, µs.
    edge: f64,
}

/// Clock offset and skew estimator (see the module documentation).
#[derive(Clone, Debug)]
pub struct ClockSync {
    cfg: SyncConfig,
    /// Host time of the first exchange (all times are kept relative to it).
    origin: Option<f64>,
    samples: [Sample; CAPACITY],
    len: usize,
    min_rtt: f64,
    rejected_run: u32,
    /// The node's time at the reply of the newest exchange, with the host
    /// time it arrived.
    last: Option<(u64, u64)>,
    fit: Fit,
    /// The slope used while the data's own is less certain, and how far
    /// off it may be.
    prior_b: f64,
    prior_bound: f64,
    /// The first kept sample is the old fit's band, not an exchange.
    anchored: bool,
    /// Exchanges taken into the fit since it (re)started, kept or not.
    seen: u64,
    exchanges: u64,
    rejected: u64,
    changes: u32,
    /// The rates every exchange before the last change allowed (hard
    /// limits), when one rate explained them: what the clock ran at
    /// before it changed.
    before_change: Option<(f64, f64)>,
}

impl Default for ClockSync {
    fn default() -> Self {
        Self::new(SyncConfig::default())
    }
}

impl ClockSync {
    /// A synchronizer on `cfg`, with no exchanges yet.
    pub fn new(cfg: SyncConfig) -> ClockSync {
        ClockSync {
            cfg,
            origin: None,
            samples: [Sample::default(); CAPACITY],
            len: 0,
            min_rtt: f64::INFINITY,
            rejected_run: 0,
            last: None,
            fit: Fit {
                skew_bound: B_RANGE,
                ..Fit::default()
            },
            prior_b: 0.0,
            prior_bound: B_RANGE,
            anchored: false,
            seen: 0,
            exchanges: 0,
            rejected: 0,
            changes: 0,
            before_change: None,
        }
    }

    /// Exchanges the fit rests on.
    pub fn points(&self) -> u32 {
        self.len as u32
    }

    /// Changes of the node's rate detected.
    pub fn changes(&self) -> u32 {
        self.changes
    }

    /// Exchanges taken and exchanges dropped by the RTT gate.
    pub fn counts(&self) -> (u64, u64) {
        (self.exchanges, self.rejected)
    }

    /// True once offset and skew both rest on data (or on a prior skew).
    pub fn synced(&self) -> bool {
        self.len >= MIN_SAMPLES && self.fit.skew_bound < B_RANGE
    }

    /// Least round trip seen, µs.
    pub fn min_rtt(&self) -> f64 {
        self.min_rtt
    }

    fn x(&self, host: f64) -> f64 {
        host - self.origin.unwrap_or(0.0)
    }

    /// Takes one exchange; returns true when it was kept (the model moved).
    pub fn add(&mut self, e: Exchange) -> Result<bool, ClockFault> {
        self.exchanges += 1;
        if e.t3 < e.t2 {
            return Err(ClockFault::ReplyBeforeRequest);
        }
        if e.t4 < e.t1 {
            // The host's own clock: not the node's fault, and no sample.
            self.rejected += 1;
            return Ok(false);
        }
        if let Some((t3, t4)) = self.last {
            if e.t1 > t4 && e.t2 < t3 {
                return Err(ClockFault::Backwards);
            }
        }
        let turn = (e.t3 - e.t2) as f64;
        let round = (e.t4 - e.t1) as f64;
        // A node at the edge of the skew range, and a microsecond of
        // rounding on each clock.
        if turn > round * (1.0 + B_MAX) + 2.0 {
            return Err(ClockFault::Turnaround);
        }
        if self.last.is_none_or(|(_, t4)| e.t4 >= t4) {
            self.last = Some((e.t3, e.t4));
        }
        // An early slope can be anything in the search range: the node's
        // turnaround is only scaled by one the data decided.
        let b = if self.synced() {
            self.fit.b
        } else {
            self.prior_b
        };
        let rtt = round - turn / (1.0 + b);
        if rtt > self.min_rtt + self.cfg.rtt_gate_us {
            self.rejected += 1;
            self.rejected_run += 1;
            // The path got slower for good: forget the old minimum.
            if self.rejected_run > 64 {
                self.min_rtt = rtt;
                self.rejected_run = 0;
            }
            return Ok(false);
        }
        self.rejected_run = 0;
        self.min_rtt = self.min_rtt.min(rtt);
        let origin = *self.origin.get_or_insert(e.t1 as f64);
        let s = Sample {
            xf: e.t1 as f64 - origin,
            f: e.t2 as f64 - e.t1 as f64,
            xr: e.t4 as f64 - origin,
            r: e.t3 as f64 - e.t4 as f64,
        };
        self.make_room(s.xr);
        if self.anchored && self.len == 0 {
            self.anchored = false;
        }
        self.samples[self.len] = s;
        self.len += 1;
        self.seen += 1;
        let before = self.fit;
        self.refit();
        if before.skew_bound < B_RANGE && self.len > RECENT {
            // New constraints narrow the band by about the edges' own
            // uncertainty; far more means the rate changed (or the path got
            // faster, which the restart also serves).
            let allowed = self.cfg.confidence * 2.0 * before.halves[1].edge + 2.0;
            if self.fit.gap() < before.gap() - allowed {
                self.changes += 1;
                // A change found again before the data decided the last:
                // the rate moved further than the prior allows, which then
                // only holds the fit back (it would restart at every few
                // exchanges, never reaching the new rate). The new
                // exchanges decide alone.
                let unresolved = self.prior_bound < B_RANGE;
                self.prior_b = before.b;
                self.prior_bound = if unresolved { B_RANGE } else { CHANGE_BOUND };
                // The old fit was right until the change: its band at the
                // last exchange it still explains anchors the new fit's
                // offset, and the exchanges it does not explain (the
                // newest, at most a few) give the slope. With rare
                // exchanges that is one: keeping older ones would mix the
                // two rates into a fit that suits neither.
                let tol = 0.5 * allowed;
                let off = |s: &Sample| {
                    let below = (before.c_f + before.b * s.xf) - s.f;
                    let above = s.r - (before.c_r + before.b * s.xr);
                    below.max(above) > tol
                };
                let keep = (1..=RECENT / 2)
                    .take_while(|&k| off(&self.samples[self.len - k]))
                    .count()
                    .max(1);
                // What the clock ran at until then: the exchanges the old
                // fit still explains.
                let from = usize::from(self.anchored);
                let upto = self.len - keep;
                self.before_change = feasible(&self.samples[from.min(upto)..upto]);
                let x = if self.len > keep {
                    self.samples[self.len - keep - 1].xr
                } else {
                    self.samples[0].xf
                };
                let (theta, half) = (before.theta(x), 0.5 * before.gap());
                self.samples.copy_within(self.len - keep..self.len, 1);
                self.samples[0] = Sample {
                    xf: x,
                    f: theta + half,
                    xr: x,
                    r: theta - half,
                };
                self.len = keep + 1;
                self.seen = keep as u64;
                self.anchored = true;
                self.refit();
            }
        }
        self.unanchor_a_time_step();
        Ok(true)
    }

    /// After a change the fit assumes the clock's time went on and only its
    /// rate changed: the old fit's band where it last held (the anchor)
    /// and the new exchanges lie on one line. When no rate joins them (the
    /// new exchanges, alone, allow rates the anchor does not), it was the
    /// time that jumped: the anchor would hold the fit halfway between the
    /// old time and the new, so it goes, and the new exchanges decide.
    fn unanchor_a_time_step(&mut self) {
        if !self.anchored || self.len <= MIN_SAMPLES {
            return;
        }
        let new = &self.samples[1..self.len];
        let Some(rates) = feasible(new) else {
            return;
        };
        let mut a = self.samples[0];
        // The band may be inverted (reference samples): as wide either way.
        let (mid, half) = (0.5 * (a.f + a.r), 0.5 * (a.f - a.r).abs());
        (a.f, a.r) = (mid + half, mid - half);
        let joined = new.iter().try_fold(rates, |r, b| {
            let r = allowed(&a, b, r)?;
            allowed(b, &a, r)
        });
        if joined.is_none() {
            self.samples.copy_within(1..self.len, 0);
            self.len -= 1;
            self.anchored = false;
            self.refit();
        }
    }

    /// Drops what is too old and, when full, the exchange farthest from
    /// both edges among all but the newest.
    fn make_room(&mut self, now: f64) {
        let max_age = self.cfg.max_age_us;
        let mut kept = 0;
        for i in 0..self.len {
            if now - self.samples[i].xr <= max_age || i + RECENT >= self.len {
                self.samples[kept] = self.samples[i];
                kept += 1;
            }
        }
        self.len = kept;
        if self.len < CAPACITY {
            return;
        }
        let fit = self.fit;
        let mut worst = 0;
        let mut worst_res = f64::NEG_INFINITY;
        // Never the anchor: it goes once the new exchanges are surer.
        for i in self.anchored as usize..self.len - RECENT {
            let s = self.samples[i];
            let res_f = s.f - (fit.c_f + fit.b * s.xf);
            let res_r = (fit.c_r + fit.b * s.xr) - s.r;
            let res = res_f.min(res_r);
            if res > worst_res {
                worst_res = res;
                worst = i;
            }
        }
        self.samples.copy_within(worst + 1..self.len, worst);
        self.len -= 1;
    }

    /// Fits the band to the kept exchanges.
    fn refit(&mut self) {
        let n = self.len;
        if n == 0 {
            return;
        }
        let mut order = [0u8; CAPACITY];
        let mut lower = [0u8; CAPACITY];
        let mut upper = [0u8; CAPACITY];
        let s = &self.samples[..n];
        let nl = hull(s, &mut order, &mut lower, |p| (p.xf, p.f), true);
        let nu = hull(s, &mut order, &mut upper, |p| (p.xr, p.r), false);
        let c_f = |b: f64| {
            lower[..nl]
                .iter()
                .map(|&i| s[i as usize].f - b * s[i as usize].xf)
                .fold(f64::INFINITY, f64::min)
        };
        let c_r = |b: f64| {
            upper[..nu]
                .iter()
                .map(|&i| s[i as usize].r - b * s[i as usize].xr)
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let gap = |b: f64| c_f(b) - c_r(b);
        // The exchanges' host times, split at their median: each half's
        // edges are measured apart, as a slope is only as sure as the
        // thinner end it rests on. When that puts the halves' centres
        // within a quarter of the exchanges' span (a burst of them: both
        // halves in one moment, the slope seeming unknown however long
        // they span), at the middle of the span instead.
        let cut = halves_cut(s);
        let seen = self.seen.max(1) as f64;
        let edges = |b: f64| {
            let (cf, cr) = (c_f(b), c_r(b));
            let mut halves = [Half::default(), Half::default()];
            let mut res = [[[0.0f64; CAPACITY]; 2]; 2];
            for p in s {
                let late = (0.5 * (p.xf + p.xr) > cut) as usize;
                let h = &mut halves[late];
                res[late][0][h.n] = p.f - (cf + b * p.xf);
                res[late][1][h.n] = (cr + b * p.xr) - p.r;
                h.centre += 0.5 * (p.xf + p.xr);
                h.n += 1;
            }
            for (h, r) in halves.iter_mut().zip(res.iter_mut()) {
                if h.n == 0 {
                    h.edge = f64::INFINITY;
                    continue;
                }
                h.centre /= h.n as f64;
                // The k-th least residual over k; with few exchanges at
                // least twice the median over their number (what uniform
                // jitter gives), as the k-th least is then itself a lucky
                // draw.
                let m = h.n;
                let k = (m / 4).clamp(1, 8);
                let share = (seen * m as f64 / n as f64).max(1.0);
                let edge = |res: &mut [f64]| {
                    let near = kth_smallest(res, k) / k as f64;
                    let median = kth_smallest(res, m.div_ceil(2));
                    near.max(2.0 * median / share)
                };
                h.edge = edge(&mut r[0][..m]) + edge(&mut r[1][..m]);
            }
            (cf, cr, halves)
        };
        let conf = self.cfg.confidence;
        // Each half's line is known to its edges and a timestamp tick (whole
        // µs on each clock): exact exchanges still leave a tick of slope
        // over the time between the halves.
        let skew_of = |h: &[Half; 2]| {
            let apart = (h[1].centre - h[0].centre).max(1.0);
            (conf * (h[0].edge + h[1].edge) + TICK_US) / apart
        };
        // The data's slope once it is surer than the prior.
        let mut fit = None;
        if n >= MIN_SAMPLES {
            let b = golden_max(gap, B_MIN, B_MAX);
            let (cf, cr, halves) = edges(b);
            let bound = skew_of(&halves);
            // Against a prior, the data must be clearly surer: a bound
            // from few exchanges is itself uncertain.
            let surer = if self.prior_bound < B_RANGE {
                n >= 4 * MIN_SAMPLES && 2.0 * bound < self.prior_bound
            } else {
                bound < self.prior_bound
            };
            let inside = b > B_MIN + 1e-6 && b < B_MAX - 1e-6;
            if surer && inside {
                fit = Some((b, cf, cr, halves, bound));
            }
        }
        let fit_from_data = fit.is_some();
        let (b, cf, cr, halves, bound) = fit.unwrap_or_else(|| {
            let b = self.prior_b;
            let (cf, cr, halves) = edges(b);
            (b, cf, cr, halves, self.prior_bound)
        });
        if fit_from_data {
            // Once the data decide, a change later starts from them, and
            // the anchor (a guess from before the change) goes.
            self.prior_bound = B_RANGE;
            if self.anchored {
                self.anchored = false;
                self.samples.copy_within(1..n, 0);
                self.len -= 1;
                return self.refit();
            }
        }
        self.fit = Fit {
            b,
            c_f: cf,
            c_r: cr,
            halves,
            skew_bound: bound,
        };
    }

    /// The model: `local = offset + (1 + skew) · host`.
    pub fn model(&self) -> ClockModel {
        let origin = self.origin.unwrap_or(0.0);
        ClockModel {
            offset: self.fit.theta(-origin),
            skew: self.fit.b,
        }
    }

    /// Node time at host time `host`, µs.
    pub fn host_to_local(&self, host: f64) -> f64 {
        host + self.fit.theta(self.x(host))
    }

    /// Host time at node time `local`, µs.
    pub fn local_to_host(&self, local: f64) -> f64 {
        self.model().host(local)
    }

    /// How far the slope may be off, µs per host µs; infinite before the
    /// fit is [`synced`](ClockSync::synced).
    pub fn skew_bound(&self) -> f64 {
        if !self.synced() {
            return f64::INFINITY;
        }
        self.fit.skew_bound
    }

    /// The skews every kept exchange allows: the slopes of the lines that
    /// pass below every forward observation and above every reverse one,
    /// each taken a timestamp tick its own way. These are hard limits, not
    /// an estimate: whatever the jitter, a late host loop or a node slow to
    /// answer, a clock of constant rate always lies inside, and delays only
    /// widen the interval. `None` when no constant rate explains the
    /// exchanges since the fit last (re)started (its rate changed among
    /// them), or before two exchanges. Costs the square of the exchanges
    /// kept: for the rare decision that a clock is surely broken.
    pub fn feasible_skew(&self) -> Option<(f64, f64)> {
        // After a change the first sample is the old fit's band, not an
        // observation: it is left out.
        let from = usize::from(self.anchored);
        feasible(&self.samples[from..self.len])
    }

    /// A step of the clock's rate: the rates every exchange before the
    /// last change allowed, and those every exchange since allows (hard
    /// limits both, see [`ClockSync::feasible_skew`]). `None` before a
    /// change, or while either is not one rate. A crystal drifts; its rate
    /// does not jump: two intervals far apart are a clock source gone bad
    /// (whatever the delays, which only widen them).
    pub fn rate_step(&self) -> Option<((f64, f64), (f64, f64))> {
        Some((self.before_change?, self.feasible_skew()?))
    }

    /// A bound on the error of [`ClockSync::host_to_local`] at host time
    /// `host`, µs (see the module documentation); infinite before the fit is
    /// [`synced`](ClockSync::synced).
    pub fn error_bound(&self, host: f64) -> f64 {
        if !self.synced() {
            return f64::INFINITY;
        }
        let x = self.x(host);
        let [early, late] = self.fit.halves;
        let near = if x >= 0.5 * (early.centre + late.centre) {
            late
        } else {
            early
        };
        // Timestamps are whole µs on each clock: a tick either way is
        // beyond what the edges can tell.
        TICK_US
            + 0.5 * near.edge * self.cfg.confidence
            + self.fit.skew_bound * (x - near.centre).abs()
    }
}

/// Where the exchanges `s` (at most [`CAPACITY`]) split into their two
/// halves: [`span_cut`] of their host times.
fn halves_cut(s: &[Sample]) -> f64 {
    let n = s.len();
    let mut xs = [0.0f64; CAPACITY];
    for (x, p) in xs.iter_mut().zip(s) {
        *x = 0.5 * (p.xf + p.xr);
    }
    let median = kth_smallest(&mut xs[..n], n.div_ceil(2));
    span_cut(&xs[..n], median)
}

/// Where to split exchanges at host times `xs` into two halves: at their
/// `median`, unless the halves' centres would lie within a quarter of the
/// span, then at the span's middle (when it leaves exchanges either side).
fn span_cut(xs: &[f64], median: f64) -> f64 {
    let (first, last) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let centre = |late: bool| {
        let (sum, n) = xs
            .iter()
            .filter(|&&x| (x > median) == late)
            .fold((0.0, 0usize), |(s, n), &x| (s + x, n + 1));
        sum / n.max(1) as f64
    };
    let middle = 0.5 * (first + last);
    let either_side = xs.iter().any(|&x| x > middle) && xs.iter().any(|&x| x <= middle);
    if centre(true) - centre(false) < 0.25 * (last - first) && either_side {
        middle
    } else {
        median
    }
}

/// The skews every sample of `s` allows (see [`ClockSync::feasible_skew`]).
fn feasible(s: &[Sample]) -> Option<(f64, f64)> {
    if s.len() < 2 {
        return None;
    }
    s.iter().try_fold((B_MIN, B_MAX), |r, a| {
        s.iter().try_fold(r, |r, b| allowed(a, b, r))
    })
}

/// The skews of `(lo, hi)` that `a`'s forward observation and `b`'s
/// reverse one allow together: θ(a.xf) ≤ a.f + tick and θ(b.xr) ≥ b.r −
/// tick, for θ = c + skew·x, so skew · (b.xr − a.xf) ≥ (b.r − tick) −
/// (a.f + tick). `None` when none.
fn allowed(a: &Sample, b: &Sample, (lo, hi): (f64, f64)) -> Option<(f64, f64)> {
    let dx = b.xr - a.xf;
    let dy = (b.r - TICK_US) - (a.f + TICK_US);
    let (lo, hi) = if dx > 0.0 {
        (lo.max(dy / dx), hi)
    } else if dx < 0.0 {
        (lo, hi.min(dy / dx))
    } else if dy > 0.0 {
        return None;
    } else {
        (lo, hi)
    };
    (lo <= hi).then_some((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_exchanges_give_exact_model() {
        let mut s = ClockSync::default();
        let (offset, skew) = (12_345.0, 150e-6);
        let local = |h: f64| (offset + (1.0 + skew) * h).round() as u64;
        for i in 0..50u64 {
            let h = 1_000_000 + i * 10_000;
            s.add(Exchange {
                t1: h,
                t2: local(h as f64 + 100.0),
                t3: local(h as f64 + 150.0),
                t4: h + 250,
            })
            .unwrap();
        }
        let m = s.model();
        assert!((m.skew - skew).abs() < 1e-5, "{m:?}");
        let h = 1_600_000.0;
        assert!((s.host_to_local(h) - (offset + (1.0 + skew) * h)).abs() < 2.0);
        assert!((s.local_to_host(s.host_to_local(h)) - h).abs() < 1e-6);
    }

    #[test]
    fn impossible_exchanges_are_faults() {
        let mut s = ClockSync::default();
        let e = |t1, t2, t3, t4| Exchange { t1, t2, t3, t4 };
        assert_eq!(
            s.add(e(100, 500, 400, 200)),
            Err(ClockFault::ReplyBeforeRequest)
        );
        assert_eq!(s.add(e(100, 500, 5_000, 200)), Err(ClockFault::Turnaround));
        assert_eq!(s.add(e(100, 500, 510, 200)), Ok(true));
        assert_eq!(s.add(e(300, 400, 410, 400)), Err(ClockFault::Backwards));
    }

    #[test]
    fn hulls_hold_every_point() {
        let pts = [(0.0, 5.0), (1.0, 1.0), (2.0, 3.0), (3.0, 0.0), (4.0, 4.0)];
        let s: [Sample; 5] = pts.map(|(x, y)| Sample {
            xf: x,
            f: y,
            xr: x,
            r: y,
        });
        let (mut order, mut out) = ([0u8; CAPACITY], [0u8; CAPACITY]);
        let n = hull(&s, &mut order, &mut out, |p| (p.xf, p.f), true);
        assert_eq!(&out[..n], &[0, 1, 3, 4]);
        let n = hull(&s, &mut order, &mut out, |p| (p.xr, p.r), false);
        assert_eq!(&out[..n], &[0, 4]);
    }
}
