//! SVG job source for pen plotters and lasers.
//!
//! [`parse`] turns an SVG document into machine-space [`Command`]s: every
//! visible path outline becomes a pen-up travel to its start, a pen-down
//! (tool on), feed moves along the flattened outline and finally a pen-up.
//! [`parse_with_info`] also returns an [`SvgInfo`]: the pens with their path
//! counts and drawn lengths, and the pen-up travel before and after ordering.
//!
//! # Pens, order and hatching ([`SvgOptions`])
//!
//! * Pens ([`SvgOptions::pens`], default [`PenSplit::ByColour`]): paths are
//!   grouped by stroke colour (fill colour for paths without a stroke and for
//!   hatch lines; the first gradient stop for gradients, black for
//!   patterns), by top-level group / Inkscape layer, or all in one pen. Pens
//!   are drawn one after the other in order of first appearance; between
//!   two pens the pen is lifted, the machine travels to
//!   [`SvgOptions::pen_change_position`] (if set) and a
//!   `Pause { optional: false }` waits for the person to change the pen.
//! * Order ([`SvgOptions::optimize`], default on): within each pen, paths
//!   (each subpath and hatch line separately) are reordered to cut pen-up
//!   travel. Open paths may be drawn end to start; closed ones may start at
//!   any vertex. Greedy nearest neighbour over a kd-tree of candidate entry
//!   points, then 2-opt over 8 nearest neighbours (bounded work), then the
//!   best start vertex for each loop. The result never travels more than
//!   document order (if it would, document order is kept). Off: document
//!   order, paths drawn as written.
//! * Hatching ([`SvgOptions::hatch`], default off): filled shapes (`fill`
//!   not `none`; note that SVG fills shapes black by default) get parallel
//!   lines `spacing_mm` apart at `angle_deg` (machine coordinates, from +x
//!   towards +y), clipped to the interior of the flattened outline with the
//!   shape's `fill-rule` (non-zero or even-odd; every subpath counts as
//!   closed). The lines lie on a global grid (distance from the machine
//!   origin an odd multiple of half the spacing), so neighbouring shapes'
//!   lines line up. In document order they follow the outline.
//!
//! # Supported
//!
//! * Everything [`usvg`] resolves without fonts: `path` (all commands,
//!   including arcs), `rect` (also rounded), `circle`, `ellipse`, `line`,
//!   `polyline`, `polygon`, nested `g`/`svg`, `use`/`symbol`, markers,
//!   `transform` attributes, CSS styles, `viewBox`/`preserveAspectRatio`
//!   and absolute units (`mm`, `cm`, `in`, `pt`, `pc`, `px` at 96 dpi).
//! * Outlines are drawn whether a path is stroked, filled or both; paths with
//!   neither, `visibility="hidden"` and `display="none"` are skipped.
//! * Curves are flattened so that the chords stay within
//!   [`JobTarget::tolerance`] of the true curve, measured in machine mm after
//!   all transforms. usvg approximates arcs by cubics to 0.1 *user units*
//!   (up to 1 mm in a cm-based document), so arcs are rebuilt exactly:
//!   circles and ellipses are sampled from the exact ellipse, `rect` corners
//!   and `A` commands of `path` data are re-read from the source (falling
//!   back to usvg's cubics where the source cannot be matched, e.g. for path
//!   data set from CSS or elements made by DTD entities).
//! * Source locations: every command carries the `line:column` of the SVG
//!   element it came from (for `use` instances: the outermost `use`).
//!   Locations are recovered by tagging elements with generated ids before
//!   handing the text to usvg; where that is impossible (elements created by
//!   DTD entities) the nearest known element's location, or line 0, is used.
//!
//! # Not supported
//!
//! * `text` (usvg is built without fonts: convert text to paths first),
//!   raster and nested-SVG `image`s, compressed `.svgz` files.
//! * Stroke width (the pen traces the centre line), clip paths and masks
//!   (outlines and hatching are drawn unclipped), opacity, dashes.
//! * Hatching: only plain parallel lines (no cross-hatch, no outline
//!   insets; the hatch lines end on the outline, not a pen width inside),
//!   one spacing and angle for the whole document, at most
//!   [`MAX_HATCH_CROSSINGS`] line/outline crossings per document.
//! * Layers: only top-level `g` elements are pens (sublayers belong to their
//!   top-level layer); hidden layers are skipped like any hidden group.
//!   Layers with the same label share one pen.
//! * Zero-length subpaths (dots) are dropped.
//!
//! usvg computes in `f32`: coordinates carry a relative error of about
//! 1e-7 (0.1 µm at 1 m), exact for values representable in `f32` when no
//! scaling is involved. Coordinates within a few `f32` roundings of the
//! page's edges are put on the edges, so strokes along the page border stay
//! on a travel that starts where the page does.
//!
//! Documents nesting elements deeper than `motet_planner::ranges::SVG_DEPTH`
//! (256 levels) are refused at the first element too deep, by a linear scan
//! before anything parses them.

