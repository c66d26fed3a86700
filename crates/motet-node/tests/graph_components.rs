//! Graph components: kinematics round trips, generators over N frames, live
//! filter changes, inputs.

use heapless::Deque;
use motet_node::graph::*;
use motet_trajectory::Segment;
use std::f64::consts::{PI, TAU};

type G = Graph<32, 64>;

struct Rig {
    g: G,
    inputs: Inputs,
    segs: Deque<Segment, 8>,
    out: FrameOut,
    buf: Vec<u8>,
    len: usize,
    t: f64,
    frames: u64,
}

impl Rig {
    fn new(b: GraphBuilder<32, 64>) -> Rig {
        Rig {
            g: b.build().expect("graph builds"),
            inputs: Inputs::default(),
            segs: Deque::new(),
            out: FrameOut::default(),
            buf: vec![0; 1 << 16],
            len: 0,
            t: 0.0,
            frames: 0,
        }
    }
    fn frame(&mut self) {
        let mut tape = Tape::with_len(&mut self.buf, self.len);
        self.g
            .frame(self.t, &self.inputs, &self.segs, &mut self.out, &mut tape);
        self.len = tape.len();
        self.t += self.g.frame_us();
        self.frames += 1;
        if self.frames.rem_euclid(25) == 0 {
            self.g.slow_frame(&self.inputs);
        }
    }
    fn run(&mut self, n: usize) {
        for _ in 0..n {
            self.frame();
        }
    }
    fn v(&self, c: u8, p: u8) -> f64 {
        self.g.value(port(c, p)).unwrap()
    }
}

const FPS: usize = 25_000;

#[test]
fn corexy_round_trip() {
    for &(x, y) in &[
        (0.0, 0.0),
        (1.0, 2.0),
        (-3.5, 7.25),
        (1e3, -1e3),
        (0.1, 0.2),
    ] {
        let (a, b) = CoreXY::motors(x, y);
        assert_eq!((a, b), (x + y, x - y));
        let (x2, y2) = CoreXY::cartesian(a, b);
        assert!((x2 - x).abs() < 1e-12 && (y2 - y).abs() < 1e-12);
    }
}

#[test]
fn polar_round_trip() {
    for &(r, t) in &[
        (1.0, 0.0),
        (5.0, 1.0),
        (2.0, -2.5),
        (10.0, 7.0),
        (3.0, -20.0),
    ] {
        let (x, y) = PolarToCartesian::cartesian(r, t);
        assert!((x - r * t.cos()).abs() < 1e-12 && (y - r * t.sin()).abs() < 1e-12);
        // The inverse unwraps θ to the turn nearest a reference.
        let (r2, t2) = PolarToCartesian::polar(x, y, t + 0.1);
        assert!((r2 - r).abs() < 1e-12, "{r} {r2}");
        assert!((t2 - t).abs() < 1e-9, "{t} {t2}");
    }
}

#[test]
fn fivebar_round_trip() {
    let cases = [
        FiveBarForward::new(50.0, 100.0, 100.0, 150.0, 150.0),
        FiveBarForward::new(60.0, 90.0, 110.0, 160.0, 140.0),
        FiveBarForward {
            ext: 20.0,
            ..FiveBarForward::new(50.0, 100.0, 100.0, 150.0, 150.0)
        },
    ];
    for fb in cases {
        for &(t1, t2) in &[
            (100.0f64, 80.0f64),
            (120.0, 70.0),
            (95.0, 40.0),
            (140.0, 100.0),
        ] {
            let (t1, t2) = (t1.to_radians(), t2.to_radians());
            let (x, y) = fb.stylus(t1, t2).expect("reachable");
            let (u1, u2) = fb.angles(x, y).expect("invertible");
            assert!(
                (u1 - t1).abs() < 1e-9 && (u2 - t2).abs() < 1e-9,
                "{fb:?} {t1} {t2} -> {u1} {u2}"
            );
        }
    }
    // Symmetric linkage, symmetric angles: the stylus is on the centre line.
    let fb = FiveBarForward::new(50.0, 100.0, 100.0, 150.0, 150.0);
    let (x, y) = fb.stylus(PI - 1.2, 1.2).unwrap();
    assert!((x - 25.0).abs() < 1e-9 && y > 0.0);
}

