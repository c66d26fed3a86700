//! Properties every plan must have, over random move sequences.

use motet_planner::*;
use motet_trajectory::{kinematics::KinematicsKind, JointMap, Point, ProfileKind, Segment};
use proptest::prelude::*;

fn limits(profile: ProfileKind, joints: Vec<JointLimits>) -> Limits {
    let axis = |v: f64, a: f64, path: bool| AxisLimits {
        max_velocity: v,
        max_acceleration: a,
        max_jerk: Some(a * 20.0),
        path,
    };
    Limits {
        axes: vec![
            axis(300.0, 3000.0, true),
            axis(200.0, 2000.0, true),
            axis(20.0, 200.0, true),
            axis(50.0, 5000.0, false),
        ],
        joints,
        junction_deviation: 0.05,
        profile,
        tools: vec![
            ToolTiming {
                stop: true,
                settle: 0.1,
            },
            ToolTiming {
                stop: false,
                settle: 0.0,
            },
        ],
        lookahead: 10_000,
        stop_horizon: 0,
        min_move_s: 0.0,
        max_move_s: 0.0,
    }
}

fn mv(p: [f64; 4], feed: f64) -> Command {
    Command::Move(Move {
        target: [p[0], p[1], p[2], p[3], 0.0, 0.0],
        feed,
        kind: if feed.is_finite() {
            MoveKind::Feed
        } else {
            MoveKind::Rapid
        },
    })
}

fn plan(l: &Limits, cmds: &[Command], one_by_one: bool) -> Vec<Planned> {
    plan_from(l, cmds, one_by_one, [0.0; 6])
}

fn plan_from(l: &Limits, cmds: &[Command], one_by_one: bool, start: Point) -> Vec<Planned> {
    let mut p = Planner::new(l.clone(), start, 0.0);
    let mut out = vec![];
    for c in cmds {
        p.push(c).unwrap();
        if one_by_one {
            while let Some(x) = p.pop() {
                out.push(x);
            }
        }
    }
    p.finish();
    while let Some(x) = p.pop() {
        out.push(x);
    }
    out
}

fn segments(out: &[Planned]) -> Vec<Segment> {
    out.iter()
        .filter_map(|p| {
            if let Planned::Segment(s) = p {
                Some(*s)
            } else {
                None
            }
        })
        .collect()
}

/// Samples each segment and checks axis and joint speeds and accelerations.
fn check_limits(l: &Limits, segs: &[Segment]) {
    for s in segs {
        let len = s.profile.length();
        let dur = s.profile.duration();
        let n = 40;
        for k in 0..=n {
            let t = dur * k as f64 / n as f64;
            let (_, v, a) = s.profile.state(t);
            for (i, ax) in l.axes.iter().enumerate() {
                let u = s.axis_rate(i).abs();
                assert!(
                    u * v <= ax.max_velocity * (1.0 + 1e-6) + 1e-9,
                    "axis {i} speed {} > {}",
                    u * v,
                    ax.max_velocity
                );
                assert!(
                    u * a.abs() <= ax.max_acceleration * (1.0 + 1e-6) + 1e-9,
                    "axis {i} accel {} > {}",
                    u * a.abs(),
                    ax.max_acceleration
                );
            }
            // Joints by finite differences along time.
            for j in &l.joints {
                if len <= 0.0 {
                    continue;
                }
                let h = dur / 2000.0;
                if t < h || t > dur - h {
                    continue;
                }
                let val = |tt: f64| j.map.value(&s.position_at(s.t0 + tt * 1e6), 0.0);
                let (a0, a1, a2) = (val(t - h), val(t), val(t + h));
                if (a2 - a0).abs() > 180.0 {
                    continue; // angle branch cut between samples
                }
                let vel = (a2 - a0) / (2.0 * h);
                assert!(
                    vel.abs() <= j.max_velocity * 1.001 + 1e-6,
                    "joint speed {vel} > {}",
                    j.max_velocity
                );
                let acc = (a2 - 2.0 * a1 + a0) / (h * h);
                // The finite difference of a ramp corner overshoots; allow a margin.
                assert!(
                    acc.abs() <= j.max_acceleration * 1.05 + 1.0,
                    "joint accel {acc} > {}",
                    j.max_acceleration
                );
            }
        }
    }
}

