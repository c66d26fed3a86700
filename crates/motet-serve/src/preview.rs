//! What a job draws, before it runs: its moves in the machine's first two
//! axes, split into tool-on strokes (a tool output above 0, or the `e` axis
//! of a printer extruding) and travel, thinned to what a screen can show.

use motet_host::Machine;
use motet_planner::{Command, Located};
use serde::Serialize;

/// Points kept in a preview at most: a screen cannot show more, and a
/// slicer's print has millions.
pub const MAX_POINTS: usize = 200_000;

/// A polyline of the job, tool on or travel.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Stroke {
    /// Tool on (drawing, cutting, extruding) or travel.
    pub on: bool,
    /// Points, `[x, y]`, machine units.
    pub points: Vec<[f64; 2]>,
}

/// A job's preview.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Preview {
    /// The polylines, in job order.
    pub strokes: Vec<Stroke>,
    /// Bounds of every point: `[x_min, y_min, x_max, y_max]` (zeros when
    /// the job does not move).
    pub bounds: [f64; 4],
    /// Points left out (closer than `min_step` to the last one kept).
    pub thinned: usize,
    /// Shortest distance between two points kept, units.
    pub min_step: f64,
}

impl Preview {
    /// The preview of `commands`, from the machine's start.
    pub fn of(machine: &Machine, commands: &[Located<Command>]) -> Preview {
        let moves = commands
            .iter()
            .filter(|c| matches!(c.item, Command::Move(_)))
            .count();
        // Thin long jobs: keep about MAX_POINTS by skipping points closer
        // than a fraction of the work area's size.
        let span = machine
            .axes
            .iter()
            .take(2)
            .map(|a| a.travel[1] - a.travel[0])
            .fold(0.0f64, f64::max);
        let min_step = if moves > MAX_POINTS { span * 1e-3 } else { 0.0 };
        let e_axis = machine.axis("e");
        let mut tools = vec![false; machine.tools.len()];
        let mut at = machine.start;
        let mut p = Preview {
            min_step,
            ..Preview::default()
        };
        let mut bounds = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut kept = 0usize;
        for c in commands {
            match c.item {
                Command::Tool { tool, value } | Command::ToolPerSpeed { tool, value, .. } => {
                    if let Some(t) = tools.get_mut(tool as usize) {
                        *t = value > 0.0;
                    }
                }
                Command::Move(m) => {
                    let extruding = e_axis.is_some_and(|e| m.target[e] > at[e]);
                    let on = extruding || tools.iter().any(|&t| t);
                    let from = [at[0], at[1]];
                    let to = [m.target[0], m.target[1]];
                    at = m.target;
                    if from == to {
                        continue;
                    }
                    let same = p.strokes.last().is_some_and(|s| s.on == on);
                    if !same {
                        p.strokes.push(Stroke {
                            on,
                            points: vec![from],
                        });
                        kept += 1;
                    }
                    let s = p.strokes.last_mut().expect("pushed above");
                    let last = *s.points.last().expect("a stroke starts with a point");
                    let d = (to[0] - last[0]).hypot(to[1] - last[1]);
                    if d < min_step || kept >= MAX_POINTS {
                        p.thinned += 1;
                        continue;
                    }
                    s.points.push(to);
                    kept += 1;
                    for q in [from, to] {
                        bounds = [
                            bounds[0].min(q[0]),
                            bounds[1].min(q[1]),
                            bounds[2].max(q[0]),
                            bounds[3].max(q[1]),
                        ];
                    }
                }
                _ => {}
            }
        }
        p.bounds = if bounds[0].is_finite() {
            bounds
        } else {
            [0.0; 4]
        };
        p
    }

    /// Number of points kept.
    pub fn points(&self) -> usize {
        self.strokes.iter().map(|s| s.points.len()).sum()
    }
}
