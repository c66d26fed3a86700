//! A heater's samples as the host keeps them: a bounded trace for its plot
//! (reading, target and power against time) and running figures of each
//! heat-up (how far it overshot, when it settled within its window), the
//! waits for it and how it stopped.
//!
//! What it keeps is bounded whatever the run's length: at most
//! [`MAX_POINTS`] points (when full, neighbours are merged in pairs: the
//! means of their readings and powers, the later target, so a long run
//! keeps its shape at a coarser step) and the first [`MAX_HEAT_UPS`]
//! heat-ups (the rest counted).

use motet_wire::control::{SampleBatch, SampleData};

/// Most points a trace keeps.
pub const MAX_POINTS: usize = 4096;
/// Most heat-ups a trace keeps the figures of.
pub const MAX_HEAT_UPS: usize = 32;

/// One point of a trace.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TracePoint {
    /// Host time, s.
    pub t_s: f64,
    /// The reading, °C.
    pub reading: f64,
    /// The target, °C (0: off).
    pub target: f64,
    /// The power, 0 to 1.
    pub power: f64,
}

impl TracePoint {
    fn merge(self, later: TracePoint, n: f64) -> TracePoint {
        // `self` stands for `n` samples, `later` for one.
        TracePoint {
            t_s: later.t_s,
            reading: (self.reading * n + later.reading) / (n + 1.0),
            target: later.target,
            power: (self.power * n + later.power) / (n + 1.0),
        }
    }
}

/// How one target was reached: from its setting to the next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeatUp {
    /// °C.
    pub target_c: f64,
    /// The reading when it was set, °C.
    pub from_c: f64,
    /// When it was set, s of host time.
    pub at_s: f64,
    /// How long after it was set the reading entered the window for good
    /// (`None`: it was outside the window at the end), s.
    pub settle_s: Option<f64>,
    /// Most the reading went past the target once it had reached it, °C.
    pub overshoot_c: f64,
    /// |reading − target| at its end, °C.
    pub final_error_c: f64,
}

/// A heater's samples.
#[derive(Clone, Debug)]
pub struct HeaterTrace {
    /// The heater's name.
    pub name: String,
    /// Its ready window, °C either side (what "settled" means).
    pub window_c: f64,
    points: Vec<TracePoint>,
    stride: usize,
    acc: Option<(TracePoint, usize)>,
    /// Samples taken, and lost on the node.
    pub samples: u64,
    /// Lost on the node (its queue upstream was full).
    pub dropped: u64,
    heat_ups: Vec<HeatUp>,
    /// Heat-ups in all (some may not be kept).
    pub heat_up_count: u64,
    current: Option<HeatUp>,
    /// Seconds the trajectory waited for it, and how many waits.
    pub wait_s: f64,
    /// Waits for it.
    pub waits: u64,
    /// Why it stopped, as the person reads it.
    pub fault: Option<String>,
    last: Option<TracePoint>,
}

impl HeaterTrace {
    /// An empty trace of the heater `name`, settled within `window_c`.
    pub fn new(name: &str, window_c: f64) -> HeaterTrace {
        HeaterTrace {
            name: name.to_string(),
            window_c,
            points: Vec::new(),
            stride: 1,
            acc: None,
            samples: 0,
            dropped: 0,
            heat_ups: Vec::new(),
            heat_up_count: 0,
            current: None,
            wait_s: 0.0,
            waits: 0,
            fault: None,
            last: None,
        }
    }

    /// A batch of the heater's samples ((reading, target, power) triples).
    pub fn take(&mut self, b: &SampleBatch) {
        self.dropped += b.dropped as u64;
        let SampleData::Values(v) = &b.data else {
            return;
        };
        for (k, s) in v.chunks_exact(3).enumerate() {
            let p = TracePoint {
                t_s: (b.t0 + k as f64 * b.period_us as f64) * 1e-6,
                reading: s[0] as f64,
                target: s[1] as f64,
                power: s[2] as f64,
            };
            self.push(p);
        }
    }

    /// One sample.
    pub fn push(&mut self, p: TracePoint) {
        self.samples += 1;
        self.figure(p);
        self.last = Some(p);
        let (acc, n) = match self.acc.take() {
            Some((a, n)) => (a.merge(p, n as f64), n + 1),
            None => (p, 1),
        };
        if n < self.stride {
            self.acc = Some((acc, n));
            return;
        }
        self.points.push(acc);
        if self.points.len() >= MAX_POINTS {
            // Full: every two points become one, and each point from now
            // on stands for twice as many samples.
            let merged = self
                .points
                .chunks(2)
                .map(|c| match c {
                    [a, b] => a.merge(*b, 1.0),
                    [a] => *a,
                    _ => unreachable!("chunks of two"),
                })
                .collect();
            self.points = merged;
            self.stride *= 2;
        }
    }

