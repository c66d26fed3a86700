//! Heater channels on the node: the target follows its event track, the
//! PID brings a lumped thermal plant to it and holds it, readiness goes
//! upstream once the reading has stayed in its window, and the runaway
//! watch trips on a lost or implausible sensor, a heater that does not
//! heat, and one that falls away from its target, switching every heater
//! of the node off.

use motet_node::{Board, Node};
use motet_wire::control::{FaultKind, SampleData, SampleSource};
use motet_wire::heater::{HeaterConfig, HeaterGains, ReadyRule, RunawayWatch, ThermalModel};
use motet_wire::{encode, HostMessage, NodeMessage, MAX_MESSAGE};

/// A heater's block (capacity, power, loss to ambient) and a sensor that
/// lags it; each heater on drive `8 + i`, sensor `i`.
#[derive(Clone, Debug)]
struct Block {
    temp: f64,
    sensor: f64,
    power: f64,
    /// Watts at full power.
    watts: f64,
    /// J/K.
    capacity: f64,
    /// W/K.
    loss: f64,
    /// s.
    lag: f64,
    /// The heater's power reaches the block (false: its wire is cut).
    connected: bool,
    /// The sensor answers.
    answers: bool,
    /// Added to what the sensor reads, °C.
    offset: f64,
}

const AMBIENT: f64 = 25.0;

impl Block {
    fn hotend() -> Block {
        Block {
            temp: AMBIENT,
            sensor: AMBIENT,
            power: 0.0,
            watts: 40.0,
            capacity: 13.0,
            loss: 0.07,
            lag: 2.0,
            connected: true,
            answers: true,
            offset: 0.0,
        }
    }

    fn model(&self) -> ThermalModel {
        ThermalModel {
            heat_rate: (self.watts / self.capacity) as f32,
            loss: (self.loss / self.capacity) as f32,
            ambient_c: AMBIENT as f32,
        }
    }

    /// `h` seconds at the power applied, in small steps.
    fn advance(&mut self, h: f64) {
        let n = (h / 0.01).ceil().max(1.0) as usize;
        let dt = h / n as f64;
        for _ in 0..n {
            let p = if self.connected { self.power } else { 0.0 };
            self.temp += (self.watts * p - self.loss * (self.temp - AMBIENT)) / self.capacity * dt;
            self.sensor += (self.temp - self.sensor) / self.lag * dt;
        }
    }
}

/// Blocks on one board, in time order of the node's calls.
struct Plant {
    blocks: Vec<Block>,
    t: f64,
    /// (time, drive, power) of every drive.
    drives: Vec<(f64, u8, f32)>,
}

impl Plant {
    fn new(blocks: Vec<Block>) -> Plant {
        Plant {
            blocks,
            t: 0.0,
            drives: vec![],
        }
    }

    fn advance(&mut self, t: f64) {
        let h = (t - self.t) * 1e-6;
        if h > 0.0 {
            for b in self.blocks.iter_mut() {
                b.advance(h);
            }
            self.t = t;
        }
    }
}

impl Board for Plant {
    fn step(&mut self, _: u8, _: bool, _: f64) {}
    fn set_tool(&mut self, _: u8, _: f32, _: f64) {}
    fn temperature(&mut self, index: u8, at_us: f64) -> Option<f32> {
        self.advance(at_us);
        let b = &self.blocks[index as usize];
        b.answers.then_some((b.sensor + b.offset) as f32)
    }
    fn drive(&mut self, channel: u8, duty: f32, at_us: f64) {
        self.advance(at_us);
        self.drives.push((at_us, channel, duty));
        if let Some(b) = self.blocks.get_mut(channel as usize - 8) {
            b.power = duty as f64;
        }
    }
}

/// The gains Ziegler–Nichols' reaction curve gives the block: gain
/// watts/loss, time constant capacity/loss, dead time about the sensor's
/// lag.
fn gains(b: &Block) -> HeaterGains {
    let (k, tau, l) = (b.watts / b.loss, b.capacity / b.loss, b.lag + 0.05);
    let kp = 1.2 * tau / (k * l);
    HeaterGains {
        kp: kp as f32,
        ki: (kp / (2.0 * l)) as f32,
        kd: (kp * 0.5 * l) as f32,
        integral_limit: 0.3,
        output_limit: 1.0,
        derivative_s: 1.0,
        feed_forward: 1.0,
    }
}

fn config(i: u8, b: &Block) -> HeaterConfig {
    HeaterConfig {
        heater: i,
        sensor: i,
        drive: 8 + i,
        track: 128 + i,
        rate_hz: 10.0,
        gains: gains(b),
        max_c: 275.0,
        min_c: 0.0,
        model: b.model(),
        watch: RunawayWatch {
            window_s: 10.0,
            margin_c: 12.0,
            hysteresis_c: 4.0,
            period_s: 20.0,
        },
        ready: ReadyRule {
            window_c: 1.0,
            residency_s: 10.0,
        },
    }
}

