//! Clock synchronisation: a node's clock as a function of the host's.
//!
//! Model: `local = offset + (1 + skew) · host`, both clocks in µs. It is
//! estimated from NTP-style exchanges: the host stamps a request when it leaves
//! (`t1`, host clock), the node when it arrives (`t2`, node clock) and when its
//! answer leaves (`t3`, node clock), the host when the answer arrives (`t4`,
//! host clock). The estimator is plain arithmetic (no clock reads, no
//! allocation) and runs on either side.
//!
//! With θ(h) = local − host at host time h, one exchange gives two one-sided
//! observations:
//! - forward `f = t2 − t1 = θ(t1) + d→ + j→ ≥ θ(t1)`,
//! - reverse `r = t3 − t4 = θ(t4) − d← − j← ≤ θ(t4)`,
//!
//! with d the fixed one-way delays and j ≥ 0 the queueing jitter.
//!
//! 1. Gate: exchanges whose round trip `(t4 − t1) − (t3 − t2)` exceeds the
//!    least seen by more than [`SyncConfig::rtt_gate_us`] are dropped
//!    (retransmissions, stalls).
//! 2. Minimum-delay filter: exchanges are taken in bins of [`SyncConfig::bin`].
//!    Within a bin each observation is moved to the bin's first host time with
//!    the current skew estimate, and the least forward and the greatest reverse
//!    value are kept. This is minimum-RTT filtering done for each half of the
//!    round trip separately: the two halves need not be lucky in the same
//!    exchange, so the composite round trip `min f − max r` approaches
//!    `d→ + d←` far faster than the least single RTT does (with jitter uniform
//!    over J, the expected excess falls as 2J/(bin+1) instead of J·√(2/bin)).
//!    The bin gives a point θ ≈ (min f + max r)/2 with the hard bound
//!    max r ≤ θ ≤ min f (exact when the fixed delays are symmetric; an
//!    asymmetry (d→ − d←)/2 is a bias no two-way method can see).
//! 3. Fit: a weighted least-squares line θ = a + b·(h − h_ref) through the
//!    points, weights 1/(excess half-width + [`SyncConfig::weight_floor_us`])²,
//!    all sums decayed by [`SyncConfig::forget`] per point so that a change of
//!    crystal drift is followed within a few 1/(1 − forget) points.
//! 4. Error estimate: the fit's prediction standard deviation, with the point
//!    variance estimated from the (decayed) normalised innovations (each new
//!    point against the fit before it).

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

/// Estimator settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SyncConfig {
    /// Exchanges per filtered point.
    pub bin: u16,
    /// Weight kept by the fit's past at each new point (0 < forget < 1).
    pub forget: f64,
    /// Exchanges whose round trip exceeds the least seen by more than this are dropped.
    pub rtt_gate_us: f64,
    /// Added to a point's excess half-width before weighting, µs.
    pub weight_floor_us: f64,
    /// Drift-change alarm: a one-sided CUSUM of the innovations in units of
    /// their standard deviation, each clipped to ±4 and less
    /// [`SyncConfig::change_slack`], beyond this threshold means the drift
    /// changed; the fit is then rebuilt from the points since the sum left
    /// zero (0 disables).
    pub change_threshold: f64,
    /// Innovations up to this many standard deviations do not add to the
    /// CUSUM.
    pub change_slack: f64,
}

