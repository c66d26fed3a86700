//! Ramer–Douglas–Peucker polyline simplification.

/// Distance from `p` to the segment `a`–`b` (to `a` when the segment is a point).
fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    if len2 == 0.0 {
        return (p[0] - a[0]).hypot(p[1] - a[1]);
    }
    let t = (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0);
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

/// Keeps the end points and every point needed so that no dropped point is
/// farther than `tol` from the simplified polyline. Closed polylines (first
/// point equal to the last) stay closed. Iterative, so long chains cannot
/// overflow the stack.
pub(crate) fn rdp(pts: &[[f64; 2]], tol: f64) -> Vec<[f64; 2]> {
    if pts.len() < 3 || tol.is_nan() || tol <= 0.0 {
        return pts.to_vec();
    }
    let mut keep = vec![false; pts.len()];
    keep[0] = true;
    keep[pts.len() - 1] = true;
    let mut stack = vec![(0usize, pts.len() - 1)];
    while let Some((i, j)) = stack.pop() {
        if j <= i + 1 {
            continue;
        }
        let (mut far, mut far_d) = (i, -1.0);
        for (k, &p) in pts.iter().enumerate().take(j).skip(i + 1) {
            let d = seg_dist(p, pts[i], pts[j]);
            if d > far_d {
                far = k;
                far_d = d;
            }
        }
        if far_d > tol {
            keep[far] = true;
            stack.push((i, far));
            stack.push((far, j));
        }
    }
    pts.iter()
        .zip(&keep)
        .filter(|(_, &k)| k)
        .map(|(&p, _)| p)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straight_line_keeps_ends() {
        let pts: Vec<_> = (0..10).map(|i| [i as f64, 0.0]).collect();
        assert_eq!(rdp(&pts, 0.5), vec![[0.0, 0.0], [9.0, 0.0]]);
    }

    #[test]
    fn closed_square_keeps_corners() {
        let mut pts = Vec::new();
        for i in 0..4 {
            pts.push([i as f64, 0.0]);
        }
        for i in 0..4 {
            pts.push([4.0, i as f64]);
        }
        for i in 0..4 {
            pts.push([4.0 - i as f64, 4.0]);
        }
        for i in 0..4 {
            pts.push([0.0, 4.0 - i as f64]);
        }
        pts.push([0.0, 0.0]);
        let s = rdp(&pts, 0.5);
        assert_eq!(
            s,
            vec![[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0], [0.0, 0.0]]
        );
    }

    #[test]
    fn tolerance_respected() {
        let pts: Vec<_> = (0..200)
            .map(|i| {
                let a = i as f64 * 0.05;
                [a * 10.0, (a * 3.0).sin() * 5.0]
            })
            .collect();
        let s = rdp(&pts, 0.3);
        assert!(s.len() < pts.len());
        for p in &pts {
            let d = s
                .windows(2)
                .map(|w| seg_dist(*p, w[0], w[1]))
                .fold(f64::INFINITY, f64::min);
            assert!(d <= 0.3 + 1e-9);
        }
    }
}
