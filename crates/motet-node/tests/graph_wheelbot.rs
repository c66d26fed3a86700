//! A Wheelbot-like graph (the paper's clay printer as a pottery wheel): pedal
//! → velocity generator → polar angle; encoder → radius; a wave added to the
//! radius; z rises one layer per revolution through a scaling filter; an x
//! scaling filter stretches circles into ellipses; the extruder follows the
//! path length of the a/b targets; four channels.
//!
//! `wheelbot_frame_cost` prints ns per frame (run with `--release`), and with
//! `GRAPH_BENCH_FRAMES=N` runs N frames only (for callgrind).

use heapless::Deque;
use motet_node::graph::*;
use motet_trajectory::Segment;
use std::f64::consts::{PI, TAU};

/// The graph size Wheelbot needs: 24 components, 32 mappings.
pub type G = Graph<24, 32>;

/// Wheelbot's graph and the component indices a test drives. Public so that
/// `examples/wheelbot_frames.rs` measures this very graph.
pub struct Wheelbot {
    /// The graph.
    pub g: G,
    /// The turntable encoder.
    pub enc_r: u8,
    /// The polar-to-Cartesian component.
    pub polar: u8,
    /// The x stretch filter (its ratio is the ellipse stretch).
    pub x_stretch: u8,
    /// The extruder's path-length generator.
    pub e_gen: u8,
    /// The channels a, b, z and e.
    pub ch: [u8; 4],
}

const LAYER: f64 = 2.0;
const NOZZLE: f64 = 4.0;

/// Wheelbot's graph: a pedal, the turntable and z encoders driving four
/// channels (a, b, z, e).
pub fn wheelbot() -> Wheelbot {
    let mut b = GraphBuilder::new();
    let pedal = b
        .add(AnalogInput::new(0).floor(0.0, 25.0).ceiling(2.75, 1020.0))
        .unwrap();
    let enc_r = b.add(Encoder::new(0)).unwrap();
    let enc_z = b.add(Encoder::new(1)).unwrap();
    let vel = b.add(VelocityGenerator).unwrap();
    // Three waves per revolution, 1.5 mm.
    let wave = b
        .add(WaveGenerator1D::new(1.5, 0.0, 0.0).driven(3.0 / TAU))
        .unwrap();
    let polar = b.add(PolarToCartesian).unwrap();
    let z_gen = b
        .add(ScalingFilter1D::new(LAYER / TAU, Mode::Incremental))
        .unwrap();
    let x_stretch = b.add(ScalingFilter1D::new(0.0, Mode::Absolute)).unwrap();
    let rate = (4.0 * LAYER * 1.0 * NOZZLE) / (PI * NOZZLE * NOZZLE);
    let e_gen = b.add(PathLength2D::new(rate)).unwrap();
    let ca = b
        .add(GraphChannel::new().filtering(200.0).output(0, 5))
        .unwrap();
    let cb = b
        .add(GraphChannel::new().filtering(200.0).output(1, 5))
        .unwrap();
    let cz = b.add(GraphChannel::new().inverted().output(2, 5)).unwrap();
    let ce = b
        .add(
            GraphChannel::new()
                .inverted()
                .filtering(1000.0)
                .output(3, 5),
        )
        .unwrap();
    b.channel_ratio(ca, 1.0, 40.0).unwrap();
    b.channel_ratio(cb, 1.0, 40.0).unwrap();
    b.channel_ratio(cz, 1.0, 1201.0).unwrap();
    b.channel_ratio(ce, 1.0, 70.0).unwrap();
    b.set_ratio(port(enc_r, 0), 1.0, 2400.0).unwrap();
    b.set_ratio(port(enc_z, 0), 1.0, 2400.0).unwrap();

    b.map(
        port(pedal, 0),
        port(vel, VelocityGenerator::SPEED),
        Mode::Absolute,
    )
    .unwrap();
    b.map(
        port(vel, 1),
        port(polar, PolarToCartesian::THETA),
        Mode::Incremental,
    )
    .unwrap();
    b.map(
        port(enc_r, 0),
        port(polar, PolarToCartesian::R),
        Mode::Incremental,
    )
    .unwrap();
    b.tap(
        port(wave, WaveGenerator1D::DRIVE),
        port(polar, PolarToCartesian::THETA),
        Mode::Incremental,
    )
    .unwrap();
    b.map(
        port(wave, 1),
        port(polar, PolarToCartesian::R),
        Mode::Incremental,
    )
    .unwrap();
    b.tap(
        port(z_gen, 0),
        port(polar, PolarToCartesian::THETA),
        Mode::Incremental,
    )
    .unwrap();
    b.map(port(z_gen, 1), port(cz, 0), Mode::Incremental)
        .unwrap();
    b.map(port(enc_z, 0), port(cz, 0), Mode::Incremental)
        .unwrap();
    b.map(
        port(polar, PolarToCartesian::X),
        port(ca, 0),
        Mode::Incremental,
    )
    .unwrap();
    b.map(
        port(polar, PolarToCartesian::X),
        port(x_stretch, 0),
        Mode::Incremental,
    )
    .unwrap();
    b.map(
        port(polar, PolarToCartesian::Y),
        port(cb, 0),
        Mode::Incremental,
    )
    .unwrap();
    b.map(port(x_stretch, 1), port(ca, 0), Mode::Incremental)
        .unwrap();
    b.tap(port(e_gen, 0), port(ca, 0), Mode::Incremental)
        .unwrap();
    b.tap(port(e_gen, 1), port(cb, 0), Mode::Incremental)
        .unwrap();
    b.map(port(e_gen, 2), port(ce, 0), Mode::Incremental)
        .unwrap();
    let g = b.build().unwrap();
    assert!(g.mappings().iter().all(|m| !m.delayed), "all same-frame");
    Wheelbot {
        g,
        enc_r,
        polar,
        x_stretch,
        e_gen,
        ch: [ca, cb, cz, ce],
    }
}

