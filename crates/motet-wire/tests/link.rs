//! The reliable link between two `Link`s through a fault-injecting channel on
//! a simulated clock.

use motet_wire::frame::{self, Deframer, Flags, Header, MAX_FRAME, MAX_PAYLOAD};
use motet_wire::link::{Config, Link, LinkError, SendError, State, WINDOW};
use std::collections::VecDeque;

/// xorshift64* — small, seeded, good enough for fault injection.
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
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn chance(&mut self, p: f64) -> bool {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 <= p && p > 0.0
    }
}

/// Fault rates, each per frame.
#[derive(Clone, Copy, Debug)]
struct Faults {
    corrupt: f64,
    drop: f64,
    duplicate: f64,
    delay: f64,
    reorder: f64,
}

impl Faults {
    const NONE: Faults = Faults {
        corrupt: 0.0,
        drop: 0.0,
        duplicate: 0.0,
        delay: 0.0,
        reorder: 0.0,
    };
    const fn all(p: f64) -> Faults {
        Faults {
            corrupt: p,
            drop: p,
            duplicate: p,
            delay: p,
            reorder: p,
        }
    }
}

#[derive(Default, Debug)]
struct FaultCounts {
    sent: u64,
    corrupted: u64,
    dropped: u64,
    duplicated: u64,
    delayed: u64,
    reordered: u64,
}

/// One direction of a lossy link: frames arrive after `latency` plus up to
/// `jitter` µs, in order unless a fault says otherwise.
struct Channel {
    rng: Rng,
    faults: Faults,
    latency: u64,
    jitter: u64,
    /// (deliver at, order, bytes)
    queue: Vec<(u64, u64, Vec<u8>)>,
    order: u64,
    last_at: u64,
    counts: FaultCounts,
}

impl Channel {
    fn new(seed: u64, faults: Faults, latency: u64, jitter: u64) -> Channel {
        Channel {
            rng: Rng::new(seed),
            faults,
            latency,
            jitter,
            queue: Vec::new(),
            order: 0,
            last_at: 0,
            counts: FaultCounts::default(),
        }
    }

    fn send(&mut self, bytes: &[u8], now: u64) {
        self.counts.sent += 1;
        let f = self.faults;
        if self.rng.chance(f.drop) {
            self.counts.dropped += 1;
            return;
        }
        let mut bytes = bytes.to_vec();
        if self.rng.chance(f.corrupt) {
            self.counts.corrupted += 1;
            for _ in 0..1 + self.rng.below(3) {
                let i = self.rng.below(bytes.len() as u64) as usize;
                bytes[i] ^= 1 << self.rng.below(8);
            }
        }
        let mut at = (now + self.latency + self.rng.below(self.jitter + 1)).max(self.last_at);
        self.last_at = at;
        self.order += 2;
        let mut order = self.order;
        if self.rng.chance(f.delay) {
            self.counts.delayed += 1;
            at += 2_000 + self.rng.below(20_000);
        } else if self.rng.chance(f.reorder) {
            // Overtake the frame queued before this one.
            if let Some(prev) = self.queue.iter().max_by_key(|e| e.1) {
                self.counts.reordered += 1;
                at = prev.0;
                order = prev.1 - 1;
            }
        }
        if self.rng.chance(f.duplicate) {
            self.counts.duplicated += 1;
            let later = at + self.rng.below(3_000);
            self.queue.push((later, order + 1, bytes.clone()));
        }
        self.queue.push((at, order, bytes));
    }

    fn due(&mut self, now: u64) -> Vec<Vec<u8>> {
        self.queue.sort_by_key(|e| (e.0, e.1));
        let n = self.queue.iter().take_while(|e| e.0 <= now).count();
        self.queue.drain(..n).map(|e| e.2).collect()
    }
}

fn payload(rng: &mut Rng, i: usize) -> Vec<u8> {
    let len = match i % 10 {
        0 => 0,
        1 => MAX_PAYLOAD,
        _ => rng.below(MAX_PAYLOAD as u64 + 1) as usize,
    };
    (0..len).map(|_| rng.next() as u8).collect()
}

/// One end: a link, what it still has to send, what it got.
struct End {
    link: Link,
    to_send: VecDeque<Vec<u8>>,
    got: Vec<Vec<u8>>,
    deframer: Deframer,
}

