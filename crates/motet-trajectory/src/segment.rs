//! Time-stamped segments: the unit of the trajectory.

use crate::point::{lerp, Point};
use crate::profile::Profile;

/// A straight move in machine space with its speed profile, stamped on the host
/// clock. Every axis moves proportionally to the distance covered along the
/// path, so one profile serves all of a segment's tracks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Start time, microseconds on the host clock. Fractional: the planner never
    /// rounds durations, so segment boundaries stay exact.
    pub t0: f64,
    /// Machine-space position at `t0`, one coordinate per axis (mm, or
    /// degrees for rotary axes).
    pub start: Point,
    /// Position at [`Segment::t1`]; the move is the straight line from
    /// `start`, so a joint that is not linear in the axes (polar, arms) is
    /// what curves, not the tool.
    pub end: Point,
    /// Speed along the path over time. Its [`Profile::length`] is the path
    /// length the planner measured (over the axes that set the feed rate, or
    /// over all axes for a move of riding axes only); every axis covers its
    /// share of `end - start` in proportion.
    pub profile: Profile,
}

impl Segment {
    /// Duration in microseconds.
    #[inline]
    pub fn duration_us(&self) -> f64 {
        self.profile.duration() * 1e6
    }

    /// End time in microseconds.
    #[inline]
    pub fn t1(&self) -> f64 {
        self.t0 + self.duration_us()
    }

    /// Fraction of the segment done at host time `t` (µs), in `0..=1`.
    #[inline]
    pub fn fraction_at(&self, t: f64) -> f64 {
        let len = self.profile.length();
        if len <= 0.0 {
            return 0.0;
        }
        let d = self.profile.distance_at((t - self.t0) * 1e-6);
        (d / len).clamp(0.0, 1.0)
    }

    /// Position at host time `t` (µs); clamped to the segment's ends.
    #[inline]
    pub fn position_at(&self, t: f64) -> Point {
        if t >= self.t1() {
            return self.end;
        }
        lerp(&self.start, &self.end, self.fraction_at(t))
    }

    /// Position after distance `s` along the path.
    #[inline]
    pub fn position_at_distance(&self, s: f64) -> Point {
        let len = self.profile.length();
        if len <= 0.0 {
            return self.start;
        }
        lerp(&self.start, &self.end, (s / len).clamp(0.0, 1.0))
    }

    /// Host time (µs) at which distance `s` along the path is reached.
    #[inline]
    pub fn time_at_distance(&self, s: f64) -> f64 {
        self.t0 + self.profile.time_at(s) * 1e6
    }

    /// Rate of change of axis `i` per unit path distance.
    #[inline]
    pub fn axis_rate(&self, i: usize) -> f64 {
        let len = self.profile.length();
        if len <= 0.0 {
            0.0
        } else {
            (self.end[i] - self.start[i]) / len
        }
    }
}
