//! Speed along the path over the time of one segment.
//!
//! A profile ramps from the entry speed `v0` to the cruise speed `vc`, cruises, and
//! ramps to the exit speed `v1`. Ramps are constant-acceleration (trapezoid) or,
//! when a jerk limit is set, jerk-limited S-curves. Ramps are symmetric in time,
//! so a ramp's distance is always `(v_from + v_to) / 2 * duration`, which keeps
//! the planner's arithmetic the same for both kinds.
//!
//! Units: path distance in machine units (mm), time in seconds, speeds in
//! units/s. Segment time stamps elsewhere are in microseconds.

use crate::math::{cbrt, sqrt};
use serde::{Deserialize, Serialize};

/// The shape of a profile's ramps, chosen per machine (`profile` in the
/// machine file's `[motion]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ProfileKind {
    /// Constant acceleration ramps.
    Trapezoid,
    /// Jerk-limited ramps.
    SCurve,
}

/// One speed change at bounded acceleration (and jerk, for S-curves).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Ramp {
    v_from: f64,
    /// +1 when speeding up, -1 when slowing down.
    sign: f64,
    /// Peak acceleration magnitude reached.
    accel: f64,
    /// Jerk magnitude; 0 for a constant-acceleration ramp.
    jerk: f64,
    /// Duration of each jerk phase (0 for trapezoid ramps).
    t_jerk: f64,
    /// Duration of the constant-acceleration phase.
    t_const: f64,
}

impl Ramp {
    /// A ramp from `v_from` to `v_to` with acceleration limit `accel` and jerk
    /// limit `jerk` (0 = unlimited).
    pub(crate) fn new(v_from: f64, v_to: f64, accel: f64, jerk: f64) -> Ramp {
        let dv = v_to - v_from;
        let sign = if dv < 0.0 { -1.0 } else { 1.0 };
        let dv = dv * sign;
        if dv <= 0.0 || accel <= 0.0 {
            return Ramp {
                v_from,
                sign,
                accel: 0.0,
                jerk: 0.0,
                t_jerk: 0.0,
                t_const: 0.0,
            };
        }
        if jerk <= 0.0 {
            return Ramp {
                v_from,
                sign,
                accel,
                jerk: 0.0,
                t_jerk: 0.0,
                t_const: dv / accel,
            };
        }
        if dv * jerk >= accel * accel {
            let t_jerk = accel / jerk;
            Ramp {
                v_from,
                sign,
                accel,
                jerk,
                t_jerk,
                t_const: dv / accel - t_jerk,
            }
        } else {
            let t_jerk = sqrt(dv / jerk);
            Ramp {
                v_from,
                sign,
                accel: jerk * t_jerk,
                jerk,
                t_jerk,
                t_const: 0.0,
            }
        }
    }

    /// Seconds the ramp takes.
    #[inline]
    pub(crate) fn duration(&self) -> f64 {
        2.0 * self.t_jerk + self.t_const
    }

    /// Speed at the ramp's end (units/s).
    #[inline]
    pub(crate) fn v_to(&self) -> f64 {
        self.v_from + self.sign * self.accel * (self.t_jerk + self.t_const)
    }

    /// Distance the ramp covers: the mean of its end speeds times its
    /// duration, since ramps are symmetric in time.
    #[inline]
    pub(crate) fn distance(&self) -> f64 {
        0.5 * (self.v_from + self.v_to()) * self.duration()
    }

    /// (distance, speed, acceleration) at time `t` into the ramp (clamped).
    pub(crate) fn state(&self, t: f64) -> (f64, f64, f64) {
        let t = t.clamp(0.0, self.duration());
        let (s, a, j) = (self.sign, self.accel, self.jerk);
        let v0 = self.v_from;
        if self.t_jerk == 0.0 {
            return (v0 * t + 0.5 * s * a * t * t, v0 + s * a * t, s * a);
        }
        let tj = self.t_jerk;
        // End of the first jerk phase.
        let v1 = v0 + s * 0.5 * j * tj * tj;
        let d1 = v0 * tj + s * j * tj * tj * tj / 6.0;
        if t <= tj {
            return (
                v0 * t + s * j * t * t * t / 6.0,
                v0 + s * 0.5 * j * t * t,
                s * j * t,
            );
        }
        let tc = self.t_const;
        if t <= tj + tc {
            let u = t - tj;
            return (d1 + v1 * u + 0.5 * s * a * u * u, v1 + s * a * u, s * a);
        }
        let v2 = v1 + s * a * tc;
        let d2 = d1 + v1 * tc + 0.5 * s * a * tc * tc;
        let u = t - tj - tc;
        (
            d2 + v2 * u + s * (0.5 * a * u * u - j * u * u * u / 6.0),
            v2 + s * (a * u - 0.5 * j * u * u),
            s * (a - j * u),
        )
    }

