//! Every kinematics in the table against the same properties: forward
//! undoes inverse, each joint's path along a line is solved back to the
//! distance that gave it, and the rate bound the planner uses holds along
//! lines that run close to a singularity. Points are drawn in three
//! dimensions: planar kinematics leave z alone, a delta's joints follow it.

use motet_trajectory::kinematics::{Delta, FiveBar, Scara, Xyz};
use motet_trajectory::{JointMap, JointPath, KinematicsKind, MAX_AXES};
use proptest::prelude::*;

/// Each kind with a geometry a machine might have, and the box of points
/// sampled for it: x, y and z ranges.
type Box3 = [f64; 6];

fn machines() -> Vec<(KinematicsKind, Box3)> {
    const PLANE: Box3 = [-200.0, 200.0, -200.0, 200.0, -50.0, 50.0];
    vec![
        (KinematicsKind::CARTESIAN, PLANE),
        (KinematicsKind::COREXY, PLANE),
        (KinematicsKind::HBOT, PLANE),
        (KinematicsKind::POLAR, PLANE),
        (
            KinematicsKind::Scara(Scara {
                l1: 150.0,
                l2: 120.0,
                elbow: 1.0,
            }),
            [-270.0, 270.0, -270.0, 270.0, 0.0, 0.0],
        ),
        (
            KinematicsKind::Scara(Scara {
                l1: 100.0,
                l2: 100.0,
                elbow: -1.0,
            }),
            PLANE,
        ),
        (
            KinematicsKind::FiveBar(FiveBar::new(60.0, 80.0, 80.0, 120.0, 120.0)),
            [-100.0, 160.0, 0.0, 220.0, 0.0, 10.0],
        ),
        (
            KinematicsKind::FiveBar(FiveBar {
                ext: 20.0,
                ..FiveBar::new(40.0, 70.0, 90.0, 110.0, 100.0)
            }),
            [-120.0, 160.0, 0.0, 240.0, 0.0, 0.0],
        ),
        (
            KinematicsKind::Delta(Delta {
                radius: 105.0,
                arm: 250.0,
            }),
            [-180.0, 180.0, -180.0, 180.0, 0.0, 300.0],
        ),
        (
            KinematicsKind::Delta(Delta {
                radius: 140.0,
                arm: 180.0,
            }),
            [-150.0, 150.0, -150.0, 150.0, -20.0, 20.0],
        ),
    ]
}

/// How many machines [`machines`] lists.
const KINDS: usize = 10;

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
        assert!(matches!(joints.len(), 0 | 2 | 3), "{joints:?}");
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
        ("delta", vec![-1.0, 250.0], "radius"),
        ("delta", vec![100.0, f64::NAN], "arm"),
        // Rods nearly flat at the centre: no point would be in reach.
        ("delta", vec![200.0, 210.0], "arm"),
    ] {
        let e = KinematicsKind::from_name(name, &values)
            .unwrap()
            .unwrap_err();
        assert_eq!(e.key, key, "{name} {values:?}");
    }
    assert!(KinematicsKind::from_name("hexapod", &[]).is_none());
}

fn point(p: Xyz) -> [f64; MAX_AXES] {
    let mut q = [0.0; MAX_AXES];
    q[..3].copy_from_slice(&p);
    q
}

fn lerp(p: Xyz, q: Xyz, t: f64) -> Xyz {
    [0, 1, 2].map(|i| p[i] + (q[i] - p[i]) * t)
}

fn distance(p: Xyz, q: Xyz) -> f64 {
    (0..3).map(|i| (q[i] - p[i]).powi(2)).sum::<f64>().sqrt()
}

/// Draws a point in the box `b` that the kinematics reaches clear of
/// singularities (`None` if the draw missed).
fn reachable(kin: KinematicsKind, b: Box3, u: (f64, f64, f64)) -> Option<Xyz> {
    let p = [
        b[0] + (b[1] - b[0]) * u.0,
        b[2] + (b[3] - b[2]) * u.1,
        b[4] + (b[5] - b[4]) * u.2,
    ];
    kin.reach(p).ok().map(|_| p)
}

/// Whether the straight line from `p` to `q` stays within reach all along
/// (the host refuses the others), and for polar machines clear of the
/// centre by `polar_clearance`.
fn line_in_reach(kin: KinematicsKind, p: Xyz, q: Xyz, polar_clearance: f64) -> bool {
    (0..=200).all(|i| {
        let x = lerp(p, q, i as f64 / 200.0);
        kin.reach(x).is_ok()
            && !(kin == KinematicsKind::POLAR && x[0].hypot(x[1]) < polar_clearance)
    })
}

/// A straight line between two drawn points of machine `k`, within reach
/// all along (clear of a polar centre by `clearance`) and not too short to
/// measure: the lines the host lets through.
#[derive(Clone, Copy)]
struct Line {
    kin: KinematicsKind,
    p: Xyz,
    q: Xyz,
    length: f64,
}

