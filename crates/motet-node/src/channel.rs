//! A channel: one actuator's step output driven by the trajectory.
//!
//! The channel follows its joint along the queued segments and steps whenever
//! the joint, in steps, crosses a half-step boundary, so the executed position
//! never differs from the commanded one by more than half a step. The time of
//! each crossing is solved in closed form from the segment's geometry and speed
//! profile, so steps are placed exactly inside a frame, not rounded to it.
//!
//! On the common stretch (a joint affine in the distance, inside one piece
//! of the speed profile) the channel solves up to [`AHEAD`] steps at once
//! and hands them out one by one: each solve is independent of the last, so
//! the processor overlaps their square roots and divisions instead of
//! waiting on each, and the checks that pick the stretch are made once per
//! batch, not once per step. The times are the same as one at a time.

use heapless::Deque;
use motet_trajectory::{JointPath, Segment, TimeCursor};
use motet_wire::ChannelConfig;

/// Most steps solved ahead of the one being taken.
pub const AHEAD: usize = 8;

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
    /// Steps taken, counted in the joint's positive direction.
    position: i64,
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
    /// Steps solved and not yet taken: `times[head..len]`, all in the
    /// direction `positive`, at distances `dists[head..len]` into the
    /// segment (kept so that a retime can go back to the first).
    ahead: Ahead,
    last_time: f64,
}

#[derive(Clone, Debug)]
struct Ahead {
    times: [f64; AHEAD],
    dists: [f64; AHEAD],
    head: usize,
    len: usize,
    positive: bool,
}

impl Ahead {
    const EMPTY: Ahead = Ahead {
        times: [0.0; AHEAD],
        dists: [0.0; AHEAD],
        head: 0,
        len: 0,
        positive: true,
    };

    #[inline(always)]
    fn next(&self) -> Option<Step> {
        (self.head < self.len).then(|| Step {
            time: self.times[self.head],
            positive: self.positive,
        })
    }

    fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
    }

    /// Just `step`, found the long way.
    fn one(&mut self, step: Step, s: f64) {
        self.times[0] = step.time;
        self.dists[0] = s;
        self.head = 0;
        self.len = 1;
        self.positive = step.positive;
    }
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
            position: 0,
            seg: 0,
            path: None,
            s: 0.0,
            leg: Leg::NONE,
            timer: TimeCursor::START,
            t0: 0.0,
            joint_ref: 0.0,
            ahead: Ahead::EMPTY,
            last_time: f64::NEG_INFINITY,
        }
    }

    /// What the host configured: board channel id, joint map, steps per unit and step timing.
    pub fn config(&self) -> &ChannelConfig {
        &self.config
    }

    /// Steps taken so far, in the joint's positive direction.
    pub fn position(&self) -> i64 {
        self.position
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
        self.position = libm_round(value * self.spu);
        self.seg = 0;
        self.path = None;
        self.leg = Leg::NONE;
        self.ahead.clear();
    }

    /// The next step on the queued segments, if they hold one.
    pub fn next_step<const Q: usize>(&mut self, segments: &Deque<Segment, Q>) -> Option<Step> {
        self.next_step_within(segments, segments.len())
    }

    /// The next step on the first `end` queued segments (the committed ones;
    /// the rest are not to be run yet).
    #[inline(always)]
    pub fn next_step_within<const Q: usize>(
        &mut self,
        segments: &Deque<Segment, Q>,
        end: usize,
    ) -> Option<Step> {
        // Most calls end here: the step was solved with others before it.
        if let Some(step) = self.ahead.next() {
            return Some(step);
        }
        self.solve_ahead(segments, end)
    }

    /// Solves the next steps: a batch on a line leg, or one the long way.
    #[inline(never)]
    fn solve_ahead<const Q: usize>(
        &mut self,
        segments: &Deque<Segment, Q>,
        end: usize,
    ) -> Option<Step> {
        if self.seg < end {
            if let Some(step) = self.steps_on_line() {
                return Some(step);
            }
        }
        self.find_step(segments, end)
    }

    /// The common case, kept short: the next steps lie in the current leg
    /// of a joint affine in the distance, and in the profile piece the
    /// timer is in. Solves up to [`AHEAD`] of them; `None` (nothing
    /// changed) sends the caller the long way.
    #[inline(always)]
    fn steps_on_line(&mut self) -> Option<Step> {
        let (a0, per_step) = self.leg.line?;
        let pos = self.position as f64;
        let at_hi = self.leg.at_hi;
        let (mut boundary, positive) = if at_hi > pos + 0.5 {
            (pos + 0.5, true)
        } else if at_hi < pos - 0.5 {
            (pos - 0.5, false)
        } else {
            return None;
        };
        let dir = if positive { 1.0 } else { -1.0 };
        // The distances of the leg's next boundaries, each never short of
        // the one before, then their times in the current profile piece.
        let a = &mut self.ahead;
        let (mut prev, hi) = (self.s, self.leg.hi);
        let mut n = 0;
        while n < AHEAD {
            // Past the leg's last boundary: the rest is the long way's.
            if (at_hi - boundary) * dir <= 0.0 {
                break;
            }
            let s = (boundary - a0) * per_step;
            let s = if s > prev { s } else { prev };
            let s = if s < hi { s } else { hi };
            a.dists[n] = s;
            prev = s;
            n += 1;
            boundary += dir;
        }
        let n = self.timer.times_in_piece(&a.dists[..n], &mut a.times[..n]);
        if n == 0 {
            return None;
        }
        let mut last = self.last_time;
        for t in a.times[..n].iter_mut() {
            let time = self.t0 + *t * 1e6;
            // Never earlier than the step before, whatever the rounding.
            last = if time > last { time } else { last };
            *t = last;
        }
        self.s = a.dists[n - 1];
        a.head = 0;
        a.len = n;
        a.positive = positive;
        a.next()
    }

    /// Where a joint affine in the distance crosses `boundary`, inside the
    /// leg. Plain comparisons (not `f64::max`, which costs NaN checks per
    /// step); a NaN stays where the leg is.
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
    /// joint shape and any profile piece.
    fn find_step<const Q: usize>(
        &mut self,
        segments: &Deque<Segment, Q>,
        end: usize,
    ) -> Option<Step> {
        loop {
            if self.seg >= end {
                return None;
            }
            let seg = segments.get(self.seg)?;
            if self.path.is_none() && !self.start_segment(seg) {
                self.seg += 1;
                continue;
            }
            let pos = self.position as f64;
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
            let step = Step {
                time: self.step_time(t),
                positive,
            };
            self.ahead.one(step, s);
            return Some(step);
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
        let a = &mut self.ahead;
        if a.head < a.len {
            self.s = a.dists[a.head];
            let t = self.timer.time_at(&seg.profile, self.s);
            let time = self.step_time(t);
            let a = &mut self.ahead;
            a.times[a.head] = time;
            a.len = a.head + 1;
        }
    }

    /// Takes the pending step; returns the direction output.
    #[inline]
    pub fn take_step(&mut self) -> Option<(f64, bool)> {
        let step = self.ahead.next()?;
        self.ahead.head += 1;
        self.position += if step.positive { 1 } else { -1 };
        self.last_time = step.time;
        Some((step.time, step.positive != self.invert))
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
