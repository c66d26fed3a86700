//! Input-to-step latency and long-run exactness of the graph runtime.
//!
//! # What the runtime guarantees (measured here)
//! Hardware inputs are read at the start of a frame (input phase), the other
//! components run next, channels last; every forward mapping (source runs
//! before target) carries its value within the frame. So an encoder count that
//! changes before frame `k` produces its channel's step in frame `k` itself:
//! **latency 0 frames**, directly or through kinematics (CoreXY here), whatever
//! order the components were created in, as long as no mapping on the path is
//! backward. Each backward mapping (a later component into an earlier one,
//! `Mapping::delayed`) adds exactly one frame. (A channel's own filter and
//! pulse-rate limit delay further, by design; a channel takes at most one step
//! per frame, so a jump of `n` steps starts in frame `k` and ends in frame
//! `k + n − 1`.)
//!
//! The exactness run drives two encoders into CoreXY x/y, a fine encoder
//! fanned in on x, a pedal (analog input → velocity generator) fanned in on y,
//! and a fourth encoder plus the first one fanned in on a z channel's two
//! target inputs, for ten simulated minutes at 25 kHz (15,000,000 frames,
//! about 3 s in the test profile; `cargo run --release -p motet-node --example
//! wheelbot_frames -- --minutes 10` runs it too and prints the errors). Every
//! frame each channel's position must be within half a step of the exact sum
//! of its inputs, computed independently from the integer counts and the
//! pedal's integral, give or take the f64 rounding of the runtime's
//! incremental sums (the target drifts from the exact sum by about 2e-5 step
//! in ten minutes; the half-step bound against the runtime's own target holds
//! exactly).

use heapless::Deque;
use motet_node::graph::*;
use motet_trajectory::Segment;

/// The graph size the rigs use: 16 components, 32 mappings.
pub type G = Graph<16, 32>;

/// A graph with its inputs and frame outputs.
pub struct Rig {
    /// The graph under test.
    pub g: G,
    /// The hardware readings the next frame sees.
    pub inputs: Inputs,
    segs: Deque<Segment, 1>,
    /// What the last frame emitted.
    pub out: FrameOut,
    t: f64,
}

impl Rig {
    /// A rig running the graph `b` describes, at time 0.
    pub fn new(b: GraphBuilder<16, 32>) -> Rig {
        Rig {
            g: b.build().expect("graph builds"),
            inputs: Inputs::default(),
            segs: Deque::new(),
            out: FrameOut::default(),
            t: 0.0,
        }
    }

    /// Runs one frame; the steps it emitted are in `self.out`.
    #[inline]
    pub fn frame(&mut self) {
        let mut none = [];
        let mut tape = Tape::new(&mut none);
        self.g
            .frame(self.t, &self.inputs, &self.segs, &mut self.out, &mut tape);
        self.t += self.g.frame_us();
    }

    /// Net steps of channel `c` in the last frame.
    pub fn steps(&self, c: u8) -> i64 {
        self.out
            .steps
            .iter()
            .filter(|s| s.channel == c)
            .map(|s| if s.forward { 1 } else { -1 })
            .sum()
    }

    /// Position of channel component `c`, steps.
    pub fn position(&self, c: u8) -> f64 {
        match self.g.component(c) {
            Some(Component::Channel(ch)) => ch.current_position(),
            _ => panic!("not a channel"),
        }
    }
}

/// Applies `change` before a frame and counts the frames until channel `c`
/// steps (0 = in the same frame); `None` after `limit` frames.
fn latency(r: &mut Rig, c: u8, change: impl FnOnce(&mut Inputs), limit: usize) -> Option<usize> {
    change(&mut r.inputs);
    (0..limit).find(|_| {
        r.frame();
        r.steps(c) != 0
    })
}

/// Encoder 0 → channel, 1 count = 1 step; `channel_first` creates the channel
/// before the encoder.
fn direct(channel_first: bool) -> (Rig, u8) {
    let mut b = GraphBuilder::new();
    let (e, c) = if channel_first {
        let c = b.add(GraphChannel::new()).unwrap();
        (b.add(Encoder::new(0)).unwrap(), c)
    } else {
        let e = b.add(Encoder::new(0)).unwrap();
        (e, b.add(GraphChannel::new()).unwrap())
    };
    b.map(port(e, 0), port(c, 0), Mode::Incremental).unwrap();
    (Rig::new(b), c)
}

