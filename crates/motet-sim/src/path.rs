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
        PathRecorder { x, y, resolution, strokes: Vec::new(), current: None }
    }

    /// Adds the machine's position after a step or a tool change.
    pub fn sample(&mut self, p: &Point, tool_on: bool) {
        let q = [p[self.x], p[self.y]];
        let same_state = self.strokes.last().is_some_and(|s| s.tool_on == tool_on);
        if !same_state {
            // Close the previous stroke where the machine really was, and start the
            // new one there, so strokes join without gaps.
            let mut points = Vec::new();
            if let Some(c) = self.current {
                if let Some(s) = self.strokes.last_mut() {
                    if s.points.last() != Some(&c) {
                        s.points.push(c);
                    }
                }
                points.push(c);
            }
            self.strokes.push(Stroke { points, tool_on });
        }
        if let Some(s) = self.strokes.last_mut() {
            let far = s.points.last().is_none_or(|l| ((q[0] - l[0]).powi(2) + (q[1] - l[1]).powi(2)).sqrt() >= self.resolution);
            if far {
                s.points.push(q);
            }
        }
        self.current = Some(q);
    }

    /// Ends the last stroke at the final position.
    pub fn finish(mut self) -> Vec<Stroke> {
        if let (Some(c), Some(s)) = (self.current, self.strokes.last_mut()) {
            if s.points.last() != Some(&c) {
                s.points.push(c);
            }
        }
        self.strokes
    }
}
