//! Auto-tuning a servo actuator on its simulated plant, through the node's
//! own loop: the node runs the experiments (`ServoTest`: drive steps, a
//! relay) at its loop rate and sends every tick upstream; the host
//! identifies the plant and computes the gains.
//!
//! * Two drive steps give the motor's speed per duty `Kv` (counts/s), the
//!   friction's duty and the velocity's reaction curve as a delay `L` and
//!   a time constant `T` (the thesis's Ziegler–Nichols quantities, found
//!   by Smith's two points, 28.3 % and 63.2 % of the final speed, rather
//!   than by a tangent on differenced encoder counts). The feed-forward follows from
//!   the model: `kv = 1/Kv`, `ka = T/Kv`, `kf` the friction's duty.
//! * Feedback, by `Rule`: the thesis's Ziegler–Nichols table on the
//!   position's reaction curve (an integrating process of slope `Kv`:
//!   `kp = 1.2/(Kv·L)`, `Ti = 2L`, `Td = L/2`); with a relay
//!   (Åström–Hägglund), the ultimate gain `Ku = 4d/(π·a)` and period `Tu`
//!   in Ziegler–Nichols' ultimate-gain rules (`kp = 0.6 Ku`, `Ti = Tu/2`,
//!   `Td = Tu/8`); or `Model`, from the identified model: the derivative
//!   cancels the motor's pole (`kd = kp·T`), the crossover is set where the
//!   delay leaves 60° of phase (`kp·Kv = 0.4/L`, at most a twentieth of
//!   the loop rate), the integral a decade below it.

use crate::servo::ServoPlants;
use motet_host::{Machine, ServoSpec};
use motet_node::Node;
use motet_planner::{Command, Located, Move, MoveKind, SourceLoc};
use motet_trajectory::{JointMap, Point};
use motet_wire::control::{SampleData, SampleSource, ServoGains, ServoTest};
use motet_wire::{encode, HostMessage, NodeMessage, MAX_MESSAGE};

/// Which experiment gives the feedback gains.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Drive steps: the reaction curve.
    Step,
    /// Relay feedback: the ultimate gain and period.
    Relay,
}

/// How the feedback gains follow from what was identified.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    /// Ziegler–Nichols (the thesis's table, or the ultimate-gain rules
    /// after a relay).
    ZieglerNichols,
    /// From the identified model (see the module's description).
    Model,
}

/// What the experiments found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Identified {
    /// Motor speed per unit duty, counts/s.
    pub kv: f64,
    /// The duty friction takes.
    pub friction_duty: f64,
    /// The velocity's reaction curve: delay and time constant, s.
    pub delay_s: f64,
    /// Time constant, s.
    pub tau_s: f64,
    /// Relay: ultimate gain (duty/count) and period (s).
    pub ultimate: Option<(f64, f64)>,
}

/// A tuning: the gains, what they came from, the experiments' traces and
/// a move run with them.
pub struct Tuning {
    /// The gains found.
    pub gains: ServoGains,
    /// What the experiments identified.
    pub identified: Identified,
    /// Each experiment's trace: name, (time s, counts from its start).
    pub experiments: Vec<(String, Vec<(f64, f64)>)>,
    /// The check move with the new gains: its report and the samples of
    /// the servo at every tick.
    pub check: crate::StreamRun,
}

