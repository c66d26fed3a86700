//! Records the executed tool path as strokes for rendering, thinned to what a
//! picture can show.

use motet_render::Stroke;
use motet_trajectory::Point;

/// The open stroke's state is kept in plain fields rather than in an
/// `Option<Stroke>`: [`PathRecorder::sample`] runs once per step, and its
/// common case (same stroke, movement below the resolution) is then a
/// comparison and one squared distance against values already at hand.
pub struct PathRecorder {
    x: usize,
    y: usize,
    /// Smallest movement worth a new point, mm.
    resolution: f64,
    /// `resolution` squared, compared on every step.
    r2: f64,
    /// The open stroke's tool state (`None`: no stroke open).
    open_on: Option<bool>,
    /// The open stroke's points.
    points: Vec<[f64; 2]>,
    /// The open stroke's last point (meaningful while a stroke is open).
    last: [f64; 2],
    /// Finished strokes not yet taken, simplified.
    done: Vec<Stroke>,
    /// The true latest position, kept even when thinning drops it.
    current: Option<[f64; 2]>,
}

/// Points a stroke collects before it is simplified and handed out, the
/// next piece starting where it ended: what the recorder holds however long
/// one stroke runs (a week of hand-driven motion with the tool on).
pub const MAX_STROKE_POINTS: usize = 8192;

impl PathRecorder {
    /// Draws machine axes `x` and `y` (indices into a point); a new point is
    /// kept once the path has moved `resolution` mm from the last one.
    pub fn new(x: usize, y: usize, resolution: f64) -> PathRecorder {
        PathRecorder {
            x,
            y,
            resolution,
            r2: resolution * resolution,
            open_on: None,
            points: Vec::new(),
            last: [0.0; 2],
            done: Vec::new(),
            current: None,
        }
    }

    /// The machine axes drawn as the picture's x and y.
    pub fn x(&self) -> usize {
        self.x
    }

    /// See [`PathRecorder::x`].
    pub fn y(&self) -> usize {
        self.y
    }

    /// Whether the stroke being recorded is a tool-on one (`None`: none is
    /// open yet).
    #[inline]
    pub fn tool_on(&self) -> Option<bool> {
        self.open_on
    }

    /// Adds the machine's position after a step or a tool change.
    #[inline]
    pub fn sample(&mut self, p: &Point, tool_on: bool) {
        self.sample_xy([p[self.x], p[self.y]], tool_on);
    }

    /// [`PathRecorder::sample`] with the drawn axes' values `q` already
    /// picked out of the point.
    #[inline]
    pub fn sample_xy(&mut self, q: [f64; 2], tool_on: bool) {
        // The common case, once per step: the same stroke goes on.
        if self.open_on == Some(tool_on) && self.points.len() < MAX_STROKE_POINTS {
            let (dx, dy) = (self.last[0] - q[0], self.last[1] - q[1]);
            if dx * dx + dy * dy >= self.r2 {
                self.points.push(q);
                self.last = q;
            }
            self.current = Some(q);
            return;
        }
        self.sample_new_stroke(q, tool_on);
    }

    /// A sample that starts a stroke: the tool's state changed, or the open
    /// stroke is full.
    #[inline(never)]
    fn sample_new_stroke(&mut self, q: [f64; 2], tool_on: bool) {
        if self.open_on != Some(tool_on) {
            // Close the previous stroke where the machine really was, and start the
            // new one there, so strokes join without gaps.
            let start = self.current;
            if let Some(c) = start {
                self.close(c);
            }
            self.open(start, tool_on);
        } else if let Some(&last) = self.points.last() {
            // A long stroke goes on as a new piece from its last point.
            self.close(last);
            self.open(Some(last), tool_on);
        }
        let far = self.points.last().is_none_or(|l| {
            let (dx, dy) = (l[0] - q[0], l[1] - q[1]);
            dx * dx + dy * dy >= self.r2
        });
        if far {
            self.points.push(q);
            self.last = q;
        }
        self.current = Some(q);
    }

    /// Opens a stroke, starting at `start` if given.
    fn open(&mut self, start: Option<[f64; 2]>, tool_on: bool) {
        self.points.clear();
        if let Some(s) = start {
            self.points.push(s);
            self.last = s;
        }
        self.open_on = Some(tool_on);
    }