fn line(k: usize, a: (f64, f64, f64), b: (f64, f64, f64), clearance: f64) -> Option<Line> {
    let (kin, bx) = machines()[k];
    let (p, q) = (reachable(kin, bx, a)?, reachable(kin, bx, b)?);
    let length = distance(p, q);
    (line_in_reach(kin, p, q, clearance) && length >= 1e-3).then_some(Line { kin, p, q, length })
}

impl Line {
    /// Each joint: its index, map, value at the start and path along the line.
    fn paths(&self) -> Vec<(usize, JointMap, f64, JointPath)> {
        (0..self.kin.joints().len())
            .map(|j| {
                let map = self.kin.joint_map(j, [0, 1, 2]);
                let start = map.value(&point(self.p), 0.0);
                let path =
                    JointPath::between(&map, &point(self.p), &point(self.q), self.length, start);
                (j, map, start, path)
            })
            .collect()
    }
}

fn unit() -> impl Strategy<Value = (f64, f64, f64)> {
    (0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn forward_undoes_inverse(k in 0usize..KINDS, u in unit()) {
        let (kin, b) = machines()[k];
        let Some(p) = reachable(kin, b, u) else { return Ok(()) };
        if kin == KinematicsKind::POLAR && p[0].hypot(p[1]) < 1e-6 {
            return Ok(());
        }
        // The kinematics' joints, then the coordinates they leave alone.
        let n = kin.joints().len();
        let mut joints = p;
        for (j, slot) in joints.iter_mut().enumerate().take(n) {
            *slot = kin.inverse(j, p, 0.0).unwrap();
        }
        let f = kin.forward(joints).unwrap();
        prop_assert!(distance(f, p) < 1e-8,
            "{:?} {:?} -> {:?} -> {:?}", kin, p, joints, f);
    }

    /// No joint changes faster than its gradient bound says, wherever the
    /// kinematics reaches (a finite difference in each direction).
    #[test]
    fn gradient_bounds_hold(k in 0usize..KINDS, u in unit()) {
        let (kin, b) = machines()[k];
        let Some(p) = reachable(kin, b, u) else { return Ok(()) };
        for j in 0..kin.joints().len() {
            let Some(bound) = kin.gradient_bound(j) else { continue };
            let h = 1e-6;
            let g: f64 = (0..3)
                .map(|i| {
                    let mut q = p;
                    q[i] += h;
                    let d = (kin.inverse(j, q, 0.0).unwrap() - kin.inverse(j, p, 0.0).unwrap()) / h;
                    d * d
                })
                .sum::<f64>()
                .sqrt();
            prop_assert!(g <= bound * (1.0 + 1e-4), "{:?} joint {} at {:?}: |∇| {} > {}", kin, j, p, g, bound);
        }
    }

    /// Along a line within reach, every joint value is solved back to its
    /// distance, leg by leg between turns, as a node steps it.
    #[test]
    fn paths_solve_back(k in 0usize..KINDS, a in unit(), b in unit()) {
        let Some(line) = line(k, a, b, 0.0) else { return Ok(()) };
        let Line { kin, length, .. } = line;
        for (j, _, _, path) in line.paths() {
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

    /// A joint's path is the kinematics' inverse at every point of the
    /// line (closed forms included), and it turns where sampling finds it
    /// turning: each sampled extremum has a turn within a sample of it.
    #[test]
    fn paths_follow_the_inverse_and_turn_where_it_turns(k in 0usize..KINDS, a in unit(), b in unit()) {
        let Some(line) = line(k, a, b, 1.0) else { return Ok(()) };
        let Line { kin, p, q, length } = line;
        for (j, map, start, path) in line.paths() {
            let n = 2000;
            let h = length / n as f64;
            let values: Vec<f64> = (0..=n).map(|i| path.value_at(h * i as f64)).collect();
            let mut reference = start;
            for (i, v) in values.iter().enumerate() {
                let want = map.value(&point(lerp(p, q, i as f64 / n as f64)), reference);
                prop_assert!((v - want).abs() < 1e-7 * (1.0 + want.abs()),
                    "{:?} joint {}: {} at sample {}, the inverse gives {}", kin, j, v, i, want);
                reference = want;
            }
            let mut turns = vec![];
            let mut after = 0.0;
            while let Some(t) = path.next_turn(after) {
                turns.push(t);
                after = t;
            }
            for i in 1..n {
                let (l, m, r) = (values[i - 1], values[i], values[i + 1]);
                // A clear extremum (not flat noise) between samples i-1 and i+1.
                let tol = 1e-9 * (1.0 + m.abs());
                if (m > l + tol && m > r + tol) || (m < l - tol && m < r - tol) {
                    let s = h * i as f64;
                    prop_assert!(turns.iter().any(|t| (t - s).abs() <= h * 1.01),
                        "{:?} joint {}: an extremum near s = {} but turns at {:?}", kin, j, s, turns);
                }
            }
        }
    }

    /// The planner's bound on a joint's rate holds along a line, sampled
    /// far more finely than the bound itself was.
    #[test]
    fn rate_bounds_hold(k in 0usize..KINDS, a in unit(), b in unit()) {
        let Some(line) = line(k, a, b, 1.0) else { return Ok(()) };
        let Line { kin, length, .. } = line;
        for (j, _, _, path) in line.paths() {
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
