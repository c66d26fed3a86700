//! A sensor channel: a reading (an accelerometer, a load cell) taken at a
//! fixed rate and sent upstream as the mean of each sample's window. A
//! reading that does not come is a fault, reported once.

use super::samples::{Sampler, Upstream};
use super::ticker::Ticker;
use crate::board::Board;
use motet_wire::control::{FaultKind, SampleSource, SensorConfig};

/// One sensor channel.
#[derive(Clone, Debug)]
pub struct Sensor {
    config: SensorConfig,
    ticker: Ticker,
    lost: bool,
    sampler: Sampler,
}

impl Sensor {
    /// A sensor on `config`.
    pub fn new(config: SensorConfig) -> Sensor {
        Sensor {
            config,
            ticker: Ticker::new(config.rate_hz),
            lost: false,
            sampler: Sampler::new(SampleSource::Sensor(config.sensor)),
        }
    }

    /// What the host configured.
    pub fn config(&self) -> &SensorConfig {
        &self.config
    }

    /// The next tick's time.
    pub fn due(&self, now: f64) -> f64 {
        self.ticker.due(now)
    }

    /// Whether it asks to be polled: sampled and not lost, while the
    /// machine moves.
    pub fn active(&self, moving: bool) -> bool {
        moving && !self.lost && self.sampler.every() > 0
    }

    /// The sampler of its readings.
    pub fn sampler_mut(&mut self) -> &mut Sampler {
        &mut self.sampler
    }

    /// Runs the tick due at `t`; true when the reading was lost (the first
    /// time).
    pub fn tick<B: Board>(&mut self, t: f64, board: &mut B, up: &mut Upstream) -> bool {
        self.ticker.advance(t);
        if self.lost || self.sampler.every() == 0 {
            return false;
        }
        match board.sensor(self.config.sensor, t) {
            Some(v) if v.is_finite() => {
                let period = self.ticker.period_us();
                self.sampler.value(t, period, v, up);
                false
            }
            _ => {
                self.lost = true;
                self.sampler.flush(up);
                up.fault(
                    SampleSource::Sensor(self.config.sensor),
                    FaultKind::SensorLost,
                    t,
                    0.0,
                );
                true
            }
        }
    }
}
