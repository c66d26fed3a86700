//! The time at which a profile reaches a distance, for distances asked in
//! increasing order: a stepping channel's question, once per step.
//!
//! [`Profile::time_at`] answers any distance from scratch. A channel asks for
//! distances that only grow, so [`TimeCursor`] keeps the profile piece it is
//! in and that piece's constants: a cruise costs a multiplication, a
//! constant-acceleration piece one square root and one division, and a
//! jerk-limited (cubic) piece a few Newton steps started from the previous
//! answer.

use crate::math::{cbrt, sqrt};
use crate::profile::{Piece, Profile, PIECES};

/// How the current piece is inverted.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Solve {
    /// Constant speed: `u = x / v`.
    Cruise { per_unit: f64 },
    /// Constant acceleration: `u = 2x / (v + √(v² + 2ax))`, without
    /// cancellation whatever the sign of `a`.
    Quadratic { vv: f64, two_a: f64 },
    /// Jerk-limited: Newton on the cubic, from the last answer.
    Cubic {
        half_a: f64,
        sixth_j: f64,
        half_j: f64,
    },
    /// Standing still: the piece's start.
    Still,
}

/// The closed form of a piece's inverse, for callers that solve many
/// distances in one piece ([`TimeCursor::piece_inverse`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PieceForm {
    /// Constant speed: `u = x · per_unit` seconds for `x` units into the piece.
    Cruise {
        /// Seconds per unit (the speed's inverse).
        per_unit: f64,
    },
    /// Constant acceleration: `u = 2x / (v + √(vv + two_a·x))`.
    Quadratic {
        /// Speed at the piece's start.
        v: f64,
        /// Its square.
        vv: f64,
        /// Twice the acceleration.
        two_a: f64,
    },
    /// Anything else (jerk-limited, standing still): one distance at a time
    /// through [`TimeCursor::time_in_piece`].
    Other,
}

/// The piece a [`TimeCursor`] is in, with what a caller needs to invert it
/// on its own exactly as [`TimeCursor::time_in_piece`] does: a distance
/// `d` beyond `d_end` is not in it; `x = d − d0` at or below 0 is its start
/// `t0`, at or beyond `span` its end `t0 + duration`, and in between its
/// `form`'s time, at most `duration`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PieceInverse {
    /// Seconds into the profile where the piece starts.
    pub t0: f64,
    /// Seconds it lasts.
    pub duration: f64,
    /// Distance into the profile where it starts.
    pub d0: f64,
    /// Distance it covers.
    pub span: f64,
    /// Where the next non-empty piece starts (infinite in the last).
    pub d_end: f64,
    /// Its inverse.
    pub form: PieceForm,
}

/// Inverts one profile for distances that never decrease.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeCursor {
    /// Index of the current piece.
    index: usize,
    piece: Piece,
    /// Distance where the next non-empty piece starts (infinite in the last).
    d_end: f64,
    solve: Solve,
    /// Distance the piece covers.
    span: f64,
    /// The last answer's time into the piece, where Newton starts.
    u: f64,
}

impl TimeCursor {
    /// A cursor that enters its profile's first piece on its first
    /// question: made for free, so that a channel with no step in a segment
    /// never pays for one.
    pub const START: TimeCursor = TimeCursor {
        index: usize::MAX,
        piece: Piece {
            t0: 0.0,
            d0: 0.0,
            duration: 0.0,
            v: 0.0,
            a: 0.0,
            j: 0.0,
        },
        d_end: f64::NEG_INFINITY,
        solve: Solve::Still,
        span: 0.0,
        u: 0.0,
    };

    /// A cursor at the start of `profile`.
    pub fn new(profile: &Profile) -> TimeCursor {
        let mut c = TimeCursor::START;
        c.enter(profile, 0);
        c
    }

    /// Seconds into `profile` (the one the cursor was made for, or any for
    /// [`TimeCursor::START`]) at which
    /// distance `d` is reached; `d` at least the previous call's.
    #[inline(always)]
    pub fn time_at(&mut self, profile: &Profile, d: f64) -> f64 {
        loop {
            if let Some(t) = self.time_in_piece(d) {
                return t;
            }
            self.next_piece(profile);
        }
    }

    /// [`TimeCursor::time_at`] while `d` lies in the current piece (`None`
    /// past it): needs no profile, so a caller can keep this path short.
    #[inline(always)]
    pub fn time_in_piece(&mut self, d: f64) -> Option<f64> {
        if d > self.d_end {
            return None;
        }
        let p = &self.piece;
        let x = d - p.d0;
        if x <= 0.0 {
            return Some(p.t0);
        }
        if x >= self.span {
            // The piece's end, exactly: near a stop the distance is flat in
            // time and a solve would land anywhere on the flat.
            return Some(p.t0 + p.duration);
        }
        let u = match self.solve {
            Solve::Cruise { per_unit } => x * per_unit,
            Solve::Quadratic { vv, two_a } => {
                let disc = vv + two_a * x;
                let root = sqrt(if disc > 0.0 { disc } else { 0.0 });
                let denom = p.v + root;
                if denom > 0.0 {
                    2.0 * x / denom
                } else {
                    p.duration
                }
            }
            Solve::Cubic {
                half_a,
                sixth_j,
                half_j,
            } => {
                let start = if self.u > 0.0 {
                    self.u
                } else if p.v > 0.0 {
                    x / p.v
                } else if p.a > 0.0 {
                    sqrt(2.0 * x / p.a)
                } else {
                    cbrt(6.0 * x / p.j.abs())
                };
                let u = newton(p, half_a, sixth_j, half_j, x, start);
                self.u = u;
                u
            }
            Solve::Still => 0.0,
        };
        // A plain comparison, not `f64::min`: this runs once per step.
        Some(p.t0 + if u < p.duration { u } else { p.duration })
    }

