//! Fault injection: a [`Transport`] wrapper that corrupts, drops,
//! duplicates, delays, reorders and jitters the frames arriving at its end.
//!
//! Faults are drawn from a seeded xorshift generator, so a run with the same
//! seed and the same traffic injects the same faults. Faults apply to frames
//! as they are received; wrap both ends of a pair to fault both directions.
//! Delays are counted in later frames or in µs of a [`FaultClock`], which is
//! either real time or a simulated clock the caller advances.

pub use crate::clock::SimClock;
use crate::{Crystal, LinkStats, Stamp, Transport};
use std::io;
use std::time::{Duration, Instant};

/// xorshift64*: tiny, seeded, reproducible.
#[derive(Clone, Debug)]
pub struct XorShift(u64);

impl XorShift {
    /// A generator seeded with `seed`; the same seed gives the same sequence
    /// (seed 0 is allowed).
    pub fn new(seed: u64) -> XorShift {
        // Spread small seeds and keep the state non-zero.
        XorShift(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [0, n); 0 when `n` is 0.
    pub fn below(&mut self, n: u64) -> u64 {
        if n == 0 {
            0
        } else {
            self.next_u64() % n
        }
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        p > 0.0 && self.unit() < p
    }
}

/// Where a [`Faulty`] transport reads the time for delays and jitter.
#[derive(Clone, Debug)]
pub enum FaultClock {
    /// Wall-clock µs since the transport was made; `recv` waits for delayed
    /// frames that come due within its timeout.
    Real(Instant),
    /// A shared µs counter the caller advances ([`SimClock::set`]); `recv`
    /// never waits for it.
    Simulated(SimClock),
}

impl FaultClock {
    /// Real time, starting now.
    pub fn real() -> FaultClock {
        FaultClock::Real(Instant::now())
    }

    /// µs since the clock's origin (creation for [`FaultClock::Real`], the
    /// shared counter for [`FaultClock::Simulated`]).
    pub fn now_us(&self) -> u64 {
        match self {
            FaultClock::Real(t0) => t0.elapsed().as_micros() as u64,
            FaultClock::Simulated(c) => c.get(),
        }
    }
}

impl crate::clock::Clock for FaultClock {
    fn now_us(&self) -> u64 {
        FaultClock::now_us(self)
    }

    fn real(&self, us: u64) -> Duration {
        match self {
            FaultClock::Real(_) => Duration::from_micros(us),
            FaultClock::Simulated(_) => Duration::ZERO,
        }
    }
}

/// Fault rates (probability per received frame) and sizes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultConfig {
    /// Seed of the fault generator: the same seed and traffic give the same
    /// faults.
    pub seed: u64,
    /// Flip one byte (never the trailing delimiter, never into 0x00).
    pub corrupt: f64,
    /// Lose the frame.
    pub drop: f64,
    /// Deliver a second copy right after the frame.
    pub duplicate: f64,
    /// Hold the frame back by 1..=[`FaultConfig::delay_frames`] later frames
    /// or 1..=[`FaultConfig::delay_us`] µs (one of the two at random when
    /// both are set).
    pub delay: f64,
    /// Most later frames a frame is held back for.
    pub delay_frames: u32,
    /// Most µs a frame is held back for.
    pub delay_us: u64,
    /// Swap the frame with the next one to arrive.
    pub reorder: f64,
    /// Extra delay of every frame, uniform over [0, jitter_us] µs; frames may
    /// overtake each other.
    pub jitter_us: u64,
    /// A frame held for later frames is released after this long anyway, so
    /// that a quiet line does not keep it forever.
    pub hold_limit_us: u64,
}

impl Default for FaultConfig {
    /// No faults; delays of up to 4 frames or 5 ms when enabled.
    fn default() -> Self {
        FaultConfig {
            seed: 1,
            corrupt: 0.0,
            drop: 0.0,
            duplicate: 0.0,
            delay: 0.0,
            delay_frames: 4,
            delay_us: 5_000,
            reorder: 0.0,
            jitter_us: 0,
            hold_limit_us: 50_000,
        }
    }
}

impl FaultConfig {
    /// Every fault at rate `p`.
    pub fn all(seed: u64, p: f64) -> FaultConfig {
        FaultConfig {
            seed,
            corrupt: p,
            drop: p,
            duplicate: p,
            delay: p,
            reorder: p,
            ..FaultConfig::default()
        }
    }

