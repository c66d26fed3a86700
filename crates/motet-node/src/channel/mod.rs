//! A channel: one actuator's step output driven by the trajectory.
//!
//! The channel follows its joint along the queued segments and steps whenever
//! the joint, in steps, crosses a half-step boundary, so the executed position
//! never differs from the commanded one by more than half a step. The time of
//! each crossing is solved in closed form from the segment's geometry and speed
//! profile, so steps are placed exactly inside a frame, not rounded to it.
//!
//! Two ways to a step:
//! * **the long way** (`Channel::find_step`) starts segments and legs (the
//!   stretches over which the joint is monotone), and solves any joint shape
//!   in any profile piece, one step at a time;
//! * **a run** (`run.rs`): once the long way has solved a step on a joint
//!   affine in the distance, inside a cruise or constant-acceleration piece,
//!   every later boundary of that leg in that piece follows one closed form
//!   of its index. The run counts them once and solves up to [`AHEAD`] at a
//!   time, each a few multiplications (and a square root and a division
//!   under acceleration), with no per-step checks.
//!
//! A step taken is counted and the next one handed out ([`Channel::advance`]);
//! solving happens only when the solved steps are used up.

mod chunk;
mod run;

use heapless::Deque;
use motet_trajectory::{JointPath, Segment, TimeCursor};
use motet_wire::ChannelConfig;
use run::{Ahead, Run, RunStart};

pub use run::AHEAD;

/// A step found but not yet taken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// Host time, µs.
    pub time: f64,
    /// In the joint's positive direction (before inversion).
    pub positive: bool,
}

#[derive(Clone, Debug)]
/// One step/direction output following one joint: finds each step's exact host time from the queued
/// segments' profiles and joint paths, a few steps ahead of the one taken.
pub struct Channel {
    config: ChannelConfig,
    /// Steps per joint unit, unsigned; the sign lives in `invert`.
    spu: f64,
    invert: bool,
    /// Steps taken before the solved ones, counted in the joint's positive
    /// direction (the solved ones taken are counted by `ahead`).
    base: i64,
    /// Index of the segment being followed, relative to the queue's head.
    seg: usize,
    path: Option<JointPath>,
    /// Distance into the current segment up to which steps are found.
    s: f64,
    /// The current leg: the stretch of the segment up to its turning point
    /// or its end, over which the joint is monotone. [`Leg::NONE`] whenever
    /// `path` is `None`, so that no step is found on a stale leg.
    leg: Leg,
    /// The current segment's profile, inverted piece by piece as `s` grows.
    timer: TimeCursor,
    /// The current segment's start, host µs.
    t0: f64,
    /// Joint value where the last segment ended, to keep angles continuous.
    joint_ref: f64,
    /// Steps solved and not yet taken.
    ahead: Ahead,
    /// The steps of the current run not yet solved.
    run: Run,
    /// Time of the last step solved, µs: the next is never earlier.
    last_time: f64,
    /// Time of the last step before the solved ones, µs (what a retime
    /// keeps to when none of them is taken).
    floor: f64,
    /// Fixed-point time's tolerance, µs; 0: every step solved in `f64`
    /// ([`Channel::use_fixed_time`]).
    tolerance: f64,
}

/// What a leg's steps need, computed once per leg instead of once per step.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Leg {
    /// Distance where the leg ends.
    hi: f64,
    /// The joint there, in steps.
    at_hi: f64,
    /// For a joint affine in the distance, `(joint at s = 0 in steps,
    /// distance per step)`: a crossing is then one multiplication away.
    line: Option<(f64, f64)>,
}

impl Leg {
    const NONE: Leg = Leg {
        hi: 0.0,
        at_hi: 0.0,
        line: None,
    };
}

impl Channel {
    /// A channel on `config`, at step count 0 with nothing solved; a node sets its position
    /// (`set_position`) before it steps.
    pub fn new(config: ChannelConfig) -> Channel {
        Channel {
            config,
            spu: config.steps_per_unit.abs(),
            invert: config.steps_per_unit < 0.0,
            base: 0,
            seg: 0,
            path: None,
            s: 0.0,
            leg: Leg::NONE,
            timer: TimeCursor::START,
            t0: 0.0,
            joint_ref: 0.0,
            ahead: Ahead::EMPTY,
            run: Run::NONE,
            last_time: f64::NEG_INFINITY,
            floor: f64::NEG_INFINITY,
            tolerance: 0.0,
        }
    }

    /// Solves the steps of its runs in fixed-point time, each within
    /// `tolerance_us` of its exact time (0: exactly, in `f64`): for a
    /// core without a floating-point unit, where a step solved in `f64`
    /// costs thousands of instructions (see `chunk.rs`).
    pub fn use_fixed_time(&mut self, tolerance_us: f64) {
        self.tolerance = if tolerance_us > 0.0 {
            tolerance_us
        } else {
            0.0
        };
    }

    /// What the host configured: board channel id, joint map, steps per unit and step timing.
    pub fn config(&self) -> &ChannelConfig {
        &self.config
    }