    /// The piece the cursor is in (the one its last answer came from).
    pub fn piece_inverse(&self) -> PieceInverse {
        let p = &self.piece;
        PieceInverse {
            t0: p.t0,
            duration: p.duration,
            d0: p.d0,
            span: self.span,
            d_end: self.d_end,
            form: match self.solve {
                Solve::Cruise { per_unit } => PieceForm::Cruise { per_unit },
                Solve::Quadratic { vv, two_a } => PieceForm::Quadratic { v: p.v, vv, two_a },
                _ => PieceForm::Other,
            },
        }
    }

    #[inline(never)]
    fn next_piece(&mut self, profile: &Profile) {
        // `START`'s index wraps to the first piece.
        self.enter(profile, self.index.wrapping_add(1));
    }

    /// Moves to the first non-empty piece from `from` on (the last piece if
    /// none is), and prepares its constants.
    fn enter(&mut self, profile: &Profile, from: usize) {
        let mut i = from.min(PIECES - 1);
        while profile.piece_duration(i) <= 0.0 && i + 1 < PIECES {
            i += 1;
        }
        let piece = profile.piece(i);
        // Where the next non-empty piece starts.
        let mut k = i + 1;
        while k < PIECES && profile.piece_duration(k) <= 0.0 {
            k += 1;
        }
        let d_end = if k < PIECES {
            profile.piece(k).d0
        } else {
            f64::INFINITY
        };
        let u = piece.duration;
        self.span = u * (piece.v + u * (0.5 * piece.a + u * piece.j / 6.0));
        if d_end == f64::INFINITY {
            // The last piece ends where the profile does.
            self.span = self.span.min(profile.length() - piece.d0);
        }
        self.index = i;
        self.d_end = d_end;
        self.u = 0.0;
        self.solve = if piece.duration <= 0.0 {
            Solve::Still
        } else if piece.j != 0.0 {
            Solve::Cubic {
                half_a: 0.5 * piece.a,
                sixth_j: piece.j / 6.0,
                half_j: 0.5 * piece.j,
            }
        } else if piece.a != 0.0 {
            Solve::Quadratic {
                vv: piece.v * piece.v,
                two_a: 2.0 * piece.a,
            }
        } else if piece.v > 0.0 {
            Solve::Cruise {
                per_unit: 1.0 / piece.v,
            }
        } else {
            Solve::Still
        };
        self.piece = piece;
    }
}

/// The `u` in `[0, duration]` where the cubic piece has covered `x`: Newton
/// from `start`, kept inside a bracket. Distance is monotone in the piece
/// because speed never goes negative there.
#[inline(never)]
fn newton(p: &Piece, half_a: f64, sixth_j: f64, half_j: f64, x: f64, start: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, p.duration);
    let mut u = start.clamp(lo, hi);
    for _ in 0..60 {
        let dist = u * (p.v + u * (half_a + u * sixth_j));
        let err = dist - x;
        if err > 0.0 {
            hi = u;
        } else {
            lo = u;
        }
        if err.abs() <= 1e-15 * (1.0 + x) || hi - lo <= 1e-15 {
            break;
        }
        let v = p.v + u * (p.a + u * half_j);
        let next = if v > 0.0 {
            u - err / v
        } else {
            0.5 * (lo + hi)
        };
        u = if next > lo && next < hi {
            next
        } else {
            0.5 * (lo + hi)
        };
    }
    u
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::fastest;

    /// Walks each profile's distance in increasing steps and compares the
    /// cursor with the profile's own inverse and with its forward state.
    #[test]
    fn cursor_inverts_the_profile() {
        for (length, v0, v1, vmax, accel, jerk) in crate::profile::tests::CASES {
            let p = fastest(length, v0, v1, vmax, accel, jerk);
            for i in 0..PIECES {
                assert_eq!(p.piece_duration(i), p.piece(i).duration, "{p:?} piece {i}");
            }
            // A cursor from the start and one entering lazily agree.
            let mut lazy = TimeCursor::START;
            let mut c = TimeCursor::new(&p);
            let n = 5000;
            let mut last = -1.0;
            for k in 0..=n {
                let d = length * k as f64 / n as f64;
                let t = c.time_at(&p, d);
                assert_eq!(t, lazy.time_at(&p, d));
                let want = p.time_at(d);
                assert!(t >= last, "{p:?}: time went back at d={d}");
                last = t;
                let (back, v, _) = p.state(t);
                // Where the profile is nearly at rest, distance barely moves
                // in time: compare there in distance only.
                assert!(
                    (t - want).abs() <= 1e-9 * (1.0 + want) || v <= 1e-3 * vmax,
                    "{p:?}: d={d}: cursor {t}, profile {want}"
                );
                assert!(
                    (back - d).abs() <= 1e-9 * (1.0 + d) || v <= 1e-6,
                    "{p:?}: d={d} at t={t} is {back}"
                );
            }
            assert!((c.time_at(&p, length) - p.duration()).abs() <= 1e-9);
        }
    }
}