impl End {
    fn new(cfg: Config, payloads: Vec<Vec<u8>>) -> End {
        End {
            link: Link::new(cfg),
            to_send: payloads.into(),
            got: Vec::new(),
            deframer: Deframer::new(),
        }
    }

    fn offer(&mut self, now: u64) {
        while let Some(p) = self.to_send.front() {
            match self.link.send(p, now) {
                Ok(()) => {
                    self.to_send.pop_front();
                }
                Err(SendError::WindowFull) => break,
                Err(e) => panic!("{e:?}"),
            }
        }
    }

    fn receive(&mut self, bytes: &[u8], now: u64, stream: bool) {
        if !stream {
            if let Some(d) = self.link.on_frame(bytes, now) {
                self.got.push(d.payload.to_vec());
            }
        } else {
            let mut rest = bytes;
            while !rest.is_empty() {
                let (n, r) = self.deframer.push(rest);
                rest = &rest[n..];
                match r {
                    Some(Ok(f)) => {
                        if let Some(d) = self.link.on_decoded(&f, now) {
                            self.got.push(d.payload.to_vec());
                        }
                    }
                    Some(Err(e)) => self.link.on_frame_error(e),
                    None => {}
                }
            }
        }
        while let Some(d) = self.link.recv() {
            self.got.push(d.payload.to_vec());
        }
    }

    fn transmit(&mut self, now: u64, ch: &mut Channel) {
        let mut out = [0u8; MAX_FRAME];
        while let Some(f) = self.link.poll(now, &mut out) {
            ch.send(f, now);
        }
    }
}

struct Sim {
    a: End,
    b: End,
    ab: Channel,
    ba: Channel,
    now: u64,
    stream: bool,
}

impl Sim {
    fn new(seed: u64, faults: Faults, n_ab: usize, n_ba: usize, stream: bool) -> Sim {
        let mut rng = Rng::new(seed ^ 0xABCD);
        let pa: Vec<_> = (0..n_ab).map(|i| payload(&mut rng, i)).collect();
        let pb: Vec<_> = (0..n_ba).map(|i| payload(&mut rng, i)).collect();
        let host = Config {
            isn: 65_530, // wraps early
            ..Config::new(0x0001, 0x0102, true)
        };
        let node = Config {
            isn: 12_345,
            ..Config::new(0x0102, 0x0001, false)
        };
        Sim {
            a: End::new(host, pa),
            b: End::new(node, pb),
            ab: Channel::new(seed, faults, 300, 200),
            ba: Channel::new(seed.wrapping_add(1), faults, 300, 200),
            now: 0,
            stream,
        }
    }

    fn step(&mut self, dt: u64) {
        self.now += dt;
        let now = self.now;
        for bytes in self.ab.due(now) {
            self.b.receive(&bytes, now, self.stream);
        }
        for bytes in self.ba.due(now) {
            self.a.receive(&bytes, now, self.stream);
        }
        self.a.offer(now);
        self.b.offer(now);
        self.a.transmit(now, &mut self.ab);
        self.b.transmit(now, &mut self.ba);
    }

    fn run_until(&mut self, limit: u64, done: impl Fn(&Sim) -> bool) {
        while !done(self) {
            assert!(self.now < limit, "stuck at {} µs", self.now);
            self.step(50);
        }
    }
}

/// Sends `n` payloads each way through the faults; every payload arrives
/// exactly once, in order, unchanged.
fn exactly_once_in_order(seed: u64, faults: Faults, n: usize, stream: bool) -> Sim {
    let mut sim = Sim::new(seed, faults, n, n, stream);
    let want_ab: Vec<_> = sim.a.to_send.iter().cloned().collect();
    let want_ba: Vec<_> = sim.b.to_send.iter().cloned().collect();
    sim.run_until(600_000_000, |s| s.a.got.len() >= n && s.b.got.len() >= n);
    // Let late duplicates arrive too: nothing more may be delivered.
    for _ in 0..2_000 {
        sim.step(50);
    }
    assert_eq!(sim.b.got.len(), n);
    assert_eq!(sim.a.got.len(), n);
    assert!(sim.b.got == want_ab, "a→b payloads differ");
    assert!(sim.a.got == want_ba, "b→a payloads differ");
    for e in [&sim.a, &sim.b] {
        assert!(matches!(e.link.state(), State::Established { version: 1 }));
        assert_eq!(e.link.unacked(), 0);
    }
    sim
}

