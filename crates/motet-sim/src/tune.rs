//! Auto-tuning a servo actuator on its simulated plant, through the node's
//! own loop: the node runs the experiments (`ServoTest`: drive steps, a
//! relay) at its loop rate and sends every tick upstream; the host
//! identifies the plant and computes the gains.
//!
//! * Two drive steps each way give the motor's speed per duty `Kv`
//!   (counts/s), the friction's duty (what hinders both ways) apart from a
//!   constant load's (what helps one way: gravity, held by the integral),
//!   and the velocity's reaction curve as a delay `L` and a time constant
//!   `T` (the thesis's Ziegler–Nichols quantities), fitted by least squares
//!   to the counts over the whole step rather than read off speeds
//!   differenced from them. The feed-forward follows from the model:
//!   `kv = 1/Kv`, `ka = T/Kv`, `kf` the friction's duty, and its `lead`
//!   `L` (the current's lag and the tick's hold, which the node's
//!   feed-forward looks ahead by).
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
    /// The position's lag behind a constant speed, s: where the high
    /// step's position, once at speed, extrapolates back to zero (every
    /// lag and delay of the motor, its drive and the loop's tick added).
    pub lag_s: f64,
    /// The duty a constant load takes (gravity on a z axis), positive
    /// against the joint's positive direction: what the steps either way
    /// differ by; the integral holds it.
    pub load_duty: f64,
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
    // Each step either way in turn, so the carriage stays near the middle
    // and a constant load (which helps one way, hinders the other) is told
    // from friction (which hinders both).
    let low = bench.step(0.08)?;
    let back_low = bench.step(-0.08)?;
    let high = bench.step(0.16)?;
    let back_high = bench.step(-0.16)?;
    let forward = identify(&low, &high, 0.08, 0.16, bench.dt())?;
    let backward = identify(
        &mirrored(&back_low),
        &mirrored(&back_high),
        0.08,
        0.16,
        bench.dt(),
    )?;
    let mut identified = combine(&forward, &backward);
    let mut experiments = vec![
        ("step to 8 % duty".to_string(), low.0),
        ("step to 16 % duty".to_string(), high.0),
        ("step to −16 % duty".to_string(), back_high.0),
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

    /// Closes the loop a test left open, holding where the motor is: after
    /// the test's last tick (at its end, which the run up to it has not
    /// reached), or that tick would open the loop again and leave it so
    /// (a z axis falling under its load between experiments).
    fn hold(&mut self) {
        self.run(2e3 / self.rate);
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
                format!("{} samples at duty {duty}", trace.len()),
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

/// A step's trace and speeds the other way up.
fn mirrored(step: &(Trace, Vec<f64>)) -> (Trace, Vec<f64>) {
    (
        step.0.iter().map(|&(t, c)| (t, -c)).collect(),
        step.1.iter().map(|v| -v).collect(),
    )
}

/// One model from the steps either way: the friction is what they share,
/// a constant load what they differ by.
fn combine(forward: &Identified, backward: &Identified) -> Identified {
    let mean = |a: f64, b: f64| (a + b) / 2.0;
    Identified {
        kv: mean(forward.kv, backward.kv),
        friction_duty: mean(forward.friction_duty, backward.friction_duty).max(0.0),
        delay_s: mean(forward.delay_s, backward.delay_s),
        tau_s: mean(forward.tau_s, backward.tau_s),
        lag_s: mean(forward.lag_s, backward.lag_s),
        load_duty: (forward.friction_duty - backward.friction_duty) / 2.0,
        ultimate: None,
    }
}

/// A trace from its first point: times and counts from there.
fn relative(trace: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let Some(&(t0, c0)) = trace.first() else {
        return Vec::new();
    };
    trace.iter().map(|&(t, c)| (t - t0, c - c0)).collect()
}

/// The model from two steps (duties `d1` < `d2`), their traces at ticks
/// `dt` s apart; the friction's duty as it shows that way (a constant load
/// in it, with its sign).
///
/// The motor's speed after a step is taken as a delay `L` and a lag `T`
/// (the thesis's reaction curve), fitted by least squares to the position
/// itself over the whole step, the final speed with them: a tangent, or
/// Smith's two points, on speeds differenced from encoder counts are at
/// the mercy of their quantisation (the more the slower the motor), and a
/// final speed read off the trace's end is short of the true one by what
/// the motor had still to gain.
fn identify(
    low: &(Trace, Vec<f64>),
    high: &(Trace, Vec<f64>),
    d1: f64,
    d2: f64,
    dt: f64,
) -> Result<Identified, TuneError> {
    let (trace, slow) = (&high.0, &low.0);
    if trace.len() < 100 || slow.len() < 100 {
        return Err(TuneError::Experiment("step", "no rise".into()));
    }
    let (l, tau, s2) = fit_reaction(trace, dt);
    let s1 = final_speed(slow, l, tau);
    if !(s2 > s1 && s1 > 0.0) {
        return Err(TuneError::Experiment(
            "step",
            format!("speeds {s1:.0} and {s2:.0} counts/s"),
        ));
    }
    let kv = (s2 - s1) / (d2 - d1);
    Ok(Identified {
        kv,
        friction_duty: d1 - s1 / kv,
        delay_s: l,
        tau_s: tau,
        lag_s: l + tau,
        load_duty: 0.0,
        ultimate: None,
    })
}

/// Counts from a step's start, per count/s of final speed, `t` s after it,
/// of a speed that follows after a delay `l` with a lag `tau`.
fn reaction(t: f64, l: f64, tau: f64) -> f64 {
    let u = t - l;
    if u > 0.0 {
        u - tau * (1.0 - (-u / tau).exp())
    } else {
        0.0
    }
}

/// The final speed that puts the reaction curve `(l, tau)` nearest the
/// trace (linear least squares).
fn final_speed(trace: &[(f64, f64)], l: f64, tau: f64) -> f64 {
    let (mut cg, mut gg) = (0.0, 0.0);
    for &(t, c) in trace {
        let g = reaction(t, l, tau);
        cg += c * g;
        gg += g * g;
    }
    if gg > 0.0 {
        cg / gg
    } else {
        0.0
    }
}

/// `(L, T, final speed)` nearest the step's trace: the final speed in
/// closed form for each curve, `T` and then `L` by ternary search.
fn fit_reaction(trace: &[(f64, f64)], dt: f64) -> (f64, f64, f64) {
    let misfit = |l: f64, tau: f64| {
        let s = final_speed(trace, l, tau);
        trace
            .iter()
            .map(|&(t, c)| (c - s * reaction(t, l, tau)).powi(2))
            .sum::<f64>()
    };
    let span = trace.last().map_or(1.0, |p| p.0);
    let best_tau = |l: f64| {
        let (mut lo, mut hi) = (dt, span / 2.0);
        for _ in 0..60 {
            let (a, b) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
            if misfit(l, a) <= misfit(l, b) {
                hi = b;
            } else {
                lo = a;
            }
        }
        (lo + hi) / 2.0
    };
    let (mut lo, mut hi) = (0.0, (span / 10.0).min(0.02));
    for _ in 0..40 {
        let (a, b) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
        if misfit(a, best_tau(a)) <= misfit(b, best_tau(b)) {
            hi = b;
        } else {
            lo = a;
        }
    }
    let l = ((lo + hi) / 2.0).max(dt);
    let tau = best_tau(l);
    (l, tau, final_speed(trace, l, tau))
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
    // The feed-forward: the motor's speed follows its drive as
    // `1/((1 + s·T)(1 + s·L'))` (the mechanical lag `T`, the current's and
    // the tick's `L'`), which a drive of `kv·v + ka·a` taken `lead` ahead
    // inverts to first order when `lead + ka·Kv` is the whole lag: the
    // lead is the reaction curve's delay, the acceleration's share the
    // rest of the measured lag.
    let lead = id.delay_s;
    let accel_lag = (id.lag_s - lead).max(0.0);
    let clamp = |v: f64, i: usize| {
        let (_, lo, hi) = motet_wire::control::GAIN_RANGES[i];
        (v as f32).clamp(lo, hi)
    };
    ServoGains {
        kp: clamp(kp, 0),
        ki: clamp(ki, 1),
        kd: clamp(kd, 2),
        kv: clamp(1.0 / id.kv, 3),
        ka: clamp(accel_lag / id.kv, 4),
        kf: clamp(id.friction_duty, 5),
        integral_limit: g.integral_limit,
        output_limit: g.output_limit,
        derivative_hz: clamp((spec.rate_hz / 20.0).min(1000.0), 8),
        lead: clamp(lead, 9),
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
