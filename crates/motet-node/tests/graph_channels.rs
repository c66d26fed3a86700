//! Graph channels and the runtime: half-step rule, limits, fan-in, mapping
//! modes, deep reset/read, validation, live updates, trajectory reading and
//! mixing planned motion with hand input.

use heapless::Deque;
use motet_node::graph::*;
use motet_trajectory::profile::fastest;
use motet_trajectory::Segment;
use proptest::prelude::*;

type G = Graph<32, 64>;

struct Rig {
    g: G,
    inputs: Inputs,
    segs: Deque<Segment, 8>,
    out: FrameOut,
    t: f64,
    /// Net steps per component index, from the frame outputs.
    steps: [i64; 32],
}

impl Rig {
    fn new(b: GraphBuilder<32, 64>) -> Rig {
        Rig {
            g: b.build().expect("graph builds"),
            inputs: Inputs::default(),
            segs: Deque::new(),
            out: FrameOut::default(),
            t: 0.0,
            steps: [0; 32],
        }
    }
    fn frame(&mut self) {
        let mut none = [];
        let mut tape = Tape::new(&mut none);
        self.g
            .frame(self.t, &self.inputs, &self.segs, &mut self.out, &mut tape);
        self.t += self.g.frame_us();
        for s in &self.out.steps {
            self.steps[s.channel as usize] += if s.forward { 1 } else { -1 };
        }
    }
    fn run(&mut self, n: usize) {
        for _ in 0..n {
            self.frame();
        }
    }
    fn chan(&self, c: u8) -> GraphChannel {
        match self.g.component(c) {
            Some(Component::Channel(ch)) => *ch,
            _ => panic!("not a channel"),
        }
    }
}

/// Position generator → channel, both at 1:1.
fn gen_channel(ch: GraphChannel) -> (GraphBuilder<32, 64>, u8, u8) {
    let mut b = GraphBuilder::new();
    let p = b.add(PositionGenerator::new(1e9)).unwrap();
    let c = b.add(ch).unwrap();
    b.map(port(p, 0), port(c, 0), Mode::Incremental).unwrap();
    (b, p, c)
}

#[test]
fn half_step_rule_one_step_per_frame() {
    // (target, frames run, expected position)
    let cases: &[(f64, usize, f64)] = &[
        (0.4, 5, 0.0),
        (0.5, 5, 0.0),
        (0.51, 5, 1.0),
        (3.49, 10, 3.0),
        (3.51, 10, 4.0),
        (10.0, 4, 4.0), // at most one step per frame
        (-2.6, 10, -3.0),
    ];
    for &(target, n, want) in cases {
        let (b, p, c) = gen_channel(GraphChannel::new());
        let mut r = Rig::new(b);
        r.g.set_param(p, PositionGenerator::GO_ABSOLUTE, target)
            .unwrap();
        r.run(n);
        assert_eq!(r.chan(c).current_position(), want, "target {target}");
        assert_eq!(r.steps[c as usize] as f64, want);
    }
}

#[test]
fn inversion_and_pulse_rate() {
    let (b, p, c) = gen_channel(GraphChannel::new().inverted().pulse_rate(5000.0));
    let mut r = Rig::new(b);
    r.g.set_param(p, PositionGenerator::GO_ABSOLUTE, 100.0)
        .unwrap();
    r.run(25); // 1 ms: at 5000 steps/s, 5 steps (one every 5 frames)
    assert_eq!(r.chan(c).current_position(), 5.0);
    assert_eq!(r.steps[c as usize], -5, "inverted direction output");
}

#[test]
fn filter_smooths_target() {
    let (mut b, p, c) = gen_channel(GraphChannel::new().filtering(100.0));
    b.set_param(p, PositionGenerator::GO_ABSOLUTE, 50.0)
        .unwrap();
    let mut r = Rig::new(b);
    r.run(1);
    // f = 50/100 = 0.5: not yet a step.
    assert_eq!(r.chan(c).current_position(), 0.0);
    r.run(3000);
    assert_eq!(r.chan(c).current_position(), 50.0);
}

