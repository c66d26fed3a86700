//! Clock synchronisation in a simulated world: a node crystal off by up to
//! ±200 ppm, up to 1 ms of random one-way jitter, a loopback-like fixed delay.
//! The true error is measured against the simulated node clock.

use motet_wire::sync::{ClockSync, Exchange, SyncConfig};

struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    fn next(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The node's crystal: a piecewise-constant skew from a start offset.
struct Crystal {
    offset: f64,
    /// (from host time µs, skew)
    skews: Vec<(f64, f64)>,
}

impl Crystal {
    fn local(&self, h: f64) -> f64 {
        let mut t = 0.0;
        let mut l = self.offset;
        let mut skew = self.skews[0].1;
        for &(from, s) in &self.skews[1..] {
            if h <= from {
                break;
            }
            l += (from - t) * (1.0 + skew);
            t = from;
            skew = s;
        }
        l + (h - t) * (1.0 + skew)
    }

    /// The exchange whose request leaves at host time `t1`, takes `d1` µs
    /// to arrive, is answered `turn` µs later and takes `d2` µs back; each
    /// clock reads whole µs.
    fn exchange(&self, t1: f64, d1: f64, turn: f64, d2: f64) -> Exchange {
        Exchange {
            t1: t1 as u64,
            t2: self.local(t1 + d1).floor() as u64,
            t3: self.local(t1 + d1 + turn).floor() as u64,
            t4: (t1 + d1 + turn + d2).floor() as u64,
        }
    }
}

/// The delays of one world.
#[derive(Clone, Copy, Debug)]
struct Path {
    /// Fixed one-way delay each way, µs.
    base: f64,
    /// One-way jitter, uniform over [0, jitter] µs, independent each way.
    jitter: f64,
    /// Exchange period, µs.
    period: f64,
}

/// Runs exchanges until `end` µs; returns the true errors (host time, µs) at
/// every exchange from `measure_from` on, and the estimator.
fn run(
    clock: &Crystal,
    path: Path,
    cfg: SyncConfig,
    seed: u64,
    end: f64,
    measure_from: f64,
) -> (Vec<(f64, f64, f64)>, ClockSync) {
    let mut rng = Rng::new(seed);
    let mut sync = ClockSync::new(cfg);
    let mut errors = Vec::new();
    let mut h = 1_000.0;
    while h < end {
        let t1 = h.floor();
        let d1 = path.base + path.jitter * rng.unit();
        let turn = 20.0 + 10.0 * rng.unit();
        let d2 = path.base + path.jitter * rng.unit();
        sync.add(clock.exchange(t1, d1, turn, d2)).unwrap();
        if h >= measure_from && sync.synced() {
            let err = sync.host_to_local(h) - clock.local(h);
            errors.push((h, err, sync.error_bound(h)));
        }
        h += path.period;
    }
    (errors, sync)
}

fn max_abs(errors: &[(f64, f64, f64)]) -> f64 {
    errors.iter().map(|e| e.1.abs()).fold(0.0, f64::max)
}

fn rms(errors: &[(f64, f64, f64)]) -> f64 {
    (errors.iter().map(|e| e.1 * e.1).sum::<f64>() / errors.len() as f64).sqrt()
}

const S: f64 = 1e6;

const PATH: Path = Path {
    base: 50.0,
    jitter: 1_000.0,
    period: 10_000.0,
};

#[test]
fn converges_to_ten_microseconds() {
    // (seed, skew, start offset µs)
    let cases = [
        (1, 200e-6, 123_456_789.0),
        (2, -200e-6, 5_000_000.0),
        (3, 37e-6, 0.0),
        (4, -150e-6, 1e9),
        (5, 0.0, 42.0),
        (6, 199e-6, 1e10),
    ];
    for (seed, skew, offset) in cases {
        let clock = Crystal {
            offset,
            skews: vec![(0.0, skew)],
        };
        let (errs, sync) = run(
            &clock,
            PATH,
            SyncConfig::default(),
            seed,
            120.0 * S,
            30.0 * S,
        );
        let (max, r) = (max_abs(&errs), rms(&errs));
        let est = errs.iter().map(|e| e.2).sum::<f64>() / errs.len() as f64;
        eprintln!(
            "skew {:+.0} ppm: error max {max:.1} µs, rms {r:.1} µs, mean bound {est:.1} µs, skew error {:.3} ppm, {:?} exchanges/dropped",
            skew * 1e6,
            (sync.model().skew - skew) * 1e6,
            sync.counts()
        );
        assert!(max <= 10.0, "seed {seed}: max error {max:.1} µs");
        // No false drift-change alarms on a steady crystal.
        assert_eq!(sync.changes(), 0, "seed {seed}");
        assert!((sync.model().skew - skew).abs() < 1e-6);
        // The bound holds, and is not absurdly wide.
        let outside = errs.iter().filter(|e| e.1.abs() > e.2).count();
        assert!(
            outside * 100 <= errs.len(),
            "seed {seed}: the bound failed {outside} times of {}",
            errs.len()
        );
        // Timestamps are whole µs: the bound carries a tick in its offset
        // and a tick over the exchanges' span in its slope.
        assert!(est < 2.0 + 3.0 * max, "bound {est:.1} vs max {max:.1}");
        // Local-to-host inverts host-to-local.
        let h = 100.0 * S;
        assert!((sync.local_to_host(sync.host_to_local(h)) - h).abs() < 1e-3);
    }
}

/// Max error before a drift step at 60 s, peak error in the 40 s after it,
/// max error from 100 s on, seconds from the step to the last error over 10
/// µs and over 15 µs, and the estimator.
fn drift_step(seed: u64, from: f64, to: f64) -> (f64, f64, f64, f64, f64, ClockSync) {
    let clock = Crystal {
        offset: 5.0,
        skews: vec![(0.0, from), (60.0 * S, to)],
    };
    let (errs, sync) = run(
        &clock,
        PATH,
        SyncConfig::default(),
        seed,
        150.0 * S,
        30.0 * S,
    );
    let window = |a: f64, b: f64| -> Vec<_> {
        errs.iter()
            .copied()
            .filter(|e| e.0 >= a * S && e.0 < b * S)
            .collect()
    };
    let before = max_abs(&window(30.0, 60.0));
    let during = max_abs(&window(60.0, 100.0));
    let after = max_abs(&window(100.0, 150.0));
    let settle = |bound: f64| {
        errs.iter()
            .rev()
            .find(|e| e.1.abs() > bound)
            .map_or(0.0, |e| e.0 / S - 60.0)
    };
    (before, during, after, settle(10.0), settle(15.0), sync)
}

#[test]
fn tracks_a_drift_change() {
    // (seed, skew before, skew after): a crystal warming up, a small step,
    // the whole ±200 ppm range at once.
    let cases = [
        (9, 200e-6, 150e-6),
        (10, 200e-6, 150e-6),
        (11, -100e-6, -80e-6),
        (12, 0.0, 200e-6),
        (13, 150e-6, 100e-6),
    ];
    for (seed, from, to) in cases {
        let (before, during, after, settle, settle15, sync) = drift_step(seed, from, to);
        eprintln!(
            "drift {:+.0} → {:+.0} ppm at 60 s: max error before {before:.1} µs, in the 40 s after {during:.1} µs, from 100 s on {after:.1} µs; last error over 10 µs {settle:.1} s, over 15 µs {settle15:.1} s after the change; skew now {:.2} ppm, {} changes detected",
            from * 1e6,
            to * 1e6,
            sync.model().skew * 1e6,
            sync.changes()
        );
        let step_ppm = ((to - from) * 1e6).abs();
        assert!(before <= 10.0, "seed {seed}: {before:.1} µs before");
        // About 1.5 s of the step's drift before the alarm.
        assert!(
            during <= 2.0 * step_ppm + 20.0,
            "seed {seed}: peak {during:.1} µs"
        );
        // Steady-state noise alone can pass 10 µs now and then: the
        // recovery is judged at 15 µs.
        assert!(
            settle15 <= 12.0,
            "seed {seed}: settled after {settle15:.1} s"
        );
        assert!(after <= 10.0, "seed {seed}: {after:.1} µs after");
        assert!(sync.changes() >= 1);
        assert!((sync.model().skew - to).abs() < 1e-6);
    }
}

/// A rate that jumps further than a crystal moves at once (a clock source
/// gone bad, a board swapped under a running host): the estimate still
/// reaches the new rate, so the host sees it (and a run stops on a rate out
/// of range) rather than holding on to the old one.
#[test]
fn follows_a_jump_beyond_the_change_bound() {
    // (seed, skew before, skew after)
    let cases = [
        (21, 150e-6, 900e-6),
        (22, 0.0, -700e-6),
        (23, 200e-6, -200e-6),
    ];
    for (seed, from, to) in cases {
        let (before, during, after, _, settle15, sync) = drift_step(seed, from, to);
        eprintln!(
            "jump {:+.0} → {:+.0} ppm at 60 s: max error before {before:.1} µs, in the 40 s after {during:.1} µs, from 100 s on {after:.1} µs, last over 15 µs {settle15:.1} s after; skew now {:.2} ppm, {} changes",
            from * 1e6,
            to * 1e6,
            sync.model().skew * 1e6,
            sync.changes()
        );
        assert!(before <= 10.0, "seed {seed}: {before:.1} µs before");
        assert!(
            settle15 <= 20.0,
            "seed {seed}: settled after {settle15:.1} s"
        );
        assert!(after <= 10.0, "seed {seed}: {after:.1} µs after");
        assert!(
            (sync.model().skew - to).abs() < 1e-6,
            "seed {seed}: skew {:.2} ppm",
            sync.model().skew * 1e6
        );
    }
}

#[test]
fn stalls_are_gated_out() {
    // Every 50th exchange is held up by 30 ms (a retransmission, a busy host).
    let clock = Crystal {
        offset: 0.0,
        skews: vec![(0.0, 100e-6)],
    };
    let mut sync = ClockSync::default();
    let mut rng = Rng::new(3);
    let mut worst = 0.0f64;
    for i in 0..12_000u64 {
        let t1 = 1_000.0 + i as f64 * 10_000.0;
        let stall = if i % 50 == 0 { 30_000.0 } else { 0.0 };
        let d1 = 50.0 + 1_000.0 * rng.unit() + stall;
        let d2 = 50.0 + 1_000.0 * rng.unit();
        sync.add(clock.exchange(t1, d1, 20.0, d2)).unwrap();
        if t1 > 30.0 * S {
            worst = worst.max((sync.host_to_local(t1) - clock.local(t1)).abs());
        }
    }
    // All stalls but the very first (nothing to compare it with yet).
    assert_eq!(sync.counts().1, 239);
    assert!(worst <= 10.0, "{worst}");
}

/// The skews every exchange allows are hard limits: whatever delays a busy
/// host or node adds (late stamps on either side, alone or in bursts of
/// slow exchanges between fast ones, up to half a second), a crystal of
/// constant rate always lies inside them, so a run is never stopped for a
/// rate a good node does not have; on a clean path they close in on the
/// rate. (The estimate's own bound is a statistic: bursts like these push
/// it past the true rate by tens of ppm.)
#[test]
fn feasible_skews_always_hold_a_steady_rate() {
    // (seed, skew, jitter µs, held up by up to µs, how: one exchange in
    // `every`, or bursts of `every` slow exchanges then as many fast ones)
    let cases = [
        (31, 200e-6, 1_000.0, 500_000.0, Held::OneIn(5)),
        (32, -200e-6, 50.0, 80_000.0, Held::OneIn(3)),
        (33, 0.0, 10.0, 30_000.0, Held::OneIn(2)),
        (34, 499e-6, 3_000.0, 200_000.0, Held::OneIn(7)),
        (35, -37e-6, 0.0, 0.0, Held::OneIn(0)),
        (12, 200e-6, 20.0, 60_000.0, Held::Bursts(22)),
        (39, 200e-6, 20.0, 60_000.0, Held::Bursts(19)),
        (7, -150e-6, 20.0, 20_000.0, Held::Bursts(17)),
    ];
    for (seed, skew, jitter, stall, how) in cases {
        let clock = Crystal {
            offset: 9e6,
            skews: vec![(0.0, skew)],
        };
        let mut sync = ClockSync::default();
        let mut rng = Rng::new(seed);
        let mut width = f64::INFINITY;
        let mut h: f64 = 1_000.0;
        for i in 0..3_000u64 {
            let slow = match how {
                Held::OneIn(n) => n > 0 && i % n == 0,
                Held::Bursts(n) => (i / n) % 2 == 0,
            };
            let held = |rng: &mut Rng| if slow { stall * rng.unit() } else { 0.0 };
            let t1 = h.floor();
            let d1 = 30.0 + jitter * rng.unit() + held(&mut rng);
            let turn = 20.0 + 0.1 * held(&mut rng);
            let d2 = 30.0 + jitter * rng.unit() + held(&mut rng);
            sync.add(clock.exchange(t1, d1, turn, d2)).unwrap();
            if let Some((lo, hi)) = sync.feasible_skew() {
                assert!(
                    lo <= skew && skew <= hi,
                    "seed {seed}, exchange {i}: {:.1} ppm outside [{:.1}, {:.1}]",
                    skew * 1e6,
                    lo * 1e6,
                    hi * 1e6
                );
                width = hi - lo;
            }
            h += 10_000.0 + held(&mut rng);
        }
        if jitter <= 50.0 {
            assert!(width < 20e-6, "seed {seed}: {:.1} ppm wide", width * 1e6);
        }
    }
}

/// How the exchanges of [`feasible_skews_always_hold_a_steady_rate`] are
/// held up.
#[derive(Clone, Copy)]
enum Held {
    OneIn(u64),
    Bursts(u64),
}

/// A rate step is told from the exchanges alone: the rates every exchange
/// before the change allowed and those every exchange since allows, hard
/// limits both. A jump (a clock source gone bad) leaves them hundreds of
/// ppm apart, a crystal warming by 50 ppm leaves them within it, and a
/// steady crystal under jitter and stalls reports no step at all.
#[test]
fn a_rate_step_is_told_by_every_exchange() {
    // (seed, skew before, skew after, jitter µs, least and most gap ppm)
    let cases = [
        (41, 150e-6, 450e-6, 0.0, 200.0, 300.0),
        (42, 150e-6, -300e-6, 1_000.0, 100.0, 450.0),
        (43, 200e-6, 150e-6, 20.0, -1e9, 50.0),
    ];
    for (seed, from, to, jitter, least, most) in cases {
        let clock = Crystal {
            offset: 3e6,
            skews: vec![(0.0, from), (60.0 * S, to)],
        };
        let path = Path { jitter, ..PATH };
        let (_, sync) = run(&clock, path, SyncConfig::default(), seed, 90.0 * S, 0.0);
        let Some(((blo, bhi), (alo, ahi))) = sync.rate_step() else {
            panic!("seed {seed}: no step told after {} changes", sync.changes())
        };
        assert!(
            blo <= from && from <= bhi,
            "seed {seed}: before [{blo}, {bhi}]"
        );
        assert!(alo <= to && to <= ahi, "seed {seed}: after [{alo}, {ahi}]");
        let gap = (alo - bhi).max(blo - ahi) * 1e6;
        assert!(least <= gap && gap <= most, "seed {seed}: gap {gap:.1} ppm");
    }
    // Steady, with jitter and stalls: no step, whatever the estimate did.
    let clock = Crystal {
        offset: 0.0,
        skews: vec![(0.0, -120e-6)],
    };
    let mut sync = ClockSync::default();
    let mut rng = Rng::new(44);
    for i in 0..12_000u64 {
        let t1 = 1_000.0 + i as f64 * 10_000.0;
        let stall = if i % 37 == 0 {
            8_000.0 * rng.unit()
        } else {
            0.0
        };
        let d1 = 50.0 + 2_000.0 * rng.unit() + stall;
        let d2 = 50.0 + 2_000.0 * rng.unit();
        sync.add(clock.exchange(t1, d1, 20.0, d2)).unwrap();
        if let Some(((blo, bhi), (alo, ahi))) = sync.rate_step() {
            let gap = (alo - bhi).max(blo - ahi);
            assert!(gap <= 0.0, "exchange {i}: a step of {:.1} ppm", gap * 1e6);
        }
    }
}

/// A clock whose time jumps (its rate steady) is followed to its new time
/// at once, not held halfway by the assumption that only its rate changed.
#[test]
fn a_jump_in_time_is_followed_at_the_old_rate() {
    let (skew, jump) = (150e-6, 5_000.0);
    let local = |h: f64| 7e6 + h * (1.0 + skew) + if h >= 30.0 * S { jump } else { 0.0 };
    let mut sync = ClockSync::default();
    let mut h = 1_000.0;
    let mut worst_after = 0.0f64;
    while h < 40.0 * S {
        let t1 = h.floor();
        let e = Exchange {
            t1: t1 as u64,
            t2: local(t1 + 50.0).floor() as u64,
            t3: local(t1 + 70.0).floor() as u64,
            t4: (t1 + 120.0) as u64,
        };
        sync.add(e).unwrap();
        if h > 30.5 * S {
            worst_after = worst_after.max((sync.host_to_local(h) - local(h)).abs());
        }
        h += if h < 30.0 * S { 1_000_000.0 } else { 10_000.0 };
    }
    assert!(sync.changes() >= 1);
    assert!(
        worst_after < 5.0,
        "{worst_after:.1} µs off half a second after"
    );
    assert!((sync.model().skew - skew).abs() < 1e-6);
}