    /// Steps taken so far, in the joint's positive direction.
    pub fn position(&self) -> i64 {
        self.base + self.ahead.taken()
    }

    /// Sets the step count from the machine at rest at `p`, without stepping.
    pub fn set_position(&mut self, p: &motet_trajectory::Point) {
        // A point out of an arm's reach (the origin, before the host sets
        // the start) leaves no value to keep an angle's turn by.
        let reference = if self.joint_ref.is_finite() {
            self.joint_ref
        } else {
            0.0
        };
        let value = self.config.map.value(p, reference);
        self.joint_ref = value;
        self.base = libm_round(value * self.spu);
        self.seg = 0;
        self.path = None;
        self.leg = Leg::NONE;
        self.ahead = Ahead::EMPTY;
        self.run = Run::NONE;
    }

    /// The next step on the queued segments, if they hold one.
    pub fn next_step<const Q: usize>(&mut self, segments: &Deque<Segment, Q>) -> Option<Step> {
        self.next_step_within(segments, segments.len())
    }

    /// The next step on the first `end` queued segments (the committed ones;
    /// the rest are not to be run yet).
    pub fn next_step_within<const Q: usize>(
        &mut self,
        segments: &Deque<Segment, Q>,
        end: usize,
    ) -> Option<Step> {
        let time = self.next_time_within(segments, end);
        (time != f64::INFINITY).then_some(Step {
            time,
            positive: self.ahead.positive,
        })
    }

    /// The next step's time on the first `end` queued segments; infinite
    /// when they hold none (yet).
    #[inline(always)]
    pub fn next_time_within<const Q: usize>(
        &mut self,
        segments: &Deque<Segment, Q>,
        end: usize,
    ) -> f64 {
        // Most calls end here: the step was solved with others before it.
        let t = self.ahead.next_time();
        if t != f64::INFINITY {
            return t;
        }
        self.solve_ahead(segments, end)
    }

    /// The direction output of the next step (the driver's line: the
    /// joint's direction, inverted if the actuator's steps per unit are
    /// negative); meaningful once a step is solved.
    #[inline(always)]
    pub fn next_forward(&self) -> bool {
        self.ahead.forward
    }

    /// Takes the step [`Channel::next_time_within`] gave (there must be
    /// one) and returns the time of the one after it on the first `end`
    /// segments (infinite: none yet). The poll's hot path.
    #[inline(always)]
    pub fn advance<const Q: usize>(&mut self, segments: &Deque<Segment, Q>, end: usize) -> f64 {
        let a = &mut self.ahead;
        a.head += 1;
        if a.head < a.len {
            return a.times[a.head];
        }
        self.solve_ahead(segments, end)
    }

    /// Solves the next steps: a batch from the current run, or one the
    /// long way (and the run that follows it).
    #[inline(never)]
    fn solve_ahead<const Q: usize>(&mut self, segments: &Deque<Segment, Q>, end: usize) -> f64 {
        // Every solved step is taken: they count from here on.
        self.base += self.ahead.taken();
        self.ahead.head = 0;
        self.ahead.len = 0;
        self.floor = self.last_time;
        if self.run.is_live() && self.seg < end {
            self.last_time = self.run.fill(&mut self.ahead, 0, self.last_time);
            self.s = self.run.last_dist();
            return self.ahead.times[0];
        }
        match self.find_step(segments, end) {
            Some((time, boundary, positive)) => {
                self.start_run(boundary, positive);
                time
            }
            None => f64::INFINITY,
        }
    }

    /// After a step found the long way at `boundary`: the run of the steps
    /// that follow it in its leg and profile piece, if they have a closed
    /// form; its first batch joins the step in the solved ones.
    fn start_run(&mut self, boundary: f64, positive: bool) {
        let Some((a0, per_step)) = self.leg.line else {
            return;
        };
        let from = RunStart {
            a0,
            per_step,
            boundary,
            dir: if positive { 1.0 } else { -1.0 },
            at_hi: self.leg.at_hi,
            seg_t0: self.t0,
            tolerance: self.tolerance,
        };
        self.run = Run::after(&from, &self.timer.piece_inverse());
        if !self.run.is_live() {
            return;
        }
        // The batch goes after the step already solved.
        self.last_time = self.run.fill(&mut self.ahead, 1, self.last_time);
        self.s = self.run.last_dist();
    }

    /// Where a joint affine in the distance crosses `boundary`, inside the
    /// leg. Plain comparisons (not `f64::max`, which costs NaN checks); a
    /// NaN stays where the leg is.
    #[inline(always)]
    fn line_crossing(&self, a0: f64, per_step: f64, boundary: f64) -> f64 {
        let s = (boundary - a0) * per_step;
        let s = if s > self.s { s } else { self.s };
        if s < self.leg.hi {
            s
        } else {
            self.leg.hi
        }
    }

