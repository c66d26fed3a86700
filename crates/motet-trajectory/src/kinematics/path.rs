//! One joint along one segment, as a function of path distance `s`: what a
//! node steps and the planner bounds.

use super::delta::Carriage;
use super::{tool_point, JointMap, KinematicsKind, Xyz, DEG};
use crate::math::{atan2, cos, sin, sqrt};
use crate::point::Point;
use crate::segment::Segment;

/// A joint's closed form along a line `p0 + w·s`, for kinematics that have
/// one (see [`super::Kinematics::closed_form`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ClosedForm {
    /// value = |p0 + w·s| (mm)
    Radius {
        /// Tool point `(x, y)` at the segment's start, mm.
        p0: (f64, f64),
        /// Change of `(x, y)` per mm of path.
        w: (f64, f64),
    },
    /// value = θ0 + the angle from p0 to p0 + w·s (degrees)
    Angle {
        /// Tool point `(x, y)` at the segment's start, mm.
        p0: (f64, f64),
        /// Change of `(x, y)` per mm of path.
        w: (f64, f64),
        /// The joint's value at `p0`, degrees, on the turn the joint is on
        /// (so the angle stays continuous across segments).
        theta0: f64,
    },
    /// A delta's carriage: z + √(arm² − d²) along the line (see
    /// [`Carriage`]).
    Carriage(Carriage),
}

/// One joint along one segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointPath {
    shape: Shape,
    length: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Shape {
    /// value = a0 + k·s
    Linear {
        a0: f64,
        k: f64,
    },
    Closed(ClosedForm),
    /// The kinematics' inverse at `p0 + w·s`; crossings bracketed. An
    /// angle's branch follows the line from `v0` (its value at `s = 0`) to
    /// `v1` (at the end, unwrapped along the way), so a joint that turns
    /// past half a turn over a segment stays continuous.
    Bracketed {
        kinematics: KinematicsKind,
        joint: u8,
        p0: Xyz,
        w: Xyz,
        v0: f64,
        v1: f64,
    },
}

/// Samples a bracketed joint is looked at along a segment to find where it
/// turns and how fast it moves. Kinematics keep a margin from their
/// singularities (`Kinematics::reach`), so a joint's rate changes little
/// between samples.
const SAMPLES: usize = 64;

/// Slack on sampled bounds: the true largest rate lies between samples.
const SLACK: f64 = 1.05;

