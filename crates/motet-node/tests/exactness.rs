//! Step exactness: every step is where the ideal joint crosses a half-step
//! boundary, checked against the trajectory evaluated independently of the node.

use crate::common;

use common::*;
use motet_node::Node;
use motet_planner::Command;
use motet_trajectory::{JointMap, KinematicsKind, ProfileKind, Segment};
use motet_wire::ChannelConfig;
use proptest::prelude::*;

/// Tolerance on the joint, in steps, at a step's time.
const EXACT: f64 = 1e-6;

/// Checks every step of every channel against the trajectory `segs`; returns the
/// number of steps checked.
fn check_steps(
    segs: &[Segment],
    configs: &[ChannelConfig],
    run: &Run,
    start_positions: &[i64],
) -> usize {
    let (t_first, t_last) = (segs[0].t0, segs.last().unwrap().t1());
    let mut checked = 0;
    for (ci, c) in configs.iter().enumerate() {
        let spu = c.steps_per_unit.abs();
        let invert = c.steps_per_unit < 0.0;
        let map = &c.map;
        // The joint's value at every segment start, unwrapped along the trajectory
        // (each segment turns an angle by well under 180°).
        let mut starts = Vec::with_capacity(segs.len());
        let mut v = map.value(&segs[0].start, 0.0);
        for s in segs {
            v = map.value(&s.start, v);
            starts.push(v);
            v = map.value(&s.end, v);
        }
        let final_value = v;
        let ideal = |t: f64| {
            let k = segs.partition_point(|s| s.t0 <= t).saturating_sub(1);
            map.value(&segs[k].position_at(t), starts[k]) * spu
        };

        let mut pos = (map.value(&segs[0].start, 0.0) * spu).round() as i64;
        assert_eq!(
            pos, start_positions[ci],
            "channel {ci}: position after SetPosition"
        );
        let mut last_time = f64::NEG_INFINITY;
        let mut history = vec![(f64::NEG_INFINITY, pos)];
        for (channel, forward, t) in run.steps() {
            if channel != c.channel {
                continue;
            }
            assert!(
                t >= t_first && t <= t_last,
                "channel {ci}: step at {t} outside [{t_first}, {t_last}]"
            );
            assert!(
                t >= last_time,
                "channel {ci}: step at {t} before {last_time}"
            );
            last_time = t;
            // Direction output is the joint direction, inverted for negative spu.
            let positive = forward != invert;
            let boundary = pos as f64 + if positive { 0.5 } else { -0.5 };
            let at = ideal(t);
            assert!(
                (at - boundary).abs() < EXACT,
                "channel {ci} ({map:?}, spu {}): step {} at {t} µs: joint {at} steps, boundary {boundary}",
                c.steps_per_unit,
                if positive { "+" } else { "-" }
            );
            pos += if positive { 1 } else { -1 };
            history.push((t, pos));
            checked += 1;
        }
        assert_eq!(pos, run.positions[ci], "channel {ci}: node's count");
        assert_eq!(
            pos,
            (final_value * spu).round() as i64,
            "channel {ci}: final count vs final joint {}",
            final_value * spu
        );

        // Between steps, the joint stays within half a step of the count: sample
        // halfway between steps and in the middle of every segment.
        let mut samples: Vec<f64> = history
            .windows(2)
            .skip(1)
            .map(|w| 0.5 * (w[0].0 + w[1].0))
            .collect();
        samples.extend(segs.iter().map(|s| s.t0 + 0.5 * s.duration_us()));
        for t in samples {
            let k = history.partition_point(|h| h.0 <= t) - 1;
            let (at, count) = (ideal(t), history[k].1);
            assert!(
                (at - count as f64).abs() <= 0.5 + EXACT,
                "channel {ci}: at {t} joint {at} steps but count {count}"
            );
        }
    }
    checked
}

fn exact_run(
    moves: &[(f64, f64, f64)],
    feed: f64,
    profile: ProfileKind,
    spu: [f64; 7],
    drive: Drive,
) -> usize {
    let cmds = ring_moves(START, moves, feed);
    let planned = plan(limits(profile), START, &cmds);
    let segs = segments(&planned);
    let machine = Machine {
        name: "all",
        channels: all_kinds(spu),
        tools: default_tools(),
        start: START,
    };
    let msgs = machine.stream(&planned);
    let mut node = Node::<8>::new();
    // Positions right after SetPosition.
    for m in machine.setup() {
        assert_eq!(send(&mut node, &m), None);
    }
    let start_positions: Vec<i64> = node.channels().iter().map(|c| c.position()).collect();
    let mut node = Node::<8>::new();
    let r = run(&mut node, &msgs, drive);
    assert_eq!(r.status.underruns, 0);
    check_steps(&segs, &machine.channels, &r, &start_positions)
}

