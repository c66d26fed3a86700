//! Every kinematics in the table against the same properties: forward
//! undoes inverse, each joint's path along a line is solved back to the
//! distance that gave it, and the rate bound the planner uses holds along
//! lines that run close to a singularity.

use motet_trajectory::kinematics::{FiveBar, Scara};
use motet_trajectory::{JointMap, JointPath, KinematicsKind, MAX_AXES};
use proptest::prelude::*;

/// Each kind with a geometry a machine might have, and the box of points
/// sampled for it.
fn machines() -> Vec<(KinematicsKind, [f64; 4])> {
    vec![
        (KinematicsKind::CARTESIAN, [-200.0, 200.0, -200.0, 200.0]),
        (KinematicsKind::COREXY, [-200.0, 200.0, -200.0, 200.0]),
        (KinematicsKind::HBOT, [-200.0, 200.0, -200.0, 200.0]),
        (KinematicsKind::POLAR, [-200.0, 200.0, -200.0, 200.0]),
        (
            KinematicsKind::Scara(Scara {
                l1: 150.0,
                l2: 120.0,
                elbow: 1.0,
            }),
            [-270.0, 270.0, -270.0, 270.0],
        ),
        (
            KinematicsKind::Scara(Scara {
                l1: 100.0,
                l2: 100.0,
                elbow: -1.0,
            }),
            [-200.0, 200.0, -200.0, 200.0],
        ),
        (
            KinematicsKind::FiveBar(FiveBar::new(60.0, 80.0, 80.0, 120.0, 120.0)),
            [-100.0, 160.0, 0.0, 220.0],
        ),
        (
            KinematicsKind::FiveBar(FiveBar {
                ext: 20.0,
                ..FiveBar::new(40.0, 70.0, 90.0, 110.0, 100.0)
            }),
            [-120.0, 160.0, 0.0, 240.0],
        ),
    ]
}

#[test]
fn the_table_names_every_kind_once() {
    let mut names: Vec<&str> = KinematicsKind::NAMES.to_vec();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), KinematicsKind::NAMES.len());
    for (kin, _) in machines() {
        assert!(KinematicsKind::NAMES.contains(&kin.name()));
        // The geometry survives being read back from its values.
        let n = kin.param_specs().len();
        let back = KinematicsKind::from_name(kin.name(), &kin.params()[..n]).unwrap();
        assert_eq!(back, Ok(kin));
        assert!(kin.is_valid());
        let joints: Vec<&str> = kin.joints().iter().map(|j| j.name).collect();
        assert!(joints.is_empty() || joints.len() == 2, "{joints:?}");
    }
}

#[test]
fn bad_geometry_is_refused_with_its_key() {
    for (name, values, key) in [
        ("scara", vec![0.0, 100.0, 1.0], "l1"),
        ("scara", vec![100.0, f64::NAN, 1.0], "l2"),
        ("scara", vec![100.0, 100.0, 0.5], "elbow"),
        ("fivebar", vec![60.0, 80.0, -1.0, 120.0, 120.0, 0.0], "l2"),
        (
            "fivebar",
            vec![f64::INFINITY, 80.0, 80.0, 120.0, 120.0, 0.0],
            "s",
        ),
        (
            "fivebar",
            vec![60.0, 80.0, 80.0, 120.0, 120.0, -130.0],
            "ext",
        ),
    ] {
        let e = KinematicsKind::from_name(name, &values)
            .unwrap()
            .unwrap_err();
        assert_eq!(e.key, key, "{name} {values:?}");
    }
    assert!(KinematicsKind::from_name("hexapod", &[]).is_none());
}

fn point(x: f64, y: f64) -> [f64; MAX_AXES] {
    let mut p = [0.0; MAX_AXES];
    p[0] = x;
    p[1] = y;
    p
}