use std::collections::HashMap;

use kurbo::{Affine, BezPath, PathEl, Point as KPoint};
use motet_planner::strokes::{dedup_points, same_point};
use motet_planner::{
    Command, JobTarget, Located, SourceError, SourceLoc, StrokeEmitter, StrokeSettings,
};
// The unit tests (`use super::*`) match on move kinds.
#[cfg(test)]
use motet_planner::MoveKind;
use usvg::roxmltree;
use usvg::tiny_skia_path::PathSegment;

mod arcs;
mod depth;
mod hatch;
mod order;

pub use hatch::MAX_HATCH_CROSSINGS;

/// Millimetres per CSS pixel (usvg works in px at 96 dpi).
pub const MM_PER_PX: f64 = 25.4 / 96.0;

/// Smallest chord tolerance used, in mm (smaller requests are raised to it).
pub const MIN_TOLERANCE: f64 = 1e-6;
/// Tolerance used when the target's tolerance is not a positive number, mm.
pub const DEFAULT_TOLERANCE: f64 = 0.01;
/// Largest coordinate magnitude accepted after transforms, in mm
/// ([`motet_planner::ranges::COORDINATE`]).
pub const MAX_COORD: f64 = motet_planner::ranges::COORDINATE.max;
/// Prefix of the ids given to elements that have none.
const GENERATED_ID: &str = "motet-svg-";
/// Inkscape's XML namespace (layer labels).
const INKSCAPE_NS: &str = "http://www.inkscape.org/namespaces/inkscape";
/// Pen name for paths outside top-level groups with [`PenSplit::ByLayer`].
pub const NO_LAYER: &str = "(no layer)";
/// Upper bound on the number of chords for one ellipse.
const MAX_ELLIPSE_STEPS: f64 = 1e6;

/// How paths are grouped into pens (each pen is drawn in one go, with a
/// pause to change the pen in between).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PenSplit {
    /// One pen per stroke colour (fill colour for paths without a stroke and
    /// for hatch lines).
    #[default]
    ByColour,
    /// One pen per top-level group (Inkscape layer); named by
    /// `inkscape:label`, else `id`, else `layer N`. Everything outside
    /// top-level groups shares the pen `(no layer)`.
    ByLayer,
    /// Everything with one pen, no pauses.
    Single,
}

/// Hatch fill for filled shapes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hatch {
    /// Distance between hatch lines, mm (must be positive).
    pub spacing_mm: f64,
    /// Direction of the lines in machine coordinates, degrees from +x
    /// towards +y.
    pub angle_deg: f64,
}

/// How document space maps onto the machine, and how it is drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct SvgOptions {
    /// Machine position (x, y in mm) of the document's origin corner:
    /// bottom-left with `flip_y`, top-left without.
    pub origin: [f64; 2],
    /// Mirror y so that the drawing is upright on a machine whose y points up
    /// (SVG's y points down).
    pub flip_y: bool,
    /// Pen-up travel speed in mm/s; `f64::INFINITY` (or any non-finite or
    /// non-positive value) means rapid moves.
    pub travel_feed: f64,
    /// Grouping of paths into pens (default: by colour).
    pub pens: PenSplit,
    /// Machine x, y (mm) to travel to for a pen change; `None` (default):
    /// stay where the last pen stopped.
    pub pen_change_position: Option<[f64; 2]>,
    /// Reorder (and reverse / rotate) the paths of each pen to cut pen-up
    /// travel (default true); `false` keeps document order.
    pub optimize: bool,
    /// Hatch filled shapes (default `None`: outlines only).
    pub hatch: Option<Hatch>,
}

impl Default for SvgOptions {
    fn default() -> Self {
        SvgOptions {
            origin: [0.0, 0.0],
            flip_y: true,
            travel_feed: f64::INFINITY,
            pens: PenSplit::ByColour,
            pen_change_position: None,
            optimize: true,
            hatch: None,
        }
    }
}

