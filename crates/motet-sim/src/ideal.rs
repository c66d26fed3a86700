//! The ideal trajectory as the observer reads it: the segments sent to the
//! nodes and not yet passed, followed in time at step instants.
//!
//! Steps reach the plant in time order, so the commanded point is followed
//! along the front segment with a cursor that keeps the profile piece it is
//! in, with that piece's polynomial in host microseconds: a step costs one
//! cubic in time, and a joint linear in the axes one multiply-add, instead
//! of a profile evaluated from its start and a joint map applied to a whole
//! point.

use motet_trajectory::{JointMap, Point, Profile, Segment, MAX_AXES, PIECES};
use std::collections::VecDeque;

/// The segments sent to the nodes and not yet in the past, and where the
/// ideal machine is on the front one.
pub struct IdealTrajectory {
    window: VecDeque<Segment>,
    /// Per actuator, its joint's coefficients in steps per axis unit, for a
    /// joint linear in the axes.
    linear: Vec<Option<Point>>,
    /// The axis whose forward motion is extrusion, if any.
    extruder: Option<usize>,
    /// The axes whose path deviation is checked, in order; `checked` of them.
    axes: [usize; MAX_AXES],
    checked: usize,
    /// The front segment as followed; `None` until a step needs it, and
    /// again whenever the front changes.
    front: Option<Followed>,
}

/// The front segment, prepared for evaluation at increasing times.
struct Followed {
    /// The segment's host times, µs.
    t0: f64,
    t1: f64,
    start: Point,
    /// Axis change per unit distance.
    unit: Point,
    length: f64,
    profile: Profile,
    /// Whether the segment moves the extruder forward.
    extruding: bool,
    /// Per actuator, for a linear joint, `(joint at s = 0, joint per unit
    /// distance)`, in steps; NaN for any other joint.
    lines: Vec<(f64, f64)>,
    /// The checked axes' start and change per unit distance, in the order
    /// of [`IdealTrajectory::new`]'s `checked` (plain arrays: the path
    /// check runs once per step).
    c_start: [f64; MAX_AXES],
    c_unit: [f64; MAX_AXES],
    piece: PieceCursor,
}

/// One profile piece as a polynomial of host time.
#[derive(Clone, Copy)]
struct PieceCursor {
    index: usize,
    /// µs after the segment's start where the piece starts and where the
    /// next non-empty one does (infinite for the last): relative, so that a
    /// time late in a long job loses no precision to the piece's offset.
    start: f64,
    next: f64,
    /// Its length in µs.
    duration: f64,
    /// Distance at its start, and speed, half the acceleration and a sixth
    /// of the jerk there, per µs.
    d0: f64,
    v: f64,
    half_a: f64,
    sixth_j: f64,
}

/// Where the ideal machine is at one step instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moment {
    /// Distance along the front segment.
    pub s: f64,
    /// Time into the current profile piece, µs.
    u: f64,
}

impl IdealTrajectory {
    /// For a machine whose actuators follow `maps`, each at `spu` unsigned
    /// steps per joint unit, extruding on axis `extruder`, its path checked
    /// on the axes `checked` (at most [`MAX_AXES`], each below it).
    pub fn new(
        maps: impl IntoIterator<Item = (JointMap, f64)>,
        extruder: Option<usize>,
        checked: &[usize],
    ) -> IdealTrajectory {
        let mut axes = [0; MAX_AXES];
        let mut n = 0;
        for &k in checked.iter().filter(|&&k| k < MAX_AXES).take(MAX_AXES) {
            axes[n] = k;
            n += 1;
        }
        let linear = maps
            .into_iter()
            .map(|(map, spu)| match map {
                JointMap::Linear { coeffs } => Some(coeffs.map(|c| c * spu)),
                _ => None,
            })
            .collect();
        IdealTrajectory {
            window: VecDeque::new(),
            linear,
            extruder,
            axes,
            checked: n,
            front: None,
        }
    }

    /// A segment was sent to the nodes.
    pub fn push(&mut self, seg: Segment) {
        self.window.push_back(seg);
    }

    /// Segments held.
    pub fn len(&self) -> usize {
        self.window.len()
    }

    /// Outputs up to `t` (µs) have all been applied: drops the segments that
    /// ended before it, one kept as the last reference.
    pub fn applied_until(&mut self, t: f64) {
        while self.window.len() > 1 && self.window[0].t1() < t && self.window[1].t0 <= t {
            self.pop();
        }
    }

    fn pop(&mut self) {
        self.window.pop_front();
        self.front = None;
    }

    /// Moves to host time `t` (µs), not earlier than the last call's: drops
    /// the segments passed, and returns where the ideal machine is when the
    /// front segment holds `t` (`None`: no segment does, and the step is
    /// not checked).
    #[inline]
    pub fn at(&mut self, t: f64) -> Option<Moment> {
        // The common case: still inside the segment followed, where nothing
        // is passed (a segment is passed only once `t` is beyond its end).
        if let Some(f) = self.front.as_mut() {
            if f.t0 <= t && t <= f.t1 {
                return Some(f.moment(t));
            }
        }
        self.at_slow(t)
    }

