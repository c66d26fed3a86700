//! Servo channels on the node: the position loop ticks at its rate in time
//! order with the other outputs, follows the trajectory on a motor, trips
//! on its following-error limit, a limit switch or a lost encoder, takes
//! gains live, and sends its samples upstream.

use crate::common;

use common::{feed, limits, plan, pt};
use motet_node::{Board, Node};
use motet_planner::Planned;
use motet_trajectory::{JointMap, ProfileKind};
use motet_wire::control::{
    FaultKind, SampleData, SampleSource, ServoConfig, ServoGains, ServoTest,
};
use motet_wire::{encode, HostMessage, NodeMessage, MAX_MESSAGE};

/// Counts per mm of the test axis.
const CPU: f64 = 100.0;

/// A motor on channel 0 as a first-order speed lag: full drive gives
/// `GAIN` counts/s, `TAU` s to get there; its encoder counts whole counts.
/// Everything the node did, in order.
struct Motor {
    pos: f64,
    vel: f64,
    duty: f32,
    t: f64,
    /// (time, duty) of every drive.
    drives: Vec<(f64, f32)>,
    /// Encoder reads, times.
    reads: Vec<f64>,
    /// The encoder answers (false: a cut cable).
    encoder: bool,
    /// A switch opens beyond this count.
    limit_at: f64,
}

const GAIN: f64 = 40_000.0;
const TAU: f64 = 0.02;

impl Motor {
    fn new() -> Motor {
        Motor {
            pos: 0.0,
            vel: 0.0,
            duty: 0.0,
            t: 0.0,
            drives: vec![],
            reads: vec![],
            encoder: true,
            limit_at: f64::INFINITY,
        }
    }

    fn advance(&mut self, t: f64) {
        let h = (t - self.t) * 1e-6;
        if h > 0.0 {
            let goal = GAIN * self.duty as f64;
            let k = (-h / TAU).exp();
            self.pos += goal * h + (self.vel - goal) * TAU * (1.0 - k);
            self.vel = goal + (self.vel - goal) * k;
            self.t = t;
        }
    }
}

impl Board for Motor {
    fn step(&mut self, _: u8, _: bool, _: f64) {}
    fn set_tool(&mut self, _: u8, _: f32, _: f64) {}
    fn encoder(&mut self, channel: u8, at_us: f64) -> Option<i64> {
        assert_eq!(channel, 0);
        self.advance(at_us);
        self.reads.push(at_us);
        self.encoder.then(|| self.pos.floor() as i64)
    }
    fn drive(&mut self, _: u8, duty: f32, at_us: f64) {
        self.advance(at_us);
        self.duty = duty;
        self.drives.push((at_us, duty));
    }
    fn limit(&mut self, _: u8, _: f64) -> bool {
        self.pos > self.limit_at
    }
}

fn gains() -> ServoGains {
    ServoGains {
        kp: 0.004,
        ki: 0.2,
        kd: 8e-5,
        kv: (1.0 / GAIN) as f32,
        ka: (TAU / GAIN) as f32,
        kf: 0.0,
        integral_limit: 0.2,
        output_limit: 1.0,
        derivative_hz: 0.0,
        lead: 0.0,
    }
}

fn servo(gains: ServoGains, following_limit: f32) -> ServoConfig {
    ServoConfig {
        channel: 0,
        map: JointMap::axis(0),
        counts_per_unit: CPU,
        rate_hz: 10_000.0,
        gains,
        following_limit,
    }
}

fn send(node: &mut Node, m: &HostMessage) -> Option<NodeMessage> {
    let mut buf = [0u8; MAX_MESSAGE];
    node.handle(encode(m, &mut buf).unwrap())
}

/// A node with the servo, given a 60 mm move and back on x.
fn moving(config: ServoConfig) -> (Node, f64) {
    moving_along(config, &[60.0, 0.0])
}

