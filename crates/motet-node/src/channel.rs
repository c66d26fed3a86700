//! A channel: one actuator's step output driven by the trajectory.
//!
//! The channel follows its joint along the queued segments and steps whenever
//! the joint, in steps, crosses a half-step boundary, so the executed position
//! never differs from the commanded one by more than half a step. The time of
//! each crossing is solved in closed form from the segment's geometry and speed
//! profile, so steps are placed exactly inside a frame, not rounded to it.

use heapless::Deque;
use motet_trajectory::{JointPath, Segment, TimeCursor};
use motet_wire::ChannelConfig;

/// A step found but not yet taken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// Host time, µs.
    pub time: f64,
    /// In the joint's positive direction (before inversion).
    pub positive: bool,
}

#[derive(Clone, Debug)]
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
    turn: Option<f64>,
    /// Distance into the current segment up to which steps are found.
    s: f64,
    /// The current leg: the stretch of the segment up to its turning point
    /// or its end, over which the joint is monotone.
    leg: Leg,
    /// The current segment's profile, inverted piece by piece as `s` grows.
    timer: TimeCursor,
    /// Joint value where the last segment ended, to keep angles continuous.
    joint_ref: f64,
    pending: Option<Step>,
    last_time: f64,
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
    pub fn new(config: ChannelConfig) -> Channel {
        Channel {
            config,
            spu: config.steps_per_unit.abs(),
            invert: config.steps_per_unit < 0.0,
            position: 0,
            seg: 0,
            path: None,
            turn: None,
            s: 0.0,
            leg: Leg::NONE,
            timer: TimeCursor::new(&motet_trajectory::Profile::dwell(0.0)),
            joint_ref: 0.0,
            pending: None,
            last_time: f64::NEG_INFINITY,
        }
    }

    pub fn config(&self) -> &ChannelConfig {
        &self.config
    }

    /// Steps taken so far, in the joint's positive direction.
    pub fn position(&self) -> i64 {
        self.position
    }

    /// Sets the step count from the machine at rest at `p`, without stepping.
    pub fn set_position(&mut self, p: &motet_trajectory::Point) {
        let value = self.config.map.value(p, self.joint_ref);
        self.joint_ref = value;
        self.position = libm_round(value * self.spu);
        self.seg = 0;
        self.path = None;
        self.pending = None;
    }

    /// The next step on the queued segments, if they hold one.
    pub fn next_step<const Q: usize>(&mut self, segments: &Deque<Segment, Q>) -> Option<Step> {
        self.next_step_within(segments, segments.len())
    }

    /// The next step on the first `end` queued segments (the committed ones;
    /// the rest are not to be run yet).
    #[inline]
    pub fn next_step_within<const Q: usize>(
        &mut self,
        segments: &Deque<Segment, Q>,
        end: usize,
    ) -> Option<Step> {
        if self.pending.is_some() {
            return self.pending;
        }
        self.find_step(segments, end)
    }

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
            let path = match self.path {
                Some(p) => p,
                None => {
                    if seg.profile.length() <= 0.0 {
                        self.seg += 1;
                        continue;
                    }
                    let p = JointPath::new(&self.config.map, seg, self.joint_ref);
                    self.turn = p.turning_point();
                    self.s = 0.0;
                    self.path = Some(p);
                    self.timer = TimeCursor::new(&seg.profile);
                    self.enter_leg(&p);
                    p
                }
            };
            let leg = self.leg;
            let pos = self.position as f64;
            let (boundary, positive) = if leg.at_hi > pos + 0.5 {
                (pos + 0.5, true)
            } else if leg.at_hi < pos - 0.5 {
                (pos - 0.5, false)
            } else if leg.hi < path.length() {
                self.s = leg.hi;
                self.enter_leg(&path);
                continue;
            } else {
                self.joint_ref = path.value_at(path.length());
                self.path = None;
                self.seg += 1;
                continue;
            };
            let s = match leg.line {
                Some((a0, per_step)) => {
                    let s = (boundary - a0) * per_step;
                    if s.is_nan() {
                        self.s
                    } else {
                        s.clamp(self.s, leg.hi)
                    }
                }
                None => path.solve(boundary / self.spu, self.s, leg.hi),
            };
            self.s = s;
            // Never earlier than the step before, whatever the rounding.
            let time = (seg.t0 + self.timer.time_at(&seg.profile, s) * 1e6).max(self.last_time);
            let step = Step { time, positive };
            self.pending = Some(step);
            return Some(step);
        }
    }

    /// Starts the leg that begins at `self.s`.
    fn enter_leg(&mut self, path: &JointPath) {
        let hi = match self.turn {
            Some(t) if self.s < t => t,
            _ => path.length(),
        };
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
            self.timer = TimeCursor::new(&seg.profile);
        }
        if let Some(step) = self.pending.as_mut() {
            step.time =
                (seg.t0 + self.timer.time_at(&seg.profile, self.s) * 1e6).max(self.last_time);
        }
    }

    /// Takes the pending step; returns the direction output.
    pub fn take_step(&mut self) -> Option<(f64, bool)> {
        let step = self.pending.take()?;
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
