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
    /// Ticks per host µs, and the ticks at host time 0: the model and the
    /// tick rate folded into one line, so a step costs a multiply-add.
    per_us: f64,
    at_zero: f64,
}

/// 2⁵²: added to a non-negative double below it, it leaves the double's
/// integer part, rounded to nearest, in the low bits of the mantissa.
const TWO_52: f64 = 4_503_599_627_370_496.0;

impl HostToTicks {
    /// The conversion for `model` on a counter of `ticks_per_us`.
    pub fn new(model: ClockModel, ticks_per_us: u32) -> HostToTicks {
        let tpu = ticks_per_us as f64;
        HostToTicks {
            per_us: (1.0 + model.skew) * tpu,
            at_zero: model.offset * tpu,
        }
    }

    /// The counter's reading at host time `host_us`, rounded to the nearest
    /// tick (wrapped to 32 bits).
    #[inline]
    pub fn ticks(&self, host_us: f64) -> Ticks {
        let t = self.at_zero + self.per_us * host_us;
        if (0.0..TWO_52).contains(&t) {
            // The integer part from the mantissa's low bits: an addition and
            // a move, where a conversion to a 64-bit integer is a library
            // call on a 32-bit core. (2⁵² ticks: 87 days at 600 MHz.)
            (t + TWO_52).to_bits() as Ticks
        } else {
            Self::far(t)
        }
    }

    /// [`HostToTicks::ticks`] beyond 2⁵² ticks, or before the clock's start
    /// (a model that puts a time there clamps to it).
    #[cold]
    fn far(t: f64) -> Ticks {
        if t > 0.0 {
            ((t + 0.5) as u64) as Ticks
        } else {
            0
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    /// The fast rounding agrees with rounding through an integer, across
    /// the counter's wrap and far from the start.
    #[test]
    fn ticks_round_to_nearest_and_wrap() {
        let c = HostToTicks::new(
            ClockModel {
                offset: 1234.5,
                skew: 123e-6,
            },
            600,
        );
        for host in [
            0.0,
            0.3,
            1.0,
            7_158_278.8,
            7_158_279.0,
            3.6e9,
            8.64e10,
            1e12,
        ] {
            let t = c.at_zero + c.per_us * host;
            let want = (t.round_ties_even() as u64) as Ticks;
            assert_eq!(c.ticks(host), want, "host {host}");
        }
        assert_eq!(c.ticks(-1e9), 0);
    }
}
