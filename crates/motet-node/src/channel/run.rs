//! A run: the stretch of a channel's steps that lies in one line leg of a
//! segment and one piece of its speed profile, where every step's time is
//! one closed form of the step's index.
//!
//! On a joint affine in the path distance, the `k`-th half-step boundary
//! after the run's first is crossed at distance `x₀ + k·dx` into the piece,
//! and the piece's inverse turns that into time: a multiplication on a
//! cruise, a square root and a division under constant acceleration. The
//! run is set up once (how many steps it holds, its constants) by the
//! channel's long way, which also solves its first step; after that a step
//! costs its own arithmetic and nothing else: no boundary, leg or piece
//! checks, and each step's time independent of the last, so the
//! processor overlaps their roots and divisions. In fixed-point time (a
//! board without an FPU, `Channel::use_fixed_time`) the same run gives its
//! steps through chunks instead (`chunk.rs`): exact anchors, integers
//! between.

use super::chunk::{Chunk, ChunkBound};
use crate::time::{fine_to_us, us_to_fine};
use motet_trajectory::{PieceForm, PieceInverse};

/// Most steps solved ahead of the one being taken.
pub const AHEAD: usize = 32;

/// Steps solved and not yet taken, all in one direction: only their
/// times are kept per step; where each lies on the path (which only a
/// retime needs) follows from the run they came from.
#[derive(Clone, Debug)]
pub(super) struct Ahead {
    /// Host times, µs, in `head..len`.
    pub times: [f64; AHEAD],
    pub head: usize,
    pub len: usize,
    /// In the joint's positive direction.
    pub positive: bool,
    /// The driver's direction line for them (`positive`, inverted for an
    /// actuator with negative steps per unit).
    pub forward: bool,
    /// Where step 0 lies when the long way found it (`from_run` 1), and
    /// the run index of the first step the run gave (`first_k`).
    pub first: f64,
    pub first_k: f64,
    pub from_run: usize,
}

impl Ahead {
    pub const EMPTY: Ahead = Ahead {
        times: [0.0; AHEAD],
        head: 0,
        len: 0,
        positive: true,
        forward: true,
        first: 0.0,
        first_k: 0.0,
        from_run: 0,
    };

    /// The next step's time, infinite when none is solved.
    #[inline(always)]
    pub fn next_time(&self) -> f64 {
        if self.head < self.len {
            self.times[self.head]
        } else {
            f64::INFINITY
        }
    }

    /// Steps taken from these, signed as the joint's direction.
    #[inline(always)]
    pub fn taken(&self) -> i64 {
        if self.positive {
            self.head as i64
        } else {
            -(self.head as i64)
        }
    }

    /// Just one step, found the long way at distance `s`.
    pub fn one(&mut self, time: f64, s: f64, positive: bool, invert: bool) {
        self.times[0] = time;
        self.head = 0;
        self.len = 1;
        self.positive = positive;
        self.forward = positive != invert;
        self.first = s;
        self.from_run = 1;
    }

    /// Where step `i` lies in the segment, for steps `run` gave.
    pub fn dist(&self, i: usize, run: &Run) -> f64 {
        if i < self.from_run {
            self.first
        } else {
            run.dist(self.first_k + (i - self.from_run) as f64)
        }
    }
}

/// How a run's piece turns distance into time, in µs.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Form {
    /// `u = x · us_per_unit`
    Cruise { us_per_unit: f64 },
    /// `u = x · 2e6 / (v + √(vv + two_a·x))`
    Quadratic { v: f64, vv: f64, two_a: f64 },
}