impl JointPath {
    /// The joint along `seg`, continuing from the joint value `reference`
    /// (which picks an angle's turn).
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
            JointMap::Kinematic {
                kinematics,
                joint,
                axes,
            } => {
                let p0 = tool_point(axes, start);
                let p1 = tool_point(axes, end);
                let w = [0, 1, 2].map(|i| (p1[i] - p0[i]) * inv);
                match kinematics.closed_form(joint as usize, p0, w, reference) {
                    Some(c) => Shape::Closed(c),
                    None => {
                        let v0 = map.value(start, reference);
                        // Unwrapped sample by sample to the end.
                        let mut v1 = v0;
                        for i in 1..=SAMPLES {
                            let s = length * i as f64 / SAMPLES as f64;
                            v1 = kinematics
                                .inverse(joint as usize, along(p0, w, s), v1)
                                .unwrap_or(v1);
                        }
                        Shape::Bracketed {
                            kinematics,
                            joint,
                            p0,
                            w,
                            v0,
                            v1,
                        }
                    }
                }
            }
        };
        JointPath { shape, length }
    }

    /// The segment's path length (mm): `s` runs over `0..=length`.
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

    /// Joint value after distance `s` along the segment (NaN off the
    /// kinematics' reach).
    #[inline]
    pub fn value_at(&self, s: f64) -> f64 {
        match self.shape {
            Shape::Linear { a0, k } => a0 + k * s,
            Shape::Closed(ClosedForm::Radius { p0, w }) => {
                let (x, y) = (p0.0 + w.0 * s, p0.1 + w.1 * s);
                sqrt(x * x + y * y)
            }
            Shape::Closed(ClosedForm::Angle { p0, w, theta0 }) => {
                let (x, y) = (p0.0 + w.0 * s, p0.1 + w.1 * s);
                let cross = p0.0 * y - p0.1 * x;
                let dot = p0.0 * x + p0.1 * y;
                if cross == 0.0 && dot <= 0.0 {
                    // At or through the centre: the angle is undefined; hold it.
                    return theta0;
                }
                theta0 + atan2(cross, dot) * DEG
            }
            Shape::Closed(ClosedForm::Carriage(c)) => c.value(s),
            Shape::Bracketed {
                kinematics,
                joint,
                p0,
                w,
                v0,
                v1,
            } => {
                let fraction = if self.length > 0.0 {
                    s / self.length
                } else {
                    0.0
                };
                let reference = v0 + (v1 - v0) * fraction;
                kinematics
                    .inverse(joint as usize, along(p0, w, s), reference)
                    .unwrap_or(f64::NAN)
            }
        }
    }

    /// The first distance after `after` inside the segment where the joint
    /// turns around, if any. Between turns the joint is monotone, so each
    /// step's crossing is unique.
    pub fn next_turn(&self, after: f64) -> Option<f64> {
        match self.shape {
            Shape::Closed(ClosedForm::Radius { p0, w }) => {
                let ww = w.0 * w.0 + w.1 * w.1;
                if ww == 0.0 {
                    return None;
                }
                let s = -(p0.0 * w.0 + p0.1 * w.1) / ww;
                (s > after && s < self.length).then_some(s)
            }
            Shape::Closed(ClosedForm::Carriage(c)) => {
                c.turn().filter(|s| *s > after && *s < self.length)
            }
            Shape::Bracketed { .. } => self.sampled_turn(after),
            _ => None,
        }
    }

    /// A bracketed joint's first extremum after `after`: where successive
    /// samples' differences change sign, refined by golden section. The
    /// rates at both ends count as differences too, so that an extremum
    /// within the first or last sample is not missed.
    fn sampled_turn(&self, after: f64) -> Option<f64> {
        let span = self.length - after;
        if span <= 0.0 {
            return None;
        }
        let h = span / SAMPLES as f64;
        let tiny = h * 1e-4;
        let v = |i: usize| self.value_at(after + h * i as f64);
        let tol = 1e-12 * (1.0 + self.length);
        let refine = |lo: f64, hi: f64, max: bool| {
            let s = self.golden(lo, hi, max);
            (s > after + tol && s < self.length - tol).then_some(s)
        };
        let start_rate = self.value_at(after + tiny) - self.value_at(after);
        let mut prev = v(1) - v(0);
        if start_rate * prev < 0.0 {
            if let Some(s) = refine(after, after + h, start_rate > 0.0) {
                return Some(s);
            }
        }
        let mut last = v(1);
        for i in 2..=SAMPLES {
            let now = v(i);
            let d = now - last;
            if d * prev < 0.0 {
                // An extremum within [s_{i-2}, s_i].
                return refine(after + h * (i - 2) as f64, after + h * i as f64, prev > 0.0);
            }
            if d != 0.0 {
                prev = d;
            }
            last = now;
        }
        let end_rate = self.value_at(self.length) - self.value_at(self.length - tiny);
        if end_rate * prev < 0.0 {
            return refine(self.length - h, self.length, prev > 0.0);
        }
        None
    }

    /// The extremum (a maximum if `max`) of the joint in `[a, b]`.
    fn golden(&self, mut a: f64, mut b: f64, max: bool) -> f64 {
        const R: f64 = 0.618_033_988_749_894_9;
        let f = |s: f64| {
            let v = self.value_at(s);
            if max {
                -v
            } else {
                v
            }
        };
        let mut c = b - R * (b - a);
        let mut d = a + R * (b - a);
        let (mut fc, mut fd) = (f(c), f(d));
        for _ in 0..80 {
            if b - a <= 1e-13 * (1.0 + self.length) {
                break;
            }
            if fc < fd {
                b = d;
                d = c;
                fd = fc;
                c = b - R * (b - a);
                fc = f(c);
            } else {
                a = c;
                c = d;
                fc = fd;
                d = a + R * (b - a);
                fd = f(d);
            }
        }
        0.5 * (a + b)
    }

    /// The largest |d value / d s| over `[s_lo, s_hi]` (joint units per path
    /// unit): exact for closed forms, sampled with slack when bracketed.
    pub fn max_rate(&self, s_lo: f64, s_hi: f64) -> f64 {
        match self.shape {
            Shape::Linear { k, .. } => k.abs(),
            Shape::Closed(ClosedForm::Radius { w, .. }) => sqrt(w.0 * w.0 + w.1 * w.1),
            Shape::Closed(ClosedForm::Angle { p0, w, .. }) => {
                // |dθ/ds| = |p × w| / |p|², largest where |p| is smallest.
                let cross = (p0.0 * w.1 - p0.1 * w.0).abs();
                let m = closest_r2(p0, w, s_lo, s_hi);
                if m <= 0.0 {
                    f64::INFINITY
                } else {
                    cross / m * DEG
                }
            }
            Shape::Bracketed { .. } | Shape::Closed(ClosedForm::Carriage(_)) => {
                self.sampled_rate(s_lo, s_hi)
            }
        }
    }

    /// A bracketed joint's largest rate: the largest secant between samples,
    /// raised by the largest change between neighbouring secants (the rate
    /// can rise that much within a sample), and the rates at both ends.
    fn sampled_rate(&self, s_lo: f64, s_hi: f64) -> f64 {
        let h = (s_hi - s_lo) / SAMPLES as f64;
        if h <= 0.0 {
            return 0.0;
        }
        let tiny = h * 1e-4;
        let end_rate = |s: f64, d: f64| ((self.value_at(s + d) - self.value_at(s)) / d).abs();
        let mut most = end_rate(s_lo, tiny).max(end_rate(s_hi, -tiny));
        let mut rise = 0.0f64;
        let mut last = self.value_at(s_lo);
        let mut last_rate = f64::NAN;
        for i in 1..=SAMPLES {
            let now = self.value_at(s_lo + h * i as f64);
            let rate = ((now - last) / h).abs();
            if rate.is_nan() {
                // Out of reach: no bound.
                return f64::INFINITY;
            }
            most = most.max(rate);
            if last_rate.is_finite() {
                rise = rise.max((rate - last_rate).abs());
            }
            (last, last_rate) = (now, rate);
        }
        if most.is_nan() {
            return f64::INFINITY;
        }
        (most + rise) * SLACK
    }

    /// The largest |d² value / d s²| over `[s_lo, s_hi]`: how hard the joint
    /// must accelerate at constant path speed (an upper bound for the angle;
    /// sampled with slack when bracketed).
    pub fn max_curvature(&self, s_lo: f64, s_hi: f64) -> f64 {
        let (p0, w) = match self.shape {
            Shape::Linear { .. } => return 0.0,
            Shape::Closed(ClosedForm::Radius { p0, w } | ClosedForm::Angle { p0, w, .. }) => {
                (p0, w)
            }
            Shape::Bracketed { .. } | Shape::Closed(ClosedForm::Carriage(_)) => {
                return self.sampled_curvature(s_lo, s_hi)
            }
        };
        let ww = w.0 * w.0 + w.1 * w.1;
        let r = sqrt(closest_r2(p0, w, s_lo, s_hi));
        let cross = (p0.0 * w.1 - p0.1 * w.0).abs();
        if r <= 0.0 {
            return if cross == 0.0 { 0.0 } else { f64::INFINITY };
        }
        match self.shape {
            // r'' = |p × w|² / r³
            Shape::Closed(ClosedForm::Radius { .. }) => cross * cross / (r * r * r),
            // |θ''| = 2 |p × w| |p · w| / r⁴ ≤ 2 |p × w| |w| / r³
            _ => 2.0 * cross * sqrt(ww) / (r * r * r) * DEG,
        }
    }

    fn sampled_curvature(&self, s_lo: f64, s_hi: f64) -> f64 {
        let h = (s_hi - s_lo) / SAMPLES as f64;
        if h <= 0.0 {
            return 0.0;
        }
        let v = |i: usize| self.value_at(s_lo + h * i as f64);
        let (mut a, mut b) = (v(0), v(1));
        let mut most = 0.0f64;
        for i in 2..=SAMPLES {
            let c = v(i);
            let k = ((c - 2.0 * b + a) / (h * h)).abs();
            most = if k.is_nan() {
                f64::INFINITY
            } else {
                most.max(k)
            };
            (a, b) = (b, c);
        }
        most * SLACK
    }

    /// The distance in `[s_lo, s_hi]` at which the joint equals `target`,
    /// given that the joint is monotone there and `target` lies between its
    /// values at the ends: closed form where there is one, else bracketed
    /// to the last bits of the distance.
    pub fn solve(&self, target: f64, s_lo: f64, s_hi: f64) -> f64 {
        let s = match self.shape {
            Shape::Linear { a0, k } => {
                if k == 0.0 {
                    s_lo
                } else {
                    (target - a0) / k
                }
            }
            Shape::Closed(ClosedForm::Radius { p0, w }) => {
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
            Shape::Closed(ClosedForm::Angle { p0, w, theta0 }) => {
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
            Shape::Closed(ClosedForm::Carriage(c)) => c.solve(target, s_lo, s_hi),
            Shape::Bracketed { .. } => self.bracket(target, s_lo, s_hi),
        };
        if s.is_nan() {
            s_lo
        } else {
            s.clamp(s_lo, s_hi)
        }
    }

    /// The crossing of `target` in `[lo, hi]` by regula falsi with the
    /// Illinois modification: superlinear, and never leaves the bracket.
    fn bracket(&self, target: f64, lo: f64, hi: f64) -> f64 {
        let f = |s: f64| self.value_at(s) - target;
        let (mut a, mut b) = (lo, hi);
        let (mut fa, mut fb) = (f(a), f(b));
        if fa == 0.0 {
            return a;
        }
        if fb == 0.0 {
            return b;
        }
        if fa.is_nan() || fb.is_nan() || fa * fb > 0.0 {
            // Not bracketed (the caller's legs make this rare): the nearer end.
            return if fa.abs() <= fb.abs() { a } else { b };
        }
        let tol = 1e-13 * (1.0 + self.length);
        let mut side = 0i8;
        let mut c = 0.5 * (a + b);
        for _ in 0..100 {
            c = (a * fb - b * fa) / (fb - fa);
            if !(c > a.min(b) && c < a.max(b)) {
                c = 0.5 * (a + b);
            }
            let fc = f(c);
            if fc == 0.0 || fc.is_nan() {
                return c;
            }
            if fc * fb > 0.0 {
                b = c;
                fb = fc;
                if side == -1 {
                    fa *= 0.5;
                }
                side = -1;
            } else {
                a = c;
                fa = fc;
                if side == 1 {
                    fb *= 0.5;
                }
                side = 1;
            }
            if (b - a).abs() <= tol {
                break;
            }
        }
        c
    }
}

/// The point `p0 + w·s`.
#[inline]
fn along(p0: Xyz, w: Xyz, s: f64) -> Xyz {
    [p0[0] + w[0] * s, p0[1] + w[1] * s, p0[2] + w[2] * s]
}

/// The smallest |p0 + w·s|² over `[s_lo, s_hi]`.
fn closest_r2(p0: (f64, f64), w: (f64, f64), s_lo: f64, s_hi: f64) -> f64 {
    let ww = w.0 * w.0 + w.1 * w.1;
    let s = if ww > 0.0 {
        (-(p0.0 * w.0 + p0.1 * w.1) / ww).clamp(s_lo, s_hi)
    } else {
        s_lo
    };
    let (x, y) = (p0.0 + w.0 * s, p0.1 + w.1 * s);
    x * x + y * y
}
