//! Predicting each axis's next move from the stream so far, so that a batch
//! carries only the prediction's miss.
//!
//! A job's consecutive moves are alike: along a curve each chord turns a
//! little from the last (a second difference is small), a straight run
//! repeats its step, and an extruder, a riding axis, moves in proportion to
//! the path length (the same millimetres of filament per millimetre of
//! path). No one predictor fits every job: a zigzag infill defeats the
//! second difference that suits a curve. So each axis keeps a running cost
//! of every predictor on its own past moves, and the cheapest one
//! predicts. Encoder and decoder see the same past, so they choose the same
//! predictor without a byte spent on saying which (backward adaptation, as
//! in lossless audio and image coders).
//!
//! Everything here is integer arithmetic on position quanta: both ends get
//! the same prediction on any machine, with or without a floating-point
//! unit.

use motet_trajectory::MAX_AXES;

/// Predictors of an axis's delta: none (0), the last delta, the last delta
/// plus its last change, the last delta scaled by the path lengths.
const PREDICTORS: usize = 4;
const NONE: usize = 0;
const REPEAT: usize = 1;
const CURVE: usize = 2;
const RATIO: usize = 3;

/// Largest prediction, in quanta: far beyond any position (2⁵³ quanta), and
/// small enough that a delta minus a prediction never overflows.
const LIMIT: i64 = 1 << 60;

/// What one axis's past moves tell about its next. Only moves count: a
/// segment in which the axis stays put leaves its history as it was (an
/// extruder resumes after a travel move at the ratio it had).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AxisHistory {
    /// The axis's last delta, quanta.
    d1: i64,
    /// The delta before it.
    d2: i64,
    /// The path length of the last delta's segment, quanta (0: none yet).
    len1: i64,
    /// Each predictor's recent cost: the bit lengths of its misses,
    /// decaying by a quarter every move.
    cost: [u32; PREDICTORS],
}

/// Every axis's history: part of a stream's state, kept in step by encoder
/// and decoder.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct History {
    axes: [AxisHistory; MAX_AXES],
}

impl History {
    /// No moves yet.
    pub const fn new() -> History {
        const NO_MOVES: AxisHistory = AxisHistory {
            d1: 0,
            d2: 0,
            len1: 0,
            cost: [0; PREDICTORS],
        };
        History {
            axes: [NO_MOVES; MAX_AXES],
        }
    }

    /// Sets the path length of axis `i`'s last move, quanta (known on the
    /// node only once every path axis is read).
    pub(crate) fn set_length(&mut self, i: usize, length: i64) {
        self.axes[i].len1 = length;
    }

    /// Axis `i`'s history.
    pub(crate) fn axis(&self, i: usize) -> &AxisHistory {
        &self.axes[i]
    }

    /// Records that axis `i` moved by `delta` in a segment `length` quanta
    /// long, predicted with `known` (the length as known when predicting).
    pub(crate) fn record(&mut self, i: usize, delta: i64, known: Option<i64>, length: i64) {
        self.axes[i].record(delta, known, length);
    }
}

impl AxisHistory {
    /// The candidates' predictions, given the segment's path length in
    /// quanta where it is known before this axis is read.
    fn candidates(&self, length: Option<i64>) -> [Option<i64>; PREDICTORS] {
        let mut c = [None; PREDICTORS];
        c[NONE] = Some(0);
        c[REPEAT] = Some(self.d1);
        c[CURVE] = Some(self.d1.saturating_mul(2).saturating_sub(self.d2));
        c[RATIO] = length.and_then(|l| scale(self.d1, l, self.len1));
        c.map(|p| p.map(|p| p.clamp(-LIMIT, LIMIT)))
    }

    /// The prediction of the next delta, quanta: the cheapest available
    /// predictor's (the lowest-numbered among equals).
    pub(crate) fn predict(&self, length: Option<i64>) -> i64 {
        let c = self.candidates(length);
        let mut best = (u32::MAX, 0);
        for (k, p) in c.iter().enumerate() {
            if let Some(p) = p {
                if self.cost[k] < best.0 {
                    best = (self.cost[k], *p);
                }
            }
        }
        best.1
    }

    fn record(&mut self, delta: i64, known: Option<i64>, length: i64) {
        for (k, p) in self.candidates(known).iter().enumerate() {
            // A predictor that could not predict pays the most a miss costs.
            let bits = p.map_or(64, |p| 64 - zigzag(delta.saturating_sub(p)).leading_zeros());
            self.cost[k] = self.cost[k] - self.cost[k] / 4 + bits;
        }
        self.d2 = self.d1;
        self.d1 = delta;
        self.len1 = length;
    }
}

/// `d · l / len`, rounded to nearest (halves away from zero), when `len` is
/// a length and the result fits.
fn scale(d: i64, l: i64, len: i64) -> Option<i64> {
    if len <= 0 {
        return None;
    }
    let n = d as i128 * l as i128;
    let half = len as i128 / 2;
    let q = if n >= 0 {
        (n + half) / len as i128
    } else {
        (n - half) / len as i128
    };
    i64::try_from(q).ok()
}

fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    /// Feeds `deltas` (with lengths) to one axis; returns each miss.
    fn misses(deltas: &[(i64, i64)], rider: bool) -> Vec<i64> {
        let mut h = AxisHistory::default();
        deltas
            .iter()
            .map(|&(d, len)| {
                let known = rider.then_some(len);
                let miss = d - h.predict(known);
                h.record(d, known, len);
                miss
            })
            .collect()
    }

    #[test]
    fn each_kind_of_motion_finds_its_predictor() {
        // A straight run in equal steps: repeated exactly.
        let run: Vec<_> = (0..20).map(|_| (1234, 1234)).collect();
        assert!(misses(&run, false)[4..].iter().all(|m| *m == 0));
        // Steps growing steadily (a chord of a curve turning): the second
        // difference.
        let grow: Vec<_> = (0..20).map(|k| (1000 + 37 * k, 2000)).collect();
        assert!(misses(&grow, false)[8..].iter().all(|m| *m == 0));
        // An extruder: in proportion to path lengths that vary (the last
        // delta's rounding grows with the ratio of the lengths).
        let lens = [
            1200i64, 530, 2210, 90, 1750, 640, 3000, 410, 980, 1500, 77, 2600,
        ];
        let ride: Vec<_> = lens.iter().map(|&l| (l * 3 / 10, l)).collect();
        let m = misses(&ride, true);
        assert!(m[6..].iter().all(|m| m.abs() <= 5), "{m:?}");
        // A zigzag: the second difference would miss by four times the
        // step; the predictor falls back to less.
        let zig: Vec<_> = (0..20)
            .map(|k| (if k % 2 == 0 { 500 } else { -500 }, 500))
            .collect();
        assert!(misses(&zig, false)[6..].iter().all(|m| m.abs() <= 1000));
    }

    #[test]
    fn scaling_rounds_to_nearest_and_refuses_no_length() {
        assert_eq!(scale(10, 3, 4), Some(8)); // 7.5 → 8
        assert_eq!(scale(-10, 3, 4), Some(-8));
        assert_eq!(scale(10, 1, 3), Some(3));
        assert_eq!(scale(5, 7, 0), None);
        assert_eq!(scale(i64::MAX, i64::MAX, 1), None);
    }

    #[test]
    fn extreme_histories_predict_within_the_limit() {
        let mut h = AxisHistory::default();
        h.record(i64::MAX / 4, Some(1), 1);
        h.record(-(i64::MAX / 4), Some(1), 1);
        for len in [None, Some(i64::MAX), Some(1)] {
            assert!(h.predict(len).abs() <= LIMIT);
        }
    }
}