/// A node with the servo, given moves on x to each of `xs` (mm) from 0,
/// starting 10 ms in; and when they end.
fn moving_along(config: ServoConfig, xs: &[f64]) -> (Node, f64) {
    let mut node: Node = Node::new();
    assert_eq!(send(&mut node, &HostMessage::ConfigureServo(config)), None);
    assert_eq!(
        send(
            &mut node,
            &HostMessage::SetPosition {
                position: pt(0.0, 0.0, 0.0)
            }
        ),
        None
    );
    let planned = plan(
        limits(ProfileKind::Trapezoid),
        pt(0.0, 0.0, 0.0),
        &xs.iter()
            .map(|&x| feed(x, 0.0, 0.0, 100.0))
            .collect::<Vec<_>>(),
    );
    let mut end = 0.0;
    for (seq, p) in planned.iter().enumerate() {
        let Planned::Segment(s) = p else { continue };
        end = s.t1();
        let mut axes = heapless::Vec::new();
        axes.push(motet_wire::AxisSpan {
            axis: 0,
            from: s.start[0],
            to: s.end[0],
        })
        .unwrap();
        let m = HostMessage::Segment(motet_wire::SegmentMsg {
            seq: seq as u32,
            t0: s.t0 + 10_000.0,
            profile: s.profile.params(),
            axes,
        });
        assert_eq!(send(&mut node, &m), None);
    }
    (node, end + 10_000.0)
}

/// Polls every `frame` µs (or at the node's deadlines when 0) until
/// `until`, collecting what the node sends upstream.
fn run(node: &mut Node, motor: &mut Motor, until: f64, frame: f64) -> Vec<NodeMessage> {
    let mut up = vec![];
    let mut t = 0.0;
    while t < until {
        t = if frame > 0.0 {
            (t + frame).min(until)
        } else {
            node.next_deadline()
                .map_or(until, |d| d.max(t) + 1.0)
                .min(until)
        };
        node.poll(t, motor);
        up.extend(std::iter::from_fn(|| node.take_upstream()));
    }
    up
}

#[test]
fn follows_a_move_at_its_rate() {
    let (mut node, end) = moving(servo(gains(), 200.0));
    let every = HostMessage::Sampling {
        source: SampleSource::Servo(0),
        every: 1,
    };
    assert_eq!(send(&mut node, &every), None);
    let mut motor = Motor::new();
    let up = run(&mut node, &mut motor, end + 50_000.0, 40.0);
    assert!(
        up.iter().all(|m| !matches!(m, NodeMessage::Fault { .. })),
        "{up:?}"
    );
    // Every tick's following error, from the samples (1/16 count).
    let worst = up
        .iter()
        .filter_map(|m| match m {
            NodeMessage::Samples(b) => match &b.data {
                SampleData::Servo { samples, .. } => samples
                    .iter()
                    .map(|s| s.error_lo.unsigned_abs().max(s.error_hi.unsigned_abs()))
                    .max(),
                _ => None,
            },
            _ => None,
        })
        .max()
        .unwrap();
    eprintln!("worst following error {} counts", worst as f64 / 16.0);
    assert!(worst <= 4 * 16, "{worst}");
    // One read and one drive a tick, every 100 µs, in time order.
    let ticks = motor.reads.len();
    assert!(
        (ticks as f64 - (end + 50_000.0) / 100.0).abs() <= 2.0,
        "{ticks}"
    );
    assert!(motor
        .reads
        .windows(2)
        .all(|w| (w[1] - w[0] - 100.0).abs() < 1e-6));
    assert_eq!(motor.drives.len(), ticks);
    // Back where it started, within a count, and never far behind.
    assert!(motor.pos.abs() < 2.0, "{}", motor.pos);
    let worst = node.control().servos()[0].following_error();
    assert!(worst.abs() < 2.0, "{worst}");
    // Segments are gone once the servo is past them.
    assert_eq!(node.queued(), 0);
}

/// The loop's outputs are the same whether the caller polls every frame
/// or jumps to the node's own deadlines.
#[test]
fn frame_skipping_is_exact() {
    let runs: Vec<Vec<(u64, u32)>> = [40.0, 1000.0, 0.0]
        .iter()
        .map(|&frame| {
            let (mut node, end) = moving(servo(gains(), 200.0));
            let mut motor = Motor::new();
            run(&mut node, &mut motor, end + 30_000.0, frame);
            motor
                .drives
                .iter()
                .map(|(t, d)| (t.to_bits(), d.to_bits()))
                .collect()
        })
        .collect();
    assert!(runs[0].len() > 1000);
    for r in &runs[1..] {
        let first = runs[0].iter().zip(r).position(|(a, b)| a != b);
        assert_eq!((first, r.len()), (None, runs[0].len()));
    }
}