#[test]
fn limits_neither_emit_nor_count() {
    let (mut b, p, c) = gen_channel(GraphChannel::new().limits(-2.0, 3.0));
    b.channel_ratio(1, 1.0, 10.0).unwrap();
    let mut r = Rig::new(b);
    r.g.set_param(p, PositionGenerator::GO_ABSOLUTE, 5.0)
        .unwrap();
    r.run(200);
    // Stopped at 3 world units = 30 steps; the target ran on to 50.
    assert_eq!(r.chan(c).current_position(), 30.0);
    assert_eq!(r.steps[c as usize], 30);
    assert_eq!(r.chan(c).target_position(), 50.0);
    // Coming back inside, motion resumes from the real position at once.
    r.g.set_param(p, PositionGenerator::GO_ABSOLUTE, 2.5)
        .unwrap();
    r.run(1);
    assert_eq!(r.chan(c).current_position(), 29.0);
    r.run(100);
    assert_eq!(r.chan(c).current_position(), 25.0);
    assert_eq!(r.steps[c as usize], 25);
    r.g.set_param(p, PositionGenerator::GO_ABSOLUTE, -10.0)
        .unwrap();
    r.run(300);
    assert_eq!(r.chan(c).current_position(), -20.0);
    assert_eq!(r.steps[c as usize], -20);
}

#[test]
fn fan_in_sums_and_absolute_overwrites() {
    let mut b = GraphBuilder::new();
    let p1 = b.add(PositionGenerator::new(1e9)).unwrap();
    let p2 = b.add(PositionGenerator::new(1e9)).unwrap();
    let p3 = b.add(PositionGenerator::new(1e9)).unwrap();
    let f = b.add(ScalingFilter1D::new(1.0, Mode::Incremental)).unwrap();
    let fa = b.add(ScalingFilter1D::new(1.0, Mode::Incremental)).unwrap();
    // Fan-in: p1 + p2 into f; fan-out by pull: fa taps f's input absolutely.
    b.map(port(p1, 0), port(f, 0), Mode::Incremental).unwrap();
    b.map(port(p2, 0), port(f, 0), Mode::Incremental).unwrap();
    b.tap(port(fa, 0), port(f, 0), Mode::Absolute).unwrap();
    let c = b.add(GraphChannel::new()).unwrap();
    b.map(port(p3, 0), port(c, 0), Mode::Absolute).unwrap();
    b.set_ratio(port(p2, 0), 2.0, 1.0).unwrap(); // p2's block unit is 2 world units
    let mut r = Rig::new(b);
    let cases = [(1.0, 2.0, 3.0), (-4.0, 0.5, 7.0), (0.0, 0.0, -1.0)];
    for (a, bb, cc) in cases {
        r.g.set_param(p1, PositionGenerator::GO_ABSOLUTE, a)
            .unwrap();
        r.g.set_param(p2, PositionGenerator::GO_ABSOLUTE, bb)
            .unwrap();
        r.g.set_param(p3, PositionGenerator::GO_ABSOLUTE, cc)
            .unwrap();
        r.run(20);
        let sum = a + 2.0 * bb;
        assert!((r.g.value(port(f, 1)).unwrap() - sum).abs() < 1e-12);
        assert!((r.g.value(port(fa, 1)).unwrap() - sum).abs() < 1e-12);
        assert_eq!(r.chan(c).target_position(), cc);
        assert_eq!(r.chan(c).current_position(), cc);
    }
}

/// Encoders for r and θ → polar kinematics → two channels.
fn polar_rig() -> (Rig, u8, u8, u8, u8) {
    let mut b = GraphBuilder::new();
    let er = b.add(Encoder::new(0)).unwrap();
    let et = b.add(Encoder::new(1)).unwrap();
    let k = b.add(PolarToCartesian).unwrap();
    let cx = b.add(GraphChannel::new()).unwrap();
    let cy = b.add(GraphChannel::new()).unwrap();
    b.set_ratio(port(er, 0), 1.0, 100.0).unwrap();
    b.set_ratio(port(et, 0), 1.0, 1000.0).unwrap();
    b.map(port(er, 0), port(k, PolarToCartesian::R), Mode::Incremental)
        .unwrap();
    b.map(
        port(et, 0),
        port(k, PolarToCartesian::THETA),
        Mode::Incremental,
    )
    .unwrap();
    b.map(port(k, PolarToCartesian::X), port(cx, 0), Mode::Incremental)
        .unwrap();
    b.map(port(k, PolarToCartesian::Y), port(cy, 0), Mode::Incremental)
        .unwrap();
    b.channel_ratio(cx, 1.0, 80.0).unwrap();
    b.channel_ratio(cy, 1.0, 80.0).unwrap();
    (Rig::new(b), er, et, cx, cy)
}

