//! Greedy ordering of polylines by nearest end point.

/// Orders `lines` so that each one starts at the free end point nearest to
/// where the previous one ended (reversing lines as needed), beginning with
/// the end point nearest to `from`. A uniform grid over the end points keeps
/// each step close to constant time.
pub(crate) fn order(mut lines: Vec<Vec<[f64; 2]>>, from: [f64; 2]) -> Vec<Vec<[f64; 2]>> {
    lines.retain(|l| !l.is_empty());
    let n = lines.len();
    if n <= 1 {
        return lines;
    }
    let end_points: Vec<[[f64; 2]; 2]> = lines.iter().map(|l| [l[0], l[l.len() - 1]]).collect();
    let ends = |i: usize, end: bool| end_points[i][end as usize];
    // Grid bounds over all end points.
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for i in 0..n {
        for e in [false, true] {
            let p = ends(i, e);
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-9);
    // About two lines per cell on average.
    let per_side = ((n as f64 / 2.0).sqrt().ceil() as usize).clamp(1, 512);
    let cell = span / per_side as f64;
    let gw = (((hi[0] - lo[0]) / cell) as usize + 1).min(per_side + 1);
    let gh = (((hi[1] - lo[1]) / cell) as usize + 1).min(per_side + 1);
    let cell_of = |p: [f64; 2]| -> (usize, usize) {
        let cx = (((p[0] - lo[0]) / cell).max(0.0) as usize).min(gw - 1);
        let cy = (((p[1] - lo[1]) / cell).max(0.0) as usize).min(gh - 1);
        (cx, cy)
    };
    let mut grid: Vec<Vec<(u32, bool)>> = vec![Vec::new(); gw * gh];
    for i in 0..n {
        for e in [false, true] {
            let (cx, cy) = cell_of(ends(i, e));
            grid[cy * gw + cx].push((i as u32, e));
        }
    }
    let dist = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);

    let mut done = vec![false; n];
    let mut out = Vec::with_capacity(n);
    let mut pos = from;
    for _ in 0..n {
        // Search rings of cells around `pos` until no closer end point can
        // remain. For `pos` outside the grid the ring bound below still
        // holds from the clamped cell.
        let (cx, cy) = cell_of(pos);
        let mut best: Option<(f64, usize, bool)> = None;
        let max_r = gw.max(gh);
        for r in 0..=max_r {
            if let Some((d, _, _)) = best {
                // Anything in ring r is at least (r - 1) cells away.
                if d <= (r as f64 - 1.0).max(0.0) * cell {
                    break;
                }
            }
            let (x0, x1) = (cx as isize - r as isize, cx as isize + r as isize);
            let (y0, y1) = (cy as isize - r as isize, cy as isize + r as isize);
            for y in y0.max(0)..=y1.min(gh as isize - 1) {
                let ring_row = y == y0 || y == y1;
                let mut x = x0.max(0);
                while x <= x1.min(gw as isize - 1) {
                    for &(i, e) in &grid[y as usize * gw + x as usize] {
                        let d = dist(pos, ends(i as usize, e));
                        if best.is_none_or(|(bd, _, _)| d < bd) {
                            best = Some((d, i as usize, e));
                        }
                    }
                    // Inside the ring only its left and right columns.
                    if ring_row || x == x1 {
                        x += 1;
                    } else {
                        x = x1;
                    }
                }
            }
        }
        let Some((_, i, at_end)) = best else { break };
        done[i] = true;
        for e in [false, true] {
            let (gx, gy) = cell_of(ends(i, e));
            grid[gy * gw + gx].retain(|&(j, _)| j as usize != i);
        }
        let mut line = std::mem::take(&mut lines[i]);
        if at_end {
            line.reverse();
        }
        pos = *line.last().expect("non-empty");
        out.push(line);
    }
    debug_assert!(done.iter().all(|&d| d));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chains_nearest_and_reverses() {
        let lines = vec![
            vec![[10.0, 0.0], [20.0, 0.0]],
            vec![[0.0, 0.0], [5.0, 0.0]],
            vec![[30.0, 0.0], [21.0, 0.0]],
        ];
        let o = order(lines, [0.0, 0.0]);
        assert_eq!(o[0], vec![[0.0, 0.0], [5.0, 0.0]]);
        assert_eq!(o[1], vec![[10.0, 0.0], [20.0, 0.0]]);
        assert_eq!(o[2], vec![[21.0, 0.0], [30.0, 0.0]]);
    }

    #[test]
    fn matches_brute_force() {
        // Pseudo-random segments; the grid search must pick exactly what a
        // linear scan picks.
        let mut s = 12345u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 33) as f64 / (1u64 << 31) as f64 * 100.0
        };
        let lines: Vec<Vec<[f64; 2]>> = (0..300)
            .map(|_| vec![[rnd(), rnd()], [rnd(), rnd()]])
            .collect();
        let from = [-50.0, 130.0];
        let got = order(lines.clone(), from);
        // Brute force.
        let mut left = lines;
        let mut pos = from;
        let mut want = Vec::new();
        while !left.is_empty() {
            let mut best = (f64::INFINITY, 0, false);
            for (i, l) in left.iter().enumerate() {
                for (e, p) in [(false, l[0]), (true, l[l.len() - 1])] {
                    let d = (p[0] - pos[0]).hypot(p[1] - pos[1]);
                    if d < best.0 {
                        best = (d, i, e);
                    }
                }
            }
            let mut l = left.remove(best.1);
            if best.2 {
                l.reverse();
            }
            pos = l[l.len() - 1];
            want.push(l);
        }
        assert_eq!(got.len(), want.len());
        assert_eq!(got, want);
    }
}