    #[inline(never)]
    fn at_slow(&mut self, t: f64) -> Option<Moment> {
        while self.window.len() > 1 && self.window[0].t1() < t {
            self.pop();
        }
        if self.front.is_none() {
            let seg = self.window.front()?;
            self.front = Some(Followed::new(
                seg,
                &self.linear,
                self.extruder,
                &self.axes[..self.checked],
            ));
        }
        let f = self.front.as_mut()?;
        if !(f.t0 <= t && t <= f.t1) {
            return None;
        }
        Some(f.moment(t))
    }

    /// The commanded point at `i`.
    pub fn point(&self, i: Moment) -> Point {
        match &self.front {
            Some(f) => core::array::from_fn(|k| f.start[k] + f.unit[k] * i.s),
            None => [0.0; MAX_AXES],
        }
    }

    /// Squared distance from `p` to the commanded point at `i`, over the
    /// checked axes.
    #[inline]
    pub fn distance2(&self, i: Moment, p: &Point) -> f64 {
        let Some(f) = &self.front else {
            return 0.0;
        };
        let n = self.checked.min(MAX_AXES);
        let mut d2 = 0.0;
        for ((&k, &a), &w) in self.axes[..n]
            .iter()
            .zip(&f.c_start[..n])
            .zip(&f.c_unit[..n])
        {
            let d = p[k] - (a + w * i.s);
            d2 += d * d;
        }
        d2
    }

    /// Actuator `a`'s ideal joint value in steps at `i`, when its joint is
    /// linear in the axes.
    #[inline]
    pub fn joint_steps(&self, a: usize, i: Moment) -> Option<f64> {
        let (q0, k) = *self.front.as_ref()?.lines.get(a)?;
        let v = q0 + k * i.s;
        (!v.is_nan()).then_some(v)
    }

    /// Actuator `a`'s ideal joint speed in steps per µs at `i`, when its
    /// joint is linear in the axes: `i` must be the last moment asked for.
    #[inline]
    pub fn joint_rate(&self, a: usize, i: Moment) -> Option<f64> {
        let f = self.front.as_ref()?;
        let (q0, k) = *f.lines.get(a)?;
        if q0.is_nan() {
            return None;
        }
        let p = &f.piece;
        Some(k * (p.v + i.u * (2.0 * p.half_a + 3.0 * i.u * p.sixth_j)))
    }

    /// The path's acceleration at `i`, units/s² (`i` the last moment).
    pub fn accel_at(&self, i: Moment) -> f64 {
        let Some(f) = self.front.as_ref() else {
            return 0.0;
        };
        let p = &f.piece;
        // Per µs² to per s².
        (2.0 * p.half_a + 6.0 * i.u * p.sixth_j) * 1e12
    }

    /// The path's speed at `i`, units/s (`i` the last moment).
    pub fn speed_at(&self, i: Moment) -> f64 {
        let Some(f) = self.front.as_ref() else {
            return 0.0;
        };
        let p = &f.piece;
        (p.v + i.u * (2.0 * p.half_a + 3.0 * i.u * p.sixth_j)) * 1e6
    }

    /// Where the ideal machine rests at `t` when no held segment holds it:
    /// the end of the last one before `t`, or the start of the first after.
    pub fn rest_point(&self, t: f64) -> Option<Point> {
        let mut at = None;
        for s in self.window.iter() {
            if s.t0 > t {
                return Some(at.unwrap_or(s.start));
            }
            at = Some(s.end);
        }
        at
    }

    /// Whether the front segment extrudes.
    #[inline]
    pub fn extruding(&self) -> bool {
        match (&self.front, self.extruder) {
            (Some(f), _) => f.extruding,
            (None, Some(e)) => self
                .window
                .front()
                .is_some_and(|seg| seg.end[e] > seg.start[e]),
            (None, None) => false,
        }
    }

    /// The ideal point at any held time, searched from scratch (`None`
    /// outside every held segment): for the rare check that needs a
    /// neighbourhood of a step.
    pub fn point_anywhere(&self, t: f64) -> Option<Point> {
        self.window
            .iter()
            .find(|s| s.t0 <= t && t <= s.t1())
            .map(|s| s.position_at(t))
    }
}

