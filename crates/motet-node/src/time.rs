//! Times as the node hands them out: host µs as `f64`, and the integer
//! forms a core without a floating-point unit works in.
//!
//! A Cortex-M0+ (the Raspberry Pi Pico) has no FPU: every `f64` comparison
//! or addition is a library call of dozens to hundreds of instructions. So
//! the poll compares step times as [`Key`]s (with the `soft-float` feature
//! their bits as ordered integers, an integer comparison; the same answer), and
//! a run in fixed-point time ([`crate::Node::use_fixed_time`]) makes its
//! times as integers of [`FINE`]-th microseconds and turns each into an
//! `f64` with integer instructions ([`fine_to_us`]).

/// Fine time units per µs: a fine time is host µs × 2¹⁶ as an integer
/// (15 ps; 2⁶⁴ of them are 8.9 years).
pub const FINE: f64 = 65536.0;

/// A step time as the poll's search for the earliest compares it: the
/// time itself, or with the `soft-float` feature its bits as an ordered
/// integer ([`ordered`]), so that a comparison is an integer one.
#[cfg(feature = "soft-float")]
pub type Key = u64;
/// A step time as the poll's search for the earliest compares it (see the
/// `soft-float` feature's).
#[cfg(not(feature = "soft-float"))]
pub type Key = f64;

/// `t` as a [`Key`].
#[inline(always)]
pub fn key(t: f64) -> Key {
    #[cfg(feature = "soft-float")]
    {
        ordered(t)
    }
    #[cfg(not(feature = "soft-float"))]
    {
        t
    }
}

/// The time a [`Key`] stands for.
#[inline(always)]
pub fn of_key(k: Key) -> f64 {
    #[cfg(feature = "soft-float")]
    {
        f64::from_bits(if k >> 63 != 0 { k & !(1 << 63) } else { !k })
    }
    #[cfg(not(feature = "soft-float"))]
    {
        k
    }
}

/// An `f64` (not NaN) as an unsigned integer in the same order.
#[inline(always)]
pub fn ordered(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 0 {
        b | 1 << 63
    } else {
        !b
    }
}

/// `fine / 2¹⁶` µs as an `f64`, exactly (for `fine < 2⁵³`; beyond, the
/// nearest below), with integer instructions only.
#[inline]
pub fn fine_to_us(fine: u64) -> f64 {
    if fine == 0 {
        return 0.0;
    }
    let lead = 63 - fine.leading_zeros() as u64;
    // The mantissa: the bits below the leading one, aligned to 52.
    let mantissa = if lead >= 52 {
        (fine >> (lead - 52)) & ((1 << 52) - 1)
    } else {
        (fine << (52 - lead)) & ((1 << 52) - 1)
    };
    let exponent = lead + 1023 - 16;
    f64::from_bits(exponent << 52 | mantissa)
}

/// Host µs as fine time, rounded to the nearest (ties up; 0 below 0, and
/// the largest fine time beyond it), with integer instructions only.
#[inline]
pub fn us_to_fine(us: f64) -> u64 {
    let bits = us.to_bits();
    if bits >> 63 != 0 {
        return 0;
    }
    let exponent = (bits >> 52) as i64;
    if exponent == 0x7ff {
        // Infinite (or NaN): as late as fine time goes.
        return u64::MAX;
    }
    // The value is `mantissa · 2^shift` fine units.
    let mantissa = if exponent == 0 {
        bits & ((1 << 52) - 1)
    } else {
        bits & ((1 << 52) - 1) | 1 << 52
    };
    let shift = exponent.max(1) - 1075 + 16;
    if shift >= 0 {
        if shift > 11 {
            return u64::MAX;
        }
        mantissa << shift
    } else if shift > -64 {
        let down = (-shift) as u32;
        (mantissa + (1 << (down - 1))) >> down
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fine_times_convert_exactly_and_compare_in_order() {
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        for k in 0..100_000u64 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let fine = (x >> (11 + k % 40)).max(1);
            let want = fine as f64 / FINE;
            assert_eq!(fine_to_us(fine), want, "{fine}");
            assert_eq!(us_to_fine(want), fine);
            // Between fine units: to the nearest.
            let between = (fine as f64 + 0.25) / FINE;
            assert_eq!(us_to_fine(between), libm::round(between * FINE) as u64);
        }
        assert_eq!(us_to_fine(-1.0), 0);
        assert_eq!(us_to_fine(f64::INFINITY), u64::MAX);
        assert_eq!(us_to_fine(1e-300), 0);
        assert_eq!(us_to_fine(0.5 / FINE), 1);
        assert_eq!(fine_to_us(0), 0.0);
        let times = [
            f64::NEG_INFINITY,
            -3.0,
            -0.0,
            0.0,
            1e-300,
            2.5,
            1e10,
            1e10 + 1e-6,
            f64::INFINITY,
        ];
        for &t in &times {
            assert_eq!(of_key(key(t)).to_bits(), t.to_bits(), "{t}");
        }
        for (i, &a) in times.iter().enumerate() {
            for &b in &times[i + 1..] {
                if a < b {
                    assert!(ordered(a) < ordered(b), "{a} {b}");
                }
                assert!(ordered(b) >= ordered(a), "{a} {b}");
            }
        }
    }
}
