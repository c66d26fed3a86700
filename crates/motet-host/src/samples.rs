//! Samples the nodes send upstream, kept on the host per source for the
//! report's plots, and watched for silence.
//!
//! What a source keeps is bounded whatever the run's length: at most
//! [`MAX_POINTS`] points; when full, neighbours are merged in pairs (the
//! later point's time and value, the least and most of their ranges), so
//! a long run keeps its peaks at a coarser step.

use crate::loops::source_name;
use crate::machine::Machine;
use motet_wire::control::{SampleBatch, SampleData, SampleSource};

/// Most points a series keeps.
pub const MAX_POINTS: usize = 4096;

/// A source silent this long (host time) while its loop runs has stopped
/// reporting, µs: a batch goes at least every second.
pub const SILENCE_US: f64 = 3e6;

/// One point of a series: at `t_us`, `value` (a servo's measured counts, a
/// sensor's reading), with the least and most of what it stands for (a
/// servo's following error, counts; a sensor's reading).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplePoint {
    /// Host time, µs.
    pub t_us: f64,
    /// The measured position (counts) or the reading.
    pub value: f64,
    /// Least following error (counts) or reading over the window.
    pub lo: f64,
    /// Most following error (counts) or reading over the window.
    pub hi: f64,
}

impl SamplePoint {
    fn merge(self, later: SamplePoint) -> SamplePoint {
        SamplePoint {
            t_us: later.t_us,
            value: later.value,
            lo: self.lo.min(later.lo),
            hi: self.hi.max(later.hi),
        }
    }
}

/// One source's samples.
#[derive(Clone, Debug)]
pub struct Series {
    /// The machine node (index into `Machine::nodes`).
    pub node: usize,
    /// The loop on it.
    pub source: SampleSource,
    /// `actuator x_axis`, `sensor accel`.
    pub name: String,
    /// In time order.
    pub points: Vec<SamplePoint>,
    /// Samples each point stands for.
    stride: usize,
    /// Samples merged toward the next point.
    acc: Option<(SamplePoint, usize)>,
    /// Samples taken in all, and lost on the node.
    pub received: u64,
    /// Lost on the node (its queue was full).
    pub dropped: u64,
    /// Bytes of their messages (payload, without frames).
    pub bytes: u64,
    /// Host time of the last batch taken, µs.
    pub heard_at: f64,
}

impl Series {
    /// An empty series of `source` on node `node`, named `name`.
    pub fn new(node: usize, source: SampleSource, name: String) -> Series {
        Series {
            node,
            source,
            name,
            points: Vec::new(),
            stride: 1,
            acc: None,
            received: 0,
            dropped: 0,
            bytes: 0,
            heard_at: f64::NEG_INFINITY,
        }
    }

    /// Adds a point (bounded: see the module's description).
    pub fn push(&mut self, p: SamplePoint) {
        self.received += 1;
        let (acc, n) = match self.acc.take() {
            Some((a, n)) => (a.merge(p), n + 1),
            None => (p, 1),
        };
        if n < self.stride {
            self.acc = Some((acc, n));
            return;
        }
        self.points.push(acc);
        if self.points.len() >= MAX_POINTS {
            let merged = self
                .points
                .chunks(2)
                .map(|c| c.iter().copied().reduce(SamplePoint::merge).unwrap_or(c[0]))
                .collect();
            self.points = merged;
            self.stride *= 2;
        }
    }

    /// The points, the one being merged included.
    pub fn all_points(&self) -> impl Iterator<Item = &SamplePoint> {
        self.points.iter().chain(self.acc.as_ref().map(|(p, _)| p))
    }
}

/// Every source's samples.
#[derive(Clone, Debug, Default)]
pub struct SampleStore {
    /// One per source heard from, in the order first heard.
    pub series: Vec<Series>,
}

impl SampleStore {
    /// An empty store.
    pub fn new() -> SampleStore {
        SampleStore::default()
    }

    /// The series of `source` on node `node`, made when first asked for.
    fn series_mut(&mut self, machine: &Machine, node: usize, source: SampleSource) -> &mut Series {
        let i = match self
            .series
            .iter()
            .position(|s| s.node == node && s.source == source)
        {
            Some(i) => i,
            None => {
                let name = source_name(machine, node, source);
                self.series.push(Series::new(node, source, name));
                self.series.len() - 1
            }
        };
        &mut self.series[i]
    }

    /// Expects samples of `source` on node `node` from host time `now` on
    /// (the silence watch starts then).
    pub fn expect(&mut self, machine: &Machine, node: usize, source: SampleSource, now: f64) {
        let s = self.series_mut(machine, node, source);
        if s.heard_at == f64::NEG_INFINITY {
            s.heard_at = now;
        }
    }

    /// Takes a batch from node `node`, `bytes` long, at host time `now`.
    pub fn take(
        &mut self,
        machine: &Machine,
        node: usize,
        b: &SampleBatch,
        bytes: usize,
        now: f64,
    ) {
        let s = self.series_mut(machine, node, b.source);
        s.bytes += bytes as u64;
        s.dropped += b.dropped as u64;
        s.heard_at = s.heard_at.max(now);
        let period = b.period_us as f64;
        match &b.data {
            SampleData::Servo { base, samples } => {
                let mut count = *base;
                for (i, x) in samples.iter().enumerate() {
                    count = count.wrapping_add(x.delta as i64);
                    s.push(SamplePoint {
                        t_us: b.t0 + i as f64 * period,
                        value: count as f64,
                        lo: x.error_lo as f64 / 16.0,
                        hi: x.error_hi as f64 / 16.0,
                    });
                }
            }
            SampleData::Values(values) => {
                for (i, v) in values.iter().enumerate() {
                    let v = *v as f64;
                    s.push(SamplePoint {
                        t_us: b.t0 + i as f64 * period,
                        value: v,
                        lo: v,
                        hi: v,
                    });
                }
            }
        }
    }

    /// The first source not heard from for [`SILENCE_US`] at host time
    /// `now`, among those not in `quiet` (faulted, or not running).
    pub fn silent(&self, now: f64, quiet: impl Fn(&Series) -> bool) -> Option<&Series> {
        self.series
            .iter()
            .find(|s| !quiet(s) && now - s.heard_at > SILENCE_US)
    }

    /// The series of `source` on node `node`.
    pub fn get(&self, node: usize, source: SampleSource) -> Option<&Series> {
        self.series
            .iter()
            .find(|s| s.node == node && s.source == source)
    }
}