#[test]
fn reset_deep_makes_no_steps_and_read_deep_has_no_side_effects() {
    let (mut r, er, et, cx, cy) = polar_rig();
    for i in 0..2000 {
        r.inputs.encoders[0] = i / 2;
        r.inputs.encoders[1] = i / 3;
        r.frame();
    }
    r.run(100);
    let before_steps = r.steps;
    let snapshot = r.g.clone();
    // read_deep: r and θ from the channels through the inverse kinematics.
    let rr = r.g.read_deep(port(er, 0)).unwrap();
    let tt = r.g.read_deep(port(et, 0)).unwrap();
    assert!((rr - 9.99).abs() < 0.02, "{rr}");
    assert!((tt - 0.666).abs() < 0.01, "{tt}");
    assert_eq!(r.g, snapshot, "read_deep changed the graph");
    // reset_deep: declare r = 20 without moving.
    r.g.reset_deep(port(er, 0), 20.0).unwrap();
    r.run(500);
    assert_eq!(r.steps, before_steps, "reset produced steps");
    let x = r.chan(cx).current_position() / 80.0;
    let y = r.chan(cy).current_position() / 80.0;
    assert!(((x * x + y * y).sqrt() - 20.0).abs() < 0.02);
    assert!((r.g.read_deep(port(er, 0)).unwrap() - 20.0).abs() < 0.02);
    // And motion continues from there incrementally.
    r.inputs.encoders[0] += 100; // +1 unit of radius
    r.run(500);
    assert!((r.g.read_deep(port(er, 0)).unwrap() - 21.0).abs() < 0.02);
    // Unknown ports are refused.
    assert_eq!(
        r.g.reset_deep(port(99, 0), 1.0),
        Err(GraphError::UnknownComponent(99))
    );
    assert_eq!(
        r.g.read_deep(port(cx, 9)),
        Err(GraphError::UnknownPort(port(cx, 9)))
    );
}

#[test]
fn validation_errors() {
    let mut b: GraphBuilder<4, 3> = GraphBuilder::new();
    let e = b.add(Encoder::new(0)).unwrap();
    let k = b.add(PolarToCartesian).unwrap();
    let v = b.add(VelocityGenerator).unwrap();
    let c = b.add(GraphChannel::new()).unwrap();
    assert_eq!(
        b.add(CoreXY),
        Err(GraphError::CapacityExceeded(Capacity::Components))
    );
    let cases: Vec<(PortRef, PortRef, Mode, GraphError)> = vec![
        (
            port(9, 0),
            port(k, 0),
            Mode::Incremental,
            GraphError::UnknownComponent(9),
        ),
        (
            port(e, 5),
            port(k, 0),
            Mode::Incremental,
            GraphError::UnknownPort(port(e, 5)),
        ),
        (
            port(k, 0),
            port(c, 0),
            Mode::Incremental,
            GraphError::NotAnOutput(port(k, 0)),
        ),
        (
            port(e, 0),
            port(k, 2),
            Mode::Incremental,
            GraphError::NotAnInput(port(k, 2)),
        ),
        (
            port(k, 2),
            port(k, 1),
            Mode::Incremental,
            GraphError::UnitMismatch {
                from: port(k, 2),
                to: port(k, 1),
            },
        ),
        (
            port(e, 0),
            port(v, 0),
            Mode::Incremental,
            GraphError::ModeMismatch {
                from: port(e, 0),
                to: port(v, 0),
            },
        ),
    ];
    for (from, to, mode, err) in cases {
        assert_eq!(b.map(from, to, mode), Err(err));
    }
    // Tapping: the listener must be an input.
    assert_eq!(
        b.tap(port(k, 2), port(e, 0), Mode::Incremental),
        Err(GraphError::NotAnInput(port(k, 2)))
    );
    assert_eq!(
        b.set_ratio(port(c, 0), 0.0, 1.0),
        Err(GraphError::BadRatio(port(c, 0)))
    );
    b.map(port(e, 0), port(k, 0), Mode::Incremental).unwrap();
    assert_eq!(
        b.map(port(e, 0), port(k, 0), Mode::Incremental),
        Err(GraphError::DuplicateMapping {
            from: port(e, 0),
            to: port(k, 0)
        })
    );
    // Backward mapping (channel → earlier component): incremental is delayed…
    b.map(port(c, 2), port(k, 1), Mode::Incremental).unwrap();
    let g: Graph<4, 3> = b.build().unwrap();
    assert!(g.mappings().iter().any(|m| m.delayed));
    // …absolute is refused at build.
    b.unmap(port(c, 2));
    b.map(port(c, 2), port(k, 1), Mode::Absolute).unwrap();
    assert_eq!(
        b.build().unwrap_err(),
        GraphError::BackwardAbsolute {
            from: port(c, 2),
            to: port(k, 1)
        }
    );
    b.unmap(port(c, 2));
    // Absolute fan-in.
    b.map(port(v, 1), port(k, 0), Mode::Absolute).unwrap();
    assert_eq!(
        b.build().unwrap_err(),
        GraphError::AbsoluteFanIn(port(k, 0))
    );
    b.unmap(port(v, 1));
    // Capacity of mappings.
    b.map(port(k, 2), port(c, 0), Mode::Incremental).unwrap();
    b.map(port(k, 3), port(c, 1), Mode::Incremental).unwrap();
    assert_eq!(
        b.map(port(v, 1), port(c, 1), Mode::Incremental),
        Err(GraphError::CapacityExceeded(Capacity::Mappings))
    );
    // A component into itself in ABSOLUTE mode is a same-frame cycle.
    let mut b2: GraphBuilder<4, 4> = GraphBuilder::new();
    let f = b2.add(ScalingFilter1D::new(0.5, Mode::Absolute)).unwrap();
    b2.map(port(f, 1), port(f, 0), Mode::Absolute).unwrap();
    assert!(matches!(
        b2.build(),
        Err(GraphError::BackwardAbsolute { .. })
    ));
}

