//! Kinematics: how joints (what actuators move) follow from machine-space points.
//!
//! A machine's kinematics is reduced, per joint, to a [`JointMap`]; nodes need
//! nothing else. Linear kinematics (cartesian, CoreXY, H-bot, any Gestalt
//! kinematic matrix) are one row of coefficients. Nonlinear ones (polar; five-bar
//! and delta fit the same shape) carry their geometry and are solved along a
//! segment by [`JointPath`].

use crate::math::{atan2, cos, sin, sqrt};
use crate::point::{Point, MAX_AXES};
use crate::segment::Segment;
use core::f64::consts::PI;
use serde::{Deserialize, Serialize};

const DEG: f64 = 180.0 / PI;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum KinematicsKind {
    /// Each joint is one machine axis.
    Cartesian,
    /// a = x + y, b = x − y (two motors on a crossed belt).
    CoreXY,
    /// Same joint math as CoreXY on a single H-shaped belt (Gestalt: ΔX = ½(ΔA+ΔB),
    /// ΔY = ½(ΔA−ΔB)); the difference is mechanical (racking), not kinematic.
    HBot,
    /// r = |(x, y)| in mm, θ = angle of (x, y) in degrees (turntable plus radial arm).
    Polar,
}

impl KinematicsKind {
    pub fn name(self) -> &'static str {
        match self {
            KinematicsKind::Cartesian => "cartesian",
            KinematicsKind::CoreXY => "corexy",
            KinematicsKind::HBot => "hbot",
            KinematicsKind::Polar => "polar",
        }
    }

    /// Names of the joints that replace the x and y axes; empty for cartesian.
    pub fn xy_joints(self) -> &'static [&'static str] {
        match self {
            KinematicsKind::Cartesian => &[],
            KinematicsKind::CoreXY | KinematicsKind::HBot => &["a", "b"],
            KinematicsKind::Polar => &["r", "theta"],
        }
    }

    /// Whether joint `j` of [`KinematicsKind::xy_joints`] is an angle (degrees).
    pub fn joint_is_angle(self, j: usize) -> bool {
        matches!(self, KinematicsKind::Polar) && j == 1
    }

    /// The map of xy joint `j` given the indices of the x and y axes.
    pub fn xy_joint_map(self, j: usize, x: usize, y: usize) -> JointMap {
        let mut coeffs = [0.0; MAX_AXES];
        let (x8, y8) = (x as u8, y as u8);
        match (self, j) {
            (KinematicsKind::CoreXY | KinematicsKind::HBot, 0) => {
                coeffs[x] = 1.0;
                coeffs[y] = 1.0;
                JointMap::Linear { coeffs }
            }
            (KinematicsKind::CoreXY | KinematicsKind::HBot, _) => {
                coeffs[x] = 1.0;
                coeffs[y] = -1.0;
                JointMap::Linear { coeffs }
            }
            (KinematicsKind::Polar, 0) => JointMap::PolarRadius { x: x8, y: y8 },
            (KinematicsKind::Polar, _) => JointMap::PolarAngle { x: x8, y: y8 },
            (KinematicsKind::Cartesian, _) => {
                coeffs[if j == 0 { x } else { y }] = 1.0;
                JointMap::Linear { coeffs }
            }
        }
    }

    /// Machine (x, y) from the two xy joints: the forward kinematics.
    pub fn forward_xy(self, j0: f64, j1: f64) -> (f64, f64) {
        match self {
            KinematicsKind::Cartesian => (j0, j1),
            KinematicsKind::CoreXY | KinematicsKind::HBot => (0.5 * (j0 + j1), 0.5 * (j0 - j1)),
            KinematicsKind::Polar => {
                let t = j1 / DEG;
                (j0 * cos(t), j0 * sin(t))
            }
        }
    }
}