    /// Piece `k` (0: jerk rising, 1: constant acceleration, 2: jerk falling)
    /// of the ramp, starting `t0` seconds and `d0` units into the profile. The
    /// start speeds and distances are those [`Ramp::state`] gives, so both
    /// agree on where a piece begins.
    fn piece(&self, k: usize, t0: f64, d0: f64) -> Piece {
        let (s, a, j) = (self.sign, self.accel, self.jerk);
        let tj = self.t_jerk;
        match k {
            0 => Piece {
                t0,
                d0,
                duration: tj,
                v: self.v_from,
                a: 0.0,
                j: s * j,
            },
            1 => {
                let (d, v, _) = self.state(tj);
                Piece {
                    t0: t0 + tj,
                    d0: d0 + d,
                    duration: self.t_const,
                    v,
                    a: s * a,
                    j: 0.0,
                }
            }
            _ => {
                let t = tj + self.t_const;
                let (d, v, _) = self.state(t);
                Piece {
                    t0: t0 + t,
                    d0: d0 + d,
                    duration: tj,
                    v,
                    a: s * a,
                    j: -s * j,
                }
            }
        }
    }

    /// Time at which the ramp has covered distance `d` (clamped to the ramp).
    pub(crate) fn time_at(&self, d: f64) -> f64 {
        let total = self.duration();
        if d <= 0.0 || total == 0.0 {
            return 0.0;
        }
        if d >= self.distance() {
            return total;
        }
        if self.t_jerk == 0.0 {
            // v0 t + ½ s a t² = d, solved without cancellation.
            let disc = self.v_from * self.v_from + 2.0 * self.sign * self.accel * d;
            let root = sqrt(disc.max(0.0));
            let denom = self.v_from + root;
            return if denom > 0.0 {
                (2.0 * d / denom).min(total)
            } else {
                total
            };
        }
        // Newton on the cubic pieces, kept inside a bracket; distance is monotone
        // because speed never goes negative within a ramp.
        let (mut lo, mut hi) = (0.0, total);
        let mut t = if self.v_from > 0.0 {
            (d / self.v_from).min(total)
        } else {
            cbrt(6.0 * d / self.jerk).min(total)
        };
        for _ in 0..60 {
            let (dist, v, _) = self.state(t);
            let err = dist - d;
            if err > 0.0 {
                hi = t;
            } else {
                lo = t;
            }
            if err.abs() <= 1e-15 * (1.0 + d) || hi - lo <= 1e-15 {
                break;
            }
            let next = if v > 0.0 {
                t - err / v
            } else {
                0.5 * (lo + hi)
            };
            t = if next > lo && next < hi {
                next
            } else {
                0.5 * (lo + hi)
            };
        }
        t
    }
}

/// One polynomial piece of a profile: `d0 + v u + a u²/2 + j u³/6` units
/// covered `u` seconds after `t0`, for `u` in `0..=duration`. Speed never goes
/// negative inside a piece, so distance is monotone there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    /// Seconds into the profile where the piece starts.
    pub t0: f64,
    /// Distance into the profile where the piece starts.
    pub d0: f64,
    /// Seconds the piece lasts; 0 for a piece the profile does not have.
    pub duration: f64,
    /// Speed at the piece's start (units/s, never negative).
    pub v: f64,
    /// Acceleration at the piece's start (units/s²; negative when slowing).
    pub a: f64,
    /// Jerk, constant over the piece (units/s³; 0 in trapezoid profiles and
    /// in the constant-acceleration and cruise pieces).
    pub j: f64,
}

/// How many pieces a profile has, empty ones included: three per ramp and
/// the cruise.
pub const PIECES: usize = 7;

