//! Recording format and recorder → player round trip.

use heapless::Deque;
use motet_node::graph::record::{pack, unpack};
use motet_node::graph::*;
use motet_trajectory::Segment;

#[test]
fn byte_format() {
    let cases: &[([i8; 4], u8)] = &[
        ([0, 0, 0, 0], 0),
        ([1, 0, 0, 0], 0b11),
        ([-1, 0, 0, 0], 0b10),
        ([0, 1, 0, 0], 0b1100),
        ([0, 0, -1, 0], 0b10_0000),
        ([0, 0, 0, 1], 0b1100_0000),
        ([1, -1, 1, -1], 0b10_11_10_11),
    ];
    for &(steps, byte) in cases {
        assert_eq!(pack(steps), byte);
        assert_eq!(unpack(byte), steps);
    }
    // 01 reads as none.
    assert_eq!(unpack(0b01), [0; 4]);
}

#[test]
fn quantiser_at_most_one_step_per_frame() {
    let mut q = StepQuantizer::start(0.3);
    let steps: Vec<i8> = [0.7, 0.81, 3.0, 3.0, 3.0, 3.0, -1.0]
        .iter()
        .map(|&v| q.step(v))
        .collect();
    assert_eq!(steps, vec![0, 1, 1, 1, 0, 0, -1]);
    assert_eq!(q.count(), 2);
}

#[test]
fn tape_capacity() {
    let mut buf = [0u8; 3];
    let mut t = Tape::new(&mut buf);
    assert!(t.push(1) && t.push(2) && t.push(3));
    assert!(!t.push(4));
    assert_eq!(t.bytes(), &[1, 2, 3]);
    let mut buf2 = [9u8; 4];
    let t2 = Tape::with_len(&mut buf2, 10);
    assert_eq!(t2.len(), 4);
}

/// Records a circle and a ramp (recorder taps the channels' inputs), then
/// replays them into two other channels: the same steps come out.
#[test]
fn recorder_player_round_trip() {
    let mut b: GraphBuilder<16, 16> = GraphBuilder::new();
    let circle = b.add(CircleGenerator::new(4.0, 0.5)).unwrap();
    let z = b.add(VelocityGenerator).unwrap();
    let player = b.add(FourTrackPlayer::new()).unwrap();
    let cx = b.add(GraphChannel::new()).unwrap();
    let cy = b.add(GraphChannel::new()).unwrap();
    let cz = b.add(GraphChannel::new()).unwrap();
    let px = b.add(GraphChannel::new()).unwrap();
    let py = b.add(GraphChannel::new()).unwrap();
    let pz = b.add(GraphChannel::new()).unwrap();
    let rec = b.add(FourTrackRecorder::new()).unwrap();
    b.set_param(z, VelocityGenerator::SPEED_PARAM, -1.5)
        .unwrap();
    b.map(port(circle, 0), port(cx, 0), Mode::Incremental)
        .unwrap();
    b.map(port(circle, 1), port(cy, 0), Mode::Incremental)
        .unwrap();
    b.map(port(z, 1), port(cz, 0), Mode::Incremental).unwrap();
    for (i, c) in [cx, cy, cz].into_iter().enumerate() {
        b.tap(port(rec, i as u8), port(c, 0), Mode::Incremental)
            .unwrap();
    }
    for (i, c) in [px, py, pz].into_iter().enumerate() {
        b.map(port(player, i as u8), port(c, 0), Mode::Incremental)
            .unwrap();
    }
    // Channels at 0.01 mm per step, like the tracks.
    for c in [cx, cy, cz, px, py, pz] {
        b.channel_ratio(c, 0.01, 1.0).unwrap();
    }
    let mut g: Graph<16, 16> = b.build().unwrap();
    let mut buf = vec![0u8; 60_000];
    let mut len = 0;
    let inputs = Inputs::default();
    let segs: Deque<Segment, 2> = Deque::new();
    let mut out = FrameOut::default();
    let mut steps = [0i64; 16];
    let mut t = 0.0;
    let mut frame = |g: &mut Graph<16, 16>, len: &mut usize, steps: &mut [i64; 16]| {
        let mut tape = Tape::with_len(&mut buf, *len);
        g.frame(t, &inputs, &segs, &mut out, &mut tape);
        *len = tape.len();
        t += 40.0;
        for s in &out.steps {
            steps[s.channel as usize] += if s.forward { 1 } else { -1 };
        }
    };
    g.set_param(rec, FourTrackRecorder::RECORD, 1.0).unwrap();
    for _ in 0..50_000 {
        frame(&mut g, &mut len, &mut steps);
    }
    g.set_param(rec, FourTrackRecorder::RECORD, 0.0).unwrap();
    assert_eq!(len, 50_000);
    let recorded = [steps[cx as usize], steps[cy as usize], steps[cz as usize]];
    // 2 s: one full turn (back to 0), z at −3 mm = −300 steps.
    assert_eq!(recorded, [0, 0, -300]);
    // Replay.
    g.set_param(player, FourTrackPlayer::PLAY, 1.0).unwrap();
    let mut worst = [0i64; 3];
    let mut played_path = Vec::new();
    for i in 0..50_001 {
        frame(&mut g, &mut len, &mut steps);
        if i < 50_000 {
            played_path.push([steps[px as usize], steps[py as usize], steps[pz as usize]]);
        }
    }
    match g.component(player) {
        Some(Component::FourTrackPlayer(p)) => assert!(!p.playing()),
        _ => unreachable!(),
    }
    assert_eq!(
        [steps[px as usize], steps[py as usize], steps[pz as usize]],
        recorded
    );
    // The replayed path follows the circle within a step of resolution.
    for (i, p) in played_path.iter().enumerate() {
        let a = std::f64::consts::TAU * 0.5 * (i + 1) as f64 * 40e-6;
        let want = [
            400.0 * (a.cos() - 1.0),
            400.0 * a.sin(),
            -1.5 * (i + 1) as f64 * 40e-6 * 100.0,
        ];
        for k in 0..3 {
            let err = (p[k] as f64 - want[k]).abs();
            worst[k] = worst[k].max(err.ceil() as i64);
        }
    }
    assert!(worst.iter().all(|&w| w <= 1), "{worst:?}");
}