fn check_continuity(segs: &[Segment], targets: &[Point]) {
    assert_eq!(
        segs.first().map(|s| s.profile.v0()),
        Some(0.0).filter(|_| !segs.is_empty())
    );
    assert_eq!(
        segs.last().unwrap().profile.v1(),
        0.0,
        "does not end at rest"
    );
    for w in segs.windows(2) {
        assert_eq!(w[0].end, w[1].start);
        assert_eq!(w[0].profile.v1(), w[1].profile.v0());
        assert_eq!(w[0].t1(), w[1].t0);
    }
    let ends: Vec<Point> = segs
        .iter()
        .filter(|s| s.profile.length() > 0.0)
        .map(|s| s.end)
        .collect();
    assert_eq!(&ends, targets, "does not reach every target in order");
}

fn arb_moves() -> impl Strategy<Value = Vec<([f64; 4], f64)>> {
    prop::collection::vec(
        (
            (
                -100.0..100.0f64,
                -100.0..100.0f64,
                -5.0..5.0f64,
                -2.0..10.0f64,
            ),
            prop_oneof![Just(f64::INFINITY), 1.0..400.0f64],
            0.0..1.0f64,
        )
            .prop_map(|((x, y, z, e), f, tiny)| {
                // Mix long moves with tiny ones.
                let k = if tiny < 0.3 { 0.001 } else { 1.0 };
                ([x * k, y * k, z * k, e * k], f)
            }),
        1..60,
    )
}

fn absolute(moves: &[([f64; 4], f64)]) -> (Vec<Command>, Vec<Point>) {
    let mut pos = [0.0; 4];
    let mut cmds = vec![];
    let mut targets = vec![];
    for (d, f) in moves {
        for i in 0..4 {
            pos[i] += d[i];
        }
        cmds.push(mv(pos, *f));
        targets.push([pos[0], pos[1], pos[2], pos[3], 0.0, 0.0]);
    }
    (cmds, targets)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, .. ProptestConfig::default() })]

    #[test]
    fn plans_respect_limits_and_reach_targets(moves in arb_moves(), scurve in any::<bool>()) {
        let l = limits(if scurve { ProfileKind::SCurve } else { ProfileKind::Trapezoid }, vec![]);
        let (cmds, targets) = absolute(&moves);
        let out = plan(&l, &cmds, false);
        let segs = segments(&out);
        check_continuity(&segs, &targets);
        check_limits(&l, &segs);
    }

    #[test]
    fn streaming_equals_batch(moves in arb_moves(), lookahead in 2usize..20, horizon in prop_oneof![Just(0usize), 1usize..40]) {
        let mut l = limits(ProfileKind::Trapezoid, vec![]);
        l.stop_horizon = horizon;
        let (cmds, _) = absolute(&moves);
        prop_assert_eq!(plan(&l, &cmds, false), plan(&l, &cmds, true));
        // Deterministic under a tight lookahead bound too.
        l.lookahead = lookahead;
        prop_assert_eq!(plan(&l, &cmds, true), plan(&l, &cmds, true));
    }

    #[test]
    fn corexy_motor_limits_hold(moves in arb_moves()) {
        let kin = KinematicsKind::COREXY;
        let joints = (0..2).map(|j| JointLimits { map: kin.joint_map(j, [0, 1, 2]), max_velocity: 150.0, max_acceleration: 1500.0 }).collect();
        let l = limits(ProfileKind::Trapezoid, joints);
        let (cmds, targets) = absolute(&moves);
        let segs = segments(&plan(&l, &cmds, false));
        check_continuity(&segs, &targets);
        check_limits(&l, &segs);
    }

    #[test]
    fn polar_joint_limits_hold(moves in arb_moves()) {
        let joints = vec![
            JointLimits { map: JointMap::polar_radius(0, 1), max_velocity: 100.0, max_acceleration: 1000.0 },
            JointLimits { map: JointMap::polar_angle(0, 1), max_velocity: 360.0, max_acceleration: 3600.0 },
        ];
        let l = limits(ProfileKind::Trapezoid, joints);
        // Keep away from the centre, where the angle is undefined.
        let moves: Vec<_> = moves.into_iter().map(|(d, f)| ([d[0], d[1], d[2], d[3]], f)).collect();
        let mut cmds = vec![];
        let mut targets = vec![];
        let mut pos = [120.0, 0.0, 0.0, 0.0];
        for (d, f) in moves {
            let next = [pos[0] + d[0] * 0.3, pos[1] + d[1] * 0.3, pos[2] + d[2], pos[3] + d[3]];
            // Skip moves that pass within 20 mm of the centre.
            let (px, py, qx, qy) = (pos[0], pos[1], next[0], next[1]);
            let (wx, wy) = (qx - px, qy - py);
            let ww = wx * wx + wy * wy;
            let t = if ww > 0.0 { (-(px * wx + py * wy) / ww).clamp(0.0, 1.0) } else { 0.0 };
            let (cx, cy) = (px + wx * t, py + wy * t);
            if (cx * cx + cy * cy).sqrt() < 20.0 { continue; }
            pos = next;
            cmds.push(mv(pos, f));
            targets.push([pos[0], pos[1], pos[2], pos[3], 0.0, 0.0]);
        }
        prop_assume!(!cmds.is_empty());
        let segs = segments(&plan_from(&l, &cmds, false, [120.0, 0.0, 0.0, 0.0, 0.0, 0.0]));
        check_continuity(&segs, &targets);
        check_limits(&l, &segs);
    }
}