/// The steps of a run not yet solved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Run {
    /// Steps left (0: no run).
    left: u32,
    /// Index of the next step from the run's first (0, found the long way).
    k: f64,
    /// Distance into the piece of step `k`: `x0 + k·dx`.
    x0: f64,
    dx: f64,
    /// The piece's start distance in the segment, and the distance it covers.
    d0: f64,
    span: f64,
    /// Host time of the piece's start, µs, and its length in µs.
    t_start: f64,
    duration_us: f64,
    form: Form,
    /// The error a step's time may have, µs: 0 for every step solved in
    /// `f64`; above 0 for fixed-point time, the steps between exact anchors
    /// interpolated in integers (`chunk.rs`), and `k` then the index of
    /// the chunk's first step.
    tolerance: f64,
    chunk: Chunk,
    /// How long a chunk may be (constant acceleration).
    bound: ChunkBound,
    /// The fine time of the step after the chunk (its last anchor), the
    /// next chunk's first (`u64::MAX`: none), its time's rate per step,
    /// superfine, and the speed squared there.
    next_base: u64,
    next_rate: i64,
    next_w2: f64,
}

/// Where a run starts: the step the long way just solved.
pub(super) struct RunStart {
    /// The joint at `s = 0`, in steps, and the distance per step (signed as
    /// the joint's rate): the leg's line.
    pub a0: f64,
    pub per_step: f64,
    /// The half-step boundary of the step just solved, and the direction
    /// (±1) the run goes.
    pub boundary: f64,
    pub dir: f64,
    /// The joint in steps where the leg ends (no boundary at or beyond it
    /// belongs to the leg).
    pub at_hi: f64,
    /// The host time the segment starts, µs.
    pub seg_t0: f64,
    /// Fixed-point time's tolerance, µs (0: exact).
    pub tolerance: f64,
}

impl Run {
    pub const NONE: Run = Run {
        left: 0,
        k: 0.0,
        x0: 0.0,
        dx: 0.0,
        d0: 0.0,
        span: 0.0,
        t_start: 0.0,
        duration_us: 0.0,
        form: Form::Cruise { us_per_unit: 0.0 },
        tolerance: 0.0,
        chunk: Chunk::NONE,
        bound: ChunkBound::NONE,
        next_base: u64::MAX,
        next_rate: 0,
        next_w2: 0.0,
    };

    /// Whether steps are left to solve.
    #[inline(always)]
    pub fn is_live(&self) -> bool {
        self.left > 0
    }

    /// The run after the step at `from.boundary`, in the piece `piece` (the
    /// one that step was solved in): every later boundary of the leg that
    /// lies in the piece. [`Run::NONE`] where the piece has no closed form.
    pub fn after(from: &RunStart, piece: &PieceInverse) -> Run {
        let form = match piece.form {
            PieceForm::Cruise { per_unit } => Form::Cruise {
                us_per_unit: per_unit * 1e6,
            },
            PieceForm::Quadratic { v, vv, two_a } => Form::Quadratic { v, vv, two_a },
            PieceForm::Other => return Run::NONE,
        };
        let dx = from.dir * from.per_step;
        if !(dx > 0.0 && dx.is_finite()) {
            return Run::NONE;
        }
        let x0 = (from.boundary - from.a0) * from.per_step - piece.d0;
        let in_leg = steps_before(from.boundary, from.dir, from.at_hi);
        let in_piece = steps_within(x0, dx, piece.d_end - piece.d0);
        let left = in_leg.min(in_piece);
        if left == 0 {
            return Run::NONE;
        }
        Run {
            left,
            k: 1.0,
            x0,
            dx,
            d0: piece.d0,
            span: piece.span,
            t_start: from.seg_t0 + piece.t0 * 1e6,
            duration_us: piece.duration * 1e6,
            form,
            tolerance: from.tolerance,
            chunk: Chunk::NONE,
            bound: match form {
                Form::Quadratic { two_a, .. } if from.tolerance > 0.0 => {
                    ChunkBound::new(0.5 * two_a, dx, from.tolerance)
                }
                _ => ChunkBound::NONE,
            },
            next_base: u64::MAX,
            next_rate: 0,
            next_w2: 0.0,
        }
    }

    /// Where step `k` of the run lies in the segment.
    pub fn dist(&self, k: f64) -> f64 {
        self.d0 + (self.x0 + k * self.dx)
    }