#[test]
fn an_encoder_steps_its_channel_in_the_same_frame() {
    for channel_first in [false, true] {
        let (mut r, c) = direct(channel_first);
        assert!(r.g.mappings().iter().all(|m| !m.delayed));
        for _ in 0..10 {
            r.frame();
            assert_eq!(r.steps(c), 0);
        }
        // Changes at irregular frames, both ways: each steps in its own frame.
        let mut count = 0;
        for (k, d) in [1, 1, -1, 1, -1, -1, -1, 1].into_iter().enumerate() {
            for _ in 0..k * 3 {
                r.frame();
                assert_eq!(r.steps(c), 0);
            }
            count += d;
            assert_eq!(
                latency(&mut r, c, |i| i.encoders[0] = count, 10),
                Some(0),
                "change {k}"
            );
            assert_eq!(r.steps(c), d);
            assert_eq!(r.position(c), count as f64);
        }
        // A jump of 5 counts: one step per frame, the first in the same frame.
        count += 5;
        r.inputs.encoders[0] = count;
        let per_frame: Vec<i64> = (0..7)
            .map(|_| {
                r.frame();
                r.steps(c)
            })
            .collect();
        assert_eq!(per_frame, [1, 1, 1, 1, 1, 0, 0]);
    }
}

/// Encoders 0 (x) and 1 (y) → CoreXY → channels a, b; 1 count = 1 mm =
/// 1 step.
fn corexy() -> (Rig, u8, u8) {
    let mut b = GraphBuilder::new();
    // Channels first, kinematics last: creation order does not matter.
    let ca = b.add(GraphChannel::new()).unwrap();
    let cb = b.add(GraphChannel::new()).unwrap();
    let ex = b.add(Encoder::new(0)).unwrap();
    let ey = b.add(Encoder::new(1)).unwrap();
    let k = b.add(CoreXY).unwrap();
    b.map(port(ex, 0), port(k, CoreXY::X), Mode::Incremental)
        .unwrap();
    b.map(port(ey, 0), port(k, CoreXY::Y), Mode::Incremental)
        .unwrap();
    b.map(port(k, CoreXY::A), port(ca, 0), Mode::Incremental)
        .unwrap();
    b.map(port(k, CoreXY::B), port(cb, 0), Mode::Incremental)
        .unwrap();
    (Rig::new(b), ca, cb)
}

#[test]
fn through_corexy_both_motors_step_in_the_same_frame() {
    let (mut r, ca, cb) = corexy();
    assert!(r.g.mappings().iter().all(|m| !m.delayed));
    r.frame();
    // (dx, dy) → (da, db) in the very frame of the change.
    let moves = [(1, 0, 1, 1), (0, 1, 1, -1), (-1, 0, -1, -1), (0, -1, -1, 1)];
    let (mut x, mut y) = (0, 0);
    for _ in 0..3 {
        for (dx, dy, da, db) in moves {
            x += dx;
            y += dy;
            r.inputs.encoders[0] = x;
            r.inputs.encoders[1] = y;
            r.frame();
            assert_eq!((r.steps(ca), r.steps(cb)), (da, db));
            r.frame();
            assert_eq!((r.steps(ca), r.steps(cb)), (0, 0));
        }
    }
    assert_eq!(latency(&mut r, ca, |i| i.encoders[0] = 1, 10), Some(0));
    assert_eq!(r.steps(cb), 1);
}

#[test]
fn each_backward_mapping_adds_one_frame() {
    // encoder → s2 → s1 → channel, s1 created before s2: s2 → s1 runs
    // backward (s1 has already run when s2 pushes), so it lands a frame late.
    let mut b = GraphBuilder::new();
    let s1 = b.add(ScalingFilter1D::new(1.0, Mode::Incremental)).unwrap();
    let s2 = b.add(ScalingFilter1D::new(1.0, Mode::Incremental)).unwrap();
    let e = b.add(Encoder::new(0)).unwrap();
    let c = b.add(GraphChannel::new()).unwrap();
    b.map(port(e, 0), port(s2, 0), Mode::Incremental).unwrap();
    b.map(port(s2, 1), port(s1, 0), Mode::Incremental).unwrap();
    b.map(port(s1, 1), port(c, 0), Mode::Incremental).unwrap();
    let mut r = Rig::new(b);
    assert_eq!(r.g.mappings().iter().filter(|m| m.delayed).count(), 1);
    r.frame();
    for n in 1..=5 {
        assert_eq!(latency(&mut r, c, |i| i.encoders[0] = n, 10), Some(1));
        r.frame();
    }
    assert_eq!(r.position(c), 5.0);
}

