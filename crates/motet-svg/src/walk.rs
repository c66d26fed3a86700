//! The walk over usvg's tree in document order: each visible path flattened
//! into strokes in machine mm, given to its pen, and hatched if filled.

use std::collections::HashMap;

use kurbo::{Affine, Point as KPoint};
use motet_planner::{SourceError, SourceLoc};

use crate::exact::{path_with_arcs, rounded_rect_of, same_starts};
use crate::geometry::{
    ellipse_of, flatten, on_page_edges, sample_ellipse, stretch, usvg_bez, Subpath,
};
use crate::hatch;
use crate::pens::{paint_colour, PenGroup, Stroke};
use crate::source::{ElemInfo, Source};
use crate::{PenSplit, SvgOptions, MAX_COORD, MM_PER_PX, NO_LAYER};

/// Walks the whole document: the pens in order of first appearance, and the
/// location of the last path drawn (for the final pen-up).
pub(crate) fn walk(
    source: &Source,
    tolerance: f64,
    opts: &SvgOptions,
) -> Result<(Vec<PenGroup>, SourceLoc), SourceError> {
    let tree = &source.tree;
    let mut walker = Walker {
        index: &source.index,
        layers: &source.layers,
        tolerance,
        doc_size: [
            tree.size().width() as f64 * MM_PER_PX,
            tree.size().height() as f64 * MM_PER_PX,
        ],
        opts,
        last_loc: None,
        pens: Vec::new(),
        pen_index: HashMap::new(),
        paths: 0,
        hatch_budget: hatch::MAX_HATCH_CROSSINGS,
    };
    walker.group(tree.root(), None, None, None)?;
    Ok((walker.pens, walker.last_loc.unwrap_or_default()))
}

/// usvg's absolute transform of `path`, followed by px to mm.
fn to_mm(path: &usvg::Path) -> Affine {
    let ts = path.abs_transform();
    Affine::scale(MM_PER_PX)
        * Affine::new([
            ts.sx as f64,
            ts.ky as f64,
            ts.kx as f64,
            ts.sy as f64,
            ts.tx as f64,
            ts.ty as f64,
        ])
}

struct Walker<'a> {
    index: &'a HashMap<String, ElemInfo>,
    /// Names of the top-level groups.
    layers: &'a [String],
    tolerance: f64,
    /// The page's width and height, mm.
    doc_size: [f64; 2],
    opts: &'a SvgOptions,
    /// Location of the last path drawn, for nodes usvg made up (markers).
    last_loc: Option<SourceLoc>,
    /// Pens in order of first appearance, and their index by name.
    pens: Vec<PenGroup>,
    pen_index: HashMap<String, usize>,
    /// Paths seen so far.
    paths: usize,
    /// Hatch crossings still allowed.
    hatch_budget: usize,
}

