//! The node's local clock from the board's 32-bit tick counter, and the
//! conversions between the host's µs and local ticks.

use crate::board::Ticks;
use motet_wire::sync::ClockModel;

/// Extends the wrapping tick counter to 64 bits. Read it at least once per
/// wrap (171 s at 25 MHz, 28 s at 150 MHz): the main loop does, every
/// millisecond or so.
#[derive(Clone, Copy, Debug)]
pub struct Clock {
    last: Ticks,
    high: u64,
    ticks_per_us: u64,
}

impl Clock {
    pub fn new(now: Ticks, ticks_per_us: u32) -> Clock {
        Clock {
            last: now,
            high: 0,
            ticks_per_us: ticks_per_us as u64,
        }
    }

    /// Ticks since the clock started, from the counter's reading `now`.
    pub fn ticks(&mut self, now: Ticks) -> u64 {
        if now < self.last {
            self.high += 1 << 32;
        }
        self.last = now;
        self.high | now as u64
    }

    /// Local µs (the node's clock for the link and the services) at the
    /// counter's reading `now`.
    pub fn us(&mut self, now: Ticks) -> u64 {
        self.ticks(now) / self.ticks_per_us
    }

    /// The counter's reading at local µs `us` (wrapped to 32 bits).
    pub fn tick_at(&self, us: u64) -> Ticks {
        us.wrapping_mul(self.ticks_per_us) as Ticks
    }
}

/// Host µs to local ticks through the host's clock model:
/// `local = offset + (1 + skew) · host`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HostToTicks {
    pub model: ClockModel,
    pub ticks_per_us: f64,
}

impl HostToTicks {
    /// The counter's reading at host time `host_us` (wrapped to 32 bits).
    #[inline]
    pub fn ticks(&self, host_us: f64) -> Ticks {
        let local_us = self.model.offset + (1.0 + self.model.skew) * host_us;
        let t = local_us * self.ticks_per_us + 0.5;
        // Local time is never negative on a running node; a model that puts
        // a time before the clock's start clamps to it.
        if t > 0.0 {
            (t as u64) as Ticks
        } else {
            0
        }
    }
}