impl Followed {
    fn new(
        seg: &Segment,
        linear: &[Option<Point>],
        extruder: Option<usize>,
        checked: &[usize],
    ) -> Followed {
        let length = seg.profile.length();
        let mut unit = [0.0; MAX_AXES];
        if length > 0.0 {
            for (k, u) in unit.iter_mut().enumerate() {
                *u = (seg.end[k] - seg.start[k]) / length;
            }
        }
        let lines = linear
            .iter()
            .map(|c| match c {
                Some(c) => {
                    let (mut q0, mut k) = (0.0, 0.0);
                    for i in 0..MAX_AXES {
                        q0 += c[i] * seg.start[i];
                        k += c[i] * unit[i];
                    }
                    (q0, k)
                }
                None => (f64::NAN, f64::NAN),
            })
            .collect();
        let (mut c_start, mut c_unit) = ([0.0; MAX_AXES], [0.0; MAX_AXES]);
        for (j, &k) in checked.iter().enumerate().take(MAX_AXES) {
            c_start[j] = seg.start[k];
            c_unit[j] = unit[k];
        }
        let mut f = Followed {
            t0: seg.t0,
            t1: seg.t1(),
            start: seg.start,
            unit,
            length,
            profile: seg.profile,
            extruding: extruder.is_some_and(|e| seg.end[e] > seg.start[e]),
            lines,
            c_start,
            c_unit,
            piece: PieceCursor::enter(&seg.profile, 0),
        };
        if length <= 0.0 {
            f.piece.duration = 0.0;
        }
        f
    }

    /// Where the segment is at host time `t` (µs), `t` within it and not
    /// earlier than the last call's.
    #[inline(always)]
    fn moment(&mut self, t: f64) -> Moment {
        let t = t - self.t0;
        while t > self.piece.next {
            self.piece = PieceCursor::enter(&self.profile, self.piece.index + 1);
        }
        let p = &self.piece;
        let u = t - p.start;
        // Plain comparisons: this runs once per step.
        let u = if u < 0.0 {
            0.0
        } else if u > p.duration {
            p.duration
        } else {
            u
        };
        let s = p.d0 + u * (p.v + u * (p.half_a + u * p.sixth_j));
        Moment {
            s: if s < self.length { s } else { self.length },
            u,
        }
    }
}

impl PieceCursor {
    /// The first non-empty piece of `profile` from `from` on (the last piece
    /// if none is).
    fn enter(profile: &Profile, from: usize) -> PieceCursor {
        let mut i = from.min(PIECES - 1);
        while profile.piece_duration(i) <= 0.0 && i + 1 < PIECES {
            i += 1;
        }
        let mut k = i + 1;
        while k < PIECES && profile.piece_duration(k) <= 0.0 {
            k += 1;
        }
        let next = if k < PIECES {
            profile.piece(k).t0 * 1e6
        } else {
            f64::INFINITY
        };
        let p = profile.piece(i);
        PieceCursor {
            index: i,
            start: p.t0 * 1e6,
            next,
            duration: p.duration.max(0.0) * 1e6,
            d0: p.d0,
            v: p.v * 1e-6,
            half_a: 0.5 * p.a * 1e-12,
            sixth_j: p.j / 6.0 * 1e-18,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motet_trajectory::profile::fastest;

    /// The cursor agrees with the segment's own evaluation from scratch at
    /// increasing times through every piece, for trapezoid and S-curve
    /// profiles, and the linear joint with the joint map.
    #[test]
    fn follows_the_segment_as_evaluated_from_scratch() {
        let cases = [
            // (length, v0, v1, vmax, accel, jerk)
            (10.0, 0.0, 0.0, 100.0, 1000.0, 0.0),
            (10.0, 20.0, 5.0, 100.0, 1000.0, 0.0),
            (0.05, 0.0, 0.0, 100.0, 1000.0, 0.0),
            (10.0, 0.0, 0.0, 100.0, 1000.0, 50_000.0),
            (3.0, 10.0, 30.0, 200.0, 3000.0, 100_000.0),
        ];
        for (length, v0, v1, vmax, accel, jerk) in cases {
            let profile = fastest(length, v0, v1, vmax, accel, jerk);
            let start = [1.0, 2.0, 0.3, 5.0, 0.0, 0.0];
            let dir = [0.6, -0.8, 0.0, 0.0, 0.0, 0.0];
            let end = core::array::from_fn(|k| start[k] + dir[k] * length);
            let seg = Segment {
                t0: 1234.5,
                start,
                end,
                profile,
            };
            let map = JointMap::Linear {
                coeffs: [1.0, 1.0, 0.0, 0.0, 0.0, 0.0],
            };
            let spu = 80.0;
            let mut ideal = IdealTrajectory::new([(map, spu)], None, &[0, 1, 2]);
            ideal.push(seg);
            let n = 2000;
            for k in 0..=n {
                let t = seg.t0 + (seg.t1() - seg.t0) * k as f64 / n as f64;
                let i = ideal.at(t).expect("inside the segment");
                let want = seg.position_at(t);
                let got = ideal.point(i);
                for a in 0..3 {
                    assert!(
                        (got[a] - want[a]).abs() <= 1e-9 * (1.0 + want[a].abs()),
                        "length {length} jerk {jerk}: t={t} axis {a}: {} against {}",
                        got[a],
                        want[a]
                    );
                }
                let joint = ideal.joint_steps(0, i).expect("a linear joint");
                let want_joint = map.value(&want, 0.0) * spu;
                assert!((joint - want_joint).abs() <= 1e-6, "t={t}");
            }
            assert_eq!(ideal.at(seg.t1() + 1.0), None);
        }
    }
}