    /// Only jitter of up to `jitter_us`.
    pub fn jitter(seed: u64, jitter_us: u64) -> FaultConfig {
        FaultConfig {
            seed,
            jitter_us,
            ..FaultConfig::default()
        }
    }
}

/// What a [`Faulty`] transport did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FaultCounts {
    /// Frames taken from the inner transport.
    pub frames: u64,
    /// Frames that had one byte flipped.
    pub corrupted: u64,
    /// Frames lost.
    pub dropped: u64,
    /// Frames delivered twice.
    pub duplicated: u64,
    /// Frames held back behind later frames.
    pub delayed_frames: u64,
    /// Frames held back for a time.
    pub delayed_time: u64,
    /// Frames swapped with the next one.
    pub reordered: u64,
    /// Frames given a non-zero jitter delay.
    pub jittered: u64,
}

impl FaultCounts {
    /// Faults injected (jitter not counted).
    pub fn injected(&self) -> u64 {
        self.corrupted
            + self.dropped
            + self.duplicated
            + self.delayed_frames
            + self.delayed_time
            + self.reordered
    }
}

#[derive(Debug)]
struct Held {
    frame: Vec<u8>,
    /// Later frames still to arrive before release.
    after: u32,
    /// Not before this time.
    not_before: u64,
    /// Released at this time even if `after` is not 0.
    limit: u64,
    /// When the frames it waited for had arrived.
    freed_at: u64,
}

impl Held {
    fn due(&self, now: u64) -> bool {
        (self.after == 0 && now >= self.not_before) || now >= self.limit
    }

    /// When it came due: its arrival on the faulty link.
    fn arrival(&self) -> u64 {
        if self.after == 0 {
            self.not_before.max(self.freed_at).min(self.limit)
        } else {
            self.limit
        }
    }
}

/// A transport whose received frames suffer the faults of a [`FaultConfig`].
#[derive(Debug)]
pub struct Faulty<T: Transport> {
    inner: T,
    name: String,
    cfg: FaultConfig,
    rng: XorShift,
    clock: FaultClock,
    /// In arrival order; the first due one goes out next.
    held: Vec<Held>,
    counts: FaultCounts,
    stats: LinkStats,
    /// On a simulated clock, the receiver's clock against it: frames are
    /// stamped with their arrival (see [`Faulty::stamping`]).
    stamps: Option<Crystal>,
    last_stamp: Option<Stamp>,
}

impl<T: Transport> Faulty<T> {
    /// Faults on a real-time clock.
    pub fn new(inner: T, cfg: FaultConfig) -> Faulty<T> {
        Self::with_clock(inner, cfg, FaultClock::real())
    }

    /// Faults on `clock`: a [`FaultClock::Simulated`] one lets a test run
    /// delays without waiting for them.
    pub fn with_clock(inner: T, cfg: FaultConfig, clock: FaultClock) -> Faulty<T> {
        Faulty {
            name: format!("faulty:{}", inner.name()),
            inner,
            rng: XorShift::new(cfg.seed),
            cfg,
            clock,
            held: Vec::new(),
            counts: FaultCounts::default(),
            stats: LinkStats::default(),
            stamps: None,
            last_stamp: None,
        }
    }

