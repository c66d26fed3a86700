//! Hatch fill: parallel lines clipped to a shape's interior by scanline
//! intersection with its flattened outline.

/// Crossings of hatch lines with outlines allowed in one document.
pub const MAX_HATCH_CROSSINGS: usize = 20_000_000;

/// Hatch segments shorter than this (mm) are dropped.
const MIN_SEGMENT: f64 = 1e-6;

/// Hatch lines inside the area enclosed by `rings` (each implicitly closed)
/// under the even-odd or non-zero rule. Lines run at `angle_deg` from the +x
/// axis towards +y, `spacing` apart, on the grid of lines whose distance
/// from the origin is an odd multiple of `spacing / 2` (so that touching
/// shapes get continuous lines). `budget` counts down crossings; `None` when
/// it runs out.
pub(crate) fn hatch(
    rings: &[Vec<[f64; 2]>],
    even_odd: bool,
    spacing: f64,
    angle_deg: f64,
    budget: &mut usize,
) -> Option<Vec<[[f64; 2]; 2]>> {
    let (sin, cos) = angle_deg.to_radians().sin_cos();
    // Rotate into a frame where hatch lines are horizontal: u along, v across.
    let to_uv = |p: [f64; 2]| [p[0] * cos + p[1] * sin, -p[0] * sin + p[1] * cos];
    let to_xy = |u: f64, v: f64| [u * cos - v * sin, u * sin + v * cos];
    // (scanline index, u, winding direction)
    let mut hits: Vec<(i64, f64, i32)> = Vec::new();
    for ring in rings {
        let n = ring.len();
        if n < 2 {
            continue;
        }
        for e in 0..n {
            let a = to_uv(ring[e]);
            let b = to_uv(ring[(e + 1) % n]);
            if a[1] == b[1] {
                continue;
            }
            let dir = if b[1] > a[1] { 1 } else { -1 };
            let (lo, hi) = if a[1] < b[1] { (a, b) } else { (b, a) };
            // Scanlines v_k = (k + 1/2) spacing with lo.v <= v_k < hi.v.
            let k0 = (lo[1] / spacing - 0.5).ceil();
            let k1 = (hi[1] / spacing - 0.5).ceil();
            if !(k0.is_finite() && k1.is_finite()) || k1 - k0 > *budget as f64 {
                return None;
            }
            let (k0, k1) = (k0 as i64, k1 as i64);
            *budget -= (k1 - k0).max(0) as usize;
            for k in k0..k1 {
                let v = (k as f64 + 0.5) * spacing;
                if v < lo[1] || v >= hi[1] {
                    continue;
                }
                let t = (v - lo[1]) / (hi[1] - lo[1]);
                hits.push((k, lo[0] + t * (hi[0] - lo[0]), dir));
            }
        }
    }
    hits.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut out = Vec::new();
    let mut i = 0;
    while i < hits.len() {
        let k = hits[i].0;
        let v = (k as f64 + 0.5) * spacing;
        let mut winding = 0i32;
        let mut enter = 0.0;
        while i < hits.len() && hits[i].0 == k {
            let (_, u, dir) = hits[i];
            let was_in = inside(winding, even_odd);
            winding += dir;
            let is_in = inside(winding, even_odd);
            if !was_in && is_in {
                enter = u;
            } else if was_in && !is_in && u - enter > MIN_SEGMENT {
                out.push([to_xy(enter, v), to_xy(u, v)]);
            }
            i += 1;
        }
    }
    Some(out)
}

fn inside(winding: i32, even_odd: bool) -> bool {
    if even_odd {
        winding % 2 != 0
    } else {
        winding != 0
    }
}
