//! A chunk: the steps of a run in fixed-point time, for a core without a
//! floating-point unit.
//!
//! A run's step times are one smooth function of the step's index (affine
//! on a cruise, a square root's under constant acceleration). A chunk
//! solves its end exactly, the time and the time's rate per step (an
//! anchor, in `f64`: soft float, but one per chunk; its start is the chunk
//! before's end), and gives the steps between by the cubic through both
//! ends with those rates (Hermite), as an integer recurrence: each step
//! three additions and a shift of 64-bit integers, in units of 2⁻³² µs. A
//! cruise's chunk is a line. The chunk is as long as the cubic stays within
//! the run's tolerance of the true times: the interpolation error is at
//! most `M · n⁴ / 384` over `n` steps, `M` the largest fourth derivative of
//! time by step index there, `15 a³ dx⁴ / w⁷` (`a` the acceleration, `dx`
//! the distance a step, `w` the slowest speed in the chunk). Slow steps get
//! short chunks (one step each near a stop: every one exact), fast ones
//! long ones: anchors per second stay about the same at any speed or
//! microstep setting, and a step costs the recurrence.

/// Superfine units (2⁻³² µs) per fine unit (2⁻¹⁶ µs).
const SHIFT: u32 = 16;

/// Steps of a run interpolated between exact anchors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Chunk {
    /// Fine time of its first step (exact).
    base: u64,
    /// Offset of the next step from `base`, superfine.
    rel: u64,
    /// The next interval, its change per step, and that change's change,
    /// superfine.
    d1: i64,
    d2: i64,
    d3: i64,
    /// Steps it covers, and steps given.
    len: u32,
    taken: u32,
}

impl Chunk {
    /// No chunk (one is started at the first step).
    pub const NONE: Chunk = Chunk {
        base: 0,
        rel: 0,
        d1: 0,
        d2: 0,
        d3: 0,
        len: 0,
        taken: 0,
    };

    /// Most steps a cruise's chunk covers: its interval is rounded to a
    /// superfine unit, 2⁻¹² µs over this many steps.
    pub const CRUISE_MOST: u32 = 1 << 20;

    /// Most steps a cubic covers: its cubic coefficient is rounded to a
    /// superfine unit, 2⁻⁸ µs over this many steps.
    pub const CUBIC_MOST: u32 = 256;

    /// Every step given.
    #[inline(always)]
    pub fn is_done(&self) -> bool {
        self.taken >= self.len
    }

    /// Steps it covers.
    pub fn len(&self) -> u32 {
        self.len
    }

    /// Steps given.
    pub fn taken(&self) -> u32 {
        self.taken
    }

    /// The next step's fine time.
    #[inline(always)]
    pub fn step(&mut self) -> u64 {
        let fine = self.base + ((self.rel + (1 << (SHIFT - 1))) >> SHIFT);
        self.rel = self.rel.wrapping_add(self.d1 as u64);
        self.d1 += self.d2;
        self.d2 += self.d3;
        self.taken += 1;
        fine
    }

    /// One step, at fine time `t`.
    pub fn one(t: u64) -> Chunk {
        Chunk {
            base: t,
            len: 1,
            ..Chunk::NONE
        }
    }

    /// The `n` steps from fine time `t0` evenly spaced towards `tn`, the
    /// time of the step after them (the next chunk's first).
    pub fn line(t0: u64, tn: u64, n: u32) -> Chunk {
        if n == 0 {
            return Chunk::one(t0);
        }
        let span = (tn as i64 - t0 as i64) << SHIFT;
        Chunk {
            base: t0,
            d1: span / n as i64,
            len: n,
            ..Chunk::NONE
        }
    }

    /// The `n` steps on the cubic from fine time `t0` to `tn` (the step
    /// after them, the next chunk's first) with times' rates `s0` and `s1`
    /// per step at its ends, superfine.
    pub fn cubic(t0: u64, tn: u64, s0: i64, s1: i64, n: u32) -> Chunk {
        let t = (tn as i64 - t0 as i64) << SHIFT;
        let n = n.clamp(1, Chunk::CUBIC_MOST) as i64;
        // p(i) = t0 + s0·i + c2·i² + c3·i³ with p(n) = tn, p'(n) = s1.
        let c2 = (3 * t - (2 * s0 + s1) * n) / (n * n);
        let c3 = ((s0 + s1) * n - 2 * t) / (n * n * n);
        Chunk {
            base: t0,
            d1: s0 + c2 + c3,
            d2: 2 * c2 + 6 * c3,
            d3: 6 * c3,
            len: n as u32,
            ..Chunk::NONE
        }
    }
}

/// `log₂ x` in sixteenths, for a positive normal `x`, from its exponent
/// and the top four bits of its mantissa: rounded down (`up` false) or up.
#[inline]
fn log2_16(x: f64, up: bool) -> i32 {
    // ⌊16 · log₂(1 + i/16)⌋ and ⌈16 · log₂(1 + (i+1)/16)⌉.
    const DOWN: [i32; 16] = [0, 1, 2, 3, 5, 6, 7, 8, 9, 10, 11, 12, 12, 13, 14, 15];
    const UP: [i32; 16] = [2, 3, 4, 6, 7, 8, 9, 10, 11, 12, 13, 13, 14, 15, 16, 16];
    let bits = x.to_bits();
    let e = ((bits >> 52) & 0x7ff) as i32 - 1023;
    let top = ((bits >> 48) & 0xf) as usize;
    16 * e + if up { UP[top] } else { DOWN[top] }
}

