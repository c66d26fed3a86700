//! PNG: the tool path rasterised stroke by stroke.

use crate::{Extent, RenderError, RenderSpec, Stroke, MAX_PX, MIN_PX};
use tiny_skia::{
    Color, FillRule, LineCap, LineJoin, Mask, Paint, PathBuilder, Pixmap, Rect, Transform,
};

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

/// An image the tool path is drawn into as it is executed: travel strokes
/// straight onto the picture, tool-on strokes into a coverage mask laid over
/// it at the end, so the work is on top of travel whatever order they came
/// in. Holds the image and the mask (5 bytes a pixel), nothing per stroke.
pub struct PngCanvas {
    pixmap: Pixmap,
    /// Coverage of tool-on strokes and dots.
    tool: Mask,
    mapper: Mapper,
    pb: PathBuilder,
    travel_paint: Paint<'static>,
    travel_style: tiny_skia::Stroke,
    tool_style: tiny_skia::Stroke,
    tool_w: f32,
}

impl PngCanvas {
    /// A blank image for `spec`, with the travel frame drawn. The longest
    /// side is `spec.max_px`; the other follows the aspect ratio of
    /// `spec.bounds`. Fails on degenerate bounds or an unusable size.
    pub fn new(spec: &RenderSpec) -> Result<PngCanvas, RenderError> {
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
        let tool = Mask::new(w, h).ok_or(RenderError::InvalidSize { max_px })?;
        pixmap.fill(Color::WHITE);

        let s = (long / 1600.0) as f32;
        let tool_w = (1.5 * s).max(1.25);
        let travel_w = (0.75 * s).max(0.5);
        let frame_w = s.max(1.0);
        let pad = f64::from(tool_w) + 2.0;
        let mapper = Mapper {
            min_x: ext.min[0],
            max_y: ext.max[1],
            scale,
            margin,
            clip: [-pad, -pad, f64::from(w) + pad, f64::from(h) + pad],
        };

        // Travel-bounds frame.
        let tl = mapper.map([ext.min[0], ext.max[1]]);
        let br = mapper.map([ext.max[0], ext.min[1]]);
        if let Some(rect) = Rect::from_ltrb(tl[0] as f32, tl[1] as f32, br[0] as f32, br[1] as f32)
        {
            let frame = PathBuilder::from_rect(rect);
            pixmap.stroke_path(
                &frame,
                &paint(160, 160, 160, 255),
                &line_style(frame_w),
                Transform::identity(),
                None,
            );
        }
        Ok(PngCanvas {
            pixmap,
            tool,
            mapper,
            pb: PathBuilder::new(),
            travel_paint: paint(70, 130, 230, 140),
            travel_style: line_style(travel_w),
            tool_style: line_style(tool_w),
            tool_w,
        })
    }

    /// Draws one stroke. Never panics on odd point data.
    pub fn draw(&mut self, stroke: &Stroke) {
        let m = &self.mapper;
        match stroke.points.len() {
            0 => {}
            1 => {
                let q = m.map(stroke.points[0]);
                if stroke.tool_on && q.iter().all(|v| v.is_finite()) && m.inside(q) {
                    let mut dot = PathBuilder::new();
                    dot.push_circle(q[0] as f32, q[1] as f32, self.tool_w);
                    if let Some(path) = dot.finish() {
                        self.tool
                            .fill_path(&path, FillRule::Winding, true, Transform::identity());
                    }
                }
            }
            _ => {
                push_polyline(&mut self.pb, &stroke.points, m);
                let Some(path) = std::mem::take(&mut self.pb).finish() else {
                    return;
                };
                if stroke.tool_on {
                    if let Some(outline) = path.stroke(&self.tool_style, 1.0) {
                        self.tool.fill_path(
                            &outline,
                            FillRule::Winding,
                            true,
                            Transform::identity(),
                        );
                    }
                } else {
                    self.pixmap.stroke_path(
                        &path,
                        &self.travel_paint,
                        &self.travel_style,
                        Transform::identity(),
                        None,
                    );
                }
                self.pb = path.clear();
            }
        }
    }

    /// The finished picture: the tool-on coverage laid over the travel.
    pub fn finish(mut self) -> Pixmap {
        lay_tool(&mut self.pixmap, &self.tool);
        self.pixmap
    }

    /// The finished picture as the bytes of a PNG file.
    pub fn encode(self) -> Result<Vec<u8>, RenderError> {
        encode(self.finish())
    }

    /// The picture drawn so far as the bytes of a PNG file, the same as
    /// [`PngCanvas::encode`] would give now; the canvas goes on drawing.
    /// Needs a copy of the image while it encodes.
    pub fn snapshot(&self) -> Result<Vec<u8>, RenderError> {
        let mut pixmap = self.pixmap.clone();
        lay_tool(&mut pixmap, &self.tool);
        encode(pixmap)
    }
}

/// Lays the tool-on coverage over the picture, in the work's colour.
fn lay_tool(pixmap: &mut Pixmap, tool: &Mask) {
    let (w, h) = (pixmap.width() as f32, pixmap.height() as f32);
    if let Some(all) = Rect::from_xywh(0.0, 0.0, w, h) {
        let tool_paint = paint(20, 20, 20, 255);
        pixmap.fill_rect(all, &tool_paint, Transform::identity(), Some(tool));
    }
}

/// A pixmap as the bytes of a PNG file (the plots' too).
pub(crate) fn encode_pixmap(pixmap: Pixmap) -> Result<Vec<u8>, RenderError> {
    encode(pixmap)
}

/// The picture as the bytes of a PNG file.
fn encode(pixmap: Pixmap) -> Result<Vec<u8>, RenderError> {
    let (w, h) = (pixmap.width(), pixmap.height());
    let rgba = pixmap.take_demultiplied();
    let err = |e: png::EncodingError| RenderError::Encode(e.to_string());
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, w, h);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    // The encoder's fast level: a render of a few megapixels is written
    // in a fraction of the default's time (it comes after the run,
    // when nothing else is left to do), for a slightly larger file.
    encoder.set_compression(png::Compression::Fast);
    let mut writer = encoder.write_header().map_err(err)?;
    writer.write_image_data(&rgba).map_err(err)?;
    writer.finish().map_err(err)?;
    Ok(out)
}

/// Renders the strokes as a PNG image (bytes of a PNG file), through a
/// [`PngCanvas`].
pub fn render_png(strokes: &[Stroke], spec: &RenderSpec) -> Result<Vec<u8>, RenderError> {
    let mut canvas = PngCanvas::new(spec)?;
    for s in strokes {
        canvas.draw(s);
    }
    canvas.encode()
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