/// Why a servo could not be tuned.
#[derive(Debug, thiserror::Error)]
pub enum TuneError {
    /// No such actuator, or not a servo on an axis of its own.
    #[error("{0}")]
    Actuator(String),
    /// An experiment gave nothing to identify.
    #[error("the {0} experiment gave no usable response: {1}")]
    Experiment(&'static str, String),
    /// The check move failed.
    #[error("the check move with the new gains failed: {0}")]
    Check(#[from] crate::SimError),
}

/// The axis a servo actuator's joint is (cartesian joints only).
fn axis_of(machine: &Machine, a: usize) -> Option<usize> {
    match machine.joints[machine.actuators[a].joint].map {
        JointMap::Linear { coeffs } => {
            let nz: Vec<usize> = (0..coeffs.len()).filter(|&i| coeffs[i] != 0.0).collect();
            (nz.len() == 1 && coeffs[nz[0]] == 1.0).then(|| nz[0])
        }
        _ => None,
    }
}

/// Tunes servo actuator `name` of `machine` by `method` and `rule`.
pub fn tune(
    machine: &Machine,
    name: &str,
    method: Method,
    rule: Rule,
) -> Result<Tuning, TuneError> {
    let a = machine
        .actuators
        .iter()
        .position(|x| x.name == name)
        .ok_or_else(|| {
            let names: Vec<_> = machine.actuators.iter().map(|x| x.name.as_str()).collect();
            TuneError::Actuator(format!(
                "no actuator `{name}`; this machine has {}",
                names.join(", ")
            ))
        })?;
    let spec = machine.actuators[a]
        .servo
        .clone()
        .ok_or_else(|| TuneError::Actuator(format!("actuator {name} is a stepper, not a servo")))?;
    let axis = axis_of(machine, a).ok_or_else(|| {
        TuneError::Actuator(format!(
            "actuator {name}: only a servo on an axis of its own is tuned"
        ))
    })?;
    let mut bench = Bench::new(machine, a, axis, &spec);
    let low = bench.step(0.08)?;
    let high = bench.step(0.16)?;
    let mut identified = identify(&low.1, &high.1, 0.08, 0.16, bench.dt())?;
    let mut experiments = vec![
        ("step to 8 % duty".to_string(), low.0),
        ("step to 16 % duty".to_string(), high.0),
    ];
    if method == Method::Relay {
        let (trace, ultimate) = bench.relay(0.1, 2.0)?;
        identified.ultimate = Some(ultimate);
        experiments.push(("relay ±10 %".into(), trace));
    }
    let gains = gains_for(&identified, &spec, method, rule);
    let check = check_move(machine, a, axis, gains)?;
    Ok(Tuning {
        gains,
        identified,
        experiments,
        check,
    })
}

/// An experiment's trace: (time s, counts from its start).
type Trace = Vec<(f64, f64)>;

/// A node with one servo on its plant, for experiments.
struct Bench {
    node: Node,
    plants: ServoPlants,
    rate: f64,
    t: f64,
}

impl Bench {
    fn new(machine: &Machine, a: usize, axis: usize, spec: &ServoSpec) -> Bench {
        // At the middle of the travel, with room either way.
        let mut start: Point = machine.start;
        let t = machine.axes[axis].travel;
        if t[0].is_finite() && t[1].is_finite() {
            start[axis] = (t[0] + t[1]) / 2.0;
        }
        let act = &machine.actuators[a];
        let map = machine.joints[act.joint].map;
        let mut node: Node = Node::new();
        let plant = crate::servo::ServoPlant::new(machine, a, &start, 0.0);
        let plants = ServoPlants::single(plant);
        let mut b = Bench {
            node: Node::new(),
            plants,
            rate: spec.rate_hz,
            t: 0.0,
        };
        // Between experiments the loop holds the axis where it is (a z
        // axis would fall): with the machine file's gains, or a weak P+I
        // loop when it has none; no following limit.
        let mut quiet = spec.clone();
        if spec.gains.kp == 0.0 {
            quiet.gains = ServoGains {
                kp: 1e-4,
                ki: 1e-3,
                kd: 0.0,
                kv: 0.0,
                ka: 0.0,
                kf: 0.0,
                ..spec.gains
            };
        }
        quiet.following_limit = motet_wire::control::MAX_FOLLOWING as f64;
        let setup = [
            HostMessage::ConfigureServo(quiet.config(0, map, act.steps_per_unit)),
            HostMessage::SetPosition { position: start },
            HostMessage::Sampling {
                source: SampleSource::Servo(0),
                every: 1,
            },
        ];
        std::mem::swap(&mut b.node, &mut node);
        for m in &setup {
            b.send(m);
        }
        b
    }

    fn dt(&self) -> f64 {
        1.0 / self.rate
    }

    fn send(&mut self, m: &HostMessage) {
        let mut buf = [0u8; MAX_MESSAGE];
        if let Ok(bytes) = encode(m, &mut buf) {
            self.node.handle(bytes);
        }
    }

    /// Runs `ms` of host time; the servo's counts at every tick.
    fn run(&mut self, ms: f64) -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        let until = self.t + ms * 1e3;
        while self.t < until {
            // Short enough that the node's queue upstream (four batches)
            // never fills between polls.
            self.t = (self.t + 2_000.0).min(until);
            self.node.poll(self.t, &mut self.plants);
            while let Some(m) = self.node.take_upstream() {
                if let NodeMessage::Samples(b) = m {
                    if let SampleData::Servo { base, samples } = &b.data {
                        let mut c = *base;
                        for (i, s) in samples.iter().enumerate() {
                            c += s.delta as i64;
                            out.push(((b.t0 + i as f64 * b.period_us as f64) * 1e-6, c as f64));
                        }
                    }
                }
            }
        }
        // What is still gathered goes too.
        self.send(&HostMessage::Sampling {
            source: SampleSource::Servo(0),
            every: 1,
        });
        while let Some(NodeMessage::Samples(b)) = self.node.take_upstream() {
            if let SampleData::Servo { base, samples } = &b.data {
                let mut c = *base;
                for (i, s) in samples.iter().enumerate() {
                    c += s.delta as i64;
                    out.push(((b.t0 + i as f64 * b.period_us as f64) * 1e-6, c as f64));
                }
            }
        }
        out
    }

    /// Closes the loop a test left open, holding where the motor is.
    fn hold(&mut self) {
        self.send(&HostMessage::SetPosition { position: [0.0; 6] });
    }

    /// Waits for the held shaft to come to rest (at most 10 s).
    fn settle(&mut self) {
        for _ in 0..100 {
            let trace = self.run(100.0);
            let (lo, hi) = trace
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                    (a.min(p.1), b.max(p.1))
                });
            if hi - lo <= 1.0 {
                return;
            }
        }
    }

    /// A drive step of `duty` for 200 ms from rest: the trace (from the
    /// step, counts from where it started) and the speed at every tick.
    fn step(&mut self, duty: f32) -> Result<(Trace, Vec<f64>), TuneError> {
        self.settle();
        let test = ServoTest::Step {
            duty,
            duration_ms: 200,
        };
        self.send(&HostMessage::ServoTest { channel: 0, test });
        let trace = self.run(200.0);
        self.hold();
        let trace = relative(&trace);
        if trace.len() < 100 {
            return Err(TuneError::Experiment(
                "step",
                format!("{} samples", trace.len()),
            ));
        }
        let speed = (0..trace.len())
            .map(|i| {
                let (lo, hi) = (i.saturating_sub(4), (i + 4).min(trace.len() - 1));
                (trace[hi].1 - trace[lo].1) / (trace[hi].0 - trace[lo].0).max(1e-9)
            })
            .collect();
        Ok((trace, speed))
    }

    /// A relay of ±`amplitude` with a band of ±`hysteresis` counts for
    /// 400 ms: the trace and (Ku, Tu) from its last half.
    fn relay(&mut self, amplitude: f32, hysteresis: f32) -> Result<(Trace, (f64, f64)), TuneError> {
        self.settle();
        let test = ServoTest::Relay {
            amplitude,
            hysteresis,
            duration_ms: 400,
        };
        self.send(&HostMessage::ServoTest { channel: 0, test });
        let trace = relative(&self.run(400.0));
        self.hold();
        let half = &trace[trace.len() / 2..];
        let (lo, hi) = half
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.1), b.max(p.1))
            });
        let mid = (lo + hi) / 2.0;
        let ups: Vec<f64> = half
            .windows(2)
            .filter(|w| w[0].1 < mid && w[1].1 >= mid)
            .map(|w| w[1].0)
            .collect();
        if ups.len() < 3 {
            return Err(TuneError::Experiment(
                "relay",
                format!("{} oscillations", ups.len()),
            ));
        }
        let tu = (ups[ups.len() - 1] - ups[0]) / (ups.len() - 1) as f64;
        let a = ((hi - lo) / 2.0).max(hysteresis as f64 * 1.01);
        let a = (a * a - (hysteresis as f64).powi(2)).sqrt();
        let ku = 4.0 * amplitude as f64 / (std::f64::consts::PI * a);
        Ok((trace, (ku, tu)))
    }
}