fn report(name: &str, sim: &Sim) {
    let s = sim.a.link.stats();
    eprintln!(
        "{name}: {:.2} s simulated; channel a→b {:?}; host stats: retransmits {} (timeouts {}, fast {}), crc errors {}, cobs errors {}, duplicates dropped {}, out of window {}, srtt {} µs, rto {} µs",
        sim.now as f64 / 1e6,
        sim.ab.counts,
        s.retransmits,
        s.timeouts,
        s.fast_retransmits,
        s.crc_errors,
        s.cobs_errors,
        s.duplicates_dropped,
        s.out_of_window,
        s.srtt_us,
        s.rto_us,
    );
}

#[test]
fn ten_thousand_payloads_through_one_percent_faults() {
    let sim = exactly_once_in_order(1, Faults::all(0.01), 10_000, false);
    report("1 % each, 10 000 each way", &sim);
    let c = &sim.ab.counts;
    assert!(c.corrupted > 50 && c.dropped > 50 && c.duplicated > 50);
    assert!(c.delayed > 50 && c.reordered > 50);
    let s = sim.b.link.stats();
    assert!(s.crc_errors + s.cobs_errors > 0 && s.duplicates_dropped > 0);
    assert!(sim.a.link.stats().retransmits > 0);
}

#[test]
fn fault_mixes() {
    // (seed, faults, payloads each way, byte stream through a Deframer)
    let cases = [
        (2, Faults::NONE, 2_000, false),
        (3, Faults::all(0.01), 3_000, true),
        (4, Faults::all(0.05), 2_000, false),
        (5, Faults::all(0.05), 2_000, true),
        (
            6,
            Faults {
                drop: 0.2,
                ..Faults::NONE
            },
            1_000,
            false,
        ),
        (
            7,
            Faults {
                corrupt: 0.2,
                ..Faults::NONE
            },
            1_000,
            true,
        ),
        (
            8,
            Faults {
                duplicate: 0.3,
                reorder: 0.3,
                ..Faults::NONE
            },
            1_000,
            false,
        ),
        (
            9,
            Faults {
                delay: 0.1,
                ..Faults::NONE
            },
            1_000,
            false,
        ),
    ];
    for (seed, faults, n, stream) in cases {
        let sim = exactly_once_in_order(seed, faults, n, stream);
        report(&format!("seed {seed} {faults:?} stream {stream}"), &sim);
        if seed == 2 {
            // No faults: no timeouts, no retransmissions.
            assert_eq!(sim.a.link.stats().retransmits, 0);
            assert_eq!(sim.a.link.stats().timeouts, 0, "seed {seed}");
        }
    }
}

/// Runs a and b against each other without faults until `done`.
fn handshake(a: Config, b: Config) -> (Link, Link) {
    let mut a = Link::new(a);
    let mut b = Link::new(b);
    let mut out = [0u8; MAX_FRAME];
    for now in (0..50_000u64).step_by(100) {
        while let Some(f) = a.poll(now, &mut out) {
            let f = f.to_vec();
            b.on_frame(&f, now);
        }
        while let Some(f) = b.poll(now, &mut out) {
            let f = f.to_vec();
            a.on_frame(&f, now);
        }
    }
    (a, b)
}

#[test]
fn version_negotiation() {
    // (host range, node range, agreed version or None)
    let cases = [
        ((1, 1), (1, 1), Some(1)),
        ((1, 3), (2, 5), Some(3)),
        ((2, 5), (1, 3), Some(3)),
        ((4, 9), (1, 4), Some(4)),
        ((1, 1), (2, 3), None),
        ((3, 4), (1, 2), None),
    ];
    for (h, n, agreed) in cases {
        let host = Config {
            version_min: h.0,
            version_max: h.1,
            ..Config::new(1, 2, true)
        };
        let node = Config {
            version_min: n.0,
            version_max: n.1,
            ..Config::new(2, 1, false)
        };
        let (mut a, mut b) = handshake(host, node);
        match agreed {
            Some(v) => {
                assert_eq!(a.state(), State::Established { version: v });
                assert_eq!(b.state(), State::Established { version: v });
            }
            None => {
                let want_a = LinkError::VersionMismatch { ours: h, theirs: n };
                let want_b = LinkError::VersionMismatch { ours: n, theirs: h };
                assert_eq!(a.state(), State::Failed(want_a), "{h:?} {n:?}");
                assert_eq!(b.state(), State::Failed(want_b), "{h:?} {n:?}");
                // No data either way.
                assert_eq!(a.send(b"x", 60_000), Err(SendError::Failed(want_a)));
                let mut out = [0u8; MAX_FRAME];
                let hdr = Header {
                    dst: 2,
                    src: 1,
                    port: 10,
                    flags: Flags::DATA | Flags::ACK,
                    seq: 1,
                    ack: 1,
                };
                for seq in 0..20 {
                    let n = frame::encode(&Header { seq, ..hdr }, b"move", &mut out).unwrap();
                    assert!(b.on_frame(&out[..n], 60_000).is_none());
                }
                assert!(b.recv().is_none());
                assert!(b.stats().refused >= 20);
                assert_eq!(b.stats().payloads_delivered, 0);
            }
        }
    }
}