    /// The index of the next step to solve.
    fn next_k(&self) -> f64 {
        if self.tolerance > 0.0 {
            self.k + self.chunk.taken() as f64
        } else {
            self.k
        }
    }

    /// Where the last step solved lies in the segment.
    pub fn last_dist(&self) -> f64 {
        self.dist(self.next_k() - 1.0)
    }

    /// The time into the piece of step `k`'s crossing at `x`, µs, before
    /// the piece's bounds: the form's closed form.
    #[inline(always)]
    fn u_of(&self, x: f64) -> f64 {
        match self.form {
            Form::Cruise { us_per_unit } => x * us_per_unit,
            Form::Quadratic { v, vv, two_a } => accelerating_us(v, x, speed(vv, two_a, x)),
        }
    }

    /// Step `k`'s fine time, exactly, and (under constant acceleration)
    /// its time's rate per step, superfine (`dx / w`; negative where the
    /// speed is 0: no rate to interpolate with), and the speed squared
    /// there: one square root for all three.
    fn anchor(&self, k: f64) -> (u64, i64, f64) {
        let Form::Quadratic { v, vv, two_a } = self.form else {
            return (us_to_fine(self.time_at(k)), 0, 0.0);
        };
        let x = self.x0 + k * self.dx;
        let w2 = vv + two_a * x;
        let w = speed(vv, two_a, x);
        // As `time_at` (the same operations, the same bits).
        let t = us_to_fine(self.piece_time(x, accelerating_us(v, x, w)));
        if w > 0.0 {
            // µs a step, in 2⁻³² µs.
            let rate = self.dx * 1e6 * 4_294_967_296.0 / w;
            if rate < 9.0e18 {
                return (t, rate as i64, w2);
            }
        }
        (t, -1, w2)
    }

    /// Step `k`'s host time, µs, exactly as the `f64` fill solves it.
    fn time_at(&self, k: f64) -> f64 {
        let x = self.x0 + k * self.dx;
        self.piece_time(x, self.u_of(x))
    }

    /// The host time, µs, of the crossing `x` units into the piece that
    /// its closed form puts `u` µs in, within the piece's bounds.
    #[inline(always)]
    fn piece_time(&self, x: f64, u: f64) -> f64 {
        within_piece::<true>(x, u, self.span, self.duration_us, self.t_start)
    }

    /// Solves the next steps into `ahead` from place `at` on (the places
    /// before it solved already), none earlier than `last` (µs, the step
    /// before) or than the one before it; returns the time of the last one
    /// solved. The form is picked once for the batch.
    #[inline(always)]
    pub fn fill(&mut self, ahead: &mut Ahead, at: usize, last: f64) -> f64 {
        let n = (self.left as usize).min(AHEAD - at);
        ahead.first_k = self.next_k();
        ahead.from_run = at;
        let times = &mut ahead.times[at..at + n];
        let last = if self.tolerance > 0.0 {
            self.fill_fixed(times, last)
        } else {
            self.fill_exact(times, last)
        };
        self.left -= n as u32;
        ahead.head = 0;
        ahead.len = at + n;
        last
    }

    /// The steps in `f64`, each solved in closed form.
    #[inline(always)]
    fn fill_exact(&mut self, times: &mut [f64], last: f64) -> f64 {
        match self.form {
            // A cruise's time is affine in the distance and reaches the
            // piece's end exactly at its span: only the duration bounds it,
            // so its loop skips the span's check (a few instructions a
            // step).
            Form::Cruise { us_per_unit } => {
                self.fill_with::<false>(times, last, |x| x * us_per_unit)
            }
            Form::Quadratic { v, vv, two_a } => {
                self.fill_with::<true>(times, last, |x| accelerating_us(v, x, speed(vv, two_a, x)))
            }
        }
    }

