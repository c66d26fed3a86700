//! The geometry under the fit: convex hulls of the observations, a
//! golden-section search over a concave gap, and order statistics.

use super::{Sample, CAPACITY};

/// Golden-section search for the maximum of a concave function on `[lo, hi]`.
pub(super) fn golden_max(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    const R: f64 = 0.618_033_988_749_894_9;
    let mut a = hi - R * (hi - lo);
    let mut b = lo + R * (hi - lo);
    let (mut fa, mut fb) = (f(a), f(b));
    // 0.04 × 0.618^80 ≈ 1e-18: below any skew that matters.
    for _ in 0..80 {
        if fa < fb {
            lo = a;
            a = b;
            fa = fb;
            b = lo + R * (hi - lo);
            fb = f(b);
        } else {
            hi = b;
            b = a;
            fb = fa;
            a = hi - R * (hi - lo);
            fa = f(a);
        }
    }
    0.5 * (lo + hi)
}

/// The lower (`lower`) or upper convex hull of the points `key(s[i])`,
/// as indices into `s` in order of x; returns its length.
pub(super) fn hull(
    s: &[Sample],
    order: &mut [u8; CAPACITY],
    out: &mut [u8; CAPACITY],
    key: impl Fn(&Sample) -> (f64, f64),
    lower: bool,
) -> usize {
    let n = s.len();
    for (i, o) in order.iter_mut().enumerate().take(n) {
        *o = i as u8;
    }
    // Insertion sort: the exchanges arrive almost in order.
    for i in 1..n {
        let mut j = i;
        while j > 0 && key(&s[order[j - 1] as usize]).0 > key(&s[order[j] as usize]).0 {
            order.swap(j - 1, j);
            j -= 1;
        }
    }
    let mut m = 0usize;
    for &i in &order[..n] {
        let p = key(&s[i as usize]);
        while m >= 2 {
            let o = key(&s[out[m - 2] as usize]);
            let a = key(&s[out[m - 1] as usize]);
            let cross = (a.0 - o.0) * (p.1 - o.1) - (a.1 - o.1) * (p.0 - o.0);
            if (lower && cross <= 0.0) || (!lower && cross >= 0.0) {
                m -= 1;
            } else {
                break;
            }
        }
        out[m] = i;
        m += 1;
    }
    m
}

/// The k-th least of `v` (1-based), at least 0, reordering `v`.
pub(super) fn kth_smallest(v: &mut [f64], k: usize) -> f64 {
    let k = k.min(v.len()).max(1);
    let (_, kth, _) = v.select_nth_unstable_by(k - 1, f64::total_cmp);
    kth.max(0.0)
}