/// The speed at every boundary lets the machine stop within the next `n`
/// segments, each at its own acceleration.
fn check_horizon(segs: &[Segment], n: usize) {
    for i in 1..segs.len() {
        let v = segs[i].profile.v0();
        let room: f64 = segs[i..(i + n).min(segs.len())]
            .iter()
            .map(|s| s.profile.params().accel * s.profile.length())
            .sum();
        assert!(
            v * v <= 2.0 * room * (1.0 + 1e-9),
            "boundary {i}: {v} cannot stop within {n} segments ({room})"
        );
    }
}

/// Every segment's two ramps fit within its length.
fn check_ramps_fit(segs: &[Segment]) {
    for (i, s) in segs.iter().enumerate() {
        let p = &s.profile;
        assert!(
            p.ramps_length() <= p.length() * (1.0 + 1e-9) + 1e-12,
            "segment {i}: ramps need {} of {} ({:?})",
            p.ramps_length(),
            p.length(),
            p.params()
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, .. ProptestConfig::default() })]

    /// S-curve plans, streamed or whole, under any lookahead and stop
    /// horizon: every segment's ramps fit its length.
    #[test]
    fn s_curve_ramps_fit_every_segment(moves in arb_moves(), lookahead in 2usize..40, horizon in prop_oneof![Just(0usize), 1usize..40], one_by_one in any::<bool>()) {
        let mut l = limits(ProfileKind::SCurve, vec![]);
        l.stop_horizon = horizon;
        l.lookahead = lookahead;
        let (cmds, targets) = absolute(&moves);
        let segs = segments(&plan(&l, &cmds, one_by_one));
        check_continuity(&segs, &targets);
        check_ramps_fit(&segs);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 100, .. ProptestConfig::default() })]

    #[test]
    fn stop_horizon_holds_for_any_moves(moves in arb_moves(), horizon in 1usize..40) {
        let mut l = limits(ProfileKind::Trapezoid, vec![]);
        l.stop_horizon = horizon;
        let (cmds, targets) = absolute(&moves);
        let segs = segments(&plan(&l, &cmds, true));
        check_continuity(&segs, &targets);
        check_limits(&l, &segs);
        check_horizon(&segs, horizon);
    }
}

#[test]
fn tiny_fast_moves_slow_down_to_the_stop_horizon() {
    // 10,000 moves of 0.02 mm along a gentle curve at 300 mm/s.
    let cmds: Vec<Command> = (1..=10_000)
        .map(|k| {
            let a = k as f64 * 1e-4;
            let r = 0.02 / 1e-4;
            mv([r * a.sin(), r * (1.0 - a.cos()), 0.0, 0.0], 300.0)
        })
        .collect();
    let mut l = limits(ProfileKind::Trapezoid, vec![]);
    let free = segments(&plan(&l, &cmds, true));
    for n in [32, 8] {
        l.stop_horizon = n;
        let segs = segments(&plan(&l, &cmds, true));
        assert_eq!(segs.len(), cmds.len());
        check_horizon(&segs, n);
        // The horizon binds: without it the machine runs faster.
        let peak = |s: &[Segment]| s.iter().map(|s| s.profile.vc()).fold(0.0, f64::max);
        assert!(
            peak(&segs) < peak(&free),
            "{} vs {}",
            peak(&segs),
            peak(&free)
        );
        // And it slows down rather than stopping: no rest in the middle.
        assert!(segs[1..segs.len() - 1].iter().all(|s| s.profile.v1() > 0.0));
    }
}