/// A trace from its first point: times and counts from there.
fn relative(trace: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let Some(&(t0, c0)) = trace.first() else {
        return Vec::new();
    };
    trace.iter().map(|&(t, c)| (t - t0, c - c0)).collect()
}

/// The model from two steps' speeds (duties `d1` < `d2`), `dt` s apart.
fn identify(v1: &[f64], v2: &[f64], d1: f64, d2: f64, dt: f64) -> Result<Identified, TuneError> {
    let tail = |v: &[f64]| {
        let n = v.len();
        v[n * 7 / 10..n - 4].iter().sum::<f64>() / (n - 4 - n * 7 / 10) as f64
    };
    let (s1, s2) = (tail(v1), tail(v2));
    if !(s2 > s1 && s1 > 0.0) {
        return Err(TuneError::Experiment(
            "step",
            format!("speeds {s1:.0} and {s2:.0} counts/s"),
        ));
    }
    let kv = (s2 - s1) / (d2 - d1);
    let friction_duty = (d1 - s1 / kv).max(0.0);
    // The reaction curve of the larger step as a delay and a lag, from
    // the times it reaches 28.3 % and 63.2 % of its final speed (Smith's
    // two points: the tangent of the thesis's construction, found from
    // differenced encoder counts, is at the mercy of their quantisation).
    // Each crossing between ticks, interpolated.
    let first = |frac: f64| {
        let goal = frac * s2;
        let i = v2.iter().position(|&v| v >= goal)?;
        let before = if i > 0 { v2[i - 1] } else { 0.0 };
        let f = if v2[i] > before {
            (goal - before) / (v2[i] - before)
        } else {
            1.0
        };
        Some((i as f64 - 1.0 + f).max(0.0) * dt)
    };
    let (Some(t28), Some(t63)) = (first(0.283), first(0.632)) else {
        return Err(TuneError::Experiment("step", "no rise".into()));
    };
    let tau = (1.5 * (t63 - t28)).max(dt);
    let delay = (t63 - tau).max(dt);
    Ok(Identified {
        kv,
        friction_duty,
        delay_s: delay,
        tau_s: tau,
        ultimate: None,
    })
}