/// A segment's speed over time: ramp, cruise, ramp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile {
    length: f64,
    v0: f64,
    vc: f64,
    v1: f64,
    ramp_in: Ramp,
    ramp_out: Ramp,
    /// Seconds at `vc`.
    cruise: f64,
    /// The limits the ramps were built with (a ramp may peak below them).
    accel: f64,
    jerk: f64,
}

/// The parameters a profile is rebuilt from on a node; everything else is derived
/// by the same code on both ends, so host and node agree bit for bit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProfileParams {
    /// Path length (mm); 0 for a dwell.
    pub length: f64,
    /// Entry speed (units/s).
    pub v0: f64,
    /// Cruise speed (units/s); the ramps to and from it fit into `length`.
    pub vc: f64,
    /// Exit speed (units/s).
    pub v1: f64,
    /// Acceleration limit the ramps were built with (units/s²).
    pub accel: f64,
    /// Jerk limit (units/s³); 0 for trapezoid ramps.
    pub jerk: f64,
    /// Seconds of standing still, for dwells (`length == 0`).
    pub dwell: f64,
}

impl Profile {
    /// A move of `length` entering at `v0`, cruising at `vc` and leaving at `v1`.
    /// `vc` must be reachable: the two ramps must fit into `length`.
    pub fn new(length: f64, v0: f64, vc: f64, v1: f64, accel: f64, jerk: f64) -> Profile {
        let ramp_in = Ramp::new(v0, vc, accel, jerk);
        let ramp_out = Ramp::new(vc, v1, accel, jerk);
        let rest = length - ramp_in.distance() - ramp_out.distance();
        let cruise = if vc > 0.0 { (rest / vc).max(0.0) } else { 0.0 };
        Profile {
            length,
            v0,
            vc,
            v1,
            ramp_in,
            ramp_out,
            cruise,
            accel,
            jerk,
        }
    }

    /// Standing still for `seconds`.
    pub fn dwell(seconds: f64) -> Profile {
        let ramp = Ramp::new(0.0, 0.0, 0.0, 0.0);
        Profile {
            length: 0.0,
            v0: 0.0,
            vc: 0.0,
            v1: 0.0,
            ramp_in: ramp,
            ramp_out: ramp,
            cruise: seconds.max(0.0),
            accel: 0.0,
            jerk: 0.0,
        }
    }

    /// Rebuilds the profile [`Profile::params`] gave, bit for bit: what a
    /// node does with the parameters the wire carries.
    pub fn from_params(p: &ProfileParams) -> Profile {
        if p.length == 0.0 {
            Profile::dwell(p.dwell)
        } else {
            Profile::new(p.length, p.v0, p.vc, p.v1, p.accel, p.jerk)
        }
    }

    /// The parameters that rebuild this profile on a node
    /// ([`Profile::from_params`]).
    pub fn params(&self) -> ProfileParams {
        ProfileParams {
            length: self.length,
            v0: self.v0,
            vc: self.vc,
            v1: self.v1,
            accel: self.accel,
            jerk: self.jerk,
            dwell: if self.length == 0.0 { self.cruise } else { 0.0 },
        }
    }

    /// Path length (mm); 0 for a dwell.
    #[inline]
    pub fn length(&self) -> f64 {
        self.length
    }
    /// Entry speed (units/s): the previous segment's exit speed.
    #[inline]
    pub fn v0(&self) -> f64 {
        self.v0
    }
    /// Cruise speed (units/s), the highest the profile reaches.
    #[inline]
    pub fn vc(&self) -> f64 {
        self.vc
    }
    /// Exit speed (units/s): the next segment's entry speed.
    #[inline]
    pub fn v1(&self) -> f64 {
        self.v1
    }

    /// Seconds from entry to exit.
    #[inline]
    pub fn duration(&self) -> f64 {
        self.ramp_in.duration() + self.cruise + self.ramp_out.duration()
    }

    /// Distance the two ramps take; at most [`Profile::length`] in a plan
    /// (the planner lowers speeds until they fit).
    pub fn ramps_length(&self) -> f64 {
        self.ramp_in.distance() + self.ramp_out.distance()
    }

    /// Largest |acceleration| along the path anywhere in the profile
    /// (units/s²); at most the limit it was built with.
    pub fn peak_accel(&self) -> f64 {
        self.ramp_in.accel.max(self.ramp_out.accel)
    }