/// One pen of a parsed document.
#[derive(Clone, Debug, PartialEq)]
pub struct PenInfo {
    /// `#rrggbb` ([`PenSplit::ByColour`]), the layer's label
    /// ([`PenSplit::ByLayer`]) or `pen` ([`PenSplit::Single`]).
    pub name: String,
    /// The colour, for [`PenSplit::ByColour`].
    pub colour: Option<[u8; 3]>,
    /// SVG path elements (shapes) with something drawn by this pen.
    pub paths: usize,
    /// Polylines drawn (subpaths and hatch lines), each with one pen-down.
    pub strokes: usize,
    /// Of `strokes`, hatch lines.
    pub hatch_lines: usize,
    /// Pen-down length, mm.
    pub drawn_mm: f64,
    /// Pen-up travel in document order, mm (from where the pen starts: the
    /// machine start, the pen change position or the previous pen's end).
    pub travel_before_mm: f64,
    /// Pen-up travel as emitted, mm.
    pub travel_after_mm: f64,
}

/// What [`parse_with_info`] found besides the commands.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SvgInfo {
    /// Pens in drawing order (order of first appearance in the document).
    pub pens: Vec<PenInfo>,
    /// Total pen-up travel in document order, mm (including trips to the
    /// pen change position).
    pub travel_before_mm: f64,
    /// Total pen-up travel as emitted, mm.
    pub travel_after_mm: f64,
}

/// Parse an SVG document into machine commands for `target`.
///
/// Returns an empty list for a document without visible paths. Errors:
/// malformed XML/SVG (message `invalid SVG: ...`, located where the parser
/// reports it), a machine without `x` or `y` axis, coordinates beyond
/// [`MAX_COORD`] mm, invalid hatch options or hatching too dense.
pub fn parse(
    data: &[u8],
    target: &JobTarget,
    opts: &SvgOptions,
) -> Result<Vec<Located<Command>>, SourceError> {
    parse_with_info(data, target, opts).map(|(cmds, _)| cmds)
}

/// [`parse`], also returning the pens and pen-up travel statistics.
pub fn parse_with_info(
    data: &[u8],
    target: &JobTarget,
    opts: &SvgOptions,
) -> Result<(Vec<Located<Command>>, SvgInfo), SourceError> {
    let xi = target
        .axis("x")
        .ok_or_else(|| SourceError::new(0, 0, "SVG needs an x axis; the machine has none"))?;
    let yi = target
        .axis("y")
        .ok_or_else(|| SourceError::new(0, 0, "SVG needs a y axis; the machine has none"))?;
    if let Some(h) = opts.hatch {
        if !(h.spacing_mm.is_finite() && h.spacing_mm > 0.0) {
            return Err(SourceError::new(
                0,
                0,
                format!(
                    "hatch spacing must be a positive number of mm, not {}",
                    h.spacing_mm
                ),
            ));
        }
        if !h.angle_deg.is_finite() {
            return Err(SourceError::new(0, 0, "hatch angle must be finite"));
        }
    }
    if let Some(p) = opts.pen_change_position {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return Err(SourceError::new(0, 0, "pen change position must be finite"));
        }
    }

    let text = decode(data)?;
    depth::check_text(text)?;
    let xml_opt = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    let doc = roxmltree::Document::parse_with_options(text, xml_opt).map_err(xml_error)?;
    depth::check_tree(&doc)?;
    let root_loc = {
        let p = doc.text_pos_at(doc.root_element().range().start);
        SourceLoc {
            line: p.row,
            column: p.col,
        }
    };

    let usvg_opt = usvg_options();
    let (annotated, mut index, layers) = annotate(&doc);
    arcs::check(&index)?;
    let tagged = match &annotated {
        Some(text) => usvg::Tree::from_str(text, &usvg_opt).ok(),
        None => None,
    };
    let tree = match tagged {
        Some(tree) => tree,
        None => {
            if annotated.is_some() {
                // Tagging broke something: parse the original, without
                // the generated ids.
                index.retain(|_, info| !info.generated);
            }
            usvg::Tree::from_xmltree(&doc, &usvg_opt).map_err(|e| usvg_error(e, root_loc))?
        }
    };

    let tolerance = if target.tolerance.is_finite() && target.tolerance > 0.0 {
        target.tolerance.max(MIN_TOLERANCE)
    } else {
        DEFAULT_TOLERANCE
    };

    let mut walker = Walker {
        index: &index,
        layers: &layers,
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
    let end_loc = walker.last_loc.unwrap_or_default();
    let pens = walker.pens;

    let mut emitter = StrokeEmitter::new(
        StrokeSettings::for_target(target, xi, yi).with_travel_feed(opts.travel_feed),
    );
    let start = [target.start[xi], target.start[yi]];
    let info = draw_pens(&pens, start, opts, &mut emitter);
    Ok((emitter.finish(end_loc), info))
}