/// `2^(q/128)`, rounded down, for `q ≥ 0` (0 when it does not fit 32 bits).
#[inline]
fn pow2_128(q: i32) -> u32 {
    // ⌊256 · 2^(i/8)⌋.
    const FRAC: [u32; 8] = [256, 279, 304, 331, 362, 394, 430, 469];
    let (whole, part) = (q >> 7, ((q & 127) >> 4) as usize);
    if !(0..24).contains(&whole) {
        return if whole < 0 { 0 } else { u32::MAX };
    }
    ((FRAC[part] as u64) << whole >> 8) as u32
}

/// How long a cubic may be under constant acceleration, found with
/// integer instructions: `n` steps whose slowest speed is `w` stay within
/// the tolerance when `K² · n⁸ ≤ w^14`, `K` the run's
/// ([`ChunkBound::new`]); `w²` is the one figure a speed costs, and
/// logarithms in sixteenths, read off the exponents and a few mantissa
/// bits, bound both sides (within about 1.1 of the longest).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ChunkBound {
    /// `log₂ K²` in sixteenths, rounded up.
    k2: i32,
}

impl ChunkBound {
    /// No bound: for runs whose steps are not chunked.
    pub const NONE: ChunkBound = ChunkBound { k2: i32::MAX / 16 };

    /// For acceleration `a` (units/s²), `dx` units a step and a tolerance
    /// of `tolerance` µs, nine tenths of it for the interpolation (the
    /// rounding takes the rest): `K = 15a³dx⁴ · 10⁶ / (384 · 0.9 · tol)`,
    /// the interpolation error over `n` steps being `M · n⁴ / 384` with
    /// `M = 15a³dx⁴/w⁷` s (× 10⁶: µs) the fourth derivative of time by
    /// step.
    pub fn new(a: f64, dx: f64, tolerance: f64) -> ChunkBound {
        let a3 = a * a * a;
        let k = 15.0 * a3 * dx * dx * dx * dx * 1e6 / (384.0 * 0.9 * tolerance);
        let k2 = k * k;
        if k2 > 0.0 && k2.is_finite() {
            ChunkBound {
                k2: log2_16(k2, true),
            }
        } else {
            ChunkBound::NONE
        }
    }

    /// The most steps a chunk whose slowest speed squared is `w2` may
    /// have (0: none).
    #[inline]
    pub fn steps(&self, w2: f64) -> u32 {
        if w2.is_nan() || w2 <= 0.0 || !w2.is_finite() {
            return 0;
        }
        // log₂ n ≤ (7 log₂ w² − log₂ K²) / 8, in 128ths.
        let q = 7 * log2_16(w2, false) - self.k2;
        if q < 0 {
            0
        } else {
            pow2_128(q)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A line and a cubic give their anchors exactly, and a cubic whose
    /// coefficients are whole superfine units every step exactly.
    #[test]
    fn chunks_pass_their_anchors() {
        let mut c = Chunk::line(1_000_000, 1_000_000 + 65536 * 100, 10);
        let got: [u64; 10] = core::array::from_fn(|_| c.step());
        for (j, g) in got.iter().enumerate() {
            assert_eq!(*g, 1_000_000 + 65536 * 10 * j as u64);
        }
        assert!(c.is_done());
        // t(i) = 5000 + 300 i + 2 i² + i³/64 (fine), rates 300 + 4i + 3i²/64:
        // exact in superfine units, so the cubic gives it exactly.
        let t = |i: u64| (5000 + 300 * i + 2 * i * i) * 65536 + i * i * i * 1024;
        let rate = |i: i64| (300 + 4 * i) * (1 << 32) + 3 * i * i * (1 << 26);
        let mut c = Chunk::cubic(t(0), t(64), rate(0), rate(64), 64);
        for i in 0..64 {
            assert_eq!(c.step(), t(i), "step {i}");
        }
        assert!(c.is_done());
    }

    /// The bound never allows a chunk longer than the error bound does,
    /// and is within a fifth of the longest it allows; the logarithm and
    /// power tables bound as they should.
    #[test]
    fn the_bound_keeps_to_the_tolerance() {
        for (a, dx, tol) in [
            (3000.0, 1.0 / 80.0, 0.05),
            (4000.0, 1.0 / 640.0, 0.05),
            (500.0, 0.1, 0.5),
        ] {
            let b = ChunkBound::new(a, dx, tol);
            let mut w = 0.5;
            while w < 3000.0 {
                let n = b.steps(w * w) as f64;
                let w7 = w * w * w * w * w * w * w;
                let fourth = 15.0 * a * a * a * dx * dx * dx * dx / w7 * 1e6;
                let longest = libm::pow(384.0 * 0.9 * tol / fourth, 0.25);
                assert!(n <= longest, "a {a} dx {dx} w {w}: {n} > {longest}");
                if longest > 20.0 && longest < 1e6 {
                    assert!(1.2 * n > longest, "a {a} dx {dx} w {w}: {n} ≪ {longest}");
                }
                w *= 1.07;
            }
        }
        let mut x = 1.0e-3;
        while x < 1e6 {
            let l = libm::log2(x) * 16.0;
            assert!(
                log2_16(x, false) as f64 <= l + 1e-9 && l <= log2_16(x, true) as f64 + 1e-9,
                "{x}"
            );
            assert!(
                l - (log2_16(x, false) as f64) < 2.5 && (log2_16(x, true) as f64) - l < 2.5,
                "{x}"
            );
            x *= 1.013;
        }
        for q in 0..2000 {
            let p = pow2_128(q) as f64;
            let want = libm::pow(2.0, q as f64 / 128.0);
            assert!(
                p <= want && (want < 16.0 || p > want * 0.85),
                "{q}: {p} {want}"
            );
        }
    }
}
