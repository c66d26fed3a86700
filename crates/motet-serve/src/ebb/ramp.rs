//! The board's rate-and-acceleration moves (`LM`, `LT`, `T3`), one axis at
//! a time: every 40 µs tick the rate (changed by the acceleration, itself
//! changed by the jerk) is added to a 31-bit accumulator, and each
//! overflow is a step. The step counts and times are computed in closed
//! form as the EBB 3.0 firmware's own model does (the formulas plotink's
//! `ebb_calc` gives the AxiDraw software), in exact integers where they
//! decide a step.

/// The board's step interrupt, Hz: these moves count time in its ticks.
pub const ISR_HZ: f64 = 25_000.0;
/// An accumulator's step threshold, 2^31.
const ONE: i128 = 1 << 31;
/// What a cleared accumulator starts at for a move that begins backwards.
const NEG_START: i64 = (1 << 31) - 1;

/// One axis's move: where it ends (signed steps), how many ticks it takes
/// (`LM` only), and the accumulator it leaves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AxisMove {
    /// Signed steps.
    pub steps: i64,
    /// Ticks to take them.
    pub ticks: i64,
    /// The accumulator afterwards.
    pub accum: i64,
}

/// `rate + accel/2 - trunc(accel/2)`, doubled so it is an integer.
fn rate_eff2(rate: i64, accel: i64) -> i128 {
    2 * rate as i128 + accel as i128 - 2 * (accel / 2) as i128
}

fn starts_backwards(rate: i64, accel: i64) -> bool {
    let r = rate - accel / 2 + accel;
    r < 0 || (r == 0 && accel < 0)
}

/// `LT`: the steps after `ticks` at `rate` and `accel`, from `accum`
/// (`None`: cleared).
pub fn lt(ticks: i64, rate: i64, accel: i64, accum: Option<i64>) -> AxisMove {
    if ticks == 0 {
        return AxisMove::default();
    }
    let acc = accum.unwrap_or(if starts_backwards(rate, accel) {
        NEG_START
    } else {
        0
    });
    let t = ticks as i128;
    let twice = 2 * acc as i128 + rate_eff2(rate, accel) * t + accel as i128 * t * t;
    let steps = twice.div_euclid(2 * ONE);
    AxisMove {
        steps: steps as i64,
        ticks,
        accum: ((twice - 2 * ONE * steps) / 2) as i64,
    }
}

/// `T3`: as [`lt`] with a jerk.
pub fn t3(ticks: i64, rate: i64, accel: i64, jerk: i64, accum: Option<i64>) -> AxisMove {
    if ticks == 0 {
        return AxisMove::default();
    }
    let half = accel / 2;
    let j6 = jerk / 6;
    let acc = accum.unwrap_or({
        let r = rate - half + j6 + accel;
        let back = r < 0 || (r == 0 && (accel + jerk < 0 || (accel + jerk == 0 && jerk < 0)));
        if back {
            NEG_START
        } else {
            0
        }
    });
    let (r, a, j, t) = (rate as i128, accel as i128, jerk as i128, ticks as i128);
    // Six times: rate_eff = rate + accel/2 - half + j6 - jerk/6.
    let re6 = 6 * r + 3 * a - 6 * half as i128 + 6 * j6 as i128 - j;
    let six = 6 * acc as i128 + t * (re6 + t * (3 * a + t * j));
    // Rounded half away from zero, as the firmware's model rounds.
    let rounded = if six >= 0 {
        (six + 3) / 6
    } else {
        -((-six + 3) / 6)
    };
    let steps = rounded.div_euclid(ONE);
    AxisMove {
        steps: steps as i64,
        ticks,
        accum: (rounded - ONE * steps) as i64,
    }
}

