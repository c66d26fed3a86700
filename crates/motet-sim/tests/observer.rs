//! The plant's observer must notice late, early and missing steps: otherwise the
//! report's accuracy figures would prove nothing.

use motet_host::{Distributor, Machine};
use motet_node::{Board, Node};
use motet_planner::{Command, Move, MoveKind, Planned, Planner};
use motet_sim::path::PathRecorder;
use motet_sim::plant::{Output, Plant, Stamped};
use motet_wire::{encode, MAX_MESSAGE};
use std::path::Path;

const MACHINE: &str = r#"
name = "one axis"
[axes.x]
travel = [0, 100]
max_velocity = 100
max_acceleration = 1000
[actuators.m]
joint = "x"
chain = [{ leadscrew = { lead = 8.0 } }, { stepper = { step_angle = 1.8 } }, { microstep = 16 }]
"#;

struct Collect(Vec<Stamped>);
impl Board for Collect {
    fn step(&mut self, _channel: u8, forward: bool, at_us: f64) {
        self.0.push(Stamped {
            time: at_us,
            output: Output::Step {
                actuator: 0,
                forward,
            },
        });
    }
    fn set_tool(&mut self, _: u8, _: f32, _: f64) {}
}

/// Plans a move, runs the real node on it, and returns the machine, segments and
/// the node's step outputs.
fn ideal_run() -> (Machine, Vec<motet_trajectory::Segment>, Vec<Stamped>) {
    let m = Machine::parse(MACHINE, Path::new("one-axis.toml")).unwrap();
    let mut planner = Planner::new(m.limits(), m.start, 0.0);
    for x in [10.0, 4.0, 30.0] {
        let mut target = m.start;
        target[0] = x;
        planner
            .push(&Command::Move(Move {
                target,
                feed: 60.0,
                kind: MoveKind::Feed,
            }))
            .unwrap();
    }
    planner.finish();
    let mut segs = vec![];
    while let Some(p) = planner.pop() {
        if let Planned::Segment(s) = p {
            segs.push(s);
        }
    }
    let mut dist = Distributor::new(&m);
    let mut node: Node<64> = Node::new();
    let mut buf = [0u8; MAX_MESSAGE];
    for msg in dist.setup(&m, 0, &m.start) {
        assert!(node.handle(encode(&msg, &mut buf).unwrap()).is_none());
    }
    for s in &segs {
        let msg = dist.route(0, &Planned::Segment(*s)).unwrap();
        assert!(node.handle(encode(&msg, &mut buf).unwrap()).is_none());
    }
    let mut out = Collect(vec![]);
    node.poll(segs.last().unwrap().t1() + 1.0, &mut out);
    (m, segs, out.0)
}

fn observe(m: &Machine, segs: &[motet_trajectory::Segment], steps: &mut [Stamped]) -> (f64, f64) {
    let mut plant = Plant::new(m, PathRecorder::new(0, 0, 0.1));
    for s in segs {
        plant.planned(*s);
    }
    plant.apply(steps);
    let st = &plant.actuator_stats()[0];
    (st.max_step_error_us, st.max_deviation_steps)
}

#[test]
fn exact_steps_measure_as_exact() {
    let (m, segs, mut steps) = ideal_run();
    assert!(steps.len() > 1000);
    let (err, dev) = observe(&m, &segs, &mut steps);
    assert!(
        err < 0.01,
        "step time error {err} µs on the node's own steps"
    );
    assert!(dev <= 0.5 + 1e-6, "deviation {dev}");
}

#[test]
fn shifted_steps_are_caught() {
    // (shift in µs, every n-th step shifted)
    for (shift, every) in [(2.0, 1), (-3.0, 7), (5.0, 100)] {
        let (m, segs, mut steps) = ideal_run();
        for (i, s) in steps.iter_mut().enumerate() {
            if i % every == 0 {
                s.time += shift;
            }
        }
        let (err, _) = observe(&m, &segs, &mut steps);
        assert!(
            (err - f64::abs(shift)).abs() < 0.05 * f64::abs(shift),
            "shift {shift} measured as {err}"
        );
    }
}

#[test]
fn a_missing_step_shows_as_deviation() {
    let (m, segs, mut steps) = ideal_run();
    steps.remove(steps.len() / 3);
    let (_, dev) = observe(&m, &segs, &mut steps);
    assert!(dev >= 1.0, "a dropped step must show: deviation {dev}");
}