impl Default for SyncConfig {
    /// 32 exchanges per point, forget 0.95 (about 20 points of memory), gate
    /// 10 ms, weight floor 10 µs, change alarm at a CUSUM of 10σ with 0.5σ slack.
    fn default() -> Self {
        SyncConfig {
            bin: 32,
            forget: 0.95,
            rtt_gate_us: 10_000.0,
            weight_floor_us: 10.0,
            change_threshold: 10.0,
            change_slack: 0.5,
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

/// Square root by Newton's method (core has none without std).
fn sqrt(x: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x.is_infinite() {
        return x;
    }
    // Halve the exponent for a start within a factor of two.
    let mut y = f64::from_bits((x.to_bits() >> 1) + (1023u64 << 51));
    for _ in 0..6 {
        y = 0.5 * (y + x / y);
    }
    y
}

/// Points kept for rebuilding the fit after a drift change.
const HISTORY: usize = 16;

/// One filtered point: host time, θ, half-width.
#[derive(Clone, Copy, Debug, Default)]
struct Point {
    x: f64,
    y: f64,
    half: f64,
}

/// One side of the two-sided CUSUM: the sum and the points since it was 0.
#[derive(Clone, Copy, Debug, Default)]
struct Cusum {
    sum: f64,
    run: u32,
}

impl Cusum {
    fn add(&mut self, z: f64, slack: f64) {
        self.sum = (self.sum + z - slack).max(0.0);
        self.run = if self.sum > 0.0 { self.run + 1 } else { 0 };
    }
}

/// Clock offset and skew estimator (see the module documentation).
#[derive(Clone, Debug)]
pub struct ClockSync {
    cfg: SyncConfig,
    // current bin
    n: u16,
    bin_ref: f64,
    min_f: f64,
    max_r: f64,
    // gating
    min_rtt: f64,
    rejected_run: u32,
    // fit, x = host − x_ref, y = θ − y_ref
    x_ref: f64,
    y_ref: f64,
    sw: f64,
    swx: f64,
    swy: f64,
    swxx: f64,
    swxy: f64,
    a: f64,
    b: f64,
    points: u32,
    min_half: f64,
    // normalised innovation variance
    nres: f64,
    nres_n: f64,
    ures: f64,
    up: Cusum,
    down: Cusum,
    history: [Point; HISTORY],
    history_len: usize,
    changes: u32,
    exchanges: u64,
    rejected: u64,
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
            n: 0,
            bin_ref: 0.0,
            min_f: f64::INFINITY,
            max_r: f64::NEG_INFINITY,
            min_rtt: f64::INFINITY,
            rejected_run: 0,
            x_ref: 0.0,
            y_ref: 0.0,
            sw: 0.0,
            swx: 0.0,
            swy: 0.0,
            swxx: 0.0,
            swxy: 0.0,
            a: 0.0,
            b: 0.0,
            points: 0,
            min_half: f64::INFINITY,
            nres: 0.0,
            nres_n: 0.0,
            ures: 0.0,
            up: Cusum::default(),
            down: Cusum::default(),
            history: [Point::default(); HISTORY],
            history_len: 0,
            changes: 0,
            exchanges: 0,
            rejected: 0,
        }
    }

    /// An estimator that starts from a known skew (from a coarser estimate):
    /// the first bins then place their observations with it instead of with
    /// no drift at all, which would bias them by up to skew × bin span.
    pub fn with_skew(cfg: SyncConfig, skew: f64) -> ClockSync {
        let mut s = ClockSync::new(cfg);
        if skew.is_finite() {
            s.b = skew;
        }
        s
    }

    /// Filtered points fitted so far.
    pub fn points(&self) -> u32 {
        self.points
    }

    /// Drift changes detected.
    pub fn changes(&self) -> u32 {
        self.changes
    }

    /// Exchanges taken and exchanges dropped by the RTT gate.
    pub fn counts(&self) -> (u64, u64) {
        (self.exchanges, self.rejected)
    }

    /// True once offset and skew both rest on data (two points).
    pub fn synced(&self) -> bool {
        self.points >= 2
    }

    /// Least round trip seen, µs.
    pub fn min_rtt(&self) -> f64 {
        self.min_rtt
    }

    /// Local minus host time at host time `host`.
    fn theta(&self, host: f64) -> f64 {
        self.y_ref + self.a + self.b * (host - self.x_ref)
    }

    /// Takes one exchange; returns true when it completed a point and the
    /// model changed.
    pub fn add(&mut self, e: Exchange) -> bool {
        let (t1, t2, t3, t4) = (e.t1 as f64, e.t2 as f64, e.t3 as f64, e.t4 as f64);
        self.exchanges += 1;
        let rtt = (t4 - t1) - (t3 - t2) / (1.0 + self.b);
        if rtt.is_nan() || rtt < 0.0 {
            self.rejected += 1;
            return false;
        }
        if rtt > self.min_rtt + self.cfg.rtt_gate_us {
            self.rejected += 1;
            self.rejected_run += 1;
            // The path got slower for good: forget the old minimum.
            if self.rejected_run > 4 * self.cfg.bin as u32 {
                self.min_rtt = rtt;
                self.rejected_run = 0;
            }
            return false;
        }
        self.rejected_run = 0;
        self.min_rtt = self.min_rtt.min(rtt);
        if self.n == 0 {
            self.bin_ref = t1;
            self.min_f = f64::INFINITY;
            self.max_r = f64::NEG_INFINITY;
        }
        let f = (t2 - t1) - self.b * (t1 - self.bin_ref);
        let r = (t3 - t4) - self.b * (t4 - self.bin_ref);
        self.min_f = self.min_f.min(f);
        self.max_r = self.max_r.max(r);
        self.n += 1;
        if self.n < self.cfg.bin.max(1) {
            return false;
        }
        self.n = 0;
        let y = 0.5 * (self.min_f + self.max_r);
        let half = 0.5 * (self.min_f - self.max_r);
        self.add_point(self.bin_ref, y, half);
        true
    }

    fn add_point(&mut self, x: f64, y: f64, half: f64) {
        self.history.copy_within(1.., 0);
        self.history[HISTORY - 1] = Point { x, y, half };
        self.history_len = (self.history_len + 1).min(HISTORY);
        if let Some(run) = self.detect_change(x, y, half) {
            self.changes += 1;
            self.rebuild(run);
        } else {
            self.fit_point(x, y, half, true);
        }
    }

    /// Feeds the innovation of a new point to the CUSUMs; returns the
    /// points since the change when they raise the alarm.
    fn detect_change(&mut self, x: f64, y: f64, _half: f64) -> Option<usize> {
        let h = self.cfg.change_threshold;
        if h <= 0.0 || self.points < 6 || self.nres_n <= 0.0 {
            return None;
        }
        let sigma = sqrt(self.ures / self.nres_n);
        if sigma <= 0.0 {
            return None;
        }
        // Clipped so that a single wild point cannot raise the alarm.
        let z = ((y - self.theta(x)) / sigma).clamp(-4.0, 4.0);
        let k = self.cfg.change_slack;
        self.up.add(z, k);
        self.down.add(-z, k);
        let run = if self.up.sum > h {
            self.up.run
        } else if self.down.sum > h {
            self.down.run
        } else {
            return None;
        };
        Some((run as usize).clamp(2, self.history_len))
    }

    /// Refits from the newest `n` points only (the drift before them is
    /// stale).
    fn rebuild(&mut self, n: usize) {
        self.up = Cusum::default();
        self.down = Cusum::default();
        self.points = 0;
        self.sw = 0.0;
        self.swx = 0.0;
        self.swy = 0.0;
        self.swxx = 0.0;
        self.swxy = 0.0;
        self.a = 0.0;
        self.b = 0.0;
        let first = HISTORY - n;
        for i in first..HISTORY {
            let p = self.history[i];
            self.fit_point(p.x, p.y, p.half, false);
        }
    }

    /// Adds a point to the decayed fit; `learn` also updates the innovation
    /// statistics.
    fn fit_point(&mut self, x: f64, y: f64, half: f64, learn: bool) {
        if self.points == 0 {
            self.x_ref = x;
            self.y_ref = y;
        }
        self.min_half = self.min_half.min(half);
        let excess = (half - self.min_half).max(0.0) + self.cfg.weight_floor_us;
        let w = 1.0 / (excess * excess);
        let k = self.cfg.forget;
        if learn && self.points >= 2 {
            let innov = y - self.theta(x);
            let u2 = innov * innov;
            // Plain innovations size the change detector (the weights make a
            // lucky point's normalised innovation large without any change);
            // clipped at 3σ so that a drift change does not inflate them.
            let u2 = if self.nres_n > 0.0 {
                u2.min(9.0 * self.ures / self.nres_n)
            } else {
                u2
            };
            self.ures = k * self.ures + u2;
            self.nres = k * self.nres + innov * innov * w;
            self.nres_n = k * self.nres_n + 1.0;
        }
        // Decay and move the reference to the new point.
        let d = x - self.x_ref;
        let (sw, swx, swy, swxx, swxy) = (
            k * self.sw,
            k * self.swx,
            k * self.swy,
            k * self.swxx,
            k * self.swxy,
        );
        let theta_at_x = self.theta(x);
        self.x_ref = x;
        self.sw = sw;
        self.swx = swx - d * sw;
        self.swxx = swxx - 2.0 * d * swx + d * d * sw;
        self.swy = swy;
        self.swxy = swxy - d * swy;
        self.a = theta_at_x - self.y_ref;
        // Add the point (x = 0 now).
        let yy = y - self.y_ref;
        self.sw += w;
        self.swy += w * yy;
        self.points += 1;
        let det = self.sw * self.swxx - self.swx * self.swx;
        if self.points >= 2 && det > 1e-12 * self.sw * self.swxx.max(1e-300) {
            self.b = (self.sw * self.swxy - self.swx * self.swy) / det;
            self.a = (self.swy - self.b * self.swx) / self.sw;
        } else {
            self.a = self.swy / self.sw;
        }
        // Keep y_ref near the line so the sums stay small.
        let shift = self.a;
        self.y_ref += shift;
        self.a = 0.0;
        self.swy -= shift * self.sw;
        self.swxy -= shift * self.swx;
    }

    /// The model: `local = offset + (1 + skew) · host`.
    pub fn model(&self) -> ClockModel {
        ClockModel {
            offset: self.theta(0.0),
            skew: self.b,
        }
    }

    /// Node time at host time `host`, µs.
    pub fn host_to_local(&self, host: f64) -> f64 {
        host + self.theta(host)
    }

    /// Host time at node time `local`, µs.
    pub fn local_to_host(&self, local: f64) -> f64 {
        let at_ref = self.x_ref + self.theta(self.x_ref);
        self.x_ref + (local - at_ref) / (1.0 + self.b)
    }

    /// Estimated standard deviation of [`ClockSync::host_to_local`] at host
    /// time `host`, µs; infinite before two points.
    pub fn error_estimate(&self, host: f64) -> f64 {
        if self.points < 3 || self.nres_n <= 0.0 {
            return f64::INFINITY;
        }
        let sigma2 = self.nres / self.nres_n;
        let det = self.sw * self.swxx - self.swx * self.swx;
        if det <= 0.0 {
            return f64::INFINITY;
        }
        let x = host - self.x_ref;
        let v = sigma2 * (self.swxx - 2.0 * x * self.swx + x * x * self.sw) / det;
        sqrt(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sqrt_is_accurate() {
        for &x in &[1e-12, 0.25, 2.0, 1e6, 3.7e15] {
            let s = sqrt(x);
            assert!((s * s - x).abs() <= 1e-12 * x, "{x}");
        }
    }

    #[test]
    fn exact_exchanges_give_exact_model() {
        let mut s = ClockSync::new(SyncConfig {
            bin: 1,
            ..SyncConfig::default()
        });
        let (offset, skew) = (12_345.0, 150e-6);
        let local = |h: f64| (offset + (1.0 + skew) * h).round() as u64;
        for i in 0..50u64 {
            let h = 1_000_000 + i * 10_000;
            s.add(Exchange {
                t1: h,
                t2: local(h as f64 + 100.0),
                t3: local(h as f64 + 150.0),
                t4: h + 250,
            });
        }
        let m = s.model();
        assert!((m.skew - skew).abs() < 1e-6, "{m:?}");
        let h = 1_600_000.0;
        assert!((s.host_to_local(h) - (offset + (1.0 + skew) * h)).abs() < 2.0);
        assert!((s.local_to_host(s.host_to_local(h)) - h).abs() < 1e-6);
    }
}