#[test]
fn kinematics_in_a_graph_follow_their_inputs() {
    let mut b = GraphBuilder::new();
    let e1 = b.add(Encoder::new(0)).unwrap();
    let e2 = b.add(Encoder::new(1)).unwrap();
    let k = b.add(CoreXY).unwrap();
    let ca = b.add(GraphChannel::new()).unwrap();
    let cb = b.add(GraphChannel::new()).unwrap();
    b.set_ratio(port(e1, 0), 24.0, 2400.0).unwrap();
    b.set_ratio(port(e2, 0), 24.0, 2400.0).unwrap();
    b.map(port(e1, 0), port(k, CoreXY::X), Mode::Incremental)
        .unwrap();
    b.map(port(e2, 0), port(k, CoreXY::Y), Mode::Incremental)
        .unwrap();
    b.map(port(k, CoreXY::A), port(ca, 0), Mode::Incremental)
        .unwrap();
    b.map(port(k, CoreXY::B), port(cb, 0), Mode::Incremental)
        .unwrap();
    b.channel_ratio(ca, 25.4, 2874.0).unwrap();
    b.channel_ratio(cb, 25.4, 2874.0).unwrap();
    let mut r = Rig::new(b);
    // Turn the knobs slowly: 1 count per frame for 300 frames, then 2 the other way.
    for i in 0..300 {
        r.inputs.encoders[0] = i + 1;
        r.inputs.encoders[1] = -(i / 2);
        r.frame();
    }
    r.run(500);
    let x = 300.0 * 0.01;
    let y = -149.0 * 0.01;
    let spm = 2874.0 / 25.4;
    let a = r.v(ca, GraphChannel::POSITION) * spm;
    let bb = r.v(cb, GraphChannel::POSITION) * spm;
    assert!((a - (x + y) * spm).abs() <= 0.5, "{a}");
    assert!((bb - (x - y) * spm).abs() <= 0.5, "{bb}");
    assert!((r.g.read_deep(port(k, CoreXY::X)).unwrap() - x).abs() < 0.5 / spm + 1e-9);
}

#[test]
fn velocity_generator_integrates() {
    for &(speed, secs) in &[(2.5, 1.0), (-4.0, 0.5), (0.0, 0.2), (100.0, 0.04)] {
        let mut b = GraphBuilder::new();
        let v = b.add(VelocityGenerator).unwrap();
        b.set_param(v, VelocityGenerator::SPEED_PARAM, speed)
            .unwrap();
        let mut r = Rig::new(b);
        let n = (secs * FPS as f64).round() as usize;
        r.run(n);
        assert!((r.v(v, VelocityGenerator::OUT) - speed * secs).abs() < 1e-9);
    }
}

#[test]
fn position_generator_goes_at_constant_speed() {
    let mut b = GraphBuilder::new();
    let p = b.add(PositionGenerator::new(5.0)).unwrap();
    let mut r = Rig::new(b);
    r.g.set_param(p, PositionGenerator::GO_ABSOLUTE, 10.0)
        .unwrap();
    r.run(FPS);
    assert!((r.v(p, 0) - 5.0).abs() < 1e-9);
    r.run(FPS + 10);
    assert_eq!(r.v(p, 0), 10.0);
    assert!(matches!(r.g.component(p), Some(Component::PositionGenerator(g)) if !g.moving()));
    r.g.set_param(p, PositionGenerator::GO_RELATIVE, -3.0)
        .unwrap();
    r.run(FPS / 5);
    assert!((r.v(p, 0) - 9.0).abs() < 1e-9);
    r.run(FPS);
    assert_eq!(r.v(p, 0), 7.0);
    assert!(r.g.set_param(p, PositionGenerator::SPEED, -1.0).is_err());
}

#[test]
fn wave_1d_phase_is_inside_the_sine() {
    for &(a, f, ph) in &[(2.0, 10.0, 0.5), (1.0, 3.0, 0.0), (0.5, 50.0, PI / 2.0)] {
        let mut b = GraphBuilder::new();
        let w = b.add(WaveGenerator1D::new(a, f, ph)).unwrap();
        let mut r = Rig::new(b);
        let mut max: f64 = 0.0;
        for n in 1..=5000usize {
            r.frame();
            let t = n as f64 * 40e-6;
            let want = a * (TAU * f * t + ph).sin();
            let got = r.v(w, WaveGenerator1D::OUT);
            assert!((got - want).abs() < 1e-9, "n={n} {got} {want}");
            max = max.max(got.abs());
        }
        assert!(max <= a + 1e-12);
    }
}