/// Everything drawn with one pen, in document order.
struct PenGroup {
    name: String,
    colour: Option<[u8; 3]>,
    strokes: Vec<Stroke>,
}

/// A cleaned machine-space polyline: no repeated consecutive points, at
/// least two points; closed ones without the repeated first point.
struct Stroke {
    pts: Vec<[f64; 2]>,
    closed: bool,
    loc: SourceLoc,
    /// Which SVG path (in walk order) it came from.
    path: usize,
    hatch: bool,
}

impl Stroke {
    /// Clean `pts`; `None` if nothing is left to draw.
    fn new(
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
fn draw_pens(
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
fn paint_colour(paint: &usvg::Paint) -> [u8; 3] {
    let c = match paint {
        usvg::Paint::Color(c) => Some(*c),
        usvg::Paint::LinearGradient(g) => g.stops().first().map(|s| s.color()),
        usvg::Paint::RadialGradient(g) => g.stops().first().map(|s| s.color()),
        usvg::Paint::Pattern(_) => None,
    }
    .unwrap_or(usvg::Color::black());
    [c.red, c.green, c.blue]
}

/// usvg options: no external files, no images.
fn usvg_options() -> usvg::Options<'static> {
    usvg::Options {
        image_href_resolver: usvg::ImageHrefResolver {
            resolve_data: Box::new(|_, _, _| None),
            resolve_string: Box::new(|_, _| None),
        },
        ..Default::default()
    }
}

fn invalid(loc: SourceLoc, what: impl std::fmt::Display) -> SourceError {
    SourceError {
        loc,
        message: format!("invalid SVG: {what}"),
    }
}

/// Bytes to text, with a located error for non-UTF-8 input.
fn decode(data: &[u8]) -> Result<&str, SourceError> {
    if data.starts_with(&[0x1f, 0x8b]) {
        return Err(invalid(
            SourceLoc::default(),
            "compressed SVG (svgz) is not supported; decompress it first",
        ));
    }
    let text = match std::str::from_utf8(data) {
        Ok(t) => t,
        Err(e) => {
            // The prefix up to the bad byte is valid UTF-8 by definition.
            let good = std::str::from_utf8(&data[..e.valid_up_to()]).unwrap_or("");
            let (line, column) = line_col(good, 1, 1);
            return Err(invalid(
                SourceLoc { line, column },
                "not UTF-8 text (or a binary file)",
            ));
        }
    };
    Ok(text.strip_prefix('\u{feff}').unwrap_or(text))
}

/// Line and column (1-based, columns in chars) after reading `s` starting
/// at `line:col`.
fn line_col(s: &str, mut line: u32, mut col: u32) -> (u32, u32) {
    for c in s.chars() {
        if c == '\n' {
            line = line.saturating_add(1);
            col = 1;
        } else {
            col = col.saturating_add(1);
        }
    }
    (line, col)
}

fn xml_error(e: roxmltree::Error) -> SourceError {
    let pos = e.pos();
    let msg = e.to_string();
    let suffix = format!(" at {pos}");
    let msg = msg.strip_suffix(&suffix).unwrap_or(&msg);
    invalid(
        SourceLoc {
            line: pos.row,
            column: pos.col,
        },
        msg,
    )
}

fn usvg_error(e: usvg::Error, root: SourceLoc) -> SourceError {
    match e {
        usvg::Error::ParsingFailed(e) => xml_error(e),
        usvg::Error::InvalidSize => invalid(
            root,
            "the document size is invalid (width/height must be positive)",
        ),
        e => invalid(SourceLoc::default(), e),
    }
}

/// Where an element is and what it is.
#[derive(Clone, Debug)]
struct ElemInfo {
    loc: SourceLoc,
    tag: String,
    /// The id was made up by [`annotate`].
    generated: bool,
    /// Path data of a `path` element that has arcs.
    d: Option<String>,
    /// Index of the top-level group (layer) the element is in.
    layer: Option<usize>,
}

/// Give every element without an id a generated one, so that usvg's nodes
/// can be traced back to their source element. Returns the tagged text
/// (`None` if nothing could be tagged), the id index and the names of the
/// top-level groups (layers).
fn annotate(doc: &roxmltree::Document) -> (Option<String>, HashMap<String, ElemInfo>, Vec<String>) {
    let text = doc.input_text();
    let root = doc.root_element();
    let mut layers: Vec<String> = Vec::new();
    let mut layer_of: HashMap<roxmltree::NodeId, usize> = HashMap::new();
    for g in root
        .children()
        .filter(|n| n.is_element() && n.tag_name().name() == "g")
    {
        let name = g
            .attribute((INKSCAPE_NS, "label"))
            .or_else(|| g.attribute("id"))
            .map_or_else(|| format!("layer {}", layers.len() + 1), str::to_string);
        layer_of.insert(g.id(), layers.len());
        layers.push(name);
    }
    let mut index: HashMap<String, ElemInfo> = HashMap::new();

    let existing: Vec<&str> = doc
        .descendants()
        .filter_map(|n| n.attribute("id"))
        .collect();
    let mut prefix = String::from(GENERATED_ID);
    while existing.iter().any(|id| id.starts_with(prefix.as_str())) {
        prefix.push('_');
    }

    // Each element's layer from its parent's, in document order (parents
    // first): linear, where walking up from every element is not.
    let mut layer_by_node: Vec<Option<usize>> = Vec::new();
    let mut layer_at = |node: roxmltree::Node| {
        let layer = match node.parent_element() {
            Some(p) if p == root => layer_of.get(&node.id()).copied(),
            Some(p) => layer_by_node.get(p.id().get_usize()).copied().flatten(),
            None => None,
        };
        let i = node.id().get_usize();
        if layer_by_node.len() <= i {
            layer_by_node.resize(i + 1, None);
        }
        layer_by_node[i] = layer;
        layer
    };
    let root_start = doc.root_element().range().start;
    let mut inserts: Vec<(usize, String)> = Vec::new();
    // Running position, so that locating all elements is linear.
    let (mut cur, mut line, mut col) = (0usize, 1u32, 1u32);
    for node in doc.descendants().filter(|n| n.is_element()) {
        let start = node.range().start;
        let loc = match text.get(cur..start) {
            Some(between) if start >= cur => {
                (line, col) = line_col(between, line, col);
                cur = start;
                SourceLoc { line, column: col }
            }
            _ => {
                let p = doc.text_pos_at(start);
                SourceLoc {
                    line: p.row,
                    column: p.col,
                }
            }
        };
        let info = ElemInfo {
            loc,
            tag: node.tag_name().name().to_string(),
            generated: false,
            d: node
                .attribute("d")
                .filter(|d| node.tag_name().name() == "path" && d.contains(['a', 'A']))
                .map(str::to_string),
            layer: layer_at(node),
        };
        if let Some(id) = node.attribute("id") {
            index.entry(id.to_string()).or_insert(info);
            continue;
        }
        if start < root_start {
            continue;
        }
        let Some(rest) = text.get(start..) else {
            continue;
        };
        let Some(after_lt) = rest.strip_prefix('<') else {
            continue;
        };
        let name_len = after_lt
            .find(|c: char| c.is_whitespace() || c == '/' || c == '>')
            .unwrap_or(after_lt.len());
        let qname = &after_lt[..name_len];
        if name_len == 0 || !qname.ends_with(info.tag.as_str()) {
            continue;
        }
        let at = start + 1 + name_len;
        if inserts.last().is_some_and(|(p, _)| *p >= at) {
            continue;
        }
        let id = format!("{prefix}{}", inserts.len());
        index.insert(
            id.clone(),
            ElemInfo {
                generated: true,
                ..info
            },
        );
        inserts.push((at, id));
    }
    if inserts.is_empty() {
        return (None, index, layers);
    }
    let mut out = String::with_capacity(text.len() + inserts.len() * 24);
    let mut last = 0;
    for (at, id) in &inserts {
        out.push_str(&text[last..*at]);
        out.push_str(" id=\"");
        out.push_str(id);
        out.push('"');
        last = *at;
    }
    out.push_str(&text[last..]);
    (Some(out), index, layers)
}

/// One flattened subpath in document mm (y down).
struct Subpath {
    points: Vec<KPoint>,
    closed: bool,
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

    fn path(
        &mut self,
        path: &usvg::Path,
        info: Option<&ElemInfo>,
        loc: SourceLoc,
        layer: Option<usize>,
    ) -> Result<(), SourceError> {
        let ts = path.abs_transform();
        let to_mm = Affine::scale(MM_PER_PX)
            * Affine::new([
                ts.sx as f64,
                ts.ky as f64,
                ts.kx as f64,
                ts.sy as f64,
                ts.tx as f64,
                ts.ty as f64,
            ]);
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
        let subpaths = match (ellipse, rebuilt) {
            (Some(e), _) => vec![sample_ellipse(e, to_mm, tol)],
            (None, Some(bez)) => flatten(&bez, to_mm, 0.75 * tol),
            (None, None) => flatten(&usvg_bez(data), to_mm, tol),
        };
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

/// A page point (mm, origin at the corner the machine's origin goes to)
/// with coordinates within rounding of the page's edges put on them. usvg
/// computes in `f32`, the page size and the transforms each rounded on
/// their own, so a stroke along the bottom of a page can come out a few
/// `f32` steps beyond it (-0.00001 mm): off the page, and off a travel
/// that starts where the page does.
fn on_page_edges(p: [f64; 2], size: [f64; 2]) -> [f64; 2] {
    // A few f32 roundings of the page size.
    let eps = 8.0 * f64::from(f32::EPSILON) * size[0].max(size[1]).max(1.0);
    let snap = |v: f64, len: f64| {
        if v.abs() <= eps {
            0.0
        } else if (v - len).abs() <= eps {
            len
        } else {
            v
        }
    };
    [snap(p[0], size[0]), snap(p[1], size[1])]
}

fn kp(p: usvg::tiny_skia_path::Point) -> KPoint {
    KPoint::new(p.x as f64, p.y as f64)
}

/// usvg path data as a kurbo path.
fn usvg_bez(data: &usvg::tiny_skia_path::Path) -> BezPath {
    let mut bez = BezPath::new();
    for seg in data.segments() {
        match seg {
            PathSegment::MoveTo(p) => bez.move_to(kp(p)),
            PathSegment::LineTo(p) => bez.line_to(kp(p)),
            PathSegment::QuadTo(p1, p) => bez.quad_to(kp(p1), kp(p)),
            PathSegment::CubicTo(p1, p2, p) => bez.curve_to(kp(p1), kp(p2), kp(p)),
            PathSegment::Close => bez.close_path(),
        }
    }
    bez
}

/// Largest stretch factor (singular value) of an affine map's linear part.
fn stretch(m: Affine) -> f64 {
    let [a, b, c, d, _, _] = m.as_coeffs();
    let s = a * a + b * b + c * c + d * d;
    let det = a * d - b * c;
    ((s + (s * s - 4.0 * det * det).max(0.0).sqrt()) / 2.0).sqrt()
}

/// Flatten `bez` (path coordinates), mapped by `to_mm`, into polylines
/// within `tol` mm.
fn flatten(bez: &BezPath, to_mm: Affine, tol: f64) -> Vec<Subpath> {
    let bez = to_mm * bez.clone();
    let mut out: Vec<Subpath> = Vec::new();
    let mut start = KPoint::ZERO;
    kurbo::flatten(&bez, tol, |el| match el {
        PathEl::MoveTo(p) => {
            start = p;
            out.push(Subpath {
                points: vec![p],
                closed: false,
            });
        }
        PathEl::LineTo(p) => match out.last_mut() {
            Some(sp) if !sp.closed => sp.points.push(p),
            _ => out.push(Subpath {
                points: vec![start, p],
                closed: false,
            }),
        },
        PathEl::ClosePath => {
            if let Some(sp) = out.last_mut() {
                sp.closed = true;
            }
        }
        // flatten only emits the above
        PathEl::QuadTo(..) | PathEl::CurveTo(..) => {}
    });
    out
}

/// Centre and radii of a usvg circle/ellipse path (move, cubics, close with
/// all on-curve points on the axis-aligned ellipse), in path coordinates.
fn ellipse_of(data: &usvg::tiny_skia_path::Path) -> Option<[f64; 4]> {
    let mut on_curve = Vec::new();
    for (i, seg) in data.segments().enumerate() {
        match seg {
            PathSegment::MoveTo(p) if i == 0 => on_curve.push(p),
            PathSegment::CubicTo(_, _, p) if i > 0 => on_curve.push(p),
            PathSegment::Close if i > 0 => {}
            _ => return None,
        }
    }
    if on_curve.len() < 4 {
        return None;
    }
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in &on_curve {
        x0 = x0.min(p.x as f64);
        x1 = x1.max(p.x as f64);
        y0 = y0.min(p.y as f64);
        y1 = y1.max(p.y as f64);
    }
    let (cx, cy, rx, ry) = (
        (x0 + x1) / 2.0,
        (y0 + y1) / 2.0,
        (x1 - x0) / 2.0,
        (y1 - y0) / 2.0,
    );
    if !(rx > 0.0 && ry > 0.0) {
        return None;
    }
    let first = on_curve[0];
    let on_ellipse = |x: f64, y: f64| {
        let r = ((x - cx) / rx).powi(2) + ((y - cy) / ry).powi(2);
        (r - 1.0).abs() < 1e-4
    };
    let starts_right = ((first.x as f64 - x1) / rx).abs() < 1e-5;
    (starts_right && on_curve.iter().all(|p| on_ellipse(p.x as f64, p.y as f64)))
        .then_some([cx, cy, rx, ry])
}

/// Polyline of an exact ellipse under `to_mm`, chord error <= `tol`,
/// starting at angle 0 and turning the same way as usvg's path.
fn sample_ellipse([cx, cy, rx, ry]: [f64; 4], to_mm: Affine, tol: f64) -> Subpath {
    // The largest stretch of the map bounds the ellipse's semi-axes.
    let big = stretch(to_mm) * rx.max(ry);
    // A chord over parameter step h deviates at most big * (1 - cos(h / 2)).
    let h = if tol >= big {
        std::f64::consts::PI / 2.0
    } else {
        2.0 * (1.0 - tol / big).acos()
    };
    let n = (std::f64::consts::TAU / h)
        .ceil()
        .clamp(8.0, MAX_ELLIPSE_STEPS) as usize;
    let points = (0..n)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / n as f64;
            to_mm * KPoint::new(cx + rx * t.cos(), cy + ry * t.sin())
        })
        .collect();
    Subpath {
        points,
        closed: true,
    }
}

/// Append an SVG arc to `bez` as cubics within `tol` (path units), the way
/// SVG and usvg define it (degenerate radii give a line).
fn arc_to(bez: &mut BezPath, from: KPoint, arc: kurbo::SvgArc, tol: f64) {
    let to = arc.to;
    match kurbo::Arc::from_svg_arc(&kurbo::SvgArc { from, ..arc }) {
        Some(a) => {
            for el in a.append_iter(tol) {
                bez.push(el);
            }
            // End exactly where the source says.
            if let Some(PathEl::CurveTo(p1, p2, _)) = bez.elements().last().copied() {
                bez.pop();
                bez.curve_to(p1, p2, to);
            }
        }
        None => bez.line_to(to),
    }
}

/// Path data parsed with exact arcs (`tol` path units for the arc-to-cubic
/// step). Stops at the first error, as usvg does.
fn path_with_arcs(d: &str, tol: f64) -> Option<BezPath> {
    use svgtypes::PathSegment as S;
    let mut bez = BezPath::new();
    let (mut cur, mut start) = (KPoint::ZERO, KPoint::ZERO);
    // Control point to reflect for S (cubic) / T (quadratic).
    let (mut last_cubic, mut last_quad): (Option<KPoint>, Option<KPoint>) = (None, None);
    let mut closed = false;
    let mut first = true;
    for seg in svgtypes::PathParser::from(d) {
        let Ok(seg) = seg else { break };
        let at = |abs: bool, x: f64, y: f64| {
            if abs {
                KPoint::new(x, y)
            } else {
                KPoint::new(cur.x + x, cur.y + y)
            }
        };
        if first && !matches!(seg, S::MoveTo { .. }) {
            return None;
        }
        first = false;
        if closed && !matches!(seg, S::MoveTo { .. } | S::ClosePath { .. }) {
            bez.move_to(start);
        }
        closed = false;
        let (mut cubic, mut quad) = (None, None);
        match seg {
            S::MoveTo { abs, x, y } => {
                cur = at(abs, x, y);
                start = cur;
                bez.move_to(cur);
            }
            S::LineTo { abs, x, y } => {
                cur = at(abs, x, y);
                bez.line_to(cur);
            }
            S::HorizontalLineTo { abs, x } => {
                cur = KPoint::new(if abs { x } else { cur.x + x }, cur.y);
                bez.line_to(cur);
            }
            S::VerticalLineTo { abs, y } => {
                cur = KPoint::new(cur.x, if abs { y } else { cur.y + y });
                bez.line_to(cur);
            }
            S::CurveTo {
                abs,
                x1,
                y1,
                x2,
                y2,
                x,
                y,
            } => {
                let (p1, p2, p) = (at(abs, x1, y1), at(abs, x2, y2), at(abs, x, y));
                bez.curve_to(p1, p2, p);
                cubic = Some(p2);
                cur = p;
            }
            S::SmoothCurveTo { abs, x2, y2, x, y } => {
                let p1 = last_cubic.map_or(cur, |c| cur + (cur - c));
                let (p2, p) = (at(abs, x2, y2), at(abs, x, y));
                bez.curve_to(p1, p2, p);
                cubic = Some(p2);
                cur = p;
            }
            S::Quadratic { abs, x1, y1, x, y } => {
                let (p1, p) = (at(abs, x1, y1), at(abs, x, y));
                bez.quad_to(p1, p);
                quad = Some(p1);
                cur = p;
            }
            S::SmoothQuadratic { abs, x, y } => {
                let p1 = last_quad.map_or(cur, |c| cur + (cur - c));
                let p = at(abs, x, y);
                bez.quad_to(p1, p);
                quad = Some(p1);
                cur = p;
            }
            S::EllipticalArc {
                abs,
                rx,
                ry,
                x_axis_rotation,
                large_arc,
                sweep,
                x,
                y,
            } => {
                let to = at(abs, x, y);
                let arc = kurbo::SvgArc {
                    from: cur,
                    to,
                    radii: kurbo::Vec2::new(rx, ry),
                    x_rotation: x_axis_rotation.to_radians(),
                    large_arc,
                    sweep,
                };
                arc_to(&mut bez, cur, arc, tol);
                cur = to;
            }
            S::ClosePath { .. } => {
                bez.close_path();
                cur = start;
                closed = true;
            }
        }
        (last_cubic, last_quad) = (cubic, quad);
    }
    Some(bez)
}

/// Start points of the subpaths that draw something.
fn starts(els: impl IntoIterator<Item = PathEl>) -> Vec<KPoint> {
    let mut out = Vec::new();
    let mut pending = None;
    for el in els {
        match el {
            PathEl::MoveTo(p) => pending = Some(p),
            PathEl::ClosePath => {}
            _ => out.extend(pending.take()),
        }
    }
    out
}

/// Whether a rebuilt path has the same subpaths as usvg's (a sanity check
/// that both read the same data).
fn same_starts(bez: &BezPath, data: &usvg::tiny_skia_path::Path) -> bool {
    let a = starts(bez.elements().iter().copied());
    let b = starts(usvg_bez(data).elements().iter().copied());
    let near = |p: &KPoint, q: &KPoint| {
        (p.x - q.x).abs() <= 1e-4 * (1.0 + p.x.abs())
            && (p.y - q.y).abs() <= 1e-4 * (1.0 + p.y.abs())
    };
    a.len() == b.len() && a.iter().zip(&b).all(|(p, q)| near(p, q))
}

/// A rounded rect rebuilt with exact corner arcs from usvg's path
/// (`M x+rx,y H .. A .. V .. A .. H .. A .. V .. A .. Z`); `None` for
/// sharp corners (usvg's path is exact then) or anything unexpected.
fn rounded_rect_of(data: &usvg::tiny_skia_path::Path, tol: f64) -> Option<BezPath> {
    let mut on_curve = Vec::new();
    let mut has_curves = false;
    for (i, seg) in data.segments().enumerate() {
        match seg {
            PathSegment::MoveTo(p) if i == 0 => on_curve.push(kp(p)),
            PathSegment::LineTo(p) if i > 0 => on_curve.push(kp(p)),
            PathSegment::CubicTo(_, _, p) if i > 0 => {
                has_curves = true;
                on_curve.push(kp(p));
            }
            PathSegment::Close if i > 0 => {}
            _ => return None,
        }
    }
    if !has_curves {
        return None;
    }
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in &on_curve {
        (x0, x1, y0, y1) = (x0.min(p.x), x1.max(p.x), y0.min(p.y), y1.max(p.y));
    }
    let first = on_curve[0];
    let rx = first.x - x0;
    let ry = on_curve.iter().find(|p| p.x == x1)?.y - y0;
    let (w, h) = (x1 - x0, y1 - y0);
    let ok = |r: f64, size: f64| r > 0.0 && r <= size / 2.0 + 1e-3 * size;
    if first.y != y0 || !ok(rx, w) || !ok(ry, h) {
        return None;
    }
    let (rx, ry) = (rx.min(w / 2.0), ry.min(h / 2.0));
    let mut bez = BezPath::new();
    let corners = [
        (KPoint::new(x1 - rx, y0), KPoint::new(x1, y0 + ry)),
        (KPoint::new(x1, y1 - ry), KPoint::new(x1 - rx, y1)),
        (KPoint::new(x0 + rx, y1), KPoint::new(x0, y1 - ry)),
        (KPoint::new(x0, y0 + ry), KPoint::new(x0 + rx, y0)),
    ];
    bez.move_to(KPoint::new(x0 + rx, y0));
    for (from, to) in corners {
        bez.line_to(from);
        let arc = kurbo::SvgArc {
            from,
            to,
            radii: kurbo::Vec2::new(rx, ry),
            x_rotation: 0.0,
            large_arc: false,
            sweep: true,
        };
        arc_to(&mut bez, from, arc, tol);
    }
    bez.close_path();
    Some(bez)
}

#[cfg(test)]
mod tests;
