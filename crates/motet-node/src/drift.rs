//! The node's own estimate of how fast its clock runs against the host's,
//! reported in its status (`Status::drift`).
//!
//! The host fits the node's clock from whole exchanges; the node sees only
//! half of each: the host's send time `t1` (in the request) and its own
//! arrival time `t2`. Their difference, the forward delay plus the clocks'
//! offset, grows by the node's drift; jitter only ever adds to it. So the
//! node keeps the least difference of its first few exchanges and of its
//! latest few, and the drift is their change over the host time between
//! them. A check that does not depend on the host's fit: a node whose own
//! figure disagrees with the host's estimate has a clock, a path or a host
//! worth looking at.
//!
//! Integer arithmetic and two small records: it runs on any board.

use motet_wire::service::Drift;

/// Exchanges whose least delay makes one edge.
const BUCKET: u8 = 8;
/// The drift is reported once the two edges are this far apart, µs of host
/// time: over less, jitter would dominate it.
const MIN_SPAN_US: u64 = 1_000_000;

/// The least `t2 − t1` over some exchanges, and the host time it was seen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Edge {
    t1: u64,
    delay: i64,
    count: u8,
}

impl Edge {
    fn new(t1: u64, delay: i64) -> Edge {
        Edge {
            t1,
            delay,
            count: 1,
        }
    }

    fn take(&mut self, t1: u64, delay: i64) {
        if delay < self.delay {
            self.delay = delay;
            self.t1 = t1;
        }
        self.count += 1;
    }

    fn full(&self) -> bool {
        self.count >= BUCKET
    }
}

/// Edges of the node's first and latest exchanges.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DriftMeter {
    first: Option<Edge>,
    /// The edge being gathered after the first.
    open: Option<Edge>,
    /// The latest complete edge after the first.
    last: Option<Edge>,
    /// The host's send time of the latest exchange.
    newest_t1: u64,
}

impl DriftMeter {
    /// Takes an exchange: the host sent it at `t1` (host µs), it arrived at
    /// `t2` (node µs). A host clock that went back (a new host) starts the
    /// meter again.
    pub fn take(&mut self, t1: u64, t2: u64) {
        if t1 < self.newest_t1 {
            *self = DriftMeter::default();
        }
        self.newest_t1 = t1;
        let delay = (t2 as i128 - t1 as i128).clamp(i64::MIN as i128, i64::MAX as i128) as i64;
        match (&mut self.first, &mut self.open) {
            (None, _) => self.first = Some(Edge::new(t1, delay)),
            (Some(f), _) if !f.full() => f.take(t1, delay),
            (Some(_), None) => self.open = Some(Edge::new(t1, delay)),
            (Some(_), Some(o)) => o.take(t1, delay),
        }
        if self.open.is_some_and(|o| o.full()) {
            self.last = self.open.take();
        }
    }

    /// The drift between the first and latest edges, once they are far
    /// enough apart.
    pub fn drift(&self) -> Option<Drift> {
        let (first, last) = (self.first?, self.last?);
        let span = last.t1.checked_sub(first.t1)?;
        if span < MIN_SPAN_US {
            return None;
        }
        let ppb = (last.delay as i128 - first.delay as i128) * 1_000_000_000 / span as i128;
        Some(Drift {
            ppb: ppb.clamp(i32::MIN as i128 + 1, i32::MAX as i128) as i32,
            span_s: (span / 1_000_000).min(u32::MAX as u64) as u32,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A node clock at `ppm`, exchanges every `every` µs with a delay that
    /// cycles through `jitter` (µs).
    fn meter(ppm: f64, every: u64, n: u64, jitter: &[u64]) -> DriftMeter {
        let mut m = DriftMeter::default();
        for k in 0..n {
            let t1 = 1_000_000 + k * every;
            let arrive = t1 + 50 + jitter[k as usize % jitter.len()];
            let t2 = 9_000_000_000 + (arrive as f64 * (1.0 + ppm * 1e-6)) as u64;
            m.take(t1, t2);
        }
        m
    }

    #[test]
    fn measures_the_drift_through_jitter() {
        let jitter = [0, 730, 212, 999, 5, 480, 61, 333, 870, 140];
        for ppm in [200.0, -150.0, 0.0, 37.5] {
            let d = meter(ppm, 1_000_000, 600, &jitter).drift().unwrap();
            assert!((d.ppb as f64 - ppm * 1e3).abs() < 500.0, "{ppm}: {d:?}");
            assert!(d.span_s >= 500);
        }
    }

    #[test]
    fn nothing_before_the_span_and_a_new_host_starts_again() {
        assert_eq!(meter(100.0, 10_000, 50, &[0]).drift(), None);
        let mut m = meter(100.0, 1_000_000, 100, &[0]);
        assert!(m.drift().is_some());
        m.take(5, 9_000_000_000);
        assert_eq!(m.drift(), None);
    }
}