#[test]
fn following_error_trips_the_loop() {
    // No feedback and no feed-forward: the motor never moves, the set point
    // runs away from it.
    let zero = ServoGains {
        kp: 0.0,
        ki: 0.0,
        kd: 0.0,
        kv: 0.0,
        ka: 0.0,
        ..gains()
    };
    let (mut node, end) = moving(servo(zero, 40.0));
    let mut motor = Motor::new();
    let up = run(&mut node, &mut motor, end, 40.0);
    let faults: Vec<_> = up
        .iter()
        .filter_map(|m| match m {
            NodeMessage::Fault {
                source,
                kind,
                value,
                at,
            } => Some((*source, *kind, *value, *at)),
            _ => None,
        })
        .collect();
    assert_eq!(faults.len(), 1, "{faults:?}");
    let (source, kind, value, at) = faults[0];
    assert_eq!(
        (source, kind),
        (SampleSource::Servo(0), FaultKind::Following)
    );
    assert!(value > 40.0 && value < 45.0, "{value}");
    // It drives 0 from then on, and nothing more.
    let last = motor.drives.last().unwrap();
    assert_eq!(*last, (at, 0.0));
    assert_eq!(
        node.control().servos()[0].fault(),
        Some(FaultKind::Following)
    );
}

/// With a lead the feed-forward looks ahead on the trajectory: the drive
/// starts twice the lead before the set point moves, and cruising it is
/// the same as without (the window's mean speed is the speed).
#[test]
fn the_feed_forward_looks_ahead_by_its_lead() {
    // (lead s, when the drive first moves, µs)
    let cases = [(0.0, 10_000.0), (0.0005, 9_000.0), (0.002, 6_000.0)];
    let mut cruise = vec![];
    for (lead, starts) in cases {
        let open = ServoGains {
            kp: 0.0,
            ki: 0.0,
            kd: 0.0,
            lead,
            ..gains()
        };
        let (mut node, end) = moving(servo(open, 1e6));
        let mut motor = Motor::new();
        run(&mut node, &mut motor, end, 40.0);
        let first = motor.drives.iter().find(|d| d.1 != 0.0).unwrap().0;
        assert!(
            (first - starts).abs() <= 100.0,
            "lead {lead}: drives from {first} µs, want {starts}"
        );
        // Halfway out, at 100 mm/s: kv·v.
        let mid = motor
            .drives
            .iter()
            .find(|d| d.0 >= 10_000.0 + 300_000.0)
            .unwrap()
            .1;
        cruise.push(mid);
    }
    let want = (100.0 * CPU / GAIN) as f32;
    for c in cruise {
        assert!((c - want).abs() < 1e-4, "cruising at {c}, want {want}");
    }
}

/// Held at rest short of a count (the move ends 0.3 count past one), the
/// loop takes the error within a count as none: it stops driving and
/// settles instead of hunting across the count's edge.
#[test]
fn at_rest_an_error_within_a_count_is_none() {
    let p_only = ServoGains {
        kp: 0.02,
        ki: 0.0,
        kd: 0.0,
        kv: 0.0,
        ka: 0.0,
        ..gains()
    };
    let (mut node, end) = moving_along(servo(p_only, 1e6), &[0.103]);
    let mut motor = Motor::new();
    run(&mut node, &mut motor, end + 500_000.0, 40.0);
    let tail: Vec<_> = motor
        .drives
        .iter()
        .filter(|d| d.0 > end + 400_000.0)
        .collect();
    assert!(!tail.is_empty());
    assert!(tail.iter().all(|d| d.1 == 0.0), "{:?}", &tail[..4]);
    // Still, within a count of its set point.
    assert!((10.3 - motor.pos.floor()).abs() < 1.0, "{}", motor.pos);
    let last = motor.pos;
    run_from(&mut node, &mut motor, end + 500_000.0, end + 600_000.0);
    assert!(
        (motor.pos - last).abs() < 1e-6,
        "and stays: {last} {}",
        motor.pos
    );
    assert_eq!(node.next_deadline(), None, "settled");
}

#[test]
fn a_lost_encoder_faults_before_anything_moves() {
    let (mut node, _) = moving(servo(gains(), 200.0));
    let mut motor = Motor::new();
    motor.encoder = false;
    let up = run(&mut node, &mut motor, 1000.0, 40.0);
    assert!(
        matches!(
            up.as_slice(),
            [NodeMessage::Fault {
                kind: FaultKind::SensorLost,
                at: 0.0,
                ..
            }]
        ),
        "{up:?}"
    );
    assert_eq!(motor.drives, vec![(0.0, 0.0)]);
}

#[test]
fn a_limit_switch_stops_the_drive() {
    let (mut node, end) = moving(servo(gains(), 200.0));
    let mut motor = Motor::new();
    motor.limit_at = 30.0 * CPU;
    let up = run(&mut node, &mut motor, end, 40.0);
    assert!(up.iter().any(|m| matches!(
        m,
        NodeMessage::Fault {
            kind: FaultKind::Limit,
            ..
        }
    )));
    assert_eq!(motor.drives.last().unwrap().1, 0.0);
    assert!(
        motor.pos < 31.0 * CPU,
        "stopped near the switch: {}",
        motor.pos
    );
}