/// The gains from what was identified.
fn gains_for(id: &Identified, spec: &ServoSpec, method: Method, rule: Rule) -> ServoGains {
    let g = spec.gains;
    let (kp, ki, kd) = match (method, rule, id.ultimate) {
        (Method::Relay, Rule::ZieglerNichols, Some((ku, tu))) => {
            let kp = 0.6 * ku;
            (kp, kp / (tu / 2.0), kp * tu / 8.0)
        }
        (_, Rule::ZieglerNichols, _) => {
            // The position's reaction curve: slope Kv per unit duty after
            // the delay the velocity's tangent shows plus its lag.
            let l = id.delay_s + id.tau_s;
            let kp = 1.2 / (id.kv * l);
            (kp, kp / (2.0 * l), kp * l / 2.0)
        }
        (_, Rule::Model, _) => {
            let wc = (0.4 / id.delay_s).min(std::f64::consts::TAU * spec.rate_hz / 20.0);
            let kp = wc / id.kv;
            (kp, kp * wc / 10.0, kp * id.tau_s)
        }
    };
    let clamp = |v: f64, i: usize| {
        let (_, lo, hi) = motet_wire::control::GAIN_RANGES[i];
        (v as f32).clamp(lo, hi)
    };
    ServoGains {
        kp: clamp(kp, 0),
        ki: clamp(ki, 1),
        kd: clamp(kd, 2),
        kv: clamp(1.0 / id.kv, 3),
        ka: clamp(id.tau_s / id.kv, 4),
        kf: clamp(id.friction_duty, 5),
        integral_limit: g.integral_limit,
        output_limit: g.output_limit,
        derivative_hz: clamp((spec.rate_hz / 20.0).min(1000.0), 8),
    }
}

/// A check move with `gains`: a quarter of the travel out and back, at
/// the axis's limits, every tick sampled.
fn check_move(
    machine: &Machine,
    a: usize,
    axis: usize,
    gains: ServoGains,
) -> Result<crate::StreamRun, TuneError> {
    let mut m = machine.clone();
    if let Some(s) = m.actuators[a].servo.as_mut() {
        s.gains = gains;
    }
    // A sample every few ticks (the simulator's nodes are polled a quarter
    // second at a time, their queue upstream four batches deep).
    for n in m.nodes.iter_mut() {
        n.sample_budget = 2100.0;
    }
    let start = m.start;
    let t = m.axes[axis].travel;
    let span = if t[0].is_finite() && t[1].is_finite() {
        (t[1] - t[0]) / 4.0
    } else {
        10.0
    };
    let from = if start[axis] + span <= t[1] {
        start[axis]
    } else {
        t[0]
    };
    let mut commands = Vec::new();
    for x in [from, from + span, from] {
        let mut target = start;
        target[axis] = x;
        commands.push(Ok::<_, std::convert::Infallible>(Located {
            item: Command::Move(Move {
                target,
                feed: m.axes[axis].max_velocity,
                kind: MoveKind::Feed,
            }),
            loc: SourceLoc::default(),
        }));
    }
    Ok(crate::simulate_stream(
        &m,
        "check move",
        commands.into_iter(),
        3,
        &mut |_, _| {},
        &mut |_| {},
    )?)
}