#[test]
fn failed_updates_leave_the_graph_untouched() {
    let (mut r, _er, _et, cx, _cy) = polar_rig();
    for i in 0..500 {
        r.inputs.encoders[0] = i;
        r.frame();
    }
    let before = r.g.clone();
    // Bad parameters.
    assert_eq!(
        r.g.set_param(cx, 77, 1.0),
        Err(GraphError::UnknownParam {
            comp: cx,
            param: 77
        })
    );
    assert_eq!(
        r.g.set_param(cx, GraphChannel::FILTER, -3.0),
        Err(GraphError::BadValue {
            comp: cx,
            param: GraphChannel::FILTER
        })
    );
    assert_eq!(
        r.g.set_param(40, 0, 1.0),
        Err(GraphError::UnknownComponent(40))
    );
    // A bad replacement: an absolute mapping into the radius, which the
    // encoder already feeds (absolute fan-in).
    let mut b = r.g.to_builder();
    let k = 2u8;
    let f = b.add(ScalingFilter1D::new(1.0, Mode::Absolute)).unwrap();
    b.map(port(f, 1), port(k, PolarToCartesian::R), Mode::Absolute)
        .unwrap();
    assert!(r.g.replace(b).is_err());
    assert_eq!(r.g, before);
    // A good replacement takes effect.
    let mut b = r.g.to_builder();
    b.set_param(cx, GraphChannel::FILTER, 10.0).unwrap();
    r.g.replace(b).unwrap();
    assert_eq!(r.g.param(cx, GraphChannel::FILTER), Some(10.0));
}

fn segment(t0: f64, start: [f64; 6], end: [f64; 6], v_max: f64) -> Segment {
    let len = start
        .iter()
        .zip(end.iter())
        .map(|(a, b)| (b - a) * (b - a))
        .sum::<f64>()
        .sqrt();
    Segment {
        t0,
        start,
        end,
        profile: fastest(len, 0.0, 0.0, v_max, 500.0, 0.0),
    }
}