    /// Host time of a step `t` seconds into the current segment, never
    /// earlier than the step before, whatever the rounding.
    #[inline(always)]
    fn step_time(&self, t: f64) -> f64 {
        let time = self.t0 + t * 1e6;
        if time > self.last_time {
            time
        } else {
            self.last_time
        }
    }

    /// The long way: starts segments and legs as needed, and solves any
    /// joint shape and any profile piece. Puts the step in the solved ones
    /// and returns its time, its half-step boundary and its direction.
    fn find_step<const Q: usize>(
        &mut self,
        segments: &Deque<Segment, Q>,
        end: usize,
    ) -> Option<(f64, f64, bool)> {
        self.run = Run::NONE;
        loop {
            if self.seg >= end {
                return None;
            }
            let seg = segments.get(self.seg)?;
            if self.path.is_none() && !self.start_segment(seg) {
                self.seg += 1;
                continue;
            }
            let pos = self.base as f64;
            let at_hi = self.leg.at_hi;
            let (boundary, positive) = if at_hi > pos + 0.5 {
                (pos + 0.5, true)
            } else if at_hi < pos - 0.5 {
                (pos - 0.5, false)
            } else {
                self.end_leg();
                continue;
            };
            let s = match (self.leg.line, &self.path) {
                (Some((a0, per_step)), _) => self.line_crossing(a0, per_step, boundary),
                (None, Some(path)) => path.solve(boundary / self.spu, self.s, self.leg.hi),
                (None, None) => return None,
            };
            self.s = s;
            let t = self.timer.time_at(&seg.profile, s);
            let time = self.step_time(t);
            self.last_time = time;
            self.ahead.one(time, s, positive, self.invert);
            return Some((time, boundary, positive));
        }
    }

    /// Starts following `seg`; false when it has no length to follow.
    #[inline(never)]
    fn start_segment(&mut self, seg: &Segment) -> bool {
        if seg.profile.length() <= 0.0 {
            return false;
        }
        let p = JointPath::new(&self.config.map, seg, self.joint_ref);
        self.s = 0.0;
        self.path = Some(p);
        self.timer = TimeCursor::START;
        self.t0 = seg.t0;
        self.enter_leg();
        true
    }

    /// No step is left in the current leg: moves on to the next leg, or past
    /// the segment.
    #[inline(never)]
    fn end_leg(&mut self) {
        let Some(path) = self.path else {
            return;
        };
        if self.leg.hi < path.length() {
            self.s = self.leg.hi;
            self.enter_leg();
        } else {
            self.joint_ref = path.value_at(path.length());
            self.path = None;
            self.leg = Leg::NONE;
            self.seg += 1;
        }
    }

    /// Starts the leg that begins at `self.s`.
    fn enter_leg(&mut self) {
        let Some(path) = self.path.as_ref() else {
            return;
        };
        let hi = path.next_turn(self.s).unwrap_or(path.length());
        let line = path.line().map(|(a0, k)| {
            let rate = k * self.spu;
            let per_step = if rate == 0.0 { 0.0 } else { 1.0 / rate };
            (a0 * self.spu, per_step)
        });
        self.leg = Leg {
            hi,
            at_hi: path.value_at(hi) * self.spu,
            line,
        };
    }

    /// The profiles of queued segments `from..` were replaced (same
    /// geometry): a step already found in them keeps its place on the path
    /// and takes that place's new time.
    pub fn retime<const Q: usize>(&mut self, segments: &Deque<Segment, Q>, from: usize) {
        if self.seg < from {
            return;
        }
        let Some(seg) = segments.get(self.seg) else {
            return;
        };
        if self.path.is_some() {
            self.timer = TimeCursor::START;
            self.t0 = seg.t0;
        }
        // The first step solved keeps its place on the path and takes that
        // place's new time; the ones after it are solved again.
        let a = &self.ahead;
        self.last_time = if a.head > 0 {
            a.times[a.head - 1]
        } else {
            self.floor
        };
        if a.head < a.len {
            self.s = a.dist(a.head, &self.run);
            let t = self.timer.time_at(&seg.profile, self.s);
            let time = self.step_time(t);
            self.last_time = time;
            let a = &mut self.ahead;
            a.times[a.head] = time;
            a.len = a.head + 1;
        }
        // The run followed the old profile; the long way starts a new one.
        self.run = Run::NONE;
    }

    /// Takes the pending step; returns its time and the direction output.
    #[inline]
    pub fn take_step(&mut self) -> Option<(f64, bool)> {
        let a = &mut self.ahead;
        if a.head >= a.len {
            return None;
        }
        let time = a.times[a.head];
        a.head += 1;
        Some((time, a.forward))
    }

    /// How many queued segments the channel is completely done with.
    pub fn segments_done(&self) -> usize {
        self.seg
    }

    /// The queue dropped `n` segments from its head.
    pub fn drop_segments(&mut self, n: usize) {
        self.seg -= n.min(self.seg);
    }
}

fn libm_round(x: f64) -> i64 {
    // Half-way values round away from zero, like the half-step rule's boundary.
    let r = if x >= 0.0 { x + 0.5 } else { x - 0.5 };
    r as i64
}
