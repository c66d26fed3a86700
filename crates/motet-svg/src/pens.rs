//! Pens: the strokes each pen draws, their order, and the pen changes
//! between pens.

use motet_planner::strokes::{dedup_points, same_point};
use motet_planner::{Command, SourceLoc, StrokeEmitter};

use crate::order;
use crate::{PenInfo, SvgInfo, SvgOptions};

/// Everything drawn with one pen, in document order.
pub(crate) struct PenGroup {
    pub(crate) name: String,
    pub(crate) colour: Option<[u8; 3]>,
    pub(crate) strokes: Vec<Stroke>,
}

/// A cleaned machine-space polyline: no repeated consecutive points, at
/// least two points; closed ones without the repeated first point.
pub(crate) struct Stroke {
    pub(crate) pts: Vec<[f64; 2]>,
    pub(crate) closed: bool,
    pub(crate) loc: SourceLoc,
    /// Which SVG path (in walk order) it came from.
    pub(crate) path: usize,
    pub(crate) hatch: bool,
}

impl Stroke {
    /// Clean `pts`; `None` if nothing is left to draw.
    pub(crate) fn new(
        pts: &[[f64; 2]],
        closed: bool,
        loc: SourceLoc,
        path: usize,
        hatch: bool,
    ) -> Option<Self> {
        let mut clean = dedup_points(pts);
        if closed {
            while clean.len() > 1 && same_point(clean[0], clean[clean.len() - 1]) {
                clean.pop();
            }
        }
        (clean.len() >= 2).then_some(Stroke {
            pts: clean,
            closed,
            loc,
            path,
            hatch,
        })
    }

    fn length(&self) -> f64 {
        let open: f64 = self.pts.windows(2).map(|w| order::dist(w[0], w[1])).sum();
        if self.closed {
            open + order::dist(self.pts[0], self.pts[self.pts.len() - 1])
        } else {
            open
        }
    }

    /// Points in drawing order as placed.
    fn placed_points(&self, p: order::Placed) -> Vec<[f64; 2]> {
        if self.closed {
            let r = p.rotate.min(self.pts.len() - 1);
            let mut v = Vec::with_capacity(self.pts.len() + 1);
            v.extend_from_slice(&self.pts[r..]);
            v.extend_from_slice(&self.pts[..=r]);
            v
        } else if p.reversed {
            self.pts.iter().rev().copied().collect()
        } else {
            self.pts.clone()
        }
    }
}

/// Order each pen's strokes, emit them with pen changes in between, and
/// report what was done.
pub(crate) fn draw_pens(
    pens: &[PenGroup],
    start: [f64; 2],
    opts: &SvgOptions,
    emitter: &mut StrokeEmitter,
) -> SvgInfo {
    let shapes: Vec<Vec<order::Shape>> = pens
        .iter()
        .map(|pen| {
            pen.strokes
                .iter()
                .map(|s| order::Shape {
                    pts: &s.pts,
                    closed: s.closed,
                })
                .collect()
        })
        .collect();
    let doc_tours: Vec<Vec<order::Placed>> =
        shapes.iter().map(|s| order::identity(s.len())).collect();
    let (doc_travel, doc_total) = plan_travel(&shapes, &doc_tours, start, opts);
    let mut tours = doc_tours.clone();
    let (mut travel, mut total) = (doc_travel.clone(), doc_total);
    if opts.optimize {
        let mut opt = Vec::with_capacity(pens.len());
        let mut pos = start;
        for (k, s) in shapes.iter().enumerate() {
            if k > 0 {
                pos = opts.pen_change_position.unwrap_or(pos);
            }
            let tour = order::optimize(pos, s);
            pos = order::travel(pos, s, &tour).1;
            opt.push(tour);
        }
        let (t, sum) = plan_travel(&shapes, &opt, start, opts);
        // Each pen travels no more than in document order from the same
        // start; where pens start differs, so check the whole job.
        if sum <= doc_total {
            (tours, travel, total) = (opt, t, sum);
        }
    }

    let mut info = SvgInfo {
        pens: Vec::with_capacity(pens.len()),
        travel_before_mm: doc_total,
        travel_after_mm: total,
    };
    for (k, pen) in pens.iter().enumerate() {
        if k > 0 {
            let first_loc = pen.strokes.first().map(|s| s.loc).unwrap_or_default();
            emitter.lift(first_loc);
            if let Some(p) = opts.pen_change_position {
                emitter.travel_to(p, first_loc);
            }
            emitter.push(first_loc, Command::Pause { optional: false });
        }
        for &p in &tours[k] {
            let s = &pen.strokes[p.index];
            emitter.polyline(&s.placed_points(p), s.loc);
        }
        let mut paths: Vec<usize> = pen.strokes.iter().map(|s| s.path).collect();
        paths.sort_unstable();
        paths.dedup();
        info.pens.push(PenInfo {
            name: pen.name.clone(),
            colour: pen.colour,
            paths: paths.len(),
            strokes: pen.strokes.len(),
            hatch_lines: pen.strokes.iter().filter(|s| s.hatch).count(),
            drawn_mm: pen.strokes.iter().map(Stroke::length).sum(),
            travel_before_mm: doc_travel[k],
            travel_after_mm: travel[k],
        });
    }
    info
}

/// Pen-up travel of each pen (including the trip to the pen change
/// position before it) and in total, for the given tours.
fn plan_travel(
    shapes: &[Vec<order::Shape>],
    tours: &[Vec<order::Placed>],
    start: [f64; 2],
    opts: &SvgOptions,
) -> (Vec<f64>, f64) {
    let mut pos = start;
    let mut out = Vec::with_capacity(shapes.len());
    for (k, (s, tour)) in shapes.iter().zip(tours).enumerate() {
        let mut t = 0.0;
        if k > 0 {
            if let Some(p) = opts.pen_change_position {
                t += order::dist(pos, p);
                pos = p;
            }
        }
        let (d, end) = order::travel(pos, s, tour);
        out.push(t + d);
        pos = end;
    }
    let total = out.iter().sum();
    (out, total)
}

/// Colour of a paint (first stop for gradients, black for patterns).
pub(crate) fn paint_colour(paint: &usvg::Paint) -> [u8; 3] {
    let c = match paint {
        usvg::Paint::Color(c) => Some(*c),
        usvg::Paint::LinearGradient(g) => g.stops().first().map(|s| s.color()),
        usvg::Paint::RadialGradient(g) => g.stops().first().map(|s| s.color()),
        usvg::Paint::Pattern(_) => None,
    }
    .unwrap_or(usvg::Color::black());
    [c.red, c.green, c.blue]
}
