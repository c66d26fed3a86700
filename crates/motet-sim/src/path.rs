//! Records the executed tool path as strokes for rendering, thinned to what a
//! picture can show.

use motet_render::Stroke;
use motet_trajectory::Point;

pub struct PathRecorder {
    x: usize,
    y: usize,
    /// Smallest movement worth a new point, mm.
    resolution: f64,
    pub strokes: Vec<Stroke>,
    /// The true latest position, kept even when thinning drops it.
    current: Option<[f64; 2]>,
}

impl PathRecorder {
    pub fn new(x: usize, y: usize, resolution: f64) -> PathRecorder {
        PathRecorder {
            x,
            y,
            resolution,
            strokes: Vec::new(),
            current: None,
        }
    }

    /// Adds the machine's position after a step or a tool change.
    pub fn sample(&mut self, p: &Point, tool_on: bool) {
        let q = [p[self.x], p[self.y]];
        let same_state = self.strokes.last().is_some_and(|s| s.tool_on == tool_on);
        if !same_state {
            // Close the previous stroke where the machine really was, and start the
            // new one there, so strokes join without gaps.
            let mut points = Vec::new();
            let tol = 0.5 * self.resolution;
            if let Some(c) = self.current {
                if let Some(s) = self.strokes.last_mut() {
                    if s.points.last() != Some(&c) {
                        s.points.push(c);
                    }
                    simplify(&mut s.points, tol);
                }
                points.push(c);
            }
            self.strokes.push(Stroke { points, tool_on });
        }
        if let Some(s) = self.strokes.last_mut() {
            if s.points
                .last()
                .is_none_or(|l| dist(*l, q) >= self.resolution)
            {
                s.points.push(q);
            }
        }
        self.current = Some(q);
    }

    /// The strokes so far, the last one ended at the current position; the
    /// next sample starts a new stroke there.
    pub fn take(&mut self) -> Vec<Stroke> {
        if let (Some(c), Some(s)) = (self.current, self.strokes.last_mut()) {
            if s.points.last() != Some(&c) {
                s.points.push(c);
            }
            simplify(&mut s.points, 0.5 * self.resolution);
        }
        std::mem::take(&mut self.strokes)
    }
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

/// Distance from `p` to the line through `a` and `b`.
fn line_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (wx, wy) = (b[0] - a[0], b[1] - a[1]);
    let len = (wx * wx + wy * wy).sqrt();
    if len == 0.0 {
        return dist(p, a);
    }
    ((p[0] - a[0]) * wy - (p[1] - a[1]) * wx).abs() / len
}

/// Ramer–Douglas–Peucker: keeps the points needed to stay within `tol` of the
/// original polyline. Iterative, so long strokes cannot overflow the stack.
fn simplify(points: &mut Vec<[f64; 2]>, tol: f64) {
    let n = points.len();
    if n < 3 {
        return;
    }
    let mut keep = vec![false; n];
    keep[0] = true;
    keep[n - 1] = true;
    let mut stack = vec![(0usize, n - 1)];
    while let Some((a, b)) = stack.pop() {
        let (mut worst, mut at) = (0.0, 0);
        for i in a + 1..b {
            let d = line_dist(points[i], points[a], points[b]);
            if d > worst {
                worst = d;
                at = i;
            }
        }
        if worst > tol {
            keep[at] = true;
            stack.push((a, at));
            stack.push((at, b));
        }
    }
    let mut i = 0;
    points.retain(|_| {
        i += 1;
        keep[i - 1]
    });
}
