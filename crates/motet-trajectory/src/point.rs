//! Points in machine space.

/// The most machine axes a trajectory carries (for example x, y, z, e and two spare).
///
/// Fixed so that segments have a fixed size on nodes without an allocator.
pub const MAX_AXES: usize = 6;

/// A position in machine space, one coordinate per machine axis, in the axis's
/// units (mm for linear axes, degrees for rotary ones). Unused axes stay at 0.
pub type Point = [f64; MAX_AXES];

/// Euclidean length of `b - a` over the axes selected by `mask`.
#[inline]
pub fn distance_masked(a: &Point, b: &Point, mask: u8) -> f64 {
    let mut sum = 0.0;
    for i in 0..MAX_AXES {
        if mask & (1 << i) != 0 {
            let d = b[i] - a[i];
            sum += d * d;
        }
    }
    crate::math::sqrt(sum)
}

/// `a + (b - a) * f` on every axis.
#[inline]
pub fn lerp(a: &Point, b: &Point, f: f64) -> Point {
    let mut out = *a;
    for i in 0..MAX_AXES {
        out[i] = a[i] + (b[i] - a[i]) * f;
    }
    out
}