    /// The steps in fixed-point time: chunks between exact anchors, each
    /// step an integer recurrence and an integer-built `f64` (no
    /// floating-point instruction per step; see `chunk.rs`).
    fn fill_fixed(&mut self, times: &mut [f64], last: f64) -> f64 {
        let mut last_fine = us_to_fine(last);
        let mut remaining = self.left;
        for t in times.iter_mut() {
            if self.chunk.is_done() {
                self.next_chunk(remaining);
            }
            let fine = self.chunk.step();
            last_fine = if fine > last_fine { fine } else { last_fine };
            *t = fine_to_us(last_fine);
            remaining -= 1;
        }
        fine_to_us(last_fine)
    }

    /// Starts the chunk after the one done, `remaining` steps being left
    /// in the run: as long as the interpolation stays within the
    /// tolerance, its ends exact, its first the last one's end.
    #[cold]
    fn next_chunk(&mut self, remaining: u32) {
        self.k += self.chunk.len() as f64;
        let k = self.k;
        let (t0, s0, w2) = if self.next_base != u64::MAX {
            (self.next_base, self.next_rate, self.next_w2)
        } else {
            self.anchor(k)
        };
        self.next_base = u64::MAX;
        // The chunk's end anchor is a step of the run too.
        let most = remaining.saturating_sub(1);
        match self.form {
            Form::Cruise { .. } => {
                let n = most.min(Chunk::CRUISE_MOST);
                if n == 0 {
                    self.chunk = Chunk::one(t0);
                    return;
                }
                let (tn, _, _) = self.anchor(k + n as f64);
                self.chunk = Chunk::line(t0, tn, n);
                self.next_base = tn;
            }
            Form::Quadratic { vv, two_a, .. } => {
                let mut n = self.bound.steps(w2).min(Chunk::CUBIC_MOST).min(most);
                if two_a < 0.0 {
                    // Slowing: the chunk's slowest speed is at its end.
                    for _ in 0..4 {
                        if n < 2 {
                            break;
                        }
                        let end = vv + two_a * (self.x0 + (k + n as f64) * self.dx);
                        let shorter = self.bound.steps(end);
                        if shorter >= n {
                            break;
                        }
                        n = shorter;
                    }
                }
                if n >= 2 && s0 >= 0 {
                    let (tn, s1, w2n) = self.anchor(k + n as f64);
                    if s1 >= 0 {
                        self.chunk = Chunk::cubic(t0, tn, s0, s1, n);
                        self.next_base = tn;
                        self.next_rate = s1;
                        self.next_w2 = w2n;
                        return;
                    }
                }
                self.chunk = Chunk::one(t0);
            }
        }
    }

    /// The loop of [`Run::fill_exact`] for a closed form `u_of`, the
    /// span checked or not (`SPAN`).
    #[inline(always)]
    fn fill_with<const SPAN: bool>(
        &mut self,
        times: &mut [f64],
        mut last: f64,
        u_of: impl Fn(f64) -> f64,
    ) -> f64 {
        let (x0, dx, span, dur, t_start) =
            (self.x0, self.dx, self.span, self.duration_us, self.t_start);
        let mut k = self.k;
        for t in times.iter_mut() {
            let x = x0 + k * dx;
            let time = within_piece::<SPAN>(x, u_of(x), span, dur, t_start);
            // Never earlier than the step before, whatever the rounding.
            last = if time > last { time } else { last };
            *t = last;
            k += 1.0;
        }
        self.k = k;
        last
    }
}

/// `t_start + u`, bounded to the piece: at or past its span `x`, its end
/// exactly (near a stop the distance is flat in time and a solve lands
/// anywhere on it; checked only if `SPAN`), and never past its duration.
/// Plain comparisons: this runs once per step.
#[inline(always)]
fn within_piece<const SPAN: bool>(
    x: f64,
    u: f64,
    span: f64,
    duration_us: f64,
    t_start: f64,
) -> f64 {
    let u = if !SPAN || x < span { u } else { duration_us };
    t_start + if u < duration_us { u } else { duration_us }
}

/// The speed `x` units into a constant-acceleration piece: `√(vv +
/// two_a·x)` (0 where rounding would make it imaginary).
#[inline(always)]
fn speed(vv: f64, two_a: f64, x: f64) -> f64 {
    let disc = vv + two_a * x;
    motet_trajectory::sqrt(if disc > 0.0 { disc } else { 0.0 })
}

