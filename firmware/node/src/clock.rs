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
///
/// With the `soft-float` feature (a core without a floating-point unit),
/// [`HostToTicks::near`] sets a reference time, and times close to it are
/// converted in integers: the time as fine units (`motet_node::time`),
/// its distance from the reference times the rate in fixed point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HostToTicks {
    /// Ticks per host µs, and the ticks at host time 0: the model and the
    /// tick rate folded into one line, so a step costs a multiply-add.
    per_us: f64,
    at_zero: f64,
    /// The rate in fixed point for [`HostToTicks::near`]: ticks per µs
    /// times 2^`shift`, below 2²⁷.
    #[cfg(feature = "soft-float")]
    rate: (i64, u32),
    #[cfg(feature = "soft-float")]
    near: Option<Near>,
}

/// A reference for the integer conversion: its fine time, and its ticks
/// in 2⁻¹⁶ of a tick.
#[cfg(feature = "soft-float")]
#[derive(Clone, Copy, Debug, PartialEq)]
struct Near {
    fine: u64,
    sub: u64,
}

/// How far from the reference the integer conversion reaches, fine units
/// (about half a second): the product with the rate stays within 63 bits.
#[cfg(feature = "soft-float")]
const NEAR_FINE: i64 = 1 << 35;

/// Ticks beyond which the integer conversion is not used (2⁴⁷: the
/// reference in 2⁻¹⁶ ticks stays within 63 bits).
#[cfg(feature = "soft-float")]
const TICKS_LIMIT: f64 = 140_737_488_355_328.0;

/// Ticks per µs as `(rate, shift)`: `per_us · 2^shift`, rounded, below
/// 2²⁷, so that a product with a distance within `NEAR_FINE` stays within
/// 63 bits. Once per clock model.
#[cfg(feature = "soft-float")]
fn fixed_rate(per_us: f64) -> (i64, u32) {
    let mut shift = 0;
    let mut scaled = per_us;
    while shift < 40 && scaled * 2.0 < 134_217_728.0 {
        scaled *= 2.0;
        shift += 1;
    }
    (scaled as i64, shift)
}

/// 2⁵²: added to a non-negative double below it, it leaves the double's
/// integer part, rounded to nearest, in the low bits of the mantissa.
const TWO_52: f64 = 4_503_599_627_370_496.0;

impl HostToTicks {
    /// The conversion for `model` on a counter of `ticks_per_us`.
    pub fn new(model: ClockModel, ticks_per_us: u32) -> HostToTicks {
        let tpu = ticks_per_us as f64;
        let per_us = (1.0 + model.skew) * tpu;
        HostToTicks {
            per_us,
            at_zero: model.offset * tpu,
            #[cfg(feature = "soft-float")]
            rate: fixed_rate(per_us),
            #[cfg(feature = "soft-float")]
            near: None,
        }
    }

    /// Times near host µs `host_us` (within about half a second) are converted
    /// in integers from here on (with the `soft-float` feature; without,
    /// nothing changes).
    pub fn near(self, host_us: f64) -> HostToTicks {
        #[cfg(feature = "soft-float")]
        {
            let mut c = self;
            let ticks = self.at_zero + self.per_us * host_us;
            if (0.0..TICKS_LIMIT).contains(&ticks) {
                c.near = Some(Near {
                    fine: motet_node::time::us_to_fine(host_us),
                    sub: (ticks * 65536.0) as u64,
                });
            }
            c
        }
        #[cfg(not(feature = "soft-float"))]
        {
            let _ = host_us;
            self
        }
    }

    /// The counter's reading at host time `host_us`, rounded to the nearest
    /// tick (wrapped to 32 bits).
    #[inline]
    pub fn ticks(&self, host_us: f64) -> Ticks {
        #[cfg(feature = "soft-float")]
        if let Some(n) = self.near {
            let d = motet_node::time::us_to_fine(host_us) as i64 - n.fine as i64;
            if -NEAR_FINE < d && d < NEAR_FINE {
                // Fine units (2⁻¹⁶ µs) times ticks per µs: 2⁻¹⁶ ticks.
                let (rate, shift) = self.rate;
                let step = (d * rate) >> shift;
                let sub = n.sub as i64 + step;
                if sub >= 0 {
                    return ((sub as u64 + (1 << 15)) >> 16) as Ticks;
                }
            }
        }
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

    /// Near a reference, the integer conversion gives the `f64` one's
    /// ticks (a tick apart at most, where the two round a half-tick
    /// differently), for a 1 MHz counter (the Pico's) and a fast one.
    #[cfg(feature = "soft-float")]
    #[test]
    fn near_a_reference_integers_agree() {
        for (tpu, skew) in [(1, 123e-6), (1, -499e-6), (25, 37e-6), (600, -200e-6)] {
            let model = ClockModel {
                offset: 98_765.25,
                skew,
            };
            let plain = HostToTicks::new(model, tpu);
            let host0 = 3_600e6 + 0.37;
            let near = plain.near(host0);
            assert!(near.near.is_some(), "{tpu} {skew}: no reference set");
            for k in 0..20_000 {
                let host = host0 - 2_000.0 + k as f64 * 0.731;
                let (a, b) = (plain.ticks(host), near.ticks(host));
                assert!(a.abs_diff(b) <= 1, "{tpu} {skew}: {host}: {a} {b}");
            }
            // Far from it: the plain conversion.
            assert_eq!(near.ticks(host0 + 1e7), plain.ticks(host0 + 1e7));
        }
    }
}