#[test]
fn wave_1d_driven_by_an_input_stream() {
    // Three waves per revolution of an angle driven at 1 rev/s.
    let mut b = GraphBuilder::new();
    let v = b.add(VelocityGenerator).unwrap();
    let w = b
        .add(WaveGenerator1D::new(1.5, 0.0, 0.0).driven(3.0 / TAU))
        .unwrap();
    b.set_param(v, VelocityGenerator::SPEED_PARAM, TAU).unwrap();
    b.map(
        port(v, 1),
        port(w, WaveGenerator1D::DRIVE),
        Mode::Incremental,
    )
    .unwrap();
    let mut r = Rig::new(b);
    for n in 1..=FPS {
        r.frame();
        if n % 1000 == 0 {
            let turns = n as f64 / FPS as f64;
            let want = 1.5 * (TAU * 3.0 * turns).sin();
            assert!((r.v(w, 1) - want).abs() < 1e-9);
        }
    }
}

#[test]
fn circle_generator_revolutions_per_second() {
    let mut b = GraphBuilder::new();
    let c = b.add(CircleGenerator::new(3.0, 2.0)).unwrap();
    let mut r = Rig::new(b);
    r.run(FPS / 8); // a quarter turn
    assert!((r.v(c, 0) + 3.0).abs() < 1e-9 && (r.v(c, 1) - 3.0).abs() < 1e-9);
    r.run(FPS * 3 / 8); // a full turn
    assert!(r.v(c, 0).abs() < 1e-9 && r.v(c, 1).abs() < 1e-9);
}

#[test]
fn path_length_2d_and_3d() {
    let mut b = GraphBuilder::new();
    let c = b.add(CircleGenerator::new(3.0, 1.0)).unwrap();
    let p = b.add(PathLength2D::new(2.0)).unwrap();
    b.map(port(c, 0), port(p, 0), Mode::Incremental).unwrap();
    b.map(port(c, 1), port(p, 1), Mode::Incremental).unwrap();
    let gx = b.add(PositionGenerator::new(3.0)).unwrap();
    let gy = b.add(PositionGenerator::new(4.0)).unwrap();
    let gz = b.add(PositionGenerator::new(12.0)).unwrap();
    let p3 = b.add(PathLength3D::new(0.5)).unwrap();
    for (i, g) in [gx, gy, gz].into_iter().enumerate() {
        b.map(port(g, 0), port(p3, i as u8), Mode::Incremental)
            .unwrap();
    }
    b.set_param(gx, PositionGenerator::GO_ABSOLUTE, 3.0)
        .unwrap();
    b.set_param(gy, PositionGenerator::GO_ABSOLUTE, 4.0)
        .unwrap();
    b.set_param(gz, PositionGenerator::GO_ABSOLUTE, 12.0)
        .unwrap();
    let mut r = Rig::new(b);
    r.run(FPS);
    let want = 2.0 * TAU * 3.0;
    assert!((r.v(p, 2) - want).abs() < 1e-6, "{}", r.v(p, 2));
    assert!((r.v(p3, 3) - 6.5).abs() < 1e-9, "{}", r.v(p3, 3));
}