#[test]
fn data_before_handshake_is_refused_and_queued_data_waits() {
    let mut node = Link::new(Config::new(2, 1, false));
    let mut out = [0u8; MAX_FRAME];
    let hdr = Header {
        dst: 2,
        src: 1,
        port: 10,
        flags: Flags::DATA,
        seq: 1,
        ack: 0,
    };
    let n = frame::encode(&hdr, b"early", &mut out).unwrap();
    assert!(node.on_frame(&out[..n], 0).is_none());
    assert_eq!(node.stats().refused, 1);
    // A passive link sends nothing before a SYN, even with data queued.
    node.send(b"queued", 0).unwrap();
    assert!(node.poll(0, &mut out).is_none());
    assert_eq!(node.next_timeout(), None);
    // Frames for someone else are counted and ignored.
    let n = frame::encode(&Header { dst: 3, ..hdr }, b"x", &mut out).unwrap();
    assert!(node.on_frame(&out[..n], 0).is_none());
    assert_eq!(node.stats().foreign, 1);
}

#[test]
fn peer_restart_is_reported() {
    let (mut a, _b) = handshake(Config::new(1, 2, true), Config::new(2, 1, false));
    assert!(matches!(a.state(), State::Established { .. }));
    // The node reboots with a new ISN and connects again.
    let mut b2 = Link::new(Config {
        isn: 777,
        ..Config::new(2, 1, true)
    });
    let mut out = [0u8; MAX_FRAME];
    let syn = b2.poll(0, &mut out).unwrap().to_vec();
    a.on_frame(&syn, 100);
    assert_eq!(a.state(), State::Failed(LinkError::PeerReset));
    // a answers with RST, which fails b2 too.
    let rst = a.poll(100, &mut out).unwrap().to_vec();
    b2.on_frame(&rst, 200);
    assert_eq!(b2.state(), State::Failed(LinkError::PeerReset));
}

/// A lossless sim with a fixed one-way latency.
fn steady(latency: u64) -> Sim {
    let mut sim = Sim::new(11, Faults::NONE, 0, 0, false);
    sim.ab.latency = latency;
    sim.ba.latency = latency;
    sim.ab.jitter = 0;
    sim.ba.jitter = 0;
    sim
}

fn pump(sim: &mut Sim, n: usize, start: u8) {
    let mut rng = Rng::new(start as u64);
    for i in 0..n {
        sim.a.to_send.push_back(payload(&mut rng, i));
    }
    let target = sim.b.got.len() + n;
    sim.run_until(sim.now + 600_000_000, |s| {
        s.b.got.len() >= target && s.a.link.unacked() == 0
    });
}

#[test]
fn rto_adapts_to_rtt() {
    // (one-way latency µs, expected RTT µs)
    for (latency, _) in [(1_000u64, 2_000u64), (5_000, 10_000), (20_000, 40_000)] {
        let mut sim = steady(latency);
        pump(&mut sim, 200, 1);
        let s = *sim.a.link.stats();
        let rtt = 2 * latency;
        // Samples are the RTT plus up to one 50 µs simulation step each way.
        assert!(
            s.srtt_us >= rtt && s.srtt_us <= rtt + 200,
            "{latency}: {s:?}"
        );
        assert!(
            s.rto_us >= s.srtt_us && s.rto_us <= s.srtt_us + 1_000,
            "{s:?}"
        );
        assert_eq!(s.timeouts, 0, "{latency}: spurious timeouts");
        // The path slows down: SRTT and RTO follow, with at most a few timeouts.
        sim.ab.latency = 4 * latency;
        sim.ba.latency = 4 * latency;
        pump(&mut sim, 200, 2);
        let s2 = *sim.a.link.stats();
        assert!(
            s2.srtt_us >= 7 * latency && s2.srtt_us <= 8 * latency + 300,
            "{s2:?}"
        );
        assert!(s2.rto_us > s2.srtt_us);
        assert!(s2.timeouts <= 3, "{s2:?}");
        eprintln!(
            "latency {latency} µs: srtt {} → {} µs, rto {} → {} µs, timeouts {}",
            s.srtt_us, s2.srtt_us, s.rto_us, s2.rto_us, s2.timeouts
        );
    }
    // A fast path clamps at the minimum RTO.
    let mut sim = steady(100);
    pump(&mut sim, 100, 3);
    assert_eq!(
        sim.a.link.stats().rto_us,
        Config::new(0, 0, true).min_rto_us
    );
}