fn send(node: &mut Node, m: &HostMessage) -> Option<NodeMessage> {
    let mut buf = [0u8; MAX_MESSAGE];
    node.handle(encode(m, &mut buf).unwrap())
}

/// A node with a heater for each block, heater 0 sampled every tick.
fn node_with(plant: &Plant) -> Node {
    let mut node: Node = Node::new();
    for (i, b) in plant.blocks.iter().enumerate() {
        let c = config(i as u8, b);
        assert_eq!(send(&mut node, &HostMessage::ConfigureHeater(c)), None);
    }
    let sampling = HostMessage::Sampling {
        source: SampleSource::Heater(0),
        every: 1,
    };
    assert_eq!(send(&mut node, &sampling), None);
    node
}

/// Sets heater `i`'s target at host time `at` (µs).
fn target(node: &mut Node, i: u8, at: f64, value: f32) {
    let m = HostMessage::Event {
        track: 128 + i,
        time: at,
        value,
    };
    assert_eq!(send(node, &m), None);
}

/// Polls the node in 20 ms frames until `until` µs; what went upstream,
/// and the reading of heater 0 at each of its samples.
fn run(node: &mut Node, plant: &mut Plant, until: f64) -> (Vec<NodeMessage>, Vec<(f64, f32)>) {
    let mut up = vec![];
    let mut readings = vec![];
    let mut t = node.time().max(0.0);
    while t < until {
        t = (t + 20_000.0).min(until);
        node.poll(t, plant);
        while let Some(m) = node.take_upstream() {
            if let NodeMessage::Samples(b) = &m {
                if let (SampleSource::Heater(0), SampleData::Values(v)) = (b.source, &b.data) {
                    for (k, s) in v.chunks(3).enumerate() {
                        readings.push((b.t0 + k as f64 * b.period_us as f64, s[0]));
                    }
                }
            }
            up.push(m);
        }
    }
    (up, readings)
}

fn faults(up: &[NodeMessage]) -> Vec<(SampleSource, FaultKind, f64, f32)> {
    up.iter()
        .filter_map(|m| match *m {
            NodeMessage::Fault {
                source,
                kind,
                at,
                value,
            } => Some((source, kind, at, value)),
            _ => None,
        })
        .collect()
}

#[test]
fn heats_to_its_target_settles_and_says_when_ready() {
    let mut plant = Plant::new(vec![Block::hotend()]);
    let mut node = node_with(&plant);
    // Off until its track says otherwise: nothing drives it.
    let (up, _) = run(&mut node, &mut plant, 5e6);
    assert!(faults(&up).is_empty());
    assert!(
        plant.drives.iter().all(|d| d.2 == 0.0),
        "off until a target"
    );
    target(&mut node, 0, 5e6, 215.0);
    let (up, readings) = run(&mut node, &mut plant, 300e6);
    assert!(faults(&up).is_empty(), "{:?}", faults(&up));
    let peak = readings.iter().map(|r| r.1).fold(f32::MIN, f32::max);
    assert!(peak <= 220.0, "overshoot {} °C", peak - 215.0);
    // Settled: within a degree from some point on, and the last outside
    // it no later than two minutes after the target was set.
    let last_out = readings
        .iter()
        .filter(|r| (r.1 - 215.0).abs() > 1.0)
        .map(|r| r.0)
        .fold(0.0, f64::max);
    assert!(
        last_out < 125e6,
        "still outside ±1 °C at {} s",
        last_out * 1e-6
    );
    let ready: Vec<(f64, f32)> = up
        .iter()
        .filter_map(|m| match *m {
            NodeMessage::HeaterReady { heater, at, target } => {
                assert_eq!(heater, 0);
                Some((at, target))
            }
            _ => None,
        })
        .collect();
    assert_eq!(ready.len(), 1, "once a target: {ready:?}");
    let (at, t) = ready[0];
    assert_eq!(t, 215.0);
    // The residency before it was all within the window.
    assert!(readings
        .iter()
        .filter(|r| r.0 > at - 10e6 && r.0 <= at)
        .all(|r| (r.1 - 215.0).abs() <= 1.0));
    assert!(readings
        .iter()
        .any(|r| r.0 > at - 10.2e6 && r.0 < at - 9.8e6));
    // A target above `max_c` switches it off.
    target(&mut node, 0, 301e6, 400.0);
    run(&mut node, &mut plant, 302e6);
    assert_eq!(node.control().heaters()[0].target(), 0.0);
    assert_eq!(plant.drives.last().unwrap().2, 0.0);
}