#[test]
fn trajectory_reader_follows_a_planned_segment() {
    let mut b = GraphBuilder::new();
    let rx = b.add(TrajectoryReader::new(0)).unwrap();
    let ry = b.add(TrajectoryReader::new(1)).unwrap();
    let cx = b.add(GraphChannel::new()).unwrap();
    let cy = b.add(GraphChannel::new()).unwrap();
    b.map(port(rx, 0), port(cx, 0), Mode::Incremental).unwrap();
    b.map(port(ry, 0), port(cy, 0), Mode::Absolute).unwrap();
    b.channel_ratio(cx, 1.0, 80.0).unwrap();
    b.channel_ratio(cy, 1.0, 80.0).unwrap();
    let mut r = Rig::new(b);
    let seg = segment(1000.0, [0.0; 6], [30.0, -12.0, 0.0, 0.0, 0.0, 0.0], 100.0);
    let seg2 = segment(seg.t1(), seg.end, [10.0, 5.0, 0.0, 0.0, 0.0, 0.0], 150.0);
    r.segs.push_back(seg).unwrap();
    r.segs.push_back(seg2).unwrap();
    let end = seg2.t1() + 10_000.0;
    let mut worst: f64 = 0.0;
    while r.t < end {
        r.frame();
        let t = r.t - r.g.frame_us(); // the frame's time
        let p = if t < seg.t1() {
            seg.position_at(t)
        } else {
            seg2.position_at(t)
        };
        for (c, axis) in [(cx, 0), (cy, 1)] {
            let err = r.chan(c).current_position() - p[axis] * 80.0;
            worst = worst.max(err.abs());
        }
    }
    assert!(worst <= 0.5, "worst {worst} steps");
    assert_eq!(r.chan(cx).current_position(), 800.0);
    assert_eq!(r.chan(cy).current_position(), 400.0);
}

/// Trajectory on x + an encoder turned by hand, on one channel.
fn mixed_rig() -> (Rig, u8, u8) {
    let mut b = GraphBuilder::new();
    let rd = b.add(TrajectoryReader::new(0)).unwrap();
    let e = b.add(Encoder::new(0)).unwrap();
    let c = b.add(GraphChannel::new()).unwrap();
    b.set_ratio(port(e, 0), 1.0, 400.0).unwrap(); // 400 counts per mm
    b.map(
        port(rd, 0),
        port(c, GraphChannel::TARGET),
        Mode::Incremental,
    )
    .unwrap();
    b.map(
        port(e, 0),
        port(c, GraphChannel::TARGET_B),
        Mode::Incremental,
    )
    .unwrap();
    b.channel_ratio(c, 1.0, 80.0).unwrap();
    (Rig::new(b), c, e)
}

/// Runs `frames` frames of a back-and-forth planned move plus random hand
/// input (at most 1 count per frame, i.e. 0.2 steps), checking after every
/// frame that the channel is within half a step of the exact sum.
fn mixed_run(seed: u64, frames: usize) {
    let (mut r, c, _e) = mixed_rig();
    let mut rng = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    let mut count: i64 = 0;
    let mut x = 0.0;
    let mut worst: f64 = 0.0;
    for i in 0..frames {
        // Keep a few segments queued, drop finished ones.
        while r.segs.front().is_some_and(|s| s.t1() < r.t) {
            r.segs.pop_front();
        }
        if r.segs.len() < 3 {
            let t0 = r.segs.back().map_or(r.t, |s| s.t1());
            let to = if x > 0.0 { -20.0 } else { 20.0 } + (next() % 1000) as f64 * 0.01;
            let mut end = [0.0; 6];
            end[0] = to;
            let mut start = [0.0; 6];
            start[0] = x;
            // v ≤ 200 mm/s = 0.64 steps per frame at 80 steps/mm.
            r.segs.push_back(segment(t0, start, end, 200.0)).unwrap();
            x = to;
        }
        if i % 3 == 0 {
            count += (next() % 3) as i64 - 1;
        }
        r.inputs.encoders[0] = count;
        let t = r.t;
        r.frame();
        let planned = TrajectoryReader::position(&r.segs, 0, t).unwrap_or(0.0);
        let exact = planned * 80.0 + count as f64 / 400.0 * 80.0;
        let err = r.chan(c).current_position() - exact;
        worst = worst.max(err.abs());
        assert!(err.abs() <= 0.5 + 1e-9, "frame {i}: {err}");
    }
    assert_eq!(r.steps[c as usize] as f64, r.chan(c).current_position());
    assert!(worst <= 0.5 + 1e-9);
}

#[test]
fn mixed_channel_long_run() {
    // 60 s of frames at 25 kHz.
    let frames = std::env::var("GRAPH_MIXED_FRAMES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(25_000 * 60);
    mixed_run(7, frames);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]
    #[test]
    fn mixed_channel_random(seed in any::<u64>()) {
        mixed_run(seed, 25_000);
    }
}