struct Run {
    inputs: Inputs,
    segs: Deque<Segment, 4>,
    out: FrameOut,
    t: f64,
    frames: u64,
    steps: [i64; 24],
}

impl Run {
    fn new() -> Run {
        Run {
            inputs: Inputs::default(),
            segs: Deque::new(),
            out: FrameOut::default(),
            t: 0.0,
            frames: 0,
            steps: [0; 24],
        }
    }
    #[inline]
    fn frame(&mut self, g: &mut G) {
        let mut none = [];
        let mut tape = Tape::new(&mut none);
        g.frame(self.t, &self.inputs, &self.segs, &mut self.out, &mut tape);
        self.t += 40.0;
        self.frames += 1;
        if self.frames.rem_euclid(25) == 0 {
            g.slow_frame(&self.inputs);
        }
        for s in &self.out.steps {
            self.steps[s.channel as usize] += if s.forward { 1 } else { -1 };
        }
    }
}

fn chan(g: &G, c: u8) -> GraphChannel {
    match g.component(c) {
        Some(Component::Channel(ch)) => *ch,
        _ => unreachable!(),
    }
}

#[test]
fn wheelbot_prints_a_wavy_ellipse_spiral() {
    let mut w = wheelbot();
    let mut r = Run::new();
    // Place the nozzle at radius 50 without moving (the encoder's zero is
    // arbitrary): no steps.
    w.g.reset_deep(port(w.enc_r, 0), 50.0).unwrap();
    assert_eq!(r.steps, [0; 24]);
    assert_eq!(chan(&w.g, w.ch[0]).current_position(), 2000.0);
    // Pedal half down: 1.375 rad/s; the hand lever adds 1 mm of radius per
    // 2400 counts, 1 count every 10 frames; the stretch knob goes to 0.2.
    r.inputs.analog[0] = 522.5;
    let n = 25_000 * 10;
    let mut count = 0;
    for i in 0..n {
        if i % 10 == 0 {
            count += 1;
        }
        r.inputs.encoders[0] = count;
        if i == n / 2 {
            w.g.set_param(w.x_stretch, ScalingFilter1D::RATIO, 0.2)
                .unwrap();
        }
        r.frame(&mut w.g);
    }
    // Stop the pedal and let the filters settle.
    r.inputs.analog[0] = 0.0;
    for _ in 0..25_000 {
        r.frame(&mut w.g);
    }
    let theta = w.g.value(port(w.polar, PolarToCartesian::THETA)).unwrap();
    let want_theta = 1.375 * 10.0;
    assert!((theta - want_theta).abs() < 1e-3, "{theta}");
    let wave = 1.5 * (3.0 * theta).sin();
    let radius = 50.0 + count as f64 / 2400.0 + wave;
    assert!((w.g.value(port(w.polar, PolarToCartesian::R)).unwrap() - radius).abs() < 1e-9);
    let x = radius * theta.cos();
    let y = radius * theta.sin();
    let [ca, cb, cz, ce] = w.ch;
    // Channels: a carries x(1 + stretch), b carries y, z one layer per turn.
    let want = [
        x * 1.2 * 40.0,
        y * 40.0,
        LAYER * theta / TAU * 1201.0,
        w.g.value(port(w.e_gen, 2)).unwrap() * 70.0,
    ];
    for (k, c) in [ca, cb, cz, ce].into_iter().enumerate() {
        let ch = chan(&w.g, c);
        assert!(
            (ch.target_position() - want[k]).abs() < 1e-6,
            "channel {k}: {} vs {}",
            ch.target_position(),
            want[k]
        );
        assert!(
            (ch.current_position() - want[k]).abs() <= 0.5,
            "channel {k}: {} vs {}",
            ch.current_position(),
            want[k]
        );
        // Steps emitted = position counted (z and e are inverted).
        // (a started at 2000 steps by the reset, which emitted none.)
        let sign = if k >= 2 { -1.0 } else { 1.0 };
        let start = if k == 0 { 2000.0 } else { 0.0 };
        assert_eq!(
            r.steps[c as usize] as f64 * sign,
            ch.current_position() - start
        );
    }
    // The extruder got (rate × distance travelled in a/b), more than the
    // circumference of the turns alone.
    assert!(w.g.value(port(w.e_gen, 2)).unwrap() > 1.375 * 10.0 * 50.0 * 0.6);
}

#[test]
fn wheelbot_frame_cost() {
    let mut w = wheelbot();
    let mut r = Run::new();
    w.g.reset_deep(port(w.enc_r, 0), 50.0).unwrap();
    w.g.set_param(w.x_stretch, ScalingFilter1D::RATIO, 0.1)
        .unwrap();
    r.inputs.analog[0] = 900.0;
    let frames: u64 = std::env::var("GRAPH_BENCH_FRAMES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let start = std::time::Instant::now();
    for i in 0..frames {
        r.inputs.encoders[0] = (i / 10) as i64;
        r.frame(&mut w.g);
    }
    let el = start.elapsed();
    println!(
        "wheelbot: {} frames, {:.1} ns/frame (incl. slow frame every 25), {} steps on a",
        frames,
        el.as_nanos() as f64 / frames as f64,
        r.steps[w.ch[0] as usize]
    );
    std::hint::black_box(&w.g);
}