#[test]
fn gains_change_live_and_bad_ones_are_refused() {
    let (mut node, end) = moving(servo(gains(), 200.0));
    let mut motor = Motor::new();
    run(&mut node, &mut motor, end / 2.0, 40.0);
    for bad in [f32::NAN, -1.0, 1e9] {
        let g = ServoGains { kp: bad, ..gains() };
        let r = send(
            &mut node,
            &HostMessage::ServoGains {
                channel: 0,
                gains: g,
            },
        );
        assert!(matches!(r, Some(NodeMessage::Refused { .. })), "{bad}");
    }
    let r = send(
        &mut node,
        &HostMessage::ServoGains {
            channel: 3,
            gains: gains(),
        },
    );
    assert!(
        matches!(r, Some(NodeMessage::Refused { .. })),
        "no such servo"
    );
    assert_eq!(node.control().servos()[0].config().gains, gains());
    // Mid-move, a drive limit of 1 % takes hold at the next tick.
    let slow = ServoGains {
        output_limit: 0.01,
        ..gains()
    };
    let before = motor.drives.len();
    let r = send(
        &mut node,
        &HostMessage::ServoGains {
            channel: 0,
            gains: slow,
        },
    );
    assert_eq!(r, None);
    run_from(&mut node, &mut motor, end / 2.0, end / 2.0 + 5000.0);
    assert!(motor.drives[before..].iter().all(|d| d.1.abs() <= 0.01));
    assert_eq!(node.control().servos()[0].config().gains, slow);
}

fn run_from(node: &mut Node, motor: &mut Motor, from: f64, until: f64) {
    let mut t = from;
    while t < until {
        t += 40.0;
        node.poll(t, motor);
    }
}

#[test]
fn samples_go_upstream_within_a_message() {
    let (mut node, end) = moving(servo(gains(), 200.0));
    assert_eq!(
        send(
            &mut node,
            &HostMessage::Sampling {
                source: SampleSource::Servo(0),
                every: 50
            }
        ),
        None
    );
    let mut motor = Motor::new();
    let mut up = run(&mut node, &mut motor, end + 100_000.0, 40.0);
    // Turning sampling off sends what was gathered.
    let off = HostMessage::Sampling {
        source: SampleSource::Servo(0),
        every: 0,
    };
    assert_eq!(send(&mut node, &off), None);
    up.extend(std::iter::from_fn(|| node.take_upstream()));
    let mut samples = 0;
    let mut buf = [0u8; MAX_MESSAGE];
    let mut last_t = f64::NEG_INFINITY;
    for m in &up {
        assert!(encode(m, &mut buf).is_ok());
        let NodeMessage::Samples(b) = m else { continue };
        assert_eq!(b.source, SampleSource::Servo(0));
        assert!((b.period_us - 5000.0).abs() < 1e-3);
        assert!(b.t0 > last_t);
        last_t = b.t0;
        let SampleData::Servo { samples: s, .. } = &b.data else {
            panic!()
        };
        samples += s.len();
    }
    // Every 5 ms of the run, none lost (the run settles and flushes).
    let want = ((end + 100_000.0) / 5000.0) as usize;
    assert!(samples.abs_diff(want) <= 1, "{samples} vs {want}");
}

#[test]
fn a_relay_test_oscillates_about_its_start() {
    let mut node: Node = Node::new();
    send(
        &mut node,
        &HostMessage::ConfigureServo(servo(gains(), 200.0)),
    );
    send(
        &mut node,
        &HostMessage::SetPosition {
            position: pt(0.0, 0.0, 0.0),
        },
    );
    let test = ServoTest::Relay {
        amplitude: 0.2,
        hysteresis: 2.0,
        duration_ms: 300,
    };
    assert_eq!(
        send(&mut node, &HostMessage::ServoTest { channel: 0, test }),
        None
    );
    let mut motor = Motor::new();
    run(&mut node, &mut motor, 400_000.0, 40.0);
    let switches = motor.drives.windows(2).filter(|w| w[0].1 != w[1].1).count();
    assert!(switches >= 6, "{switches}");
    // Open once it ends: 0 and nothing after.
    let last = motor.drives.last().unwrap();
    assert_eq!(last.1, 0.0);
    assert!((last.0 - 300_000.0).abs() <= 100.0, "{last:?}");
}