/// `LM`: `steps` (signed) from `rate` and `accel`, from `accum` (`None`:
/// cleared). `None` when the axis cannot move (no steps, or no rate).
pub fn lm(steps: i64, rate: i64, accel: i64, accum: Option<i64>) -> Option<AxisMove> {
    if steps == 0 || (accel == 0 && rate == 0) || (steps < 0 && rate < 0) {
        return None;
    }
    // A negative count is the older form: the same move backwards.
    let (steps, rate, accel) = if steps < 0 {
        (-steps, -rate, -accel)
    } else {
        (steps, rate, accel)
    };
    let re2 = rate_eff2(rate, accel);
    let back = starts_backwards(rate, accel);
    let acc = accum.unwrap_or(if back { NEG_START } else { 0 });
    let adj = (acc - if back { NEG_START } else { 0 }) as i128;
    let (a, r) = (accel as i128, rate as i128);
    // The tick at which the rate changes sign, and the steps taken by then.
    let mut t_rev: i128 = -1;
    if accel != 0 && rate != 0 && (accel > 0) != (rate > 0) {
        t_rev = (0.5 - rate as f64 / accel as f64) as i128;
    }
    let mut s_rev: i128 = 0;
    if t_rev > 0 {
        s_rev = (re2 * t_rev + a * t_rev * t_rev + 2 * adj).abs() / (2 * ONE);
    }
    let s = steps as i128;
    let (pos, pos_adj) = if t_rev <= 1 || s_rev >= s {
        t_rev = -1;
        let p = if back { -s } else { s };
        (p, p)
    } else if s_rev == 0 {
        if accel > 0 {
            (s, s - 1)
        } else {
            (-s, -s + 1)
        }
    } else {
        let net = s_rev - (s - s_rev);
        if accel > 0 {
            (-net, -net - 1)
        } else {
            (net, net + 1)
        }
    };
    let ticks: i128 = if accel == 0 {
        ceil_div(ONE * pos - adj, r)
    } else {
        let re = re2 as f64 / 2.0;
        let c = adj as f64 - pos_adj as f64 * ONE as f64;
        let disc = re * re - 2.0 * a as f64 * c;
        let mut best = 0i128;
        if disc >= 0.0 {
            let sq = disc.sqrt();
            let root = |x: f64| if x > 0.0 { x.ceil() as i128 } else { -1 };
            let mut neg = root((-re - sq) / a as f64);
            let mut pos_r = root((-re + sq) / a as f64);
            if t_rev > 0 && neg <= t_rev {
                neg = -1;
            }
            if t_rev > 0 && pos_r <= t_rev {
                pos_r = -1;
            }
            if neg > 0 {
                best = neg;
            }
            if pos_r > 0 && (neg <= 0 || pos_r < neg) {
                best = pos_r;
            }
        }
        best
    };
    let ticks = ticks.max(1);
    let twice = 2 * acc as i128 + re2 * ticks + a * ticks * ticks - 2 * ONE * pos;
    Some(AxisMove {
        steps: pos as i64,
        ticks: ticks as i64,
        accum: (twice / 2) as i64,
    })
}

/// `num / den` rounded up; `den` is not zero.
fn ceil_div(num: i128, den: i128) -> i128 {
    let q = num / den;
    if num % den != 0 && (num > 0) == (den > 0) {
        q + 1
    } else {
        q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // Reference values from plotink 1.14.3's `ebb_calc` (calculate_lm,
    // move_dist_lt, move_dist_t3), the model the AxiDraw software plans with.
    #[test]
    fn lm_matches_the_firmware_model() {
        let cases = [
            ((1000, 85899346, 0, None), (25000, 1000, 2000)),
            ((50, 42950000, 13400, None), (1924, 50, 63516800)),
            ((75, 17179000, -687, None), (12500, 75, 4345150)),
            (
                (-120, 30000000, 5000, Some(12345)),
                (5757, -120, 2130427605),
            ),
            // The rate turns negative: the axis reverses, 38 steps net back.
            ((40, 50000000, -400000, None), (768, -38, 2039578624)),
        ];
        for ((s, r, a, acc), (ticks, steps, accum)) in cases {
            let m = lm(s, r, a, acc).unwrap();
            assert_eq!(
                (m.ticks, m.steps, m.accum),
                (ticks, steps, accum),
                "LM {s},{r},{a}"
            );
        }
        assert_eq!(lm(0, 1, 0, None), None);
        assert_eq!(lm(10, 0, 0, None), None);
    }

    #[test]
    fn lt_and_t3_match_the_firmware_model() {
        let m = lt(12500, 17179000, -687, None);
        assert_eq!((m.steps, m.accum), (75, 4345150));
        let m = lt(25000, -33865471, 0, None);
        assert_eq!((m.steps, m.accum), (-394, 1619265959));
        let m = t3(1000, 1000000, 20000, 30, None);
        assert_eq!((m.steps, m.accum), (7, 967614464));
        let m = t3(1000, -1000000, -20000, 31, Some(5));
        assert_eq!((m.steps, m.accum), (-3, 609117449));
    }
}
