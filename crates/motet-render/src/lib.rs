//! Draws the tool path a simulated machine executed, as PNG and as SVG.
//!
//! The input is a list of [`Stroke`]s in machine coordinates (mm, x to the
//! right, **y up**). Tool-on strokes are drawn dark, travel (`tool_on =
//! false`) faint and translucent, inside a thin grey rectangle showing the
//! machine's travel [`RenderSpec::bounds`].
//!
//! Rules shared by both outputs:
//! * a stroke with fewer than 2 points is skipped, except that a single-point
//!   tool-on stroke is drawn as a dot;
//! * a non-finite coordinate (NaN, ±inf) breaks a stroke: the line is not
//!   drawn through it, the finite runs on either side are drawn separately;
//! * geometry outside the bounds is clipped at the image edge (bounds plus a
//!   small margin).
//!
//! [`render_png`] is built for large inputs (about a million points): one path
//! per stroke, one reused path builder, segments clipped against the image in
//! `f64` before they reach the rasterizer.

use std::fmt::Write as _;

use tiny_skia::{Color, FillRule, LineCap, LineJoin, Paint, PathBuilder, Pixmap, Rect, Transform};

/// Default for [`RenderSpec::max_px`].
pub const DEFAULT_MAX_PX: u32 = 1600;
/// Smallest accepted [`RenderSpec::max_px`].
pub const MIN_PX: u32 = 16;
/// Largest accepted [`RenderSpec::max_px`] (a 16384² RGBA image is 1 GiB).
pub const MAX_PX: u32 = 16384;

/// One continuous run of machine motion, in machine x,y (mm).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Stroke {
    pub points: Vec<[f64; 2]>,
    /// `true` when the tool was working (cutting, extruding, drawing);
    /// `false` for travel moves.
    pub tool_on: bool,
}

/// What to draw and how big.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSpec {
    /// `[min, max]` of the machine's travel in mm: `[[xmin, ymin], [xmax, ymax]]`.
    pub bounds: [[f64; 2]; 2],
    /// Longest image side in pixels (PNG only); [`DEFAULT_MAX_PX`] by default.
    pub max_px: u32,
    /// Title, written into the SVG `<title>`.
    pub title: String,
}

impl RenderSpec {
    /// A spec with the default image size.
    pub fn new(bounds: [[f64; 2]; 2], title: impl Into<String>) -> Self {
        Self {
            bounds,
            max_px: DEFAULT_MAX_PX,
            title: title.into(),
        }
    }
}

/// Why a PNG could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// Bounds with zero or negative width/height, or a non-finite value.
    #[error("invalid bounds {bounds:?}: need finite min < max on both axes")]
    InvalidBounds { bounds: [[f64; 2]; 2] },
    /// `max_px` outside `MIN_PX..=MAX_PX`, or an image that cannot be allocated.
    #[error("invalid image size: max_px = {max_px} (accepted {MIN_PX}..={MAX_PX})")]
    InvalidSize { max_px: u32 },
    /// The PNG encoder failed.
    #[error("PNG encoding failed: {0}")]
    Encode(String),
}

/// Validated bounds: min corner and extent, all finite, extent > 0.
#[derive(Debug, Clone, Copy)]
struct Extent {
    min: [f64; 2],
    max: [f64; 2],
    size: [f64; 2],
}

impl Extent {
    fn new(b: [[f64; 2]; 2]) -> Option<Self> {
        let size = [b[1][0] - b[0][0], b[1][1] - b[0][1]];
        let ok = b.iter().flatten().all(|v| v.is_finite())
            && size.iter().all(|s| s.is_finite() && *s > 0.0);
        ok.then_some(Self {
            min: b[0],
            max: b[1],
            size,
        })
    }

    fn longest(&self) -> f64 {
        self.size[0].max(self.size[1])
    }
}

// ---------------------------------------------------------------- PNG ----

/// Machine mm -> pixel mapping (y flipped) plus the clip rectangle in pixels.
struct Mapper {
    min_x: f64,
    max_y: f64,
    scale: f64,
    margin: f64,
    clip: [f64; 4], // x0, y0, x1, y1
}

impl Mapper {
    #[inline]
    fn map(&self, p: [f64; 2]) -> [f64; 2] {
        [
            self.margin + (p[0] - self.min_x) * self.scale,
            self.margin + (self.max_y - p[1]) * self.scale,
        ]
    }