/// How one joint's value follows from a point in machine space.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum JointMap {
    /// joint = Σ coeffs[i] · p[i].
    Linear { coeffs: [f64; MAX_AXES] },
    /// Distance of (p[x], p[y]) from the polar centre, mm.
    PolarRadius { x: u8, y: u8 },
    /// Angle of (p[x], p[y]) about the polar centre, degrees, unwrapped so that it
    /// stays continuous with the joint's previous value.
    PolarAngle { x: u8, y: u8 },
}

impl JointMap {
    /// A joint that is exactly machine axis `axis`.
    pub fn axis(axis: usize) -> JointMap {
        let mut coeffs = [0.0; MAX_AXES];
        coeffs[axis] = 1.0;
        JointMap::Linear { coeffs }
    }

    /// The joint's value at `p`. For angles, the branch nearest `reference`.
    pub fn value(&self, p: &Point, reference: f64) -> f64 {
        match *self {
            JointMap::Linear { coeffs } => {
                let mut v = 0.0;
                for i in 0..MAX_AXES {
                    v += coeffs[i] * p[i];
                }
                v
            }
            JointMap::PolarRadius { x, y } => {
                let (px, py) = (p[x as usize], p[y as usize]);
                sqrt(px * px + py * py)
            }
            JointMap::PolarAngle { x, y } => {
                let a = atan2(p[y as usize], p[x as usize]) * DEG;
                nearest_turn(a, reference)
            }
        }
    }

    /// Axes whose positions the joint depends on, as a bit mask.
    pub fn axis_mask(&self) -> u8 {
        match *self {
            JointMap::Linear { coeffs } => {
                let mut m = 0;
                for (i, c) in coeffs.iter().enumerate() {
                    if *c != 0.0 {
                        m |= 1 << i;
                    }
                }
                m
            }
            JointMap::PolarRadius { x, y } | JointMap::PolarAngle { x, y } => (1 << x) | (1 << y),
        }
    }
}

/// `angle + 360·k` nearest to `reference` (degrees).
#[inline]
pub fn nearest_turn(angle: f64, reference: f64) -> f64 {
    let turns = crate::math::round((reference - angle) / 360.0);
    angle + 360.0 * turns
}

/// One joint along one segment, as a function of path distance `s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointPath {
    shape: Shape,
    length: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Shape {
    /// value = a0 + k·s
    Linear { a0: f64, k: f64 },
    /// value = |p0 + w·s|
    Radius { p0: (f64, f64), w: (f64, f64) },
    /// value = θ0 + angle from p0 to p0 + w·s (degrees)
    Angle {
        p0: (f64, f64),
        w: (f64, f64),
        theta0: f64,
    },
}

impl JointPath {
    /// The joint along `seg`, continuing from the joint value `reference` (used to
    /// pick the angle's turn).
    pub fn new(map: &JointMap, seg: &Segment, reference: f64) -> JointPath {
        JointPath::between(map, &seg.start, &seg.end, seg.profile.length(), reference)
    }

    /// The joint along the straight line from `start` to `end`, `length` long.
    pub fn between(
        map: &JointMap,
        start: &Point,
        end: &Point,
        length: f64,
        reference: f64,
    ) -> JointPath {
        let inv = if length > 0.0 { 1.0 / length } else { 0.0 };
        let shape = match *map {
            JointMap::Linear { .. } => {
                let a0 = map.value(start, reference);
                let a1 = map.value(end, reference);
                Shape::Linear {
                    a0,
                    k: (a1 - a0) * inv,
                }
            }
            JointMap::PolarRadius { x, y } | JointMap::PolarAngle { x, y } => {
                let (x, y) = (x as usize, y as usize);
                let p0 = (start[x], start[y]);
                let w = ((end[x] - p0.0) * inv, (end[y] - p0.1) * inv);
                if let JointMap::PolarRadius { .. } = map {
                    Shape::Radius { p0, w }
                } else {
                    Shape::Angle {
                        p0,
                        w,
                        theta0: map.value(start, reference),
                    }
                }
            }
        };
        JointPath { shape, length }
    }

