//! Host side: planned segments into segments a batch carries exactly.

use super::{index, StreamConfig};
use motet_trajectory::point::distance_masked;
use motet_trajectory::profile::{fastest, reachable_speed};
use motet_trajectory::{Point, Profile, Segment};

/// Turns the planner's segments into the nearest segments a batch carries
/// exactly, one machine-wide sequence: ends on the position grid, the length
/// the node derives, speeds and accelerations rounded down to their quanta
/// (exits also down to what the entry can reach), each segment starting
/// when and as fast as the previous one ended. Quantized durations differ a
/// little from planned ones; [`Quantizer::time`] moves other planned times
/// (tool events) by the difference so far.
#[derive(Clone, Debug)]
pub struct Quantizer {
    cfg: StreamConfig,
    prev: Option<Segment>,
    tail: Point,
    /// End of the previous planned segment, µs.
    planned_t1: f64,
    /// Quantized minus planned time at `planned_t1`.
    offset: f64,
}

impl Quantizer {
    /// A stream at rest at `start`.
    pub fn new(cfg: StreamConfig, start: Point) -> Quantizer {
        Quantizer {
            cfg,
            prev: None,
            tail: start,
            planned_t1: f64::NAN,
            offset: 0.0,
        }
    }

    /// The quanta segments are rounded to.
    pub fn config(&self) -> &StreamConfig {
        &self.cfg
    }

    /// A planned time after the segments quantized so far, on the quantized
    /// timeline.
    pub fn time(&self, t: f64) -> f64 {
        match &self.prev {
            Some(p) if t == self.planned_t1 => p.t1(),
            _ => t + self.offset,
        }
    }

    /// The segment to send and record for the planned segment `s`.
    pub fn segment(&mut self, s: &Segment) -> Segment {
        let c = self.cfg;
        let p = s.profile.params();
        let prev = self.prev.as_ref().map(|x| (x.t1(), x.profile.params()));
        let contiguous = prev.is_some() && s.t0 == self.planned_t1;
        let t0 = match prev {
            Some((t1, _)) if contiguous => t1,
            Some((t1, _)) => (s.t0 + self.offset).max(t1),
            None => s.t0 + self.offset,
        };
        let seg = if p.length == 0.0 {
            Segment {
                t0,
                start: self.tail,
                end: self.tail,
                profile: Profile::dwell(p.dwell),
            }
        } else {
            let mut end = self.tail;
            for (i, e) in end.iter_mut().enumerate() {
                let (from, to) = (index(self.tail[i], c.quantum), index(s.end[i], c.quantum));
                if let (Some(from), Some(to)) = (from, to) {
                    if from != to {
                        *e = to as f64 * c.quantum;
                    }
                }
            }
            let length = match c.derived_length(&self.tail, &end) {
                Some(l) => l,
                // Riding axes only, or a move shorter than a quantum.
                None => {
                    let d = distance_masked(&self.tail, &end, 0xff);
                    let n = libm::round(d.max(p.length) / c.quantum).max(1.0);
                    n * c.quantum
                }
            };
            let v0 = match prev {
                Some((_, pp)) if contiguous => pp.v1,
                _ => floor(p.v0, c.speed_quantum),
            };
            let cruise = p.v0 == p.vc && p.vc == p.v1;
            let (accel, jerk) = match prev {
                // Without a ramp the limits do not matter: keep the previous
                // ones, which costs no bytes.
                Some((_, pp)) if cruise && pp.accel > 0.0 => (pp.accel, pp.jerk),
                _ => (
                    floor(p.accel, c.accel_quantum).max(c.accel_quantum),
                    floor(p.jerk, c.accel_quantum),
                ),
            };
            let (v1, vc) = speeds(&c, length, v0, p.v0, p.vc, p.v1, accel, jerk);
            Segment {
                t0,
                start: self.tail,
                end,
                profile: Profile::new(length, v0, vc, v1, accel, jerk),
            }
        };
        self.tail = seg.end;
        self.planned_t1 = s.t1();
        self.offset = seg.t1() - self.planned_t1;
        self.prev = Some(seg);
        seg
    }
}

/// Exit and cruise speeds on the speed grid for a segment entered at `v0`
/// (already on the grid, never above the planned `pv0`), at most the planned
/// `pvc`, `pv1`, the exit reachable from `v0` within `length`. Slowing down
/// may need a hair more than `length` (the exit rounded down, the length a
/// fraction of a quantum shorter than planned): the profile then reaches the
/// segment's end that much early and waits there, a lag far below a step,
/// where raising the exit instead would carry the excess on to the next
/// segment and, at the end of a move, past the point of rest. A jerk-limited
/// ramp's length grows with the square root of its speed change, so there a
/// change rounded up by a speed quantum can cost up to `2 v √(quantum / jerk)`
/// (below 0.1 mm at 300 mm/s with the default 1e-3 mm/s and 6·10⁴ mm/s³:
/// choose a finer speed quantum for S-curve machines).
#[allow(clippy::too_many_arguments)]
fn speeds(
    c: &StreamConfig,
    length: f64,
    v0: f64,
    pv0: f64,
    pvc: f64,
    pv1: f64,
    accel: f64,
    jerk: f64,
) -> (f64, f64) {
    let sq = c.speed_quantum;
    let mut v1 = if pv1 == pv0 { v0 } else { floor(pv1, sq) };
    let up = reachable_speed(v0, length, accel, jerk);
    if v1 > up {
        v1 = floor(up, sq);
    }
    let vc = if pvc == pv0 {
        v0
    } else if pvc == pv1 {
        v1
    } else {
        floor(fastest(length, v0, v1, pvc, accel, jerk).vc(), sq)
    };
    let mut vc = vc.max(v0).max(v1);
    if vc <= 0.0 {
        // A crawl below the speed quantum would never arrive.
        vc = sq;
    }
    (v1, vc)
}

fn floor(v: f64, q: f64) -> f64 {
    libm::floor(v / q).max(0.0) * q
}
