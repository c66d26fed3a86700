//! Clocks in µs. The network code never reads a clock itself: every call
//! takes `now`, so the same code runs on the wall clock and on a simulated
//! one (tests, fault injection, runs faster than real time).

use std::time::Instant;

/// A source of the current time in µs.
pub trait Clock {
    fn now_us(&self) -> u64;
}

/// The wall clock since creation, optionally scaled (a simulated node or a dry
/// run may run its time faster than real time) and skewed like a crystal off
/// by `ppm` parts per million.
#[derive(Clone, Copy, Debug)]
pub struct WallClock {
    start: Instant,
    rate: f64,
    offset_us: u64,
}

impl WallClock {
    pub fn new() -> WallClock {
        WallClock::with(1.0, 0.0, 0)
    }

    /// `scale` µs of this clock per real µs, times `1 + ppm·10⁻⁶`; starts at `offset_us`.
    pub fn with(scale: f64, ppm: f64, offset_us: u64) -> WallClock {
        WallClock {
            start: Instant::now(),
            rate: scale * (1.0 + ppm * 1e-6),
            offset_us,
        }
    }

    /// How long `us` µs of this clock take in real time.
    pub fn real(&self, us: u64) -> std::time::Duration {
        std::time::Duration::from_secs_f64(us as f64 * 1e-6 / self.rate)
    }
}

impl Default for WallClock {
    fn default() -> Self {
        WallClock::new()
    }
}

impl Clock for WallClock {
    fn now_us(&self) -> u64 {
        self.offset_us + (self.start.elapsed().as_secs_f64() * 1e6 * self.rate) as u64
    }
}