    /// Liang–Barsky clip of segment a-b to the clip rectangle. Returns the
    /// clipped endpoints and whether `b` itself was kept.
    #[inline]
    fn clip(&self, a: [f64; 2], b: [f64; 2]) -> Option<([f64; 2], [f64; 2], bool)> {
        let [x0, y0, x1, y1] = self.clip;
        let d = [b[0] - a[0], b[1] - a[1]];
        let mut t0 = 0.0f64;
        let mut t1 = 1.0f64;
        for (p, q) in [
            (-d[0], a[0] - x0),
            (d[0], x1 - a[0]),
            (-d[1], a[1] - y0),
            (d[1], y1 - a[1]),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    if r > t1 {
                        return None;
                    }
                    t0 = t0.max(r);
                } else {
                    if r < t0 {
                        return None;
                    }
                    t1 = t1.min(r);
                }
            }
        }
        let start = if t0 > 0.0 {
            [a[0] + t0 * d[0], a[1] + t0 * d[1]]
        } else {
            a
        };
        let (end, kept) = if t1 < 1.0 {
            ([a[0] + t1 * d[0], a[1] + t1 * d[1]], false)
        } else {
            (b, true)
        };
        Some((start, end, kept))
    }

    fn inside(&self, p: [f64; 2]) -> bool {
        let [x0, y0, x1, y1] = self.clip;
        p[0] >= x0 && p[0] <= x1 && p[1] >= y0 && p[1] <= y1
    }
}

/// Appends one stroke's polyline to `pb`, mapped and clipped. Non-finite
/// points break the line. Returns nothing; an empty builder means nothing
/// visible.
fn push_polyline(pb: &mut PathBuilder, points: &[[f64; 2]], m: &Mapper) {
    let mut prev: Option<[f64; 2]> = None;
    let mut pen_open = false; // current subpath ends at `prev`
    for &p in points {
        let q = m.map(p);
        if !(q[0].is_finite() && q[1].is_finite()) {
            prev = None;
            pen_open = false;
            continue;
        }
        if let Some(a) = prev {
            match m.clip(a, q) {
                Some((s, e, kept)) => {
                    if !pen_open {
                        pb.move_to(s[0] as f32, s[1] as f32);
                    }
                    pb.line_to(e[0] as f32, e[1] as f32);
                    pen_open = kept;
                }
                None => pen_open = false,
            }
        }
        prev = Some(q);
    }
}

fn paint(r: u8, g: u8, b: u8, a: u8) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color_rgba8(r, g, b, a);
    p.anti_alias = true;
    p
}

fn line_style(width: f32) -> tiny_skia::Stroke {
    tiny_skia::Stroke {
        width,
        line_cap: LineCap::Round,
        line_join: LineJoin::Round,
        ..Default::default()
    }
}

/// Renders the strokes as a PNG image (bytes of a PNG file).
///
/// The longest image side is `spec.max_px`; the other follows the aspect
/// ratio of `spec.bounds`. Fails on degenerate bounds or an unusable size,
/// never panics on odd point data.
pub fn render_png(strokes: &[Stroke], spec: &RenderSpec) -> Result<Vec<u8>, RenderError> {
    let pixmap = render_pixmap(strokes, spec)?;
    pixmap
        .encode_png()
        .map_err(|e| RenderError::Encode(e.to_string()))
}