impl Walker<'_> {
    /// Walk a group in document order. `use_loc`: the outermost `use` this
    /// group was instantiated by; `group_loc`: nearest known ancestor.
    fn group(
        &mut self,
        g: &usvg::Group,
        use_loc: Option<SourceLoc>,
        group_loc: Option<SourceLoc>,
        layer: Option<usize>,
    ) -> Result<(), SourceError> {
        for child in g.children() {
            match child {
                usvg::Node::Group(sub) => {
                    let info = self.index.get(sub.id());
                    let use_loc = use_loc.or_else(|| {
                        info.filter(|i| i.tag == "use" || i.tag == "symbol")
                            .map(|i| i.loc)
                    });
                    let group_loc = info.map(|i| i.loc).or(group_loc);
                    let layer = layer.or_else(|| info.and_then(|i| i.layer));
                    self.group(sub, use_loc, group_loc, layer)?;
                }
                usvg::Node::Path(path) => {
                    if !path.is_visible() {
                        continue;
                    }
                    let info = self.index.get(path.id());
                    let loc = use_loc
                        .or(info.map(|i| i.loc))
                        .or(self.last_loc)
                        .or(group_loc)
                        .unwrap_or_default();
                    let layer = layer.or_else(|| info.and_then(|i| i.layer));
                    self.path(path, info, loc, layer)?;
                    self.last_loc = Some(loc);
                }
                // Text needs fonts (not built in); images are not drawn.
                usvg::Node::Image(_) | usvg::Node::Text(_) => {}
            }
        }
        Ok(())
    }

    /// One visible path: its outline strokes, and hatch lines if filled.
    fn path(
        &mut self,
        path: &usvg::Path,
        info: Option<&ElemInfo>,
        loc: SourceLoc,
        layer: Option<usize>,
    ) -> Result<(), SourceError> {
        let to_mm = to_mm(path);
        let data = path.data();
        // Reject absurd geometry before flattening it into millions of points.
        for p in data.points() {
            let q = to_mm * KPoint::new(p.x as f64, p.y as f64);
            if !(q.x.abs() <= MAX_COORD && q.y.abs() <= MAX_COORD) {
                return Err(SourceError {
                    loc,
                    message: format!(
                        "coordinates out of range: ({}, {}) mm after transforms",
                        q.x, q.y
                    ),
                });
            }
        }
        let subpaths = self.outline(data, info, to_mm);
        let [ox, oy] = self.opts.origin;
        let path_no = self.paths;
        self.paths += 1;
        let outline_pen = self.pen_for(
            path.stroke()
                .map(|s| s.paint())
                .or(path.fill().map(|f| f.paint())),
            layer,
        );
        let mut rings: Vec<Vec<[f64; 2]>> = Vec::new();
        let doc_h = self.doc_size[1];
        for sp in subpaths {
            let pts: Vec<[f64; 2]> = sp
                .points
                .iter()
                .map(|p| {
                    let y = if self.opts.flip_y { doc_h - p.y } else { p.y };
                    let [x, y] = on_page_edges([p.x, y], self.doc_size);
                    [ox + x, oy + y]
                })
                .collect();
            if pts.iter().any(|p| !(p[0].is_finite() && p[1].is_finite())) {
                return Err(SourceError {
                    loc,
                    message: "coordinates out of range after mapping to the machine".into(),
                });
            }
            if let Some(s) = Stroke::new(&pts, sp.closed, loc, path_no, false) {
                self.pens[outline_pen].strokes.push(s);
            }
            rings.push(pts);
        }
        if let (Some(h), Some(fill)) = (self.opts.hatch, path.fill()) {
            let even_odd = fill.rule() == usvg::FillRule::EvenOdd;
            let lines = hatch::hatch(
                &rings,
                even_odd,
                h.spacing_mm,
                h.angle_deg,
                &mut self.hatch_budget,
            )
            .ok_or_else(|| SourceError {
                loc,
                message: format!(
                    "hatch spacing {} mm is too dense for this drawing (more than {} crossings)",
                    h.spacing_mm,
                    hatch::MAX_HATCH_CROSSINGS
                ),
            })?;
            let hatch_pen = self.pen_for(Some(fill.paint()), layer);
            for l in lines {
                if let Some(s) = Stroke::new(&l, false, loc, path_no, true) {
                    self.pens[hatch_pen].strokes.push(s);
                }
            }
        }
        Ok(())
    }

    /// The outline flattened in document mm: exact ellipses and arcs where
    /// the source is known, usvg's cubics elsewhere.
    fn outline(
        &self,
        data: &usvg::tiny_skia_path::Path,
        info: Option<&ElemInfo>,
        to_mm: Affine,
    ) -> Vec<Subpath> {
        let tol = self.tolerance;
        let tag = info.map_or("", |i| i.tag.as_str());
        let ellipse = match tag {
            "circle" | "ellipse" => ellipse_of(data),
            _ => None,
        };
        // usvg turns arcs into cubics with 0.1 user units of error; rebuild
        // arcs exactly where the source is known, splitting the tolerance
        // between arc approximation and flattening.
        let arc_tol = 0.25 * tol / stretch(to_mm).max(f64::MIN_POSITIVE);
        let rebuilt = match tag {
            "path" => info
                .and_then(|i| i.d.as_deref())
                .and_then(|d| path_with_arcs(d, arc_tol))
                .filter(|b| same_starts(b, data)),
            "rect" => rounded_rect_of(data, arc_tol),
            _ => None,
        };
        match (ellipse, rebuilt) {
            (Some(e), _) => vec![sample_ellipse(e, to_mm, tol)],
            (None, Some(bez)) => flatten(&bez, to_mm, 0.75 * tol),
            (None, None) => flatten(&usvg_bez(data), to_mm, tol),
        }
    }

    /// Index of the pen drawing with `paint` in `layer`, made on first use.
    fn pen_for(&mut self, paint: Option<&usvg::Paint>, layer: Option<usize>) -> usize {
        let (name, colour) = match self.opts.pens {
            PenSplit::ByColour => {
                let c = paint.map_or([0, 0, 0], paint_colour);
                (format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]), Some(c))
            }
            PenSplit::ByLayer => (
                layer
                    .and_then(|l| self.layers.get(l))
                    .map_or_else(|| NO_LAYER.to_string(), String::clone),
                None,
            ),
            PenSplit::Single => ("pen".to_string(), None),
        };
        if let Some(&k) = self.pen_index.get(&name) {
            return k;
        }
        self.pens.push(PenGroup {
            name: name.clone(),
            colour,
            strokes: Vec::new(),
        });
        self.pen_index.insert(name, self.pens.len() - 1);
        self.pens.len() - 1
    }
}