/// A sensor that stops answering, or reads what no working sensor
/// reads, trips at its first tick and every heater goes off.
#[test]
fn a_lost_or_implausible_sensor_trips_at_once() {
    // (what goes wrong with heater 0's sensor, what the fault's value
    // (the reading) must be)
    type Case = (fn(&mut Block), fn(f32) -> bool);
    let cases: [Case; 3] = [
        (|b| b.answers = false, |v| v.is_nan()),
        (|b| b.offset = -100.0, |v| v < 0.0),
        (|b| b.offset = 300.0, |v| v > 290.0),
    ];
    for (spoil, value) in cases {
        let mut plant = Plant::new(vec![Block::hotend(), Block::hotend()]);
        let mut node = node_with(&plant);
        target(&mut node, 0, 0.0, 200.0);
        target(&mut node, 1, 0.0, 200.0);
        run(&mut node, &mut plant, 10e6);
        spoil(&mut plant.blocks[0]);
        let (up, _) = run(&mut node, &mut plant, 20e6);
        let f = faults(&up);
        assert_eq!(f.len(), 1, "{f:?}");
        let (source, kind, at, v) = f[0];
        assert_eq!(
            (source, kind),
            (SampleSource::Heater(0), FaultKind::SensorLost)
        );
        assert!((10e6..=10.1e6).contains(&at), "at its first tick: {at}");
        assert!(value(v), "{v}");
        // Both heaters off from the trip on, for good.
        for d in [8, 9] {
            let last = plant.drives.iter().rev().find(|x| x.1 == d).unwrap();
            assert_eq!(last.2, 0.0);
        }
        assert!(plant.drives.iter().filter(|x| x.0 > at).all(|x| x.2 == 0.0));
        assert!(node.control().heaters().iter().all(|h| h.halted()));
    }
}

/// A heater whose power no longer reaches its block, while heating up and
/// while holding its target, is found within 20 s.
#[test]
fn a_disconnected_heater_runs_away_within_20_s() {
    // (seconds after the target was set that the wire is cut)
    for cut in [5.0, 30.0, 200.0] {
        let mut plant = Plant::new(vec![Block::hotend()]);
        let mut node = node_with(&plant);
        target(&mut node, 0, 0.0, 215.0);
        run(&mut node, &mut plant, cut * 1e6);
        plant.blocks[0].connected = false;
        let (up, _) = run(&mut node, &mut plant, (cut + 60.0) * 1e6);
        let f = faults(&up);
        assert_eq!(f.len(), 1, "cut at {cut} s: {f:?}");
        let (_, kind, at, _) = f[0];
        assert_eq!(kind, FaultKind::Runaway);
        let after = at * 1e-6 - cut;
        assert!(after < 20.0, "cut at {cut} s: found {after} s later");
        assert!(plant
            .drives
            .iter()
            .filter(|x| x.0 >= at)
            .all(|x| x.2 == 0.0));
    }
}

/// Nothing trips on a healthy heater whose model is somewhat off: a real
/// loss a third higher than its model's (a part-cooling fan).
#[test]
fn a_healthy_heater_with_more_loss_than_its_model_does_not_trip() {
    let mut plant = Plant::new(vec![Block::hotend()]);
    let mut node = node_with(&plant);
    plant.blocks[0].loss *= 4.0 / 3.0;
    target(&mut node, 0, 0.0, 240.0);
    let (up, readings) = run(&mut node, &mut plant, 400e6);
    assert!(faults(&up).is_empty(), "{:?}", faults(&up));
    assert!((readings.last().unwrap().1 - 240.0).abs() < 1.0);
}

/// A heater that cannot hold a target it reached (far more loss than it
/// can make up) trips once it has been below it by the hysteresis for
/// the period, even with a model check too lax to see it.
#[test]
fn falling_away_from_a_reached_target_trips_after_the_period() {
    let mut plant = Plant::new(vec![Block::hotend()]);
    let mut c = config(0, &plant.blocks[0]);
    c.watch.margin_c = 1000.0;
    let mut node: Node = Node::new();
    assert_eq!(send(&mut node, &HostMessage::ConfigureHeater(c)), None);
    target(&mut node, 0, 0.0, 215.0);
    run(&mut node, &mut plant, 200e6);
    // A draft no heater makes up: the block falls to below 170 °C.
    plant.blocks[0].loss = 0.4;
    let (up, _) = run(&mut node, &mut plant, 400e6);
    let f = faults(&up);
    assert_eq!(f.len(), 1, "{f:?}");
    assert_eq!(f[0].1, FaultKind::Runaway);
    assert!(
        f[0].3 < 211.0,
        "below the target by the hysteresis: {}",
        f[0].3
    );
    // Not before the period had run below it.
    assert!(f[0].2 > 220e6, "{}", f[0].2 * 1e-6);
}