#[test]
fn fixed_sequences_are_exact() {
    let spu = [40.0, -40.0, 25.0, -25.0, 40.0, -8.0, 200.0];
    let cases: Vec<Vec<(f64, f64, f64)>> = vec![
        // Straight out and back along a radius (through the radius's turning point).
        vec![(0.0, 100.0, 1.0), (0.0, 40.0, 1.5), (0.0, 80.0, 1.0)],
        // Around the centre, across the ±180° cut, both ways.
        (0..20)
            .map(|_| (30.0, 70.0, 1.0))
            .chain((0..20).map(|_| (-30.0, 70.0, 1.0)))
            .collect(),
        // Chords whose closest approach to the centre lies inside them.
        vec![
            (55.0, 60.0, 1.0),
            (-55.0, 60.0, 1.0),
            (55.0, 90.0, 2.0),
            (55.0, 90.0, 0.5),
        ],
    ];
    for (i, moves) in cases.iter().enumerate() {
        for profile in [ProfileKind::Trapezoid, ProfileKind::SCurve] {
            for drive in [Drive::Jump, Drive::Frames(40.0)] {
                let n = exact_run(moves, 120.0, profile, spu, drive);
                assert!(n > 1000, "case {i}: {n} steps");
            }
        }
    }
}

/// Direction outputs: a move in +x steps x forward, or backward when inverted.
#[test]
fn direction_follows_sign_of_steps_per_unit() {
    let planned = plan(
        limits(ProfileKind::Trapezoid),
        START,
        &[feed(90.0, 0.0, 1.0, 50.0), feed(70.0, 0.0, 1.0, 50.0)],
    );
    for spu in [40.0, -40.0] {
        let m = Machine {
            name: "x",
            channels: vec![channel(3, JointMap::axis(0), spu)],
            tools: vec![],
            start: START,
        };
        let r = run(&mut Node::<8>::new(), &m.stream(&planned), Drive::Jump);
        let steps = r.steps();
        assert_eq!(steps.len(), 40 * 30 + 40 * 20);
        let split = 40 * 30;
        assert!(steps.iter().all(|s| s.0 == 3));
        assert!(
            steps[..split].iter().all(|s| s.1 == (spu > 0.0)),
            "out: spu {spu}"
        );
        assert!(
            steps[split..].iter().all(|s| s.1 == (spu < 0.0)),
            "back: spu {spu}"
        );
        assert_eq!(r.positions, vec![(70.0 * 40.0) as i64]);
    }
}

fn moves() -> impl Strategy<Value = Vec<(f64, f64, f64)>> {
    prop::collection::vec((-59.0..59.0f64, 35.0..110.0f64, 0.0..3.0f64), 1..10)
}

fn spus() -> impl Strategy<Value = [f64; 7]> {
    let one = || (1.0..60.0f64, any::<bool>()).prop_map(|(m, neg)| if neg { -m } else { m });
    prop::array::uniform7(one())
}

fn drives() -> impl Strategy<Value = Drive> {
    prop_oneof![Just(Drive::Jump), (5.0..500.0f64).prop_map(Drive::Frames)]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    #[test]
    fn random_moves_step_exactly(
        moves in moves(),
        feed in 20.0..150.0f64,
        scurve in any::<bool>(),
        spu in spus(),
        drive in drives(),
    ) {
        let profile = if scurve { ProfileKind::SCurve } else { ProfileKind::Trapezoid };
        exact_run(&moves, feed, profile, spu, drive);
    }
}

/// Non-polar machines may go anywhere, including through the origin.
#[test]
fn linear_maps_through_the_origin() {
    let spu = [40.0, -40.0, 25.0, -25.0];
    let k = KinematicsKind::COREXY;
    let configs = vec![
        channel(0, JointMap::axis(0), spu[0]),
        channel(1, JointMap::axis(1), spu[1]),
        channel(2, k.joint_map(0, [0, 1, 2]), spu[2]),
        channel(3, k.joint_map(1, [0, 1, 2]), spu[3]),
    ];
    let cmds: Vec<Command> = vec![
        feed(-60.0, 0.0, 1.0, 100.0),
        feed(0.0, 0.0, 1.0, 100.0),
        feed(30.0, -30.0, 1.0, 80.0),
        rapid(-10.0, 45.0, 1.0),
    ];
    let planned = plan(limits(ProfileKind::SCurve), START, &cmds);
    let machine = Machine {
        name: "xy",
        channels: configs,
        tools: vec![],
        start: START,
    };
    let mut node = Node::<8>::new();
    for m in machine.setup() {
        send(&mut node, &m);
    }
    let starts: Vec<i64> = node.channels().iter().map(|c| c.position()).collect();
    let r = run(
        &mut Node::<8>::new(),
        &machine.stream(&planned),
        Drive::Frames(40.0),
    );
    assert!(check_steps(&segments(&planned), &machine.channels, &r, &starts) > 5000);
}