fn render_pixmap(strokes: &[Stroke], spec: &RenderSpec) -> Result<Pixmap, RenderError> {
    let ext = Extent::new(spec.bounds).ok_or(RenderError::InvalidBounds {
        bounds: spec.bounds,
    })?;
    let max_px = spec.max_px;
    if !(MIN_PX..=MAX_PX).contains(&max_px) {
        return Err(RenderError::InvalidSize { max_px });
    }
    let long = f64::from(max_px);
    let margin = (long * 0.02).round().max(2.0);
    let scale = (long - 2.0 * margin) / ext.longest();
    let side = |s: f64| -> u32 {
        // s * scale <= long - 2*margin, so this stays within max_px
        ((s * scale + 2.0 * margin).round() as u32).clamp(1, max_px)
    };
    let (w, h) = (side(ext.size[0]), side(ext.size[1]));
    let mut pixmap = Pixmap::new(w, h).ok_or(RenderError::InvalidSize { max_px })?;
    pixmap.fill(Color::WHITE);

    let s = (long / 1600.0) as f32;
    let tool_w = (1.5 * s).max(1.25);
    let travel_w = (0.75 * s).max(0.5);
    let frame_w = s.max(1.0);
    let pad = f64::from(tool_w) + 2.0;
    let m = Mapper {
        min_x: ext.min[0],
        max_y: ext.max[1],
        scale,
        margin,
        clip: [-pad, -pad, f64::from(w) + pad, f64::from(h) + pad],
    };

    // Travel-bounds frame.
    let tl = m.map([ext.min[0], ext.max[1]]);
    let br = m.map([ext.max[0], ext.min[1]]);
    if let Some(rect) = Rect::from_ltrb(tl[0] as f32, tl[1] as f32, br[0] as f32, br[1] as f32) {
        let frame = PathBuilder::from_rect(rect);
        pixmap.stroke_path(
            &frame,
            &paint(160, 160, 160, 255),
            &line_style(frame_w),
            Transform::identity(),
            None,
        );
    }

    let travel_paint = paint(70, 130, 230, 140);
    let tool_paint = paint(20, 20, 20, 255);
    let travel_style = line_style(travel_w);
    let tool_style = line_style(tool_w);

    let max_len = strokes.iter().map(|s| s.points.len()).max().unwrap_or(0);
    let mut pb = PathBuilder::with_capacity(max_len + 1, max_len + 1);
    let mut dots = PathBuilder::new();

    // Travel first, tool-on on top so the work is never hidden by travel.
    for tool_on in [false, true] {
        let (pt, st) = if tool_on {
            (&tool_paint, &tool_style)
        } else {
            (&travel_paint, &travel_style)
        };
        for stroke in strokes.iter().filter(|s| s.tool_on == tool_on) {
            match stroke.points.len() {
                0 => {}
                1 => {
                    let q = m.map(stroke.points[0]);
                    if tool_on && q.iter().all(|v| v.is_finite()) && m.inside(q) {
                        dots.push_circle(q[0] as f32, q[1] as f32, tool_w);
                    }
                }
                _ => {
                    push_polyline(&mut pb, &stroke.points, &m);
                    if let Some(path) = std::mem::take(&mut pb).finish() {
                        pixmap.stroke_path(&path, pt, st, Transform::identity(), None);
                        pb = path.clear();
                    }
                }
            }
        }
    }
    if let Some(path) = dots.finish() {
        pixmap.fill_path(
            &path,
            &tool_paint,
            FillRule::Winding,
            Transform::identity(),
            None,
        );
    }
    Ok(pixmap)
}

// ---------------------------------------------------------------- SVG ----

/// Formats a coordinate compactly: rounded to 0.1 µm, no `-0`.
fn num(out: &mut String, v: f64) {
    let r = if v.abs() < 1e12 {
        (v * 1e4).round() / 1e4 + 0.0
    } else {
        v
    };
    let _ = write!(out, "{r}");
}

fn xml_escape(out: &mut String, s: &str) {
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            // characters XML 1.0 does not allow at all
            c if (c as u32) < 0x20 && !matches!(c, '\t' | '\n' | '\r') => {}
            c => out.push(c),
        }
    }
}

fn finite(p: &[f64; 2]) -> bool {
    p[0].is_finite() && p[1].is_finite()
}