/// µs into a constant-acceleration piece from speed `v` to `x` units on,
/// where the speed is `w`: `2x / (v + w)`, without cancellation whatever
/// the acceleration's sign.
#[inline(always)]
fn accelerating_us(v: f64, x: f64, w: f64) -> f64 {
    let denom = v + w;
    // Only at a stop (v and w both 0) is the denominator 0; the piece's
    // end is then the time.
    if denom > 0.0 {
        x * 2e6 / denom
    } else {
        f64::INFINITY
    }
}

/// How many boundaries after `boundary`, one step apart in direction `dir`
/// (±1), lie strictly before `at_hi` (in steps): `k ≥ 1` with
/// `dir·(at_hi − (boundary + k·dir)) > 0`, exactly as a step-by-step walk
/// finds them (the boundaries are half-integers, exact in an f64).
fn steps_before(boundary: f64, dir: f64, at_hi: f64) -> u32 {
    let inside = |k: f64| (at_hi - (boundary + k * dir)) * dir > 0.0;
    let room = (at_hi - boundary) * dir;
    if room.is_nan() || room <= 1.0 {
        return 0;
    }
    // `room` is off by a rounding at most: the first k outside is its
    // ceiling, give or take one.
    // (A float-to-integer conversion truncates, and saturates: `room` is
    // above 1 here.)
    let mut k = ((room as u64) + 1).min(u32::MAX as u64 - 1) as f64;
    while k > 1.0 && !inside(k - 1.0) {
        k -= 1.0;
    }
    while inside(k) && k < u32::MAX as f64 - 1.0 {
        k += 1.0;
    }
    (k - 1.0) as u32
}

/// How many `k ≥ 1` have `x0 + k·dx ≤ limit` (as evaluated; `dx > 0`).
fn steps_within(x0: f64, dx: f64, limit: f64) -> u32 {
    let inside = |k: f64| x0 + k * dx <= limit;
    if !inside(1.0) {
        return 0;
    }
    if limit == f64::INFINITY {
        return u32::MAX - 1;
    }
    // Truncation (saturating, NaN to 0), then put right below.
    let est = ((limit - x0) / dx) as u64;
    let mut k = est.clamp(1, u32::MAX as u64 - 1) as f64;
    while k > 1.0 && !inside(k) {
        k -= 1.0;
    }
    while k < u32::MAX as f64 - 1.0 && inside(k + 1.0) {
        k += 1.0;
    }
    k as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The counts agree with walking the boundaries one by one, near
    /// integers and half-integers and far from zero.
    #[test]
    fn counts_match_a_walk() {
        for &(b, dir, hi) in &[
            (0.5, 1.0, 10.0),
            (0.5, 1.0, 10.5),
            (0.5, 1.0, 10.500000001),
            (0.5, 1.0, 1.5),
            (0.5, 1.0, 1.4),
            (-3.5, -1.0, -20.25),
            (1e9 + 0.5, 1.0, 1e9 + 77.5),
            (1e9 + 0.5, 1.0, 1e9 + 77.49999),
            (2.5, -1.0, 3.0),
        ] {
            let mut walk = 0;
            let mut k = 1.0;
            while (hi - (b + k * dir)) * dir > 0.0 {
                walk += 1;
                k += 1.0;
            }
            assert_eq!(steps_before(b, dir, hi), walk, "{b} {dir} {hi}");
        }
        for &(x0, dx, limit) in &[
            (0.0, 0.1, 1.0),
            (0.05, 0.0125, 20.0),
            (0.3, 0.1, 0.3),
            (0.3, 0.1, 0.35),
            (1e-9, 1.0 / 640.0, 37.5),
        ] {
            let mut walk = 0;
            let mut k = 1.0;
            while x0 + k * dx <= limit {
                walk += 1;
                k += 1.0;
            }
            assert_eq!(steps_within(x0, dx, limit), walk, "{x0} {dx} {limit}");
        }
    }
}