    /// (distance, speed, acceleration) at `t` seconds into the segment.
    pub fn state(&self, t: f64) -> (f64, f64, f64) {
        let t1 = self.ramp_in.duration();
        if t <= t1 {
            return self.ramp_in.state(t);
        }
        let d1 = self.ramp_in.distance();
        if t <= t1 + self.cruise {
            return (d1 + self.vc * (t - t1), self.vc, 0.0);
        }
        let d2 = d1 + self.vc * self.cruise;
        let (d, v, a) = self.ramp_out.state(t - t1 - self.cruise);
        ((d2 + d).min(self.length), v, a)
    }

    /// Distance covered `t` seconds into the segment.
    #[inline]
    pub fn distance_at(&self, t: f64) -> f64 {
        self.state(t).0
    }

    /// [`Profile::piece`]`(i).duration`, without computing the piece.
    #[inline]
    pub fn piece_duration(&self, i: usize) -> f64 {
        match i {
            0 | 2 => self.ramp_in.t_jerk,
            1 => self.ramp_in.t_const,
            3 if self.vc > 0.0 => self.cruise,
            3 => 0.0,
            5 => self.ramp_out.t_const,
            _ => self.ramp_out.t_jerk,
        }
    }

    /// Piece `i` (`0..PIECES`: the entry ramp's three, the cruise, the exit
    /// ramp's three); a piece a profile does not have has duration 0.
    pub fn piece(&self, i: usize) -> Piece {
        let t1 = self.ramp_in.duration();
        let d1 = self.ramp_in.distance();
        match i {
            0..=2 => self.ramp_in.piece(i, 0.0, 0.0),
            3 => Piece {
                t0: t1,
                d0: d1,
                duration: if self.vc > 0.0 { self.cruise } else { 0.0 },
                v: self.vc,
                a: 0.0,
                j: 0.0,
            },
            _ => self
                .ramp_out
                .piece((i - 4).min(2), t1 + self.cruise, d1 + self.vc * self.cruise),
        }
    }

    /// Seconds into the segment at which distance `d` is reached: the inverse of
    /// [`Profile::distance_at`]. Exact (closed form) for trapezoid ramps.
    pub fn time_at(&self, d: f64) -> f64 {
        let d1 = self.ramp_in.distance();
        if d <= d1 {
            return self.ramp_in.time_at(d);
        }
        let t1 = self.ramp_in.duration();
        let d2 = d1 + self.vc * self.cruise;
        if d <= d2 && self.vc > 0.0 {
            return t1 + (d - d1) / self.vc;
        }
        t1 + self.cruise + self.ramp_out.time_at(d - d2)
    }
}

/// Distance needed to change speed from `v_from` to `v_to`.
#[inline]
pub fn ramp_distance(v_from: f64, v_to: f64, accel: f64, jerk: f64) -> f64 {
    if jerk <= 0.0 {
        let d = (v_to * v_to - v_from * v_from).abs();
        return if accel > 0.0 {
            d / (2.0 * accel)
        } else {
            f64::INFINITY
        };
    }
    Ramp::new(v_from, v_to, accel, jerk).distance()
}