    /// Ends the open stroke at `c`, simplified, into the finished ones.
    fn close(&mut self, c: [f64; 2]) {
        let Some(tool_on) = self.open_on.take() else {
            return;
        };
        let mut points = std::mem::take(&mut self.points);
        if points.last() != Some(&c) {
            points.push(c);
        }
        simplify(&mut points, 0.5 * self.resolution);
        self.done.push(Stroke { points, tool_on });
    }

    /// How many points the recorder holds: the open stroke's and the finished
    /// strokes' not yet taken.
    pub fn held_points(&self) -> usize {
        self.points.len() + self.done.iter().map(|s| s.points.len()).sum::<usize>()
    }

    /// The strokes finished since the last call, in order; the open one stays.
    pub fn take_finished(&mut self) -> Vec<Stroke> {
        std::mem::take(&mut self.done)
    }

    /// Whether finished strokes wait to be taken.
    pub fn has_finished(&self) -> bool {
        !self.done.is_empty()
    }

    /// The strokes so far, the last one ended at the current position; the
    /// next sample starts a new stroke there.
    pub fn take(&mut self) -> Vec<Stroke> {
        if let Some(c) = self.current {
            self.close(c);
        }
        std::mem::take(&mut self.done)
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

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn point(x: f64, y: f64) -> Point {
        let mut p = [0.0; motet_trajectory::MAX_AXES];
        p[0] = x;
        p[1] = y;
        p
    }

    /// Samples as a walk: each moves by a small step, sometimes toggling
    /// the tool.
    fn walk() -> impl Strategy<Value = Vec<(f64, f64, bool)>> {
        prop::collection::vec(
            (-0.3f64..0.3, -0.3f64..0.3, prop::bool::weighted(0.02)),
            1..4000,
        )
        .prop_map(|moves| {
            let (mut x, mut y, mut on) = (0.0, 0.0, false);
            moves
                .into_iter()
                .map(|(dx, dy, toggle)| {
                    (x, y) = (x + dx, y + dy);
                    on ^= toggle;
                    (x, y, on)
                })
                .collect()
        })
    }

    proptest! {
        /// Strokes join without gaps, change state only where the tool did,
        /// end where the machine last was, and never exceed their size.
        #[test]
        fn strokes_are_continuous(samples in walk(), take_every in 1usize..3000) {
            let mut r = PathRecorder::new(0, 1, 0.25);
            let mut strokes = Vec::new();
            for (i, &(x, y, on)) in samples.iter().enumerate() {
                r.sample(&point(x, y), on);
                if i % take_every == 0 {
                    strokes.extend(r.take_finished());
                }
            }
            strokes.extend(r.take());
            let &(lx, ly, lon) = samples.last().unwrap();
            let last = strokes.last().unwrap();
            prop_assert_eq!(last.points.last().copied(), Some([lx, ly]));
            prop_assert_eq!(last.tool_on, lon);
            let first_on = samples[0].2;
            prop_assert_eq!(strokes[0].tool_on, first_on);
            let toggles = samples.windows(2).filter(|w| w[0].2 != w[1].2).count();
            let changes = strokes.windows(2).filter(|w| w[0].tool_on != w[1].tool_on).count();
            prop_assert_eq!(changes, toggles);
            for w in strokes.windows(2) {
                prop_assert_eq!(w[0].points.last(), w[1].points.first());
            }
            for s in &strokes {
                prop_assert!(s.points.len() <= MAX_STROKE_POINTS + 1);
            }
        }
    }

    #[test]
    fn a_long_stroke_goes_on_in_pieces() {
        let mut r = PathRecorder::new(0, 1, 0.1);
        let n = 3 * MAX_STROKE_POINTS;
        // A zigzag, so simplification keeps every point.
        for i in 0..n {
            r.sample(&point(i as f64, (i % 2) as f64), true);
        }
        let strokes = r.take();
        assert!(strokes.len() >= 3, "{} strokes", strokes.len());
        let total: usize = strokes.iter().map(|s| s.points.len()).sum();
        // Each piece after the first repeats its predecessor's last point.
        assert_eq!(total, n + strokes.len() - 1);
        assert!(strokes.iter().all(|s| s.tool_on));
    }
}
