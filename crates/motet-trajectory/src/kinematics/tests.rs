//! The joint maps' and paths' closed forms and unwrapping.

use super::*;
use crate::math::sqrt;
use crate::profile::fastest;
use crate::segment::Segment;

fn seg(start: Point, end: Point) -> Segment {
    let mut d = 0.0;
    for i in 0..3 {
        d += (end[i] - start[i]) * (end[i] - start[i]);
    }
    Segment {
        t0: 0.0,
        start,
        end,
        profile: fastest(sqrt(d), 0.0, 0.0, 100.0, 1000.0, 0.0),
    }
}

fn pt(x: f64, y: f64) -> Point {
    [x, y, 0.0, 0.0, 0.0, 0.0]
}

#[test]
fn forward_inverts_inverse() {
    let points = [(0.0, 0.0), (10.0, -3.5), (-120.0, 44.0), (1e-3, 250.0)];
    for kind in [
        KinematicsKind::Cartesian(Cartesian),
        KinematicsKind::CoreXY(CoreXY),
        KinematicsKind::HBot(HBot),
        KinematicsKind::Polar(Polar),
    ] {
        for (x, y) in points {
            if kind == KinematicsKind::Polar(Polar) && x == 0.0 && y == 0.0 {
                continue;
            }
            let p = pt(x, y);
            let j0 = kind.joint_map(0, [0, 1, 2]).value(&p, 0.0);
            let j1 = kind.joint_map(1, [0, 1, 2]).value(&p, 0.0);
            let [fx, fy, _] = kind.forward_or_nan([j0, j1, 0.0]);
            assert!(
                (fx - x).abs() < 1e-9 && (fy - y).abs() < 1e-9,
                "{kind:?} ({x},{y}) -> ({fx},{fy})"
            );
        }
    }
}

#[test]
fn corexy_rows() {
    let p = pt(3.0, 2.0);
    assert_eq!(
        KinematicsKind::CoreXY(CoreXY)
            .joint_map(0, [0, 1, 2])
            .value(&p, 0.0),
        5.0
    );
    assert_eq!(
        KinematicsKind::CoreXY(CoreXY)
            .joint_map(1, [0, 1, 2])
            .value(&p, 0.0),
        1.0
    );
}

#[test]
fn angle_unwraps_to_reference() {
    let m = POLAR.joint_map(1, [0, 1, 2]);
    let v = m.value(&pt(-1.0, -1e-9), 179.0);
    assert!((v - 180.0).abs() < 1e-6, "{v}");
    let v = m.value(&pt(1.0, 0.0), 720.0);
    assert!((v - 720.0).abs() < 1e-9);
}

#[test]
fn solve_inverts_value_for_every_shape() {
    let segments = [
        seg(pt(0.0, 0.0), pt(10.0, 5.0)),
        seg(pt(50.0, -30.0), pt(-40.0, 20.0)), // passes near the centre
        seg(pt(10.0, 10.0), pt(10.0, 60.0)),
        seg(pt(-5.0, 20.0), pt(-80.0, -3.0)), // crosses the ±180° cut
    ];
    let maps = [
        KinematicsKind::CoreXY(CoreXY).joint_map(0, [0, 1, 2]),
        KinematicsKind::CoreXY(CoreXY).joint_map(1, [0, 1, 2]),
        POLAR.joint_map(0, [0, 1, 2]),
        POLAR.joint_map(1, [0, 1, 2]),
    ];
    for s in &segments {
        for m in &maps {
            if m.is_angle() && s.start[0] == 0.0 && s.start[1] == 0.0 {
                continue;
            }
            let path = JointPath::new(m, s, 0.0);
            let len = path.length();
            let mut pieces = [(0.0, len), (len, len)];
            if let Some(t) = path.next_turn(0.0) {
                pieces = [(0.0, t), (t, len)];
            }
            for (lo, hi) in pieces {
                if hi <= lo {
                    continue;
                }
                for k in 1..20 {
                    let s_true = lo + (hi - lo) * k as f64 / 20.0;
                    let v = path.value_at(s_true);
                    let back = path.solve(v, lo, hi);
                    assert!(
                        (path.value_at(back) - v).abs() < 1e-9 * (1.0 + v.abs()),
                        "{m:?} on {s:?}: s={s_true} back={back}"
                    );
                }
            }
        }
    }
}

#[test]
fn angle_path_is_continuous_across_the_cut() {
    let s = seg(pt(-5.0, 20.0), pt(-80.0, -3.0));
    let m = POLAR.joint_map(1, [0, 1, 2]);
    let start = m.value(&s.start, 0.0);
    let path = JointPath::new(&m, &s, start);
    let mut last = path.value_at(0.0);
    for k in 1..=1000 {
        let v = path.value_at(path.length() * k as f64 / 1000.0);
        assert!((v - last).abs() < 1.0, "jump {last} -> {v}");
        last = v;
    }
    assert!(last > 180.0, "went past 180° without wrapping: {last}");
}

const POLAR: KinematicsKind = KinematicsKind::Polar(Polar);
