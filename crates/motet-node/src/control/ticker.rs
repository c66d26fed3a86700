//! A fixed-rate schedule on host time: tick `k` is at `k · period`, so
//! ticks never drift however long a run, and loops of one rate tick at the
//! same instants.

/// When a loop ticks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ticker {
    /// µs between ticks.
    period: f64,
    /// The next tick's index; `None` until the loop is started.
    next: Option<u64>,
}

impl Ticker {
    /// A schedule of `rate_hz` ticks a second, not started.
    pub fn new(rate_hz: f32) -> Ticker {
        Ticker {
            period: 1e6 / rate_hz as f64,
            next: None,
        }
    }

    /// µs between ticks.
    pub fn period_us(&self) -> f64 {
        self.period
    }

    /// Seconds between ticks.
    pub fn period_s(&self) -> f32 {
        (self.period * 1e-6) as f32
    }

    /// The next tick's time: the first at or after `now` (0 before any
    /// time) once started at it.
    pub fn due(&self, now: f64) -> f64 {
        match self.next {
            Some(k) => k as f64 * self.period,
            None if now.is_finite() && now > 0.0 => libm::ceil(now / self.period) * self.period,
            None => 0.0,
        }
    }

    /// The tick due (see [`Ticker::due`]) is taken.
    pub fn advance(&mut self, now: f64) {
        let k = match self.next {
            Some(k) => k,
            None if now.is_finite() && now > 0.0 => libm::ceil(now / self.period) as u64,
            None => 0,
        };
        self.next = Some(k.saturating_add(1));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_stay_on_their_grid() {
        let mut t = Ticker::new(10_000.0);
        assert_eq!(t.due(1234.5), 1300.0);
        t.advance(1234.5);
        assert_eq!(t.due(0.0), 1400.0);
        for _ in 0..1_000_000 {
            t.advance(0.0);
        }
        assert_eq!(t.due(0.0), 1400.0 + 1e8);
        let fresh = Ticker::new(3_000.0);
        assert_eq!(fresh.due(f64::NEG_INFINITY), 0.0);
        assert!((fresh.period_s() - 1.0 / 3000.0).abs() < 1e-9);
    }
}