    /// Stamps every frame with the moment it arrives on the faulty link,
    /// its delays and jitter included, as a receiver whose clock reads
    /// `crystal` for the simulated clock's time would ([`Transport::last_stamp`]):
    /// a simulated network interface that timestamps on receipt. Only on a
    /// [`FaultClock::Simulated`] clock.
    pub fn stamping(mut self, crystal: Crystal) -> Faulty<T> {
        if let FaultClock::Simulated(_) = self.clock {
            self.stamps = Some(crystal);
        }
        self
    }

    /// What has been injected so far.
    pub fn counts(&self) -> &FaultCounts {
        &self.counts
    }

    /// The wrapped transport.
    pub fn inner(&self) -> &T {
        &self.inner
    }

    /// The wrapped transport, mutably (frames already taken from it stay
    /// subject to the faults).
    pub fn inner_mut(&mut self) -> &mut T {
        &mut self.inner
    }

    /// Frames received but not yet handed out.
    pub fn held(&self) -> usize {
        self.held.len()
    }

    fn corrupt(&mut self, frame: &mut [u8]) {
        let body = match frame.last() {
            Some(0) => frame.len() - 1,
            _ => frame.len(),
        };
        if body == 0 {
            return;
        }
        let i = self.rng.below(body as u64) as usize;
        let x = 1 + self.rng.below(255) as u8;
        // A 0x00 inside would also split a stream; keep the damage to one byte.
        frame[i] = if frame[i] ^ x == 0 {
            frame[i] ^ !x
        } else {
            frame[i] ^ x
        };
        self.counts.corrupted += 1;
    }

    /// Applies faults to one frame from the inner transport.
    fn admit(&mut self, frame: Vec<u8>) {
        let now = self.clock.now_us();
        self.counts.frames += 1;
        // Frames whose wait ends with this one go out behind it.
        let mut released = Vec::new();
        let mut i = 0;
        while i < self.held.len() {
            let h = &mut self.held[i];
            if h.after == 1 {
                h.after = 0;
                h.freed_at = now;
                released.push(self.held.remove(i));
            } else {
                h.after = h.after.saturating_sub(1);
                i += 1;
            }
        }
        self.place(frame, now);
        self.held.append(&mut released);
    }

    fn place(&mut self, mut frame: Vec<u8>, now: u64) {
        let c = self.cfg;
        if self.rng.chance(c.drop) {
            self.counts.dropped += 1;
            return;
        }
        if self.rng.chance(c.corrupt) {
            self.corrupt(&mut frame);
        }
        let jitter = self.rng.below(c.jitter_us.saturating_add(1));
        if jitter > 0 {
            self.counts.jittered += 1;
        }
        let mut held = Held {
            frame,
            after: 0,
            not_before: now + jitter,
            limit: u64::MAX,
            freed_at: now,
        };
        if self.rng.chance(c.delay) {
            let by_frames = match (c.delay_frames, c.delay_us) {
                (0, 0) => None,
                (_, 0) => Some(true),
                (0, _) => Some(false),
                _ => Some(self.rng.chance(0.5)),
            };
            match by_frames {
                Some(true) => {
                    held.after = 1 + self.rng.below(c.delay_frames as u64) as u32;
                    self.counts.delayed_frames += 1;
                }
                Some(false) => {
                    held.not_before += 1 + self.rng.below(c.delay_us);
                    self.counts.delayed_time += 1;
                }
                None => {}
            }
        } else if self.rng.chance(c.reorder) {
            held.after = 1;
            self.counts.reordered += 1;
        }
        if held.after > 0 {
            held.limit = now.saturating_add(c.hold_limit_us);
        }
        let copy = self.rng.chance(c.duplicate).then(|| Held {
            frame: held.frame.clone(),
            ..held
        });
        self.held.push(held);
        if let Some(copy) = copy {
            self.counts.duplicated += 1;
            self.held.push(copy);
        }
    }

    fn take_due(&mut self) -> Option<Vec<u8>> {
        let now = self.clock.now_us();
        let i = self.held.iter().position(|h| h.due(now))?;
        let h = self.held.remove(i);
        self.last_stamp = self.stamps.map(|c| Stamp {
            at_us: c.local(h.arrival() as f64),
            own: false,
        });
        Some(h.frame)
    }

