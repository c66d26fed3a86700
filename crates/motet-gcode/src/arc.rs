//! Flattening XY-plane arcs (G2/G3) into chords.

use core::f64::consts::{FRAC_PI_2, TAU};
use motet_trajectory::{Point, MAX_AXES};
use thiserror::Error;

/// Most chords a single arc may be flattened into.
pub(crate) const MAX_ARC_SEGMENTS: usize = 100_000;

/// Why an arc cannot be flattened.
#[derive(Clone, Copy, Debug, Error, PartialEq)]
pub(crate) enum ArcError {
    /// The sweep at this radius needs more chords than an arc may have.
    #[error(
        "arc of radius {radius} needs more than {MAX_ARC_SEGMENTS} chords at tolerance {tolerance}"
    )]
    TooManyChords { radius: f64, tolerance: f64 },
}

/// An arc in machine space: the plane is given by axis indices `x` and `y`;
/// every other axis moves linearly from `start` to `end` (a helix).
pub(crate) struct Arc {
    pub start: Point,
    pub end: Point,
    pub center: [f64; 2],
    pub x: usize,
    pub y: usize,
    pub clockwise: bool,
    /// Go all the way round (IJK form with end == start).
    pub full: bool,
}

impl Arc {
    /// Radius to the start and to the end.
    pub(crate) fn radii(&self) -> (f64, f64) {
        let [cx, cy] = self.center;
        (
            (self.start[self.x] - cx).hypot(self.start[self.y] - cy),
            (self.end[self.x] - cx).hypot(self.end[self.y] - cy),
        )
    }

    /// Call `emit` with the end point of every chord, the last one being
    /// exactly `self.end`. Chord sagitta stays within `tolerance`.
    pub(crate) fn flatten(
        &self,
        tolerance: f64,
        mut emit: impl FnMut(Point),
    ) -> Result<(), ArcError> {
        let [cx, cy] = self.center;
        let (r0, r1) = self.radii();
        let a0 = (self.start[self.y] - cy).atan2(self.start[self.x] - cx);
        let a1 = (self.end[self.y] - cy).atan2(self.end[self.x] - cx);
        let sweep = if self.full {
            if self.clockwise {
                -TAU
            } else {
                TAU
            }
        } else {
            let mut d = a1 - a0;
            if self.clockwise {
                if d >= 0.0 {
                    d -= TAU;
                }
            } else if d <= 0.0 {
                d += TAU;
            }
            d
        };
        let r = r0.max(r1);
        // Sagitta of a chord spanning angle t: r (1 - cos(t/2)) <= tolerance.
        let max_step = if tolerance >= r {
            FRAC_PI_2
        } else {
            (2.0 * (1.0 - tolerance / r).acos()).min(FRAC_PI_2)
        };
        let n = (sweep.abs() / max_step).ceil();
        if !n.is_finite() || n > MAX_ARC_SEGMENTS as f64 {
            return Err(ArcError::TooManyChords {
                radius: r,
                tolerance,
            });
        }
        let n = (n as usize).max(1);
        for k in 1..n {
            let t = k as f64 / n as f64;
            let mut p: Point = [0.0; MAX_AXES];
            for ((p, s), e) in p.iter_mut().zip(&self.start).zip(&self.end) {
                *p = s + (e - s) * t;
            }
            let a = a0 + sweep * t;
            let rr = r0 + (r1 - r0) * t;
            p[self.x] = cx + rr * a.cos();
            p[self.y] = cy + rr * a.sin();
            emit(p);
        }
        emit(self.end);
        Ok(())
    }
}