    fn figure(&mut self, p: TracePoint) {
        let changed = self
            .current
            .map_or(p.target > 0.0, |c| c.target_c != p.target);
        if changed {
            self.close();
            if p.target > 0.0 {
                self.current = Some(HeatUp {
                    target_c: p.target,
                    from_c: p.reading,
                    at_s: p.t_s,
                    settle_s: None,
                    overshoot_c: 0.0,
                    final_error_c: (p.reading - p.target).abs(),
                });
            }
        }
        let window = self.window_c;
        let Some(h) = self.current.as_mut() else {
            return;
        };
        let error = p.reading - h.target_c;
        h.final_error_c = error.abs();
        if error.abs() > window {
            h.settle_s = None;
        } else if h.settle_s.is_none() {
            h.settle_s = Some(p.t_s - h.at_s);
        }
        // Past the target from the side it was approached from.
        let heating = h.target_c >= h.from_c;
        let past = if heating { error } else { -error };
        // Once reached, the overshoot is kept above 0 (a trace of 1e-12
        // marks "reached, not past"), so a dip back does not forget it.
        let reached = h.overshoot_c > 0.0 || past >= 0.0;
        if reached {
            h.overshoot_c = h.overshoot_c.max(past.max(0.0)).max(1e-12);
        }
    }

    fn close(&mut self) {
        if let Some(mut h) = self.current.take() {
            if h.overshoot_c <= 1e-12 {
                h.overshoot_c = 0.0;
            }
            self.heat_up_count += 1;
            if self.heat_ups.len() < MAX_HEAT_UPS {
                self.heat_ups.push(h);
            }
        }
    }

    /// The heat-ups so far, the one under way last.
    pub fn heat_ups(&self) -> Vec<HeatUp> {
        let mut out = self.heat_ups.clone();
        if let Some(mut h) = self.current {
            if h.overshoot_c <= 1e-12 {
                h.overshoot_c = 0.0;
            }
            out.push(h);
        }
        out
    }

    /// Heat-ups in all, the one under way too.
    pub fn heat_up_total(&self) -> u64 {
        self.heat_up_count + self.current.is_some() as u64
    }

    /// The points for a plot, the one being merged last.
    pub fn points(&self) -> Vec<TracePoint> {
        let mut out = self.points.clone();
        out.extend(self.acc.map(|a| a.0));
        out
    }

    /// The latest sample.
    pub fn last(&self) -> Option<TracePoint> {
        self.last
    }

    /// A wait for it from `from_s` to `to_s` (host time, s).
    pub fn waited(&mut self, from_s: f64, to_s: f64) {
        self.waits += 1;
        self.wait_s += (to_s - from_s).max(0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(t_s: f64, reading: f64, target: f64) -> TracePoint {
        TracePoint {
            t_s,
            reading,
            target,
            power: 0.5,
        }
    }

    #[test]
    fn heat_ups_measure_overshoot_and_settling() {
        let mut t = HeaterTrace::new("h", 1.0);
        // (time, reading, target)
        let samples = [
            (0.0, 25.0, 0.0),
            (1.0, 25.0, 200.0),
            (2.0, 150.0, 200.0),
            (3.0, 203.0, 200.0),
            (4.0, 199.5, 200.0),
            (5.0, 201.5, 200.0),
            (6.0, 200.4, 200.0),
            (7.0, 199.8, 200.0),
            (8.0, 150.0, 60.0),
            (9.0, 59.0, 60.0),
        ];
        for (s, r, g) in samples {
            t.push(p(s, r, g));
        }
        let h = t.heat_ups();
        assert_eq!(h.len(), 2);
        assert_eq!((h[0].target_c, h[0].from_c, h[0].at_s), (200.0, 25.0, 1.0));
        assert!((h[0].overshoot_c - 3.0).abs() < 1e-9);
        assert_eq!(h[0].settle_s, Some(5.0), "within ±1 for good from 6 s");
        assert!((h[0].final_error_c - 0.2).abs() < 1e-9);
        // Cooling to 60: overshoot is below it.
        assert!((h[1].overshoot_c - 1.0).abs() < 1e-9);
        assert_eq!(h[1].settle_s, Some(1.0));
    }

    #[test]
    fn a_long_trace_stays_bounded_and_keeps_its_span() {
        let mut t = HeaterTrace::new("h", 1.0);
        for k in 0..(5 * MAX_POINTS) {
            t.push(p(k as f64, 100.0 + (k % 7) as f64, 100.0));
        }
        let pts = t.points();
        assert!(pts.len() <= MAX_POINTS, "{}", pts.len());
        assert_eq!(t.samples, 5 * MAX_POINTS as u64);
        assert!(pts.last().unwrap().t_s > (5 * MAX_POINTS - 8) as f64);
        assert!(pts.iter().all(|x| (100.0..=106.0).contains(&x.reading)));
    }
}