    /// The largest |d² value / d s²| over `[s_lo, s_hi]`: how hard the joint must
    /// accelerate at constant path speed (an upper bound for the angle).
    pub fn max_curvature(&self, s_lo: f64, s_hi: f64) -> f64 {
        let (p0, w) = match self.shape {
            Shape::Linear { .. } => return 0.0,
            Shape::Radius { p0, w } | Shape::Angle { p0, w, .. } => (p0, w),
        };
        let ww = w.0 * w.0 + w.1 * w.1;
        let s_min = if ww > 0.0 {
            (-(p0.0 * w.0 + p0.1 * w.1) / ww).clamp(s_lo, s_hi)
        } else {
            s_lo
        };
        let (x, y) = (p0.0 + w.0 * s_min, p0.1 + w.1 * s_min);
        let r = sqrt(x * x + y * y);
        let cross = (p0.0 * w.1 - p0.1 * w.0).abs();
        if r <= 0.0 {
            return if cross == 0.0 { 0.0 } else { f64::INFINITY };
        }
        match self.shape {
            // r'' = |p × w|² / r³
            Shape::Radius { .. } => cross * cross / (r * r * r),
            // |θ''| = 2 |p × w| |p · w| / r⁴ ≤ 2 |p × w| |w| / r³
            _ => 2.0 * cross * sqrt(ww) / (r * r * r) * DEG,
        }
    }

    #[inline]
    pub fn length(&self) -> f64 {
        self.length
    }

    /// `(a0, k)` when the joint is affine in the distance, `a0 + k·s`
    /// (linear maps: cartesian, CoreXY, any kinematic matrix).
    #[inline]
    pub fn line(&self) -> Option<(f64, f64)> {
        match self.shape {
            Shape::Linear { a0, k } => Some((a0, k)),
            _ => None,
        }
    }

    /// Joint value after distance `s` along the segment.
    #[inline]
    pub fn value_at(&self, s: f64) -> f64 {
        match self.shape {
            Shape::Linear { a0, k } => a0 + k * s,
            Shape::Radius { p0, w } => {
                let (x, y) = (p0.0 + w.0 * s, p0.1 + w.1 * s);
                sqrt(x * x + y * y)
            }
            Shape::Angle { p0, w, theta0 } => {
                let (x, y) = (p0.0 + w.0 * s, p0.1 + w.1 * s);
                let cross = p0.0 * y - p0.1 * x;
                let dot = p0.0 * x + p0.1 * y;
                if cross == 0.0 && dot <= 0.0 {
                    // At or through the centre: the angle is undefined; hold it.
                    return theta0;
                }
                theta0 + atan2(cross, dot) * DEG
            }
        }
    }

    /// The distance inside the segment where the joint turns around, if any
    /// (the radius's closest approach to the centre). On either side of it the
    /// joint is monotone.
    pub fn turning_point(&self) -> Option<f64> {
        match self.shape {
            Shape::Radius { p0, w } => {
                let ww = w.0 * w.0 + w.1 * w.1;
                if ww == 0.0 {
                    return None;
                }
                let s = -(p0.0 * w.0 + p0.1 * w.1) / ww;
                (s > 0.0 && s < self.length).then_some(s)
            }
            _ => None,
        }
    }

    /// The largest |d value / d s| over `[s_lo, s_hi]` (joint units per path unit).
    pub fn max_rate(&self, s_lo: f64, s_hi: f64) -> f64 {
        match self.shape {
            Shape::Linear { k, .. } => k.abs(),
            Shape::Radius { w, .. } => sqrt(w.0 * w.0 + w.1 * w.1),
            Shape::Angle { p0, w, .. } => {
                // |dθ/ds| = |p × w| / |p|², largest where |p| is smallest.
                let r2 = |s: f64| {
                    let (x, y) = (p0.0 + w.0 * s, p0.1 + w.1 * s);
                    x * x + y * y
                };
                let ww = w.0 * w.0 + w.1 * w.1;
                let mut s_min = if ww > 0.0 {
                    -(p0.0 * w.0 + p0.1 * w.1) / ww
                } else {
                    s_lo
                };
                s_min = s_min.clamp(s_lo, s_hi);
                let cross = (p0.0 * w.1 - p0.1 * w.0).abs();
                let m = r2(s_min);
                if m <= 0.0 {
                    f64::INFINITY
                } else {
                    cross / m * DEG
                }
            }
        }
    }

