//! The host's view of the contingency tail: the same computation the nodes
//! make (`motet_trajectory::contingency`), for the seal deadline and the
//! stop report.

use motet_trajectory::contingency::{Contingency, TailError};
use motet_trajectory::Segment;

/// When the next seal must reach the nodes (the tail's start, µs) and the
/// index of the first tail segment in `segs`. A window with no room to stop
/// (or no segments) has no deadline in the future: `-∞`.
pub fn deadline<'a>(segs: impl IntoIterator<Item = &'a Segment>) -> (f64, usize) {
    let v: Vec<&Segment> = segs.into_iter().collect();
    match Contingency::of(v.iter().copied()) {
        Ok(c) => (c.start_time, c.start),
        Err(TailError::Empty) | Err(TailError::NoRoom) => (f64::NEG_INFINITY, 0),
    }
}

/// When a machine running the committed `segs` and then its tail is at rest, µs.
pub fn rest_time<'a>(segs: impl IntoIterator<Item = &'a Segment>, now: f64) -> f64 {
    let v: Vec<&Segment> = segs.into_iter().collect();
    let Ok(c) = Contingency::of(v.iter().copied()) else {
        return v.last().map_or(now, |s| s.t1());
    };
    let mut walk = c.walk();
    let mut end = v.last().map_or(now, |s| s.t1());
    for s in &v[c.start..] {
        end = walk.next(s).t1();
    }
    end
}