/// A run stopped on its tail switches every heater off there, and a reset
/// node switches off the heaters it forgot.
#[test]
fn a_tail_stop_and_a_reset_switch_heaters_off() {
    let mut plant = Plant::new(vec![Block::hotend()]);
    let mut node = node_with(&plant);
    target(&mut node, 0, 0.0, 200.0);
    run(&mut node, &mut plant, 5e6);
    assert!(plant.drives.last().unwrap().2 > 0.0);
    assert_eq!(send(&mut node, &HostMessage::Reset), None);
    // A reset node's time starts again: its first poll is at the host's.
    node.poll(5.02e6, &mut plant);
    let last = plant.drives.last().unwrap();
    assert_eq!((last.1, last.2), (8, 0.0));
    assert!(last.0 >= 5e6 && last.0 <= 5.1e6, "{}", last.0);

    // Windowed: a sealed dwell, no seal after it: the node stops at its
    // end, and the heater with it.
    let mut plant = Plant::new(vec![Block::hotend()]);
    let mut node = node_with(&plant);
    assert_eq!(send(&mut node, &HostMessage::Windowed { run: 3 }), None);
    let dwell = motet_trajectory::Profile::dwell(5.0).params();
    let seg = HostMessage::Segment(motet_wire::SegmentMsg {
        seq: 0,
        t0: 0.0,
        profile: dwell,
        axes: heapless::Vec::new(),
    });
    assert_eq!(send(&mut node, &seg), None);
    target(&mut node, 0, 0.0, 200.0);
    // Taken without an answer: the link's acknowledgement confirms it.
    assert_eq!(send(&mut node, &HostMessage::Seal { next_seq: 1 }), None);
    run(&mut node, &mut plant, 4e6);
    assert!(plant.drives.last().unwrap().2 > 0.0, "heating while sealed");
    run(&mut node, &mut plant, 8e6);
    assert!(node.stopped());
    let off = plant
        .drives
        .iter()
        .find(|d| d.0 > 1e6 && d.2 == 0.0)
        .unwrap();
    assert!(off.0 >= 5e6 && off.0 < 5.2e6, "off at the tail: {off:?}");
    assert!(plant
        .drives
        .iter()
        .filter(|d| d.0 > off.0)
        .all(|d| d.2 == 0.0));
}

#[test]
fn configurations_a_node_cannot_take_are_refused() {
    let b = Block::hotend();
    // (a change to a good configuration, whether it is taken)
    type Case = (fn(&mut HeaterConfig), bool);
    let cases: [Case; 5] = [
        (|_| {}, true),
        (|c| c.rate_hz = 0.5, false),
        (|c| c.gains.kp = -1.0, false),
        (|c| c.model.heat_rate = f32::NAN, false),
        // The drive output of the other heater.
        (|c| c.drive = 9, false),
    ];
    for (change, taken) in cases {
        let mut node: Node = Node::new();
        let other = HeaterConfig {
            heater: 1,
            drive: 9,
            ..config(1, &b)
        };
        assert_eq!(send(&mut node, &HostMessage::ConfigureHeater(other)), None);
        let mut c = config(0, &b);
        change(&mut c);
        let reply = send(&mut node, &HostMessage::ConfigureHeater(c));
        assert_eq!(reply.is_none(), taken, "{c:?}: {reply:?}");
        assert_eq!(node.control().heaters().len(), 1 + taken as usize);
    }
}

/// Samples are (reading, target, power) triples, the first batch at the
/// first tick, every batch within a message.
#[test]
fn samples_are_triples_within_a_message() {
    let mut plant = Plant::new(vec![Block::hotend()]);
    let mut node = node_with(&plant);
    target(&mut node, 0, 0.0, 150.0);
    let mut t = 0.0;
    let mut batches = vec![];
    while t < 30e6 {
        t += 20_000.0;
        node.poll(t, &mut plant);
        while let Some(m) = node.take_upstream() {
            let mut buf = [0u8; MAX_MESSAGE];
            assert!(encode(&m, &mut buf).is_ok(), "{m:?} fits");
            if let NodeMessage::Samples(b) = m {
                batches.push((t, b));
            }
        }
    }
    let (heard, first) = &batches[0];
    assert!(*heard <= 20_000.0 && first.len() == 3, "{first:?}");
    for (_, b) in &batches {
        let SampleData::Values(v) = &b.data else {
            panic!("{b:?}")
        };
        assert_eq!(v.len() % 3, 0);
        // (The tick at 0 comes before the event at 0.)
        for s in v.chunks(3).filter(|_| b.t0 > 0.0) {
            assert_eq!(s[1], 150.0);
            assert!((0.0..=1.0).contains(&s[2]));
        }
    }
}