    /// The distance in `[s_lo, s_hi]` at which the joint equals `target`, given that
    /// the joint is monotone there and `target` lies between its values at the
    /// ends. Closed form for every shape.
    pub fn solve(&self, target: f64, s_lo: f64, s_hi: f64) -> f64 {
        let s = match self.shape {
            Shape::Linear { a0, k } => {
                if k == 0.0 {
                    s_lo
                } else {
                    (target - a0) / k
                }
            }
            Shape::Radius { p0, w } => {
                // |p0 + w s|² = R²; the root on the side of the turning point we are on.
                let a = w.0 * w.0 + w.1 * w.1;
                let b = p0.0 * w.0 + p0.1 * w.1;
                let c = p0.0 * p0.0 + p0.1 * p0.1 - target * target;
                if a == 0.0 {
                    s_lo
                } else {
                    let s_turn = -b / a;
                    let disc = (b * b - a * c).max(0.0);
                    let root = sqrt(disc) / a;
                    if 0.5 * (s_lo + s_hi) >= s_turn {
                        s_turn + root
                    } else {
                        s_turn - root
                    }
                }
            }
            Shape::Angle { p0, w, theta0 } => {
                let phi = (target - theta0) / DEG;
                let (c, sn) = (cos(phi), sin(phi));
                // Direction of the target angle: p0 rotated by phi.
                let d = (p0.0 * c - p0.1 * sn, p0.0 * sn + p0.1 * c);
                let cross_dp = d.0 * p0.1 - d.1 * p0.0;
                let cross_dw = d.0 * w.1 - d.1 * w.0;
                if cross_dw == 0.0 {
                    s_lo
                } else {
                    -cross_dp / cross_dw
                }
            }
        };
        if s.is_nan() {
            s_lo
        } else {
            s.clamp(s_lo, s_hi)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::fastest;

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
            KinematicsKind::Cartesian,
            KinematicsKind::CoreXY,
            KinematicsKind::HBot,
            KinematicsKind::Polar,
        ] {
            for (x, y) in points {
                if kind == KinematicsKind::Polar && x == 0.0 && y == 0.0 {
                    continue;
                }
                let p = pt(x, y);
                let j0 = kind.xy_joint_map(0, 0, 1).value(&p, 0.0);
                let j1 = kind.xy_joint_map(1, 0, 1).value(&p, 0.0);
                let (fx, fy) = kind.forward_xy(j0, j1);
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
            KinematicsKind::CoreXY.xy_joint_map(0, 0, 1).value(&p, 0.0),
            5.0
        );
        assert_eq!(
            KinematicsKind::CoreXY.xy_joint_map(1, 0, 1).value(&p, 0.0),
            1.0
        );
    }

    #[test]
    fn angle_unwraps_to_reference() {
        let m = JointMap::PolarAngle { x: 0, y: 1 };
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
            KinematicsKind::CoreXY.xy_joint_map(0, 0, 1),
            KinematicsKind::CoreXY.xy_joint_map(1, 0, 1),
            JointMap::PolarRadius { x: 0, y: 1 },
            JointMap::PolarAngle { x: 0, y: 1 },
        ];
        for s in &segments {
            for m in &maps {
                if let JointMap::PolarAngle { .. } = m {
                    if s.start[0] == 0.0 && s.start[1] == 0.0 {
                        continue;
                    }
                }
                let path = JointPath::new(m, s, 0.0);
                let len = path.length();
                let mut pieces = [(0.0, len), (len, len)];
                if let Some(t) = path.turning_point() {
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
        let m = JointMap::PolarAngle { x: 0, y: 1 };
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
}
