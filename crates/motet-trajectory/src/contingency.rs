//! The contingency tail: how a window of committed segments comes to rest on
//! its own path when nothing follows it.
//!
//! The tail is computed, never transmitted: host and every node run this code
//! on the same committed segments and get the same tail bit for bit, so the
//! machine stops at the same point on every node without a byte on the wire.
//!
//! Given segments `s_0..s_{n-1}` contiguous in time, the tail starts at the
//! latest boundary `k` from which the machine, at its planned speed there,
//! can still stop exactly at the end of `s_{n-1}`: speed squared falls on a
//! straight line in distance, `v² = 2·a·R` (`R` the distance left), whose
//! slope `a = v_k² / (2·R_k)` stays within every tail segment's acceleration
//! limit. Each boundary keeps the lower of its planned speed and the line, and
//! each tail segment ramps between its two boundary speeds at constant
//! acceleration over its whole length. Geometry is never touched: the stop
//! point is the end of the last segment, a segment boundary.

use crate::math::sqrt;
use crate::point::Point;
use crate::profile::{fastest, Profile};
use crate::segment::Segment;

/// Why a window has no tail.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TailError {
    /// No segments.
    Empty,
    /// From no boundary of the window can the machine stop at its end within
    /// the acceleration limits: the window starts too fast for its length.
    NoRoom,
}

impl core::fmt::Display for TailError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            TailError::Empty => f.write_str("no committed segments"),
            TailError::NoRoom => f.write_str(
                "the window cannot stop at its end within its acceleration limits from any boundary",
            ),
        }
    }
}

/// Where and how a window of committed segments stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contingency {
    /// Index of the first tail segment; equals `len` when the window already
    /// ends at rest (no tail).
    pub start: usize,
    /// Segments in the window.
    pub len: usize,
    /// When the tail takes over, µs (host time): the start of segment `start`,
    /// or the end of the window when it has no tail. A seal that moves the
    /// window's end must reach every node before this.
    pub start_time: f64,
    /// Where the machine comes to rest: the end of the last segment.
    pub stop: Point,
    /// Slope of the line `v² = 2·decel·R` the tail's boundary speeds stay
    /// under, units/s².
    pub decel: f64,
    /// Path distance from the tail's start to the stop point.
    pub distance: f64,
}

impl Contingency {
    /// The tail of the window `segments` (in time order). Only the window's
    /// end is read until the tail start is found, so a caller may pass any
    /// suffix of a window that still holds the tail.
    pub fn of<'a, I>(segments: I) -> Result<Contingency, TailError>
    where
        I: IntoIterator<Item = &'a Segment>,
        I::IntoIter: DoubleEndedIterator + ExactSizeIterator,
    {
        let it = segments.into_iter();
        let len = it.len();
        let mut rev = it.rev();
        let last = rev.next().ok_or(TailError::Empty)?;
        let stop = last.end;
        if last.profile.v1() <= 0.0 {
            return Ok(Contingency {
                start: len,
                len,
                start_time: last.t1(),
                stop,
                decel: 0.0,
                distance: 0.0,
            });
        }
        let mut distance = 0.0;
        let mut min_accel = f64::INFINITY;
        let mut k = len;
        let mut seg = Some(last);
        while let Some(s) = seg {
            k -= 1;
            let p = s.profile.params();
            distance += p.length;
            // A dwell is a planned rest: its end boundary fits with a' = 0,
            // so the scan never reaches one.
            min_accel = min_accel.min(p.accel);
            let v = s.profile.v0();
            if v <= 0.0 {
                // At rest at this boundary: any line fits; the steepest
                // allowed one keeps the planned speeds longest.
                return Ok(Contingency {
                    start: k,
                    len,
                    start_time: s.t0,
                    stop,
                    decel: min_accel,
                    distance,
                });
            }
            let decel = v * v / (2.0 * distance);
            if decel <= min_accel {
                return Ok(Contingency {
                    start: k,
                    len,
                    start_time: s.t0,
                    stop,
                    decel,
                    distance,
                });
            }
            seg = rev.next();
        }
        Err(TailError::NoRoom)
    }

    /// Whether the window needs a tail (it does not end at rest).
    pub fn has_tail(&self) -> bool {
        self.start < self.len
    }

    /// A walk over the tail: feed it segments `start..len` in order.
    pub fn walk(&self) -> TailWalk {
        TailWalk {
            decel: self.decel,
            remaining: self.distance,
            v: None,
            t0: self.start_time,
            left: self.len - self.start,
        }
    }

    /// Replaces the tail of `segments` (the whole window, in time order) in
    /// place and returns the contingency.
    pub fn apply(segments: &mut [Segment]) -> Result<Contingency, TailError> {
        let c = Contingency::of(segments.iter())?;
        let mut walk = c.walk();
        for s in segments[c.start..].iter_mut() {
            *s = walk.next(s);
        }
        Ok(c)
    }
}

/// Turns the window's tail segments, one by one in order, into their tail
/// versions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TailWalk {
    decel: f64,
    remaining: f64,
    /// Speed at the current boundary (`None` before the first segment).
    v: Option<f64>,
    t0: f64,
    left: usize,
}

impl TailWalk {
    /// The tail version of the next tail segment `seg`: same geometry, the
    /// tail's profile, starting when the previous tail segment ends.
    pub fn next(&mut self, seg: &Segment) -> Segment {
        let p = seg.profile.params();
        let v0 = self.v.unwrap_or(seg.profile.v0());
        self.left = self.left.saturating_sub(1);
        self.remaining = (self.remaining - p.length).max(0.0);
        let v1 = if self.left == 0 {
            0.0
        } else {
            seg.profile
                .v1()
                .min(sqrt(2.0 * self.decel * self.remaining))
        };
        self.v = Some(v1);
        let profile = if p.length <= 0.0 {
            seg.profile
        } else if v0 <= 0.0 && v1 <= 0.0 {
            // A window whose last segment leaves a planned rest: rest to
            // rest over it, no faster than planned.
            fastest(p.length, 0.0, 0.0, seg.profile.vc(), self.decel, 0.0)
        } else {
            // One ramp over the whole length; the boundary speeds are
            // mutually reachable within the segment's limit (both the
            // planned speeds and the line are), so this never exceeds it.
            let a = ((v0 * v0 - v1 * v1).abs() / (2.0 * p.length)).min(p.accel);
            Profile::new(p.length, v0, v0.max(v1), v1, a, 0.0)
        };
        let out = Segment {
            t0: self.t0,
            start: seg.start,
            end: seg.end,
            profile,
        };
        self.t0 = out.t1();
        out
    }
}

#[cfg(test)]
mod tests;