/// Counts per mm of encoders 0 and 1 (x, y), of the fine encoder 2 (x), and
/// of encoder 3 (z).
const COUNTS_PER_MM: [f64; 4] = [100.0, 100.0, 400.0, 2.0];
/// Steps per mm of channels a, b (CoreXY) and z.
const STEPS_PER_MM: [f64; 3] = [80.0, 80.0, 1.0];
/// Pedal: raw 0..1023 → −5..5 mm/s.
fn pedal() -> AnalogInput {
    AnalogInput::new(0).floor(-5.0, 0.0).ceiling(5.0, 1023.0)
}

/// The mixed-input exactness run: see the module documentation.
pub struct Mixed {
    /// The rig running the mixed graph.
    pub rig: Rig,
    /// Channels a, b, z.
    pub ch: [u8; 3],
    counts: [i64; 4],
    rng: u64,
    /// ∫ pedal speed dt, mm.
    travel: f64,
    pedal: AnalogInput,
    /// Frames run.
    pub frames: u64,
    /// Net steps emitted per channel.
    pub steps: [i64; 3],
    /// Largest |position − exact sum| per channel, steps.
    pub max_error: [f64; 3],
    /// Largest |position − the runtime's own target| per channel, steps.
    pub max_lag: [f64; 3],
    /// Largest |runtime target − exact sum| per channel, steps: the f64
    /// rounding of incremental transmission.
    pub max_drift: [f64; 3],
}

impl Default for Mixed {
    fn default() -> Self {
        Mixed::new()
    }
}