/// Renders the strokes as SVG text, user units = mm.
///
/// The viewBox covers the bounds plus a small margin; machine y points up via
/// a `scale(1,-1)` group transform, so `<polyline>` points are the machine
/// coordinates unchanged. Every stroke with ≥ 2 finite points becomes one
/// `<polyline>` in input order (several if non-finite points split it); a
/// single-point tool-on stroke becomes a `<circle>`.
///
/// Degenerate bounds cannot fail here: the bounding box of the finite points
/// (at least 1 mm wide) is used instead, and no frame is drawn.
pub fn render_svg(strokes: &[Stroke], spec: &RenderSpec) -> String {
    let valid = Extent::new(spec.bounds);
    let ext = valid.unwrap_or_else(|| fallback_extent(strokes));
    let long = ext.longest();
    let margin = long * 0.02;
    let unit = long / 1600.0; // one pixel at the default image size
    let (tool_w, travel_w, frame_w) = (1.5 * unit, 0.75 * unit, unit);

    let npts: usize = strokes.iter().map(|s| s.points.len()).sum();
    let mut out = String::with_capacity(1024 + npts * 20 + strokes.len() * 96);
    let (vx, vy) = (ext.min[0] - margin, -(ext.max[1] + margin));
    let (vw, vh) = (ext.size[0] + 2.0 * margin, ext.size[1] + 2.0 * margin);

    out.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    out.push_str("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"");
    num(&mut out, vw);
    out.push_str("mm\" height=\"");
    num(&mut out, vh);
    out.push_str("mm\" viewBox=\"");
    for (i, v) in [vx, vy, vw, vh].into_iter().enumerate() {
        if i > 0 {
            out.push(' ');
        }
        num(&mut out, v);
    }
    out.push_str("\">\n<title>");
    xml_escape(&mut out, &spec.title);
    out.push_str("</title>\n<rect x=\"");
    num(&mut out, vx);
    out.push_str("\" y=\"");
    num(&mut out, vy);
    out.push_str("\" width=\"");
    num(&mut out, vw);
    out.push_str("\" height=\"");
    num(&mut out, vh);
    out.push_str("\" fill=\"#ffffff\"/>\n");
    out.push_str(
        "<g transform=\"scale(1,-1)\" fill=\"none\" stroke-linecap=\"round\" stroke-linejoin=\"round\">\n",
    );
    if valid.is_some() {
        out.push_str("<rect x=\"");
        num(&mut out, ext.min[0]);
        out.push_str("\" y=\"");
        num(&mut out, ext.min[1]);
        out.push_str("\" width=\"");
        num(&mut out, ext.size[0]);
        out.push_str("\" height=\"");
        num(&mut out, ext.size[1]);
        out.push_str("\" stroke=\"#a0a0a0\" stroke-width=\"");
        num(&mut out, frame_w);
        out.push_str("\"/>\n");
    }

    for stroke in strokes {
        let pts = &stroke.points;
        if pts.len() == 1 {
            if stroke.tool_on && finite(&pts[0]) {
                out.push_str("<circle class=\"dot\" cx=\"");
                num(&mut out, pts[0][0]);
                out.push_str("\" cy=\"");
                num(&mut out, pts[0][1]);
                out.push_str("\" r=\"");
                num(&mut out, tool_w);
                out.push_str("\" fill=\"#141414\" stroke=\"none\"/>\n");
            }
            continue;
        }
        for run in pts.split(|p| !finite(p)).filter(|r| r.len() >= 2) {
            if stroke.tool_on {
                out.push_str("<polyline class=\"tool\" stroke=\"#141414\" stroke-width=\"");
                num(&mut out, tool_w);
            } else {
                out.push_str(
                    "<polyline class=\"travel\" stroke=\"#4682e6\" stroke-opacity=\"0.55\" stroke-width=\"",
                );
                num(&mut out, travel_w);
            }
            out.push_str("\" points=\"");
            for (i, p) in run.iter().enumerate() {
                if i > 0 {
                    out.push(' ');
                }
                num(&mut out, p[0]);
                out.push(',');
                num(&mut out, p[1]);
            }
            out.push_str("\"/>\n");
        }
    }
    out.push_str("</g>\n</svg>\n");
    out
}

/// Bounding box of the finite points, at least 1 mm on each side; 0..1 mm
/// when there are none.
fn fallback_extent(strokes: &[Stroke]) -> Extent {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in strokes.iter().flat_map(|s| &s.points).filter(|p| finite(p)) {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let mut min = [0.0; 2];
    let mut max = [1.0; 2];
    for k in 0..2 {
        if lo[k] <= hi[k] {
            let size = hi[k] - lo[k];
            if size.is_finite() && size >= 1.0 {
                min[k] = lo[k];
                max[k] = hi[k];
            } else if size.is_finite() {
                let c = 0.5 * (lo[k] + hi[k]);
                min[k] = c - 0.5;
                max[k] = c + 0.5;
            }
        }
    }
    // Guard against huge centres where ±0.5 vanishes in rounding.
    Extent::new([min, max]).unwrap_or(Extent {
        min: [0.0; 2],
        max: [1.0; 2],
        size: [1.0; 2],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mapper() -> Mapper {
        Mapper {
            min_x: 0.0,
            max_y: 10.0,
            scale: 10.0,
            margin: 5.0,
            clip: [0.0, 0.0, 110.0, 110.0],
        }
    }

    #[test]
    fn clip_keeps_inside_segment() {
        let m = mapper();
        let (s, e, kept) = m.clip([1.0, 1.0], [50.0, 60.0]).unwrap();
        assert_eq!((s, e, kept), ([1.0, 1.0], [50.0, 60.0], true));
    }

    #[test]
    fn clip_cuts_crossing_segment() {
        let m = mapper();
        let (s, e, kept) = m.clip([-10.0, 55.0], [210.0, 55.0]).unwrap();
        let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() + (a[1] - b[1]).abs() < 1e-9;
        assert!(close(s, [0.0, 55.0]), "{s:?}");
        assert!(close(e, [110.0, 55.0]), "{e:?}");
        assert!(!kept);
        assert!(m.clip([-10.0, -10.0], [-5.0, 200.0]).is_none());
    }

    #[test]
    fn y_is_flipped() {
        let m = mapper();
        assert_eq!(m.map([0.0, 10.0]), [5.0, 5.0]);
        assert_eq!(m.map([10.0, 0.0]), [105.0, 105.0]);
    }
}