#[test]
fn scaling_filters_live_ratio() {
    for mode in [Mode::Incremental, Mode::Absolute] {
        let mut b = GraphBuilder::new();
        let v = b.add(VelocityGenerator).unwrap();
        let f = b.add(ScalingFilter1D::new(2.0, mode)).unwrap();
        let f2 = b.add(ScalingFilter2D::new(-1.0, mode)).unwrap();
        b.set_param(v, VelocityGenerator::SPEED_PARAM, 1.0).unwrap();
        b.map(port(v, 1), port(f, 0), Mode::Incremental).unwrap();
        b.map(port(v, 1), port(f2, 1), Mode::Incremental).unwrap();
        let mut r = Rig::new(b);
        r.run(FPS / 2);
        assert!((r.v(f, 1) - 1.0).abs() < 1e-9);
        assert!((r.v(f2, 3) + 0.5).abs() < 1e-9);
        r.g.set_param(f, ScalingFilter1D::RATIO, 3.0).unwrap();
        r.g.set_param(f2, ScalingFilter2D::RATIO, 4.0).unwrap();
        assert!(r.g.set_param(f, ScalingFilter1D::RATIO, f64::NAN).is_err());
        assert_eq!(r.g.param(f, ScalingFilter1D::RATIO), Some(3.0));
        r.run(FPS / 2);
        let (want, want2) = match mode {
            Mode::Incremental => (1.0 + 1.5, -0.5 + 2.0),
            Mode::Absolute => (3.0, 4.0),
        };
        assert!((r.v(f, 1) - want).abs() < 1e-9, "{mode:?} {}", r.v(f, 1));
        assert!((r.v(f2, 3) - want2).abs() < 1e-9, "{mode:?} {}", r.v(f2, 3));
    }
}

#[test]
fn threshold_clamps_and_flags() {
    let mut b = GraphBuilder::new();
    let p = b.add(PositionGenerator::new(10.0)).unwrap();
    let t = b.add(ThresholdGenerator::new(-1.0, 2.0)).unwrap();
    b.map(port(p, 0), port(t, 0), Mode::Incremental).unwrap();
    let mut r = Rig::new(b);
    for &(target, out, flag) in &[(5.0, 2.0, 1.0), (1.5, 1.5, 0.0), (-4.0, -1.0, -1.0)] {
        r.g.set_param(p, PositionGenerator::GO_ABSOLUTE, target)
            .unwrap();
        r.run(FPS);
        assert_eq!(r.v(t, ThresholdGenerator::OUT), out);
        assert_eq!(r.v(t, ThresholdGenerator::FLAG), flag);
    }
    assert!(r.g.set_param(t, ThresholdGenerator::LOWER, 3.0).is_err());
}

#[test]
fn analog_input_mapping() {
    let a = AnalogInput::new(0).floor(0.0, 25.0).ceiling(2.75, 1020.0);
    for &(raw, want) in &[
        (25.0, 0.0),
        (0.0, 0.0),
        (1020.0, 2.75),
        (1023.0, 2.75),
        (522.5, 1.375),
    ] {
        assert!((a.map(raw) - want).abs() < 1e-12, "{raw}");
    }
    let d = AnalogInput::new(0)
        .floor(-1.0, 0.0)
        .ceiling(1.0, 1000.0)
        .deadband(500.0, 20.0);
    assert_eq!(d.map(515.0), 0.0);
    assert!((d.map(600.0) - 0.2).abs() < 1e-12);
    // Averaging in a graph: an exponential step response.
    let mut b = GraphBuilder::new();
    let ai = b
        .add(AnalogInput::new(2).ceiling(1.0, 1000.0).averaging(4.0))
        .unwrap();
    let v = b.add(VelocityGenerator).unwrap();
    b.map(
        port(ai, 0),
        port(v, VelocityGenerator::SPEED),
        Mode::Absolute,
    )
    .unwrap();
    let mut r = Rig::new(b);
    r.frame();
    r.inputs.analog[2] = 1000.0;
    r.frame();
    assert!((r.v(ai, 0) - 0.25).abs() < 1e-9);
    r.run(200);
    assert!((r.v(ai, 0) - 1.0).abs() < 1e-9);
    assert!((r.v(v, VelocityGenerator::SPEED) - 1.0).abs() < 1e-9);
}