    /// How long until the next held frame comes due by time alone (real
    /// clock only).
    fn next_due_in(&self) -> Option<Duration> {
        let FaultClock::Real(_) = self.clock else {
            return None;
        };
        let now = self.clock.now_us();
        self.held
            .iter()
            .map(|h| if h.after == 0 { h.not_before } else { h.limit })
            .min()
            .map(|t| Duration::from_micros(t.saturating_sub(now)))
    }
}

impl<T: Transport> Transport for Faulty<T> {
    fn name(&self) -> &str {
        &self.name
    }

    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        self.inner.send(frame)?;
        self.stats.sent(frame.len());
        Ok(())
    }

    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>> {
        let deadline = timeout.map(|d| Instant::now() + d);
        loop {
            while let Some(f) = self.inner.recv(None)? {
                self.admit(f);
            }
            if let Some(f) = self.take_due() {
                self.stats.received(f.len());
                return Ok(Some(f));
            }
            let Some(deadline) = deadline else {
                return Ok(None);
            };
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            let wait = self.next_due_in().map_or(left, |d| d.min(left));
            if let Some(f) = self.inner.recv(Some(wait))? {
                self.admit(f);
            }
        }
    }

    fn stats(&self) -> &LinkStats {
        &self.stats
    }

    fn last_stamp(&self) -> Option<Stamp> {
        self.last_stamp
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mem::pair;
    use crate::testutil::link_exchange_clocked;
    use crate::udp::UdpTransport;

    fn sim_pair(
        cfg: FaultConfig,
        clock: &SimClock,
    ) -> (Faulty<crate::MemTransport>, crate::MemTransport) {
        let (a, b) = pair("a", "b");
        (
            Faulty::with_clock(b, cfg, FaultClock::Simulated(clock.clone())),
            a,
        )
    }

    /// A stamping receiver reads each frame's arrival (its jitter
    /// included; for a reordered one, the arrival of the frame that freed
    /// it) through its crystal, however late it takes the frame.
    #[test]
    fn stamps_are_arrivals_in_the_receivers_clock() {
        let crystal = Crystal {
            ppm: -100.0,
            offset_us: 1_000_000,
        };
        let reorder = FaultConfig {
            reorder: 1.0,
            hold_limit_us: 1_000_000,
            ..FaultConfig::default()
        };
        // (faults, for frames 1, 2, 3 sent at 100, 200, 300 µs: the
        // earliest and latest arrival, host µs)
        type Case = (FaultConfig, [(u64, u64); 3]);
        let cases: [Case; 3] = [
            (FaultConfig::default(), [(100, 100), (200, 200), (300, 300)]),
            (
                FaultConfig::jitter(5, 400),
                [(100, 500), (200, 600), (300, 700)],
            ),
            (reorder, [(200, 200), (300, 300), (1_000_300, 1_000_300)]),
        ];
        for (cfg, want) in cases {
            let clock = SimClock::new();
            let (f, mut tx) = sim_pair(cfg, &clock);
            let mut f = f.stamping(crystal);
            let mut got = Vec::new();
            let mut take = |f: &mut Faulty<crate::MemTransport>| {
                while let Some(frame) = f.recv(None).unwrap() {
                    got.push((frame[0], crystal.reference(f.last_stamp().unwrap().at_us)));
                }
            };
            for (i, t) in [100, 200, 300].into_iter().enumerate() {
                clock.set(t);
                tx.send(&[i as u8 + 1, 0]).unwrap();
                take(&mut f);
            }
            clock.set(10_000_000);
            take(&mut f);
            got.sort();
            assert_eq!(got.len(), 3, "{cfg:?}");
            for ((id, at), (lo, hi)) in got.iter().zip(want) {
                // A whole µs of the receiver's clock either way.
                assert!(lo <= at + 1 && *at <= hi + 1, "{cfg:?}: frame {id} at {at}");
            }
        }
    }

    /// Sends frames `0..n` (one byte each, plus a delimiter) and collects what    /// Sends frames `0..n` (one byte each, plus a delimiter) and collects what
    /// comes out, advancing the simulated clock by `step` per frame.
    fn through(cfg: FaultConfig, n: u8, step: u64) -> (Vec<Vec<u8>>, FaultCounts) {
        let clock = SimClock::new();
        let (mut f, mut tx) = sim_pair(cfg, &clock);
        let mut out = Vec::new();
        for i in 0..n {
            tx.send(&[i + 1, 0]).unwrap();
            clock.advance(step);
            while let Some(g) = f.recv(None).unwrap() {
                out.push(g);
            }
        }
        clock.advance(1_000_000);
        while let Some(g) = f.recv(None).unwrap() {
            out.push(g);
        }
        (out, *f.counts())
    }

    #[test]
    fn no_faults_passes_everything_in_order() {
        let (out, c) = through(FaultConfig::default(), 200, 10);
        let want: Vec<Vec<u8>> = (0..200u8).map(|i| vec![i + 1, 0]).collect();
        assert_eq!(out, want);
        assert_eq!(c.injected(), 0);
        assert_eq!(c.frames, 200);
    }

    #[test]
    fn each_fault_alone() {
        let n = 250u8;
        let base = FaultConfig {
            seed: 7,
            ..FaultConfig::default()
        };
        // drop: fewer frames, order kept.
        let (out, c) = through(FaultConfig { drop: 0.2, ..base }, n, 10);
        assert!(c.dropped > 20 && c.injected() == c.dropped);
        assert_eq!(out.len() as u64, n as u64 - c.dropped);
        assert!(out.windows(2).all(|w| w[0][0] < w[1][0]));
        // corrupt: same count, one byte differs, delimiter kept, no new 0x00.
        let (out, c) = through(
            FaultConfig {
                corrupt: 0.2,
                ..base
            },
            n,
            10,
        );
        assert!(c.corrupted > 20);
        assert_eq!(out.len(), n as usize);
        let bad = out
            .iter()
            .enumerate()
            .filter(|(i, f)| f[0] != *i as u8 + 1)
            .count();
        assert_eq!(bad as u64, c.corrupted);
        assert!(out.iter().all(|f| f[0] != 0 && f[1] == 0));
        // duplicate: extra copies right after their original.
        let (out, c) = through(
            FaultConfig {
                duplicate: 0.2,
                ..base
            },
            n,
            10,
        );
        assert!(c.duplicated > 20);
        assert_eq!(out.len() as u64, n as u64 + c.duplicated);
        let mut dedup = out.clone();
        dedup.dedup();
        assert_eq!(dedup.len(), n as usize);
        // reorder and delay: everything arrives, not in order.
        for cfg in [
            FaultConfig {
                reorder: 0.2,
                ..base
            },
            FaultConfig {
                delay: 0.2,
                delay_us: 0,
                ..base
            },
            FaultConfig {
                delay: 0.2,
                delay_frames: 0,
                ..base
            },
            FaultConfig {
                jitter_us: 100,
                ..base
            },
        ] {
            let (out, c) = through(cfg, n, 10);
            assert_eq!(out.len(), n as usize, "{cfg:?}");
            let mut sorted = out.clone();
            sorted.sort();
            let want: Vec<Vec<u8>> = (0..n).map(|i| vec![i + 1, 0]).collect();
            assert_eq!(sorted, want, "{cfg:?}");
            let swaps = out.windows(2).filter(|w| w[0][0] > w[1][0]).count();
            assert!(swaps >= 5, "{cfg:?}: {swaps} out of order, {c:?}");
        }
    }

    #[test]
    fn same_seed_same_faults() {
        let cfg = FaultConfig::all(42, 0.1);
        let a = through(cfg, 200, 10);
        let b = through(cfg, 200, 10);
        assert_eq!(a, b);
        let c = through(FaultConfig { seed: 43, ..cfg }, 200, 10);
        assert_ne!(a.0, c.0);
    }

    #[test]
    fn time_delay_holds_until_clock_passes() {
        let clock = SimClock::new();
        let cfg = FaultConfig {
            delay: 1.0,
            delay_frames: 0,
            delay_us: 1_000,
            ..FaultConfig::default()
        };
        let (mut f, mut tx) = sim_pair(cfg, &clock);
        tx.send(&[5, 0]).unwrap();
        assert_eq!(f.recv(None).unwrap(), None);
        assert_eq!(f.held(), 1);
        clock.advance(1_000);
        assert_eq!(f.recv(None).unwrap(), Some(vec![5, 0]));
        // A quiet line releases frames held for later frames after the limit.
        let cfg = FaultConfig {
            reorder: 1.0,
            hold_limit_us: 500,
            ..FaultConfig::default()
        };
        let (mut f, mut tx) = sim_pair(cfg, &clock);
        tx.send(&[6, 0]).unwrap();
        assert_eq!(f.recv(None).unwrap(), None);
        clock.advance(500);
        assert_eq!(f.recv(None).unwrap(), Some(vec![6, 0]));
    }

    #[test]
    fn real_clock_recv_waits_for_delayed_frame() {
        let (mut a, b) = pair("a", "b");
        let cfg = FaultConfig {
            jitter_us: 0,
            delay: 1.0,
            delay_frames: 0,
            delay_us: 2_000,
            ..FaultConfig::default()
        };
        let mut f = Faulty::new(b, cfg);
        a.send(&[1, 0]).unwrap();
        assert_eq!(
            f.recv(Some(Duration::from_secs(5))).unwrap(),
            Some(vec![1, 0])
        );
        assert_eq!(f.counts().delayed_time, 1);
    }

    fn assert_faults_happened(c: &FaultCounts) {
        assert!(c.dropped > 0, "{c:?}");
        assert!(c.corrupted > 0, "{c:?}");
        assert!(c.duplicated > 0, "{c:?}");
        assert!(c.delayed_frames + c.delayed_time > 0, "{c:?}");
        assert!(c.reordered > 0, "{c:?}");
    }

    #[test]
    fn link_over_faulty_mem_delivers_10000_exactly_once_in_order() {
        let clock = SimClock::new();
        let (a, b) = pair("host", "node");
        let sim = || FaultClock::Simulated(clock.clone());
        let mut a = Faulty::with_clock(a, FaultConfig::all(11, 0.01), sim());
        let mut b = Faulty::with_clock(b, FaultConfig::all(12, 0.01), sim());
        let x = link_exchange_clocked(&mut a, &mut b, 10_000, None, &mut || {
            clock.advance(50);
            clock.get()
        });
        assert_eq!(x.got, (0..10_000).collect::<Vec<u32>>());
        assert_faults_happened(a.counts());
        assert_faults_happened(b.counts());
        assert!(x.host.retransmits > 0);
        assert!(x.host.crc_errors + x.node.crc_errors > 0);
    }

    #[test]
    fn link_over_faulty_udp_delivers_in_order() {
        let (a, b) = UdpTransport::loopback_pair().unwrap();
        let mut a = Faulty::new(a, FaultConfig::all(21, 0.01));
        let mut b = Faulty::new(b, FaultConfig::all(22, 0.01));
        let t0 = Instant::now();
        let got = link_exchange_clocked(
            &mut a,
            &mut b,
            3_000,
            Some(Duration::from_micros(500)),
            &mut || t0.elapsed().as_micros() as u64,
        )
        .got;
        assert_eq!(got, (0..3_000).collect::<Vec<u32>>());
        let (ca, cb) = (a.counts(), b.counts());
        assert!(ca.injected() + cb.injected() > 0);
        assert!(ca.dropped + cb.dropped > 0, "{ca:?} {cb:?}");
    }
}
