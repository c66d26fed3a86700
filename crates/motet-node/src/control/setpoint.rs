//! A servo's set point: its joint's value, speed and acceleration at a
//! tick, from the queued segments, the same trajectory a step channel
//! follows. Between segments and after the last the joint holds where the
//! one before ended.

use heapless::Deque;
use motet_trajectory::{JointMap, JointPath, Point, Segment};

/// The joint at one instant: value (joint units), speed (units/s),
/// acceleration (units/s²).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointState {
    /// Joint units.
    pub value: f64,
    /// Joint units per second.
    pub speed: f64,
    /// Joint units per second².
    pub accel: f64,
}

/// Follows one joint along the queued segments, tick by tick.
#[derive(Clone, Copy, Debug)]
pub struct SetPoint {
    map: JointMap,
    /// Index of the segment followed, from the queue's head: those before
    /// it are done.
    seg: usize,
    /// The followed segment's joint path, once started.
    path: Option<JointPath>,
    /// Where the joint rests before the followed segment (the last one's
    /// end).
    hold: f64,
}

/// Path distance over which a joint that is not affine in it is
/// differenced, mm.
const DIFF_MM: f64 = 1e-3;

impl SetPoint {
    /// A set point at rest at `p`.
    pub fn at_rest(map: JointMap, p: &Point) -> SetPoint {
        let hold = map.value(p, 0.0);
        SetPoint {
            map,
            seg: 0,
            path: None,
            hold: if hold.is_finite() { hold } else { 0.0 },
        }
    }

    /// At rest at `p` (the machine was told where it is).
    pub fn set_position(&mut self, p: &Point) {
        let v = self.map.value(p, self.hold);
        if v.is_finite() {
            self.hold = v;
        }
        self.seg = 0;
        self.path = None;
    }

    /// Where it rests when nothing moves it, joint units.
    pub fn hold(&self) -> f64 {
        self.hold
    }

    /// Segments from the queue's head it is done with.
    pub fn segments_done(&self) -> usize {
        self.seg
    }

    /// The queue dropped `n` segments from its head.
    pub fn drop_segments(&mut self, n: usize) {
        self.seg -= n.min(self.seg);
    }

    /// The joint at host time `t` (µs, never earlier than the last call),
    /// on the first `end` queued segments.
    pub fn state<const Q: usize>(
        &mut self,
        t: f64,
        segments: &Deque<Segment, Q>,
        end: usize,
    ) -> JointState {
        while self.seg < end {
            let Some(s) = segments.get(self.seg) else {
                break;
            };
            if t < s.t0 {
                return rest_at(self.hold);
            }
            let length = s.profile.length();
            if t < s.t1() && length > 0.0 {
                let path = match self.path {
                    Some(p) => p,
                    None => {
                        let p = JointPath::new(&self.map, s, self.hold);
                        self.path = Some(p);
                        p
                    }
                };
                return along(&path, s, t);
            }
            if t < s.t1() {
                // A dwell: standing still where the segment before ended.
                return rest_at(self.hold);
            }
            if length > 0.0 {
                let path = self
                    .path
                    .unwrap_or_else(|| JointPath::new(&self.map, s, self.hold));
                let v = path.value_at(length);
                if v.is_finite() {
                    self.hold = v;
                }
            }
            self.path = None;
            self.seg += 1;
        }
        rest_at(self.hold)
    }
}

fn rest_at(value: f64) -> JointState {
    JointState {
        value,
        ..JointState::default()
    }
}

/// The joint on `path` along `s` at host time `t` (inside the segment).
fn along(path: &JointPath, s: &Segment, t: f64) -> JointState {
    let (d, v, a) = s.profile.state((t - s.t0) * 1e-6);
    let value = path.value_at(d);
    match path.line() {
        Some((_, k)) => JointState {
            value,
            speed: k * v,
            accel: k * a,
        },
        None => {
            // The joint's first and second derivatives in the distance,
            // differenced inside the segment.
            let len = path.length();
            let h = DIFF_MM.min(len * 0.25);
            let c = d.clamp(h, len - h);
            let (lo, mid, hi) = (path.value_at(c - h), path.value_at(c), path.value_at(c + h));
            let d1 = (hi - lo) / (2.0 * h);
            let d2 = (hi - 2.0 * mid + lo) / (h * h);
            JointState {
                value,
                speed: d1 * v,
                accel: d2 * v * v + d1 * a,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motet_trajectory::profile::fastest;

    fn seg(t0: f64, from: f64, to: f64) -> Segment {
        let mut start = [0.0; 6];
        let mut end = [0.0; 6];
        start[0] = from;
        end[0] = to;
        Segment {
            t0,
            start,
            end,
            profile: fastest((to - from).abs(), 0.0, 0.0, 100.0, 1000.0, 0.0),
        }
    }

    #[test]
    fn follows_segments_and_holds_between() {
        let mut q: Deque<Segment, 4> = Deque::new();
        let a = seg(1000.0, 0.0, 30.0);
        // A dwell right after it, then a gap.
        let mut dwell = seg(a.t1(), 30.0, 30.0);
        dwell.profile = motet_trajectory::Profile::dwell(0.002);
        let gap = a.t1() + 5000.0;
        let b = seg(gap, 30.0, 4.0);
        q.push_back(a).unwrap();
        q.push_back(dwell).unwrap();
        q.push_back(b).unwrap();
        let map = JointMap::axis(0);
        let mut sp = SetPoint::at_rest(map, &[0.0; 6]);
        // (time, value, speed, accel)
        let mid = a.t0 + a.duration_us() / 2.0;
        let (dm, vm, _) = a.profile.state(a.duration_us() * 0.5e-6);
        let cases = [
            (0.0, 0.0, 0.0, 0.0),
            (1100.0, 5e-6, 0.1, 1000.0),
            (mid, dm, vm, 0.0),
            (a.t1() + 10.0, 30.0, 0.0, 0.0),
            (a.t1() + 3000.0, 30.0, 0.0, 0.0),
            (gap + 100.0, 30.0 - 5e-6, -0.1, -1000.0),
            (b.t1() + 1.0, 4.0, 0.0, 0.0),
        ];
        for (t, v, s, acc) in cases {
            let st = sp.state(t, &q, 3);
            assert!(
                (st.value - v).abs() < 1e-9
                    && (st.speed - s).abs() < 1e-9
                    && (st.accel - acc).abs() < 1e-6,
                "{t}: {st:?}"
            );
        }
        assert_eq!(sp.segments_done(), 3);
    }

    #[test]
    fn holds_short_of_uncommitted_segments() {
        let mut q: Deque<Segment, 4> = Deque::new();
        q.push_back(seg(0.0, 0.0, 10.0)).unwrap();
        let mut sp = SetPoint::at_rest(JointMap::axis(0), &[0.0; 6]);
        assert_eq!(sp.state(5000.0, &q, 0).value, 0.0);
        assert_eq!(sp.segments_done(), 0);
    }
}
