//! Segment batches: what the node rebuilds is what the host recorded, bit for
//! bit; no bytes make the decoder panic; no batch outgrows a message.

use motet_planner::{AxisLimits, Command, Limits, Move, MoveKind, Planned, Planner};
use motet_trajectory::profile::ramp_distance;
use motet_trajectory::{ProfileKind, Segment, MAX_AXES};
use motet_wire::stream::{BatchEncoder, BatchReader, Quantizer, StreamState};
use motet_wire::{decode, encode, HostMessage, SegmentBatch, StreamConfig, MAX_MESSAGE};
use proptest::prelude::*;

fn limits(profile: ProfileKind) -> Limits {
    let axis = |v: f64, a: f64, path: bool| AxisLimits {
        max_velocity: v,
        max_acceleration: a,
        max_jerk: Some(a * 20.0),
        path,
    };
    Limits {
        axes: vec![
            axis(300.0, 3000.0, true),
            axis(200.0, 2500.0, true),
            axis(15.0, 200.0, true),
            axis(60.0, 5000.0, false),
        ],
        joints: vec![],
        junction_deviation: 0.05,
        profile,
        tools: vec![],
        lookahead: 64,
        stop_horizon: 0,
        min_move_s: 0.0,
        max_move_s: 0.0,
    }
}

fn planned(profile: ProfileKind, moves: &[([f64; 4], f64, bool)]) -> Vec<Segment> {
    let mut p = Planner::new(limits(profile), [0.0; 6], 0.0);
    let mut pos = [0.0; 4];
    for (d, feed, dwell) in moves {
        for i in 0..4 {
            pos[i] += d[i];
        }
        p.push(&Command::Move(Move {
            target: [pos[0], pos[1], pos[2], pos[3], 0.0, 0.0],
            feed: *feed,
            kind: MoveKind::Feed,
        }))
        .unwrap();
        if *dwell {
            p.push(&Command::Dwell { seconds: 0.25 }).unwrap();
        }
    }
    p.finish();
    std::iter::from_fn(|| p.pop())
        .filter_map(|x| match x {
            Planned::Segment(s) => Some(s),
            _ => None,
        })
        .collect()
}

fn config() -> StreamConfig {
    StreamConfig {
        path_mask: 0b0111,
        ..StreamConfig::default()
    }
}

/// Same value, same bits, for the axes `mask` names.
fn assert_same(a: &Segment, b: &Segment, mask: u8) {
    let bits = |s: &Segment| {
        let p = s.profile.params();
        let mut v = vec![s.t0, p.length, p.v0, p.vc, p.v1, p.accel, p.jerk, p.dwell];
        for i in 0..MAX_AXES {
            if mask & (1 << i) != 0 {
                v.push(s.start[i]);
                v.push(s.end[i]);
            }
        }
        v.into_iter().map(f64::to_bits).collect::<Vec<_>>()
    };
    assert_eq!(bits(a), bits(b), "\n{a:?}\n{b:?}");
    assert_eq!(a.t1().to_bits(), b.t1().to_bits());
}

fn arb_moves() -> impl Strategy<Value = Vec<([f64; 4], f64, bool)>> {
    prop::collection::vec(
        (
            (-50.0..50.0f64, -50.0..50.0f64, -0.5..0.5f64, -1.0..3.0f64),
            1.0..400.0f64,
            0.0..1.0f64,
            prop::bool::weighted(0.05),
        )
            .prop_map(|((x, y, z, e), f, size, dwell)| {
                // Long moves, short ones and ones below the position quantum.
                let k = if size < 0.3 {
                    0.001
                } else if size < 0.4 {
                    1e-6
                } else {
                    1.0
                };
                ([x * k, y * k, z * k, e * k], f, dwell)
            }),
        1..120,
    )
}

/// Quantizes, encodes for a node reading `axes`, decodes, compares.
fn round_trip(segs: &[Segment], axes: u8, max_segments: usize) -> Vec<Segment> {
    let cfg = config();
    let mut q = Quantizer::new(cfg, [0.0; 6]);
    let record: Vec<Segment> = segs.iter().map(|s| q.segment(s)).collect();
    let mut enc = BatchEncoder::new(cfg, axes, [0.0; 6], 5, max_segments);
    let mut batches = vec![];
    for s in &record {
        batches.extend(enc.push(s).unwrap());
    }
    batches.extend(enc.flush());
    let mut state = StreamState::at([0.0; 6]);
    let mut got = vec![];
    let mut seq = 5;
    for b in &batches {
        assert!(b.segments >= 1 && b.segments <= max_segments);
        // Whole message within MAX_MESSAGE.
        let msg = HostMessage::Segments(b.batch.clone());
        let mut buf = [0u8; MAX_MESSAGE];
        let bytes = encode(&msg, &mut buf).expect("a batch fits a message");
        let back: HostMessage = decode(bytes).unwrap();
        assert_eq!(back, msg);
        let mut r = BatchReader::new(cfg, &b.batch).unwrap();
        assert_eq!(r.next_seq(), seq);
        let mut n = 0;
        while let Some(x) = r.next(&mut state) {
            let (m, s) = x.unwrap();
            assert_eq!(m.seq, seq);
            seq = seq.wrapping_add(1);
            got.push(s);
            n += 1;
        }
        assert_eq!(n, b.segments);
    }
    assert_eq!(got.len(), record.len());
    for (a, b) in record.iter().zip(&got) {
        assert_same(a, b, axes);
    }
    record
}