#[test]
fn moves_last_at_least_the_shortest_move_time() {
    // Moves of 0.02 to 2 mm at 300 mm/s; cruising, each must take 5 ms.
    let cmds: Vec<Command> = (1..=2_000)
        .map(|k| {
            let x = (1..=k).map(|i| 0.02 * (1 + i % 100) as f64).sum::<f64>();
            mv([x, 0.0, 0.0, 0.0], 300.0)
        })
        .collect();
    let mut l = limits(ProfileKind::Trapezoid, vec![]);
    l.min_move_s = 0.005;
    for streamed in [true, false] {
        let segs = segments(&plan(&l, &cmds, streamed));
        assert_eq!(segs.len(), cmds.len());
        for s in &segs {
            let cap = s.profile.length() / l.min_move_s;
            assert!(
                s.profile.vc() <= cap * (1.0 + 1e-9),
                "{} > {cap}",
                s.profile.vc()
            );
            assert!(s.profile.duration() >= l.min_move_s * (1.0 - 1e-9));
        }
    }
    // Streamed and whole-job plans agree with the cap too.
    assert_eq!(
        segments(&plan(&l, &cmds, true)),
        segments(&plan(&l, &cmds, false))
    );
}

#[test]
fn tool_events_and_dwells_are_placed_in_time() {
    let l = limits(ProfileKind::Trapezoid, vec![]);
    let cmds = vec![
        mv([10.0, 0.0, 0.0, 0.0], 100.0),
        Command::Tool {
            tool: 0,
            value: 1.0,
        }, // stopping tool: pen down
        mv([20.0, 0.0, 0.0, 0.0], 100.0),
        Command::Tool {
            tool: 1,
            value: 0.5,
        }, // inline tool: laser power
        mv([30.0, 0.0, 0.0, 0.0], 100.0),
        Command::Dwell { seconds: 0.5 },
    ];
    let out = plan(&l, &cmds, false);
    let segs = segments(&out);
    // Move, settle dwell, move, move, dwell.
    assert_eq!(segs.len(), 5);
    assert_eq!(segs[0].profile.v1(), 0.0, "stopping tool needs rest");
    assert!((segs[1].profile.duration() - 0.1).abs() < 1e-12);
    assert!(
        segs[2].profile.v1() > 0.0,
        "inline tool must not stop motion"
    );
    assert!((segs[4].profile.duration() - 0.5).abs() < 1e-12);
    let events: Vec<ToolEvent> = out
        .iter()
        .filter_map(|p| {
            if let Planned::Event(e) = p {
                Some(*e)
            } else {
                None
            }
        })
        .collect();
    assert_eq!(events.len(), 2);
    assert_eq!(events[0].time, segs[0].t1());
    assert_eq!(events[1].time, segs[3].t0);
    assert_eq!((events[1].tool, events[1].value), (1, 0.5));
}

#[test]
fn junction_speed_follows_junction_deviation() {
    let l = limits(ProfileKind::Trapezoid, vec![]);
    // A 90° corner in xy: v² = a δ sin(45°) / (1 − sin(45°)).
    let cmds = vec![
        mv([100.0, 0.0, 0.0, 0.0], 150.0),
        mv([100.0, 100.0, 0.0, 0.0], 150.0),
    ];
    let segs = segments(&plan(&l, &cmds, false));
    let s = (0.5f64).sqrt();
    let want = (2000.0 * 0.05 * s / (1.0 - s)).sqrt();
    assert!(
        (segs[0].profile.v1() - want).abs() < 1e-9,
        "{} vs {want}",
        segs[0].profile.v1()
    );
    // Straight on: full speed through the junction.
    let cmds = vec![
        mv([50.0, 0.0, 0.0, 0.0], 150.0),
        mv([100.0, 0.0, 0.0, 0.0], 150.0),
    ];
    let segs = segments(&plan(&l, &cmds, false));
    assert_eq!(segs[0].profile.v1(), 150.0);
}

#[test]
fn bad_commands_are_refused_without_touching_the_queue() {
    let l = limits(ProfileKind::Trapezoid, vec![]);
    let mut p = Planner::new(l, [0.0; 6], 0.0);
    p.push(&mv([10.0, 0.0, 0.0, 0.0], 100.0)).unwrap();
    let before = p.queued();
    assert!(p.push(&mv([f64::NAN, 0.0, 0.0, 0.0], 100.0)).is_err());
    assert!(p.push(&mv([1.0, 0.0, 0.0, 0.0], 0.0)).is_err());
    assert!(p.push(&mv([1.0, 0.0, 0.0, 0.0], -3.0)).is_err());
    assert!(p.push(&Command::Dwell { seconds: -1.0 }).is_err());
    assert!(p
        .push(&Command::Tool {
            tool: 9,
            value: 1.0
        })
        .is_err());
    assert_eq!(p.queued(), before);
    assert_eq!(p.tail(), [10.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
}