#[test]
fn button_debounce_and_toggle() {
    for mode in [ButtonMode::Standard, ButtonMode::Toggle] {
        let mut b = GraphBuilder::new();
        let btn = b.add(Button::new(0, mode).debounce(5)).unwrap();
        let mut g: G = b.build().unwrap();
        let mut inp = Inputs::default();
        // A 3 ms glitch is ignored.
        inp.digital[0] = true;
        for _ in 0..3 {
            g.slow_frame(&inp);
        }
        inp.digital[0] = false;
        for _ in 0..10 {
            g.slow_frame(&inp);
        }
        assert_eq!(g.value(port(btn, 0)), Some(0.0));
        // A press.
        inp.digital[0] = true;
        for _ in 0..10 {
            g.slow_frame(&inp);
        }
        assert_eq!(g.value(port(btn, 0)), Some(1.0));
        inp.digital[0] = false;
        for _ in 0..10 {
            g.slow_frame(&inp);
        }
        let after_release = match mode {
            ButtonMode::Standard => 0.0,
            ButtonMode::Toggle => 1.0,
        };
        assert_eq!(g.value(port(btn, 0)), Some(after_release));
        match g.component(btn) {
            Some(Component::Button(b)) => assert_eq!(b.events(), (1, 1)),
            _ => unreachable!(),
        }
    }
}

#[test]
fn encoder_ratio_and_inversion() {
    let mut b = GraphBuilder::new();
    let e = b.add(Encoder::new(3)).unwrap();
    let ei = b.add(Encoder::new(3).inverted()).unwrap();
    b.set_ratio(port(e, 0), 24.0, 2400.0).unwrap();
    b.set_ratio(port(ei, 0), 1.0, 2400.0).unwrap();
    let mut r = Rig::new(b);
    r.inputs.encoders[3] = 1200;
    r.frame();
    assert!((r.v(e, 0) - 12.0).abs() < 1e-12);
    assert!((r.v(ei, 0) + 0.5).abs() < 1e-12);
    // Changing the inversion live keeps the output where it is.
    r.g.set_param(e, Encoder::INVERT, 1.0).unwrap();
    r.frame();
    assert!((r.v(e, 0) - 12.0).abs() < 1e-12);
    r.inputs.encoders[3] = 1100;
    r.frame();
    assert!((r.v(e, 0) - 13.0).abs() < 1e-12);
}

#[test]
fn stream_input_counts_signals() {
    let mut b = GraphBuilder::new();
    let s = b.add(StreamInput::new(1)).unwrap();
    let mut r = Rig::new(b);
    let mut sig = wire::Signals::NONE;
    sig.set(0, true);
    sig.set(4, false);
    r.inputs.streams[1] = sig;
    r.run(7);
    assert_eq!(r.v(s, 0), 7.0);
    assert_eq!(r.v(s, 4), -7.0);
    assert_eq!(r.v(s, 1), 0.0);
}

#[test]
fn homing_seeks_backs_off_and_resets_without_steps() {
    let mut b = GraphBuilder::new();
    let lim = b.add(Button::digital(0)).unwrap();
    let h = b.add(Homing::new(-20.0, 1.0, 0.0)).unwrap();
    let ch = b.add(GraphChannel::new()).unwrap();
    b.map(port(lim, 0), port(h, Homing::LIMIT), Mode::Absolute)
        .unwrap();
    b.map(port(h, Homing::OUT), port(ch, 0), Mode::Incremental)
        .unwrap();
    b.channel_ratio(ch, 1.0, 100.0).unwrap();
    let mut r = Rig::new(b);
    r.g.set_param(h, Homing::START, 1.0).unwrap();
    // The switch closes 7.3 mm below where the axis started.
    let mut steps = 0i64;
    let mut at_reset = None;
    for _ in 0..(FPS * 2) {
        r.frame();
        for s in &r.out.steps {
            steps += if s.forward { 1 } else { -1 };
        }
        let pos = r.v(ch, GraphChannel::POSITION);
        r.inputs.digital[0] = pos <= -7.3 && at_reset.is_none();
        if at_reset.is_none() {
            if let Some(Component::Homing(hm)) = r.g.component(h) {
                if hm.state() == HomingState::Done {
                    at_reset = Some(steps);
                }
            }
        }
    }
    let at_reset = at_reset.expect("homing finished");
    // Seek to about −7.3 (plus up to 1 ms of slow-frame latency), back off 1 mm.
    assert!((at_reset as f64 / 100.0 + 6.3).abs() < 0.05, "{at_reset}");
    // After the reset the channel reads home, and no step was taken for it.
    assert_eq!(steps, at_reset);
    assert_eq!(r.v(ch, GraphChannel::POSITION), 0.0);
    assert_eq!(r.g.read_deep(port(h, Homing::OUT)).unwrap(), 0.0);
}