proptest! {
    #![proptest_config(ProptestConfig { cases: std::env::var("STREAM_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(200), .. ProptestConfig::default() })]

    #[test]
    fn decoded_batches_equal_the_record_bit_for_bit(
        moves in arb_moves(),
        scurve in any::<bool>(),
        axes in 1u8..16,
        max_segments in 1usize..40,
    ) {
        let profile = if scurve { ProfileKind::SCurve } else { ProfileKind::Trapezoid };
        let segs = planned(profile, &moves);
        round_trip(&segs, axes, max_segments);
    }

    #[test]
    fn quantized_segments_stay_near_the_plan(moves in arb_moves(), scurve in any::<bool>()) {
        let profile = if scurve { ProfileKind::SCurve } else { ProfileKind::Trapezoid };
        let segs = planned(profile, &moves);
        let record = round_trip(&segs, 0b1111, 32);
        let cfg = config();
        for (p, r) in segs.iter().zip(&record) {
            for i in 0..MAX_AXES {
                prop_assert!((p.end[i] - r.end[i]).abs() <= 0.5 * cfg.quantum + 1e-12);
            }
            let (pp, rp) = (p.profile.params(), r.profile.params());
            // Speeds and limits only ever rounded down.
            prop_assert!(rp.vc <= pp.vc.max(pp.v0).max(pp.v1) || rp.vc == cfg.speed_quantum);
            prop_assert!(rp.v1 <= pp.v1);
            prop_assert!(rp.accel <= pp.accel || pp.v0 == pp.vc && pp.vc == pp.v1);
            // The ramps fit the length, but for a fraction of a position
            // quantum where rounding took a little of a slow-down's room, and
            // for jerk-limited ramps, whose length grows with the square root
            // of the speed change: a change rounded up by a speed quantum
            // costs up to 2 v √(quantum / jerk).
            if rp.length > 0.0 {
                let scurve_slack = if rp.jerk > 0.0 {
                    2.0 * rp.v0.max(rp.vc) * (cfg.speed_quantum / rp.jerk).sqrt()
                } else {
                    0.0
                };
                let ramps = ramp_distance(rp.v0, rp.vc, rp.accel, rp.jerk)
                    + ramp_distance(rp.vc, rp.v1, rp.accel, rp.jerk);
                // Measured against the plan's own fit: quantizing must not
                // make it worse than the slack above.
                let planned = ramp_distance(pp.v0, pp.vc, pp.accel, pp.jerk)
                    + ramp_distance(pp.vc, pp.v1, pp.accel, pp.jerk);
                let planned_over = (planned - pp.length).max(0.0);
                prop_assert!(ramps - rp.length <= planned_over + 3.0 * cfg.quantum + scurve_slack, "ramps {ramps} over {} (planned {planned} over {})\n{pp:?}\n{rp:?}", rp.length, pp.length);
            }
        }
        for w in record.windows(2) {
            prop_assert_eq!(w[0].end, w[1].start);
            prop_assert_eq!(w[0].t1(), w[1].t0);
            prop_assert_eq!(w[0].profile.v1(), w[1].profile.v0());
        }
        prop_assert_eq!(record.last().unwrap().profile.v1(), 0.0);
    }

    #[test]
    fn arbitrary_batches_never_panic(
        bytes in prop::collection::vec(any::<u8>(), 0..189),
        tail in prop::array::uniform6(-1e6..1e6f64),
        valid in any::<bool>(),
    ) {
        let batch = SegmentBatch { bytes: heapless::Vec::from_slice(&bytes).unwrap() };
        if let Ok(mut r) = BatchReader::new(config(), &batch) {
            let mut state = StreamState { valid, vc: 3.0, v1: 2.0, ..StreamState::at(tail) };
            while let Some(Ok(_)) = r.next(&mut state) {}
        }
        let mut framed = vec![17u8, bytes.len() as u8];
        framed.extend_from_slice(&bytes);
        let _ = decode::<HostMessage>(&framed);
    }
}

#[test]
fn a_segment_that_is_not_quantized_is_refused() {
    let segs = planned(
        ProfileKind::Trapezoid,
        &[([10.123456, 0.0, 0.0, 0.0], 50.0, false)],
    );
    let mut enc = BatchEncoder::new(config(), 0b1111, [0.0; 6], 0, 8);
    assert!(enc.push(&segs[0]).is_err());
    assert_eq!(enc.pending(), 0);
}