impl Mixed {
    /// The graph's channel names, in the order of `ch`.
    pub const CHANNELS: [&'static str; 3] = ["a", "b", "z"];

    /// The mixed graph: four encoders, a pedal and a velocity generator onto three channels.
    pub fn new() -> Mixed {
        let mut b = GraphBuilder::new();
        let enc: Vec<u8> = (0..4).map(|i| b.add(Encoder::new(i)).unwrap()).collect();
        let an = b.add(pedal()).unwrap();
        let vel = b.add(VelocityGenerator).unwrap();
        let k = b.add(CoreXY).unwrap();
        let ch: Vec<u8> = (0..3)
            .map(|_| b.add(GraphChannel::new()).unwrap())
            .collect();
        for (i, &e) in enc.iter().enumerate() {
            b.set_ratio(port(e, 0), 1.0, COUNTS_PER_MM[i]).unwrap();
        }
        for (i, &c) in ch.iter().enumerate() {
            b.channel_ratio(c, 1.0, STEPS_PER_MM[i]).unwrap();
        }
        let inc = Mode::Incremental;
        b.map(
            port(an, 0),
            port(vel, VelocityGenerator::SPEED),
            Mode::Absolute,
        )
        .unwrap();
        b.map(port(enc[0], 0), port(k, CoreXY::X), inc).unwrap();
        b.map(port(enc[2], 0), port(k, CoreXY::X), inc).unwrap();
        b.map(port(enc[1], 0), port(k, CoreXY::Y), inc).unwrap();
        b.map(port(vel, VelocityGenerator::OUT), port(k, CoreXY::Y), inc)
            .unwrap();
        b.map(port(k, CoreXY::A), port(ch[0], 0), inc).unwrap();
        b.map(port(k, CoreXY::B), port(ch[1], 0), inc).unwrap();
        b.map(port(enc[3], 0), port(ch[2], GraphChannel::TARGET), inc)
            .unwrap();
        b.map(port(enc[0], 0), port(ch[2], GraphChannel::TARGET_B), inc)
            .unwrap();
        let rig = Rig::new(b);
        assert!(rig.g.mappings().iter().all(|m| !m.delayed));
        Mixed {
            rig,
            ch: [ch[0], ch[1], ch[2]],
            counts: [0; 4],
            rng: 0x9e37_79b9_7f4a_7c15,
            travel: 0.0,
            pedal: pedal(),
            frames: 0,
            steps: [0; 3],
            max_error: [0.0; 3],
            max_lag: [0.0; 3],
            max_drift: [0.0; 3],
        }
    }

    fn random(&mut self) -> u64 {
        // xorshift64
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        self.rng
    }

    /// The scripted inputs of frame `f`: one encoder may move per frame
    /// (encoder `f mod 4`), so no channel's target moves a whole step in a
    /// frame. In 10 s periods: a random walk; x cranked forward at 6250
    /// counts/s; y cranked backward; a random walk biased forward. The pedal
    /// sweeps its whole range and back every 7 s.
    fn script(&mut self, f: u64) {
        let e = (f % 4) as usize;
        let r = self.random() % 8;
        let d = match ((f / 250_000) % 4, e) {
            (1, 0) => 1,
            (2, 1) => -1,
            (3, _) if r < 3 => 1,
            (3, _) if r < 5 => -1,
            (_, _) if r < 2 => 1,
            (_, _) if r < 4 => -1,
            _ => 0,
        };
        self.counts[e] += d;
        self.rig.inputs.encoders[e] = self.counts[e];
        let phase = (f % 175_000) as f64 / 175_000.0;
        let tri = 1.0 - (2.0 * phase - 1.0).abs();
        self.rig.inputs.analog[0] = (1023.0 * tri) as f32;
    }

    /// The exact target of each channel, steps.
    pub fn exact(&self) -> [f64; 3] {
        let mm = |i: usize| self.counts[i] as f64 / COUNTS_PER_MM[i];
        let x = mm(0) + mm(2);
        let y = mm(1) + self.travel;
        [
            (x + y) * STEPS_PER_MM[0],
            (x - y) * STEPS_PER_MM[1],
            (mm(3) + mm(0)) * STEPS_PER_MM[2],
        ]
    }

    /// Runs one frame and checks it.
    #[inline]
    pub fn frame(&mut self) {
        self.script(self.frames);
        self.rig.frame();
        self.frames += 1;
        // The velocity generator integrates the pedal in the same frame.
        let speed = self.pedal.map(self.rig.inputs.analog[0] as f64);
        self.travel += speed * (self.rig.g.frame_us() * 1e-6);
        let exact = self.exact();
        #[allow(clippy::needless_range_loop)]
        for k in 0..3 {
            let c = self.ch[k];
            self.steps[k] += self.rig.steps(c);
            let (pos, target) = match self.rig.g.component(c) {
                Some(Component::Channel(ch)) => (ch.current_position(), ch.target_position()),
                _ => unreachable!(),
            };
            let worst = |m: &mut f64, e: f64| *m = m.max(e.abs());
            worst(&mut self.max_error[k], pos - exact[k]);
            worst(&mut self.max_lag[k], pos - target);
            worst(&mut self.max_drift[k], target - exact[k]);
        }
    }

    /// Runs `frames` frames of scripted inputs, keeping each channel's
    /// worst error against the exact sum.
    pub fn run(&mut self, frames: u64) {
        for _ in 0..frames {
            self.frame();
        }
    }

    /// Panics unless every channel stayed within half a step of its target
    /// (exactly), the target within 1e-3 step of the exact sum (f64 rounding
    /// of ten minutes of increments: about 2e-5 step measured), and the
    /// channel emitted exactly the steps it counts.
    pub fn check(&self) {
        for k in 0..3 {
            let name = Mixed::CHANNELS[k];
            assert!(self.max_lag[k] <= 0.5, "channel {name}: {:?}", self.max_lag);
            assert!(
                self.max_drift[k] < 1e-3,
                "channel {name}: {:?}",
                self.max_drift
            );
            assert!(
                self.max_error[k] <= 0.5 + self.max_drift[k],
                "channel {name}: max |position − exact| = {} steps",
                self.max_error[k]
            );
            assert_eq!(self.steps[k] as f64, self.rig.position(self.ch[k]));
        }
    }
}

#[test]
fn ten_minutes_of_mixed_inputs_stay_within_half_a_step() {
    let mut m = Mixed::new();
    m.run(25_000 * 600);
    assert_eq!(m.frames, 15_000_000);
    m.check();
    // It moved: tens of thousands of steps on each CoreXY motor.
    for k in 0..2 {
        let c = m.ch[k];
        assert!(m.rig.position(c).abs() > 1000.0, "{}", m.rig.position(c));
    }
    assert!(m.travel.abs() > 1e-3);
}
