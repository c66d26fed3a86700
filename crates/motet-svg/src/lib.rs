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

use motet_planner::{Command, JobTarget, Located, SourceError, StrokeEmitter, StrokeSettings};

mod arcs;
mod depth;
mod error;
mod exact;
mod geometry;
mod hatch;
mod order;
mod pens;
mod source;
mod walk;

use crate::error::decode;
use crate::pens::draw_pens;

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
/// Pen name for paths outside top-level groups with [`PenSplit::ByLayer`].
pub const NO_LAYER: &str = "(no layer)";

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
    check_options(opts)?;
    let text = decode(data)?;
    let source = source::read(text)?;
    let tolerance = if target.tolerance.is_finite() && target.tolerance > 0.0 {
        target.tolerance.max(MIN_TOLERANCE)
    } else {
        DEFAULT_TOLERANCE
    };
    let (pens, end_loc) = walk::walk(&source, tolerance, opts)?;
    let mut emitter = StrokeEmitter::new(
        StrokeSettings::for_target(target, xi, yi).with_travel_feed(opts.travel_feed),
    );
    let start = [target.start[xi], target.start[yi]];
    let info = draw_pens(&pens, start, opts, &mut emitter);
    Ok((emitter.finish(end_loc), info))
}

/// Options that cannot be drawn with, refused before the document is read.
fn check_options(opts: &SvgOptions) -> Result<(), SourceError> {
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
    Ok(())
}