#[test]
fn rto_backs_off_exponentially_to_the_cap() {
    let mut sim = steady(1_000);
    pump(&mut sim, 20, 1);
    let base = sim.a.link.rto();
    // The peer goes silent: every frame a→b is lost.
    sim.ab.faults.drop = 1.0;
    sim.a.to_send.push_back(vec![1, 2, 3]);
    let mut sent_at = Vec::new();
    let mut out = [0u8; MAX_FRAME];
    for _ in 0..200_000 {
        sim.now += 50;
        sim.a.offer(sim.now);
        while sim.a.link.poll(sim.now, &mut out).is_some() {
            sent_at.push(sim.now);
        }
        if sent_at.len() >= 12 {
            break;
        }
    }
    let gaps: Vec<u64> = sent_at.windows(2).map(|w| w[1] - w[0]).collect();
    let cap = Config::new(0, 0, true).max_rto_us;
    for (i, g) in gaps.iter().enumerate() {
        let want = (base << i).min(cap);
        assert!(g.abs_diff(want) <= 50, "gap {i}: {g} vs {want} ({gaps:?})");
    }
    assert_eq!(*gaps.last().unwrap(), cap);
    // The path comes back: the payload arrives and a fresh sample resets the backoff.
    sim.ab.faults.drop = 0.0;
    sim.run_until(sim.now + 10_000_000, |s| s.a.link.unacked() == 0);
    // The first ack after retransmissions gives no sample (Karn); the next does.
    pump(&mut sim, 5, 4);
    assert!(sim.a.link.rto() < 4 * base, "{}", sim.a.link.rto());
}

#[test]
fn window_full_is_reported_not_lost() {
    let mut sim = steady(2_000);
    // Establish first.
    sim.run_until(1_000_000, |s| {
        matches!(s.a.link.state(), State::Established { .. })
            && matches!(s.b.link.state(), State::Established { .. })
    });
    let now = sim.now;
    let mut want = Vec::new();
    for i in 0..WINDOW {
        let p = vec![i as u8; i + 1];
        sim.a.link.send(&p, now).unwrap();
        want.push(p);
    }
    assert_eq!(sim.a.link.send_space(), 0);
    assert_eq!(
        sim.a.link.send(b"one too many", now),
        Err(SendError::WindowFull)
    );
    assert_eq!(
        sim.a.link.send(&[0; MAX_PAYLOAD + 1], now),
        Err(SendError::TooLong)
    );
    // The refused payload is the caller's: it is queued again later and
    // arrives after the others, exactly once.
    sim.a.to_send.push_back(b"one too many".to_vec());
    want.push(b"one too many".to_vec());
    sim.run_until(now + 1_000_000, |s| s.b.got.len() == WINDOW + 1);
    for _ in 0..1_000 {
        sim.step(50);
    }
    assert_eq!(sim.b.got, want);
}

#[test]
fn sequence_numbers_wrap() {
    // Start near the top of the u16 space on both sides; 70 000 payloads wrap once.
    let mut sim = Sim::new(21, Faults::all(0.002), 0, 0, false);
    let mut rng = Rng::new(5);
    let want: Vec<_> = (0..70_000u32)
        .map(|i| [i.to_le_bytes(), (rng.next() as u32).to_le_bytes()].concat())
        .collect();
    sim.a.to_send = want.iter().cloned().collect();
    sim.run_until(2_000_000_000, |s| s.b.got.len() >= 70_000);
    assert!(sim.b.got == want);
}