/// The highest speed reachable from `v_from` within `distance` (speeding up).
/// Symmetric: also the highest speed from which `v_from` can be reached.
pub fn reachable_speed(v_from: f64, distance: f64, accel: f64, jerk: f64) -> f64 {
    let trapezoid = sqrt(v_from * v_from + 2.0 * accel * distance);
    if jerk <= 0.0 {
        return trapezoid;
    }
    // Jerk only slows ramps down, so the trapezoid bound brackets the answer.
    let (mut lo, mut hi) = (v_from, trapezoid);
    for _ in 0..64 {
        let mid = 0.5 * (lo + hi);
        if ramp_distance(v_from, mid, accel, jerk) <= distance {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi {
            break;
        }
    }
    lo
}

/// The longest distance a ramp down from `v` to any speed in `[floor, v]`
/// takes. A jerk-limited ramp down is not monotone in where it ends: its
/// length grows as the end speed falls from `v` down to `u*` and shrinks
/// below it (from `v`, stopping can take less room than slowing to a third
/// of `v`). `u*` is `v/3` while the ramp never reaches `accel`
/// (`v < 1.5 accel²/jerk`) and `accel²/(2 jerk)` beyond; so the longest is
/// the ramp to `max(floor, u*)`. Without a jerk limit it is the ramp to
/// `floor`.
pub fn longest_ramp_down(v: f64, floor: f64, accel: f64, jerk: f64) -> f64 {
    let floor = floor.min(v);
    if jerk <= 0.0 {
        return ramp_distance(v, floor, accel, jerk);
    }
    let knee = accel * accel / jerk;
    let u_star = if v < 1.5 * knee { v / 3.0 } else { 0.5 * knee };
    ramp_distance(v, floor.max(u_star), accel, jerk)
}

/// The highest entry speed from which a move of `distance` can slow to
/// `exit` and to every exit above it (see [`longest_ramp_down`]): a planner
/// fixes a move's entry while its exit may still rise as later moves come,
/// and every exit it may get must stay within reach.
pub fn reachable_entry(exit: f64, distance: f64, accel: f64, jerk: f64) -> f64 {
    let trapezoid = reachable_speed(exit, distance, accel, 0.0);
    if jerk <= 0.0 {
        return trapezoid;
    }
    // Jerk only lengthens ramps: the trapezoid bound brackets the answer, and
    // the longest ramp down grows with the entry speed.
    let (mut lo, mut hi) = (exit, trapezoid);
    for _ in 0..64 {
        let mid = 0.5 * (lo + hi);
        if longest_ramp_down(mid, exit, accel, jerk) <= distance {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi {
            break;
        }
    }
    lo
}

/// The fastest profile over `length` from `v0` to `v1` with cruise speed at most
/// `v_max`. The caller guarantees `v0` and `v1` are mutually reachable.
pub fn fastest(length: f64, v0: f64, v1: f64, v_max: f64, accel: f64, jerk: f64) -> Profile {
    let floor = v0.max(v1);
    let peak = if jerk <= 0.0 {
        sqrt(((2.0 * accel * length + v0 * v0 + v1 * v1) * 0.5).max(0.0))
    } else {
        let fits = |vc: f64| {
            ramp_distance(v0, vc, accel, jerk) + ramp_distance(vc, v1, accel, jerk) <= length
        };
        if fits(v_max) {
            v_max
        } else {
            let (mut lo, mut hi) = (floor, v_max);
            for _ in 0..64 {
                let mid = 0.5 * (lo + hi);
                if fits(mid) {
                    lo = mid;
                } else {
                    hi = mid;
                }
                if hi - lo <= 1e-12 * hi {
                    break;
                }
            }
            lo
        }
    };
    let vc = peak.min(v_max).max(floor);
    Profile::new(length, v0, vc, v1, accel, jerk)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    fn check_profile(p: &Profile, accel: f64) {
        let n = 2000;
        let dur = p.duration();
        let mut last = -1.0;
        for i in 0..=n {
            let t = dur * i as f64 / n as f64;
            let (d, v, a) = p.state(t);
            assert!(d >= last - 1e-9, "distance went back at t={t}");
            assert!(v >= -1e-9, "negative speed {v}");
            assert!(a.abs() <= accel * (1.0 + 1e-9), "accel {a} over {accel}");
            last = d;
            // The inverse gives back the time.
            if v > 1e-6 {
                let back = p.time_at(d);
                assert!((back - t).abs() < 1e-9, "time_at({d}) = {back}, want {t}");
            }
        }
        assert!((p.distance_at(dur) - p.length()).abs() < 1e-9 * (1.0 + p.length()));
    }

    /// Profiles the tests walk: (length, v0, v1, vmax, accel, jerk):
    /// trapezoids and S-curves, reaching cruise or not, short and long.
    pub(crate) const CASES: [(f64, f64, f64, f64, f64, f64); 10] = [
        (10.0, 0.0, 0.0, 100.0, 1000.0, 0.0),
        (10.0, 0.0, 0.0, 1000.0, 1000.0, 0.0),
        (1.0, 20.0, 5.0, 100.0, 500.0, 0.0),
        (100.0, 50.0, 50.0, 80.0, 3000.0, 0.0),
        (100.0, 80.0, 80.0, 80.0, 3000.0, 0.0),
        (10.0, 0.0, 0.0, 100.0, 1000.0, 50_000.0),
        (10.0, 0.0, 0.0, 1000.0, 1000.0, 10_000.0),
        (0.5, 10.0, 12.0, 200.0, 2000.0, 100_000.0),
        (0.01, 0.0, 0.0, 200.0, 2000.0, 100_000.0),
        (3.0, 4.0, 2.0, 60.0, 800.0, 30_000.0),
    ];

    #[test]
    fn profiles_are_consistent() {
        for (length, v0, v1, vmax, accel, jerk) in CASES {
            let p = fastest(length, v0, v1, vmax, accel, jerk);
            assert!(p.vc() <= vmax + 1e-9);
            assert!((p.v0() - v0).abs() < 1e-9 && (p.v1() - v1).abs() < 1e-9);
            check_profile(&p, accel);
        }
    }

    #[test]
    fn trapezoid_matches_textbook() {
        // 0 → 100 mm/s at 1000 mm/s² takes 0.1 s and 5 mm each way.
        let p = fastest(20.0, 0.0, 0.0, 100.0, 1000.0, 0.0);
        assert!((p.duration() - (0.1 + 0.1 + 10.0 / 100.0)).abs() < 1e-12);
        // Triangle: peak sqrt(a L) for a short move from rest to rest.
        let p = fastest(1.0, 0.0, 0.0, 1000.0, 1000.0, 0.0);
        assert!((p.vc() - (1000.0f64).sqrt()).abs() < 1e-9);
    }

    #[test]
    fn scurve_ramp_distance_is_mean_speed_times_time() {
        for (a, b, acc, j) in [
            (0.0, 100.0, 1000.0, 10_000.0),
            (50.0, 10.0, 500.0, 1e6),
            (0.0, 1.0, 1000.0, 1e4),
        ] {
            let r = Ramp::new(a, b, acc, j);
            let (d, v, _) = r.state(r.duration());
            assert!((v - b).abs() < 1e-9);
            assert!((d - r.distance()).abs() < 1e-9);
        }
    }

    #[test]
    fn reachable_speed_inverts_ramp_distance() {
        for jerk in [0.0, 20_000.0] {
            let v = reachable_speed(10.0, 3.0, 1000.0, jerk);
            assert!((ramp_distance(10.0, v, 1000.0, jerk) - 3.0).abs() < 1e-6);
        }
    }

    #[test]
    fn longest_ramp_down_is_the_worst_end_speed() {
        // Below and above the knee (1.5 accel²/jerk = 37.5 here), from
        // several floors: the closed form against the largest of 20,000
        // sampled end speeds.
        let (accel, jerk) = (1000.0, 40_000.0);
        for v in [2.0, 20.0, 37.0, 38.0, 80.0, 300.0] {
            for floor in [0.0, 0.1 * v, 0.3 * v, 0.5 * v, v] {
                let n = 20_000;
                let brute = (0..=n)
                    .map(|k| floor + (v - floor) * k as f64 / n as f64)
                    .map(|u| ramp_distance(v, u, accel, jerk))
                    .fold(0.0, f64::max);
                let closed = longest_ramp_down(v, floor, accel, jerk);
                assert!(
                    closed >= brute * (1.0 - 1e-12),
                    "v {v} floor {floor}: {closed} < {brute}"
                );
                assert!(
                    closed <= brute * (1.0 + 1e-6) + 1e-12,
                    "v {v} floor {floor}: {closed} > {brute}"
                );
            }
            let d = 0.05 * v;
            let e = reachable_entry(0.0, d, accel, jerk);
            assert!((longest_ramp_down(e, 0.0, accel, jerk) - d).abs() < 1e-9 * d.max(1.0));
        }
    }

    #[test]
    fn dwell_stands_still() {
        let p = Profile::dwell(0.25);
        assert_eq!(p.duration(), 0.25);
        assert_eq!(p.state(0.1), (0.0, 0.0, 0.0));
        let q = Profile::from_params(&p.params());
        assert_eq!(p, q);
    }

    #[test]
    fn params_round_trip() {
        let p = fastest(3.0, 4.0, 2.0, 60.0, 800.0, 0.0);
        assert_eq!(Profile::from_params(&p.params()), p);
        let p = fastest(3.0, 4.0, 2.0, 60.0, 800.0, 30_000.0);
        assert_eq!(Profile::from_params(&p.params()), p);
    }
}
