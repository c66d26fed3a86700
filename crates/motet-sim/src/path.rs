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
    last: Option<[f64; 2]>,
    /// Distance the tool worked and travelled, from recorded points.
    pub drawn: f64,
    pub travelled: f64,
}

impl PathRecorder {
    pub fn new(x: usize, y: usize, resolution: f64) -> PathRecorder {
        PathRecorder { x, y, resolution, strokes: Vec::new(), last: None, drawn: 0.0, travelled: 0.0 }
    }

    /// Adds the machine's position; `force` keeps the point even if it is close to
    /// the previous one (tool switches).
    pub fn sample(&mut self, p: &Point, tool_on: bool, force: bool) {
        let q = [p[self.x], p[self.y]];
        let stroke_matches = self.strokes.last().is_some_and(|s| s.tool_on == tool_on);
        if let Some(last) = self.last {
            let d = ((q[0] - last[0]).powi(2) + (q[1] - last[1]).powi(2)).sqrt();
            if d < self.resolution && !force && stroke_matches {
                return;
            }
            if tool_on {
                self.drawn += d;
            } else {
                self.travelled += d;
            }
        }
        if !stroke_matches {
            // A new stroke starts where the previous one ended, so lines join up.
            let mut points = Vec::new();
            if let Some(last) = self.last {
                points.push(last);
            }
            self.strokes.push(Stroke { points, tool_on });
        }
        if let Some(s) = self.strokes.last_mut() {
            if s.points.last() != Some(&q) {
                s.points.push(q);
            }
        }
        self.last = Some(q);
    }
}