/// Draws a point in the box `b` that the kinematics reaches clear of
/// singularities (`None` if the draw missed).
fn reachable(kin: KinematicsKind, b: [f64; 4], u: f64, v: f64) -> Option<(f64, f64)> {
    let (x, y) = (b[0] + (b[1] - b[0]) * u, b[2] + (b[3] - b[2]) * v);
    kin.reach(x, y).ok().map(|_| (x, y))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn forward_undoes_inverse(k in 0usize..8, u in 0.0f64..1.0, v in 0.0f64..1.0) {
        let (kin, b) = machines()[k];
        if kin.joints().is_empty() {
            return Ok(());
        }
        let Some((x, y)) = reachable(kin, b, u, v) else { return Ok(()) };
        if kin == KinematicsKind::POLAR && x.hypot(y) < 1e-6 {
            return Ok(());
        }
        let j0 = kin.inverse(0, x, y, 0.0).unwrap();
        let j1 = kin.inverse(1, x, y, 0.0).unwrap();
        let (fx, fy) = kin.forward([j0, j1]).unwrap();
        prop_assert!((fx - x).abs() < 1e-9 && (fy - y).abs() < 1e-9,
            "{:?} ({}, {}) -> ({}, {}) -> ({}, {})", kin, x, y, j0, j1, fx, fy);
    }

    /// Along a line within reach, every joint value is solved back to its
    /// distance, leg by leg between turns, as a node steps it.
    #[test]
    fn paths_solve_back(
        k in 0usize..8,
        a in (0.0f64..1.0, 0.0f64..1.0),
        b in (0.0f64..1.0, 0.0f64..1.0),
    ) {
        let (kin, bx) = machines()[k];
        if kin.joints().is_empty() {
            return Ok(());
        }
        let (Some(p), Some(q)) = (reachable(kin, bx, a.0, a.1), reachable(kin, bx, b.0, b.1)) else {
            return Ok(());
        };
        // Only lines that stay within reach all along (the host refuses the others).
        if (0..=200).any(|i| {
            let t = i as f64 / 200.0;
            kin.reach(p.0 + (q.0 - p.0) * t, p.1 + (q.1 - p.1) * t).is_err()
        }) {
            return Ok(());
        }
        let length = (q.0 - p.0).hypot(q.1 - p.1);
        if length < 1e-3 {
            return Ok(());
        }
        for j in 0..2 {
            let map = kin.joint_map(j, 0, 1);
            let start = map.value(&point(p.0, p.1), 0.0);
            let path = JointPath::between(&map, &point(p.0, p.1), &point(q.0, q.1), length, start);
            let mut lo = 0.0;
            while lo < length {
                let hi = path.next_turn(lo).unwrap_or(length);
                prop_assert!(hi > lo);
                for i in 1..16 {
                    let s = lo + (hi - lo) * i as f64 / 16.0;
                    let v = path.value_at(s);
                    let back = path.solve(v, lo, hi);
                    let err = (path.value_at(back) - v).abs();
                    prop_assert!(err < 1e-9 * (1.0 + v.abs()),
                        "{:?} joint {}: s {} -> {} ({} off)", kin, j, s, back, err);
                }
                lo = hi;
            }
        }
    }

    /// The planner's bound on a joint's rate holds along a line, sampled
    /// far more finely than the bound itself was.
    #[test]
    fn rate_bounds_hold(
        k in 0usize..8,
        a in (0.0f64..1.0, 0.0f64..1.0),
        b in (0.0f64..1.0, 0.0f64..1.0),
    ) {
        let (kin, bx) = machines()[k];
        let (Some(p), Some(q)) = (reachable(kin, bx, a.0, a.1), reachable(kin, bx, b.0, b.1)) else {
            return Ok(());
        };
        if (0..=200).any(|i| {
            let t = i as f64 / 200.0;
            let (x, y) = (p.0 + (q.0 - p.0) * t, p.1 + (q.1 - p.1) * t);
            kin.reach(x, y).is_err() || (kin == KinematicsKind::POLAR && x.hypot(y) < 1.0)
        }) {
            return Ok(());
        }
        let length = (q.0 - p.0).hypot(q.1 - p.1);
        if length < 1e-3 {
            return Ok(());
        }
        for j in 0..kin.joints().len() {
            let map: JointMap = kin.joint_map(j, 0, 1);
            let start = map.value(&point(p.0, p.1), 0.0);
            let path = JointPath::between(&map, &point(p.0, p.1), &point(q.0, q.1), length, start);
            let bound = path.max_rate(0.0, length);
            let n = 4000;
            let h = length / n as f64;
            for i in 0..n {
                let rate = ((path.value_at(h * (i + 1) as f64) - path.value_at(h * i as f64)) / h).abs();
                prop_assert!(rate <= bound * (1.0 + 1e-9) + 1e-9,
                    "{:?} joint {}: rate {} at s {} above the bound {}", kin, j, rate, h * i as f64, bound);
            }
        }
    }
}
