//! Fixed-point time (`Node::use_fixed_time`, what a board without a
//! floating-point unit runs): every channel takes the same steps in the
//! same directions as in exact time, each within the tolerance of its
//! exact time.

use crate::common;

use common::*;
use motet_node::Node;
use motet_trajectory::ProfileKind;
use proptest::prelude::*;

/// The tolerance the Pico runs with, µs.
const TOLERANCE: f64 = 0.05;

/// Runs `moves` in exact and in fixed-point time and compares them step by
/// step, channel by channel; returns the steps and the largest difference
/// of time, µs.
fn compare(
    moves: &[(f64, f64, f64)],
    feed_rate: f64,
    profile: ProfileKind,
    spu: [f64; 7],
    drive: Drive,
) -> (usize, f64) {
    let machine = Machine {
        name: "fixed",
        channels: all_kinds(spu),
        tools: default_tools(),
        start: START,
    };
    let planned = plan(limits(profile), START, &ring_moves(START, moves, feed_rate));
    let msgs = machine.stream(&planned);
    let exact = run(&mut Node::<8>::new(), &msgs, drive);
    let mut node = Node::<8>::new();
    node.use_fixed_time(TOLERANCE);
    let fixed = run(&mut node, &msgs, drive);
    assert_eq!(fixed.positions, exact.positions);
    let (mut steps, mut worst) = (0, 0.0f64);
    for c in &machine.channels {
        let of = |r: &Run| -> Vec<(bool, f64)> {
            r.steps()
                .into_iter()
                .filter(|s| s.0 == c.channel)
                .map(|s| (s.1, s.2))
                .collect()
        };
        let (e, f) = (of(&exact), of(&fixed));
        assert_eq!(e.len(), f.len(), "channel {}", c.channel);
        for (i, (a, b)) in e.iter().zip(&f).enumerate() {
            assert_eq!(a.0, b.0, "channel {} step {i}: direction", c.channel);
            let d = (a.1 - b.1).abs();
            assert!(
                d <= TOLERANCE + 1e-4,
                "channel {} step {i}: {} against {} exactly ({d} µs)",
                c.channel,
                b.1,
                a.1
            );
            worst = worst.max(d);
        }
        // In time order on each channel.
        assert!(
            f.windows(2).all(|w| w[0].1 <= w[1].1),
            "channel {}",
            c.channel
        );
        steps += f.len();
    }
    (steps, worst)
}

/// Fine microstepping, fast moves, and moves that stop and reverse: long
/// chunks at speed, one-step chunks near each stop.
#[test]
fn fixed_time_keeps_every_step_within_its_tolerance() {
    for (spu, feed_rate, profile) in [
        (
            [80.0, 80.0, 80.0, 80.0, 80.0, 10.0, 400.0],
            150.0,
            ProfileKind::Trapezoid,
        ),
        (
            [640.0, -640.0, 400.0, -400.0, 640.0, 40.0, 3200.0],
            150.0,
            ProfileKind::Trapezoid,
        ),
        (
            [40.0, 40.0, 25.0, 25.0, 40.0, -8.0, 200.0],
            20.0,
            ProfileKind::Trapezoid,
        ),
        (
            [80.0, 80.0, 80.0, 80.0, 80.0, 10.0, 400.0],
            120.0,
            ProfileKind::SCurve,
        ),
    ] {
        let moves = [
            (0.0, 100.0, 1.0),
            (0.0, 40.0, 1.5),
            (30.0, 70.0, 1.0),
            (-55.0, 60.0, 1.0),
            (55.0, 90.0, 0.5),
        ];
        for drive in [Drive::Jump, Drive::Frames(40.0)] {
            let (steps, worst) = compare(&moves, feed_rate, profile, spu, drive);
            assert!(steps > 2000, "{steps} steps");
            assert!(
                worst > 0.0,
                "fixed-point time made no difference: not in use"
            );
        }
    }
}

fn moves() -> impl Strategy<Value = Vec<(f64, f64, f64)>> {
    prop::collection::vec((-59.0..59.0f64, 35.0..110.0f64, 0.0..3.0f64), 1..8)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn random_moves_in_fixed_time(
        moves in moves(),
        feed_rate in 20.0..150.0f64,
        scurve in any::<bool>(),
        spu in prop::array::uniform7(1.0..700.0f64),
        frames in prop_oneof![Just(None), (5.0..500.0f64).prop_map(Some)],
    ) {
        let profile = if scurve { ProfileKind::SCurve } else { ProfileKind::Trapezoid };
        let drive = frames.map_or(Drive::Jump, Drive::Frames);
        compare(&moves, feed_rate, profile, spu, drive);
    }
}
