//! SVG: the tool path written stroke by stroke.

use crate::{Extent, RenderError, RenderSpec, Stroke};
use std::fmt::Write as _;
use std::io::Write;

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

/// What [`SvgWriter::finish`] ends the document with: the output written so
/// far followed by this is a whole document.
pub const SVG_END: &str = "</g>\n</svg>\n";

/// Writes the tool path as SVG text (user units = mm) as it is executed:
/// the header when made, each stroke when given, the end on
/// [`SvgWriter::finish`]. Holds one stroke's text, nothing more.
///
/// The viewBox covers the bounds plus a small margin; machine y points up via
/// a `scale(1,-1)` group transform, so `<polyline>` points are the machine
/// coordinates unchanged. Every stroke with ≥ 2 finite points becomes one
/// `<polyline>` in input order (several if non-finite points split it); a
/// single-point tool-on stroke becomes a `<circle>`.
pub struct SvgWriter<W: Write> {
    out: W,
    buf: String,
    tool_w: f64,
    travel_w: f64,
}

impl<W: Write> SvgWriter<W> {
    /// Starts the document for `spec`; its bounds must be valid.
    pub fn new(out: W, spec: &RenderSpec) -> Result<SvgWriter<W>, RenderError> {
        let ext = Extent::new(spec.bounds).ok_or(RenderError::InvalidBounds {
            bounds: spec.bounds,
        })?;
        SvgWriter::start(out, ext, true, &spec.title).map_err(|e| RenderError::Write(e.to_string()))
    }

    fn start(out: W, ext: Extent, frame: bool, title: &str) -> std::io::Result<SvgWriter<W>> {
        let long = ext.longest();
        let margin = long * 0.02;
        let unit = long / 1600.0; // one pixel at the default image size
        let (tool_w, travel_w, frame_w) = (1.5 * unit, 0.75 * unit, unit);
        let mut w = SvgWriter {
            out,
            buf: String::with_capacity(4096),
            tool_w,
            travel_w,
        };
        let out = &mut w.buf;
        let (vx, vy) = (ext.min[0] - margin, -(ext.max[1] + margin));
        let (vw, vh) = (ext.size[0] + 2.0 * margin, ext.size[1] + 2.0 * margin);

        out.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
        out.push_str("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"");
        num(out, vw);
        out.push_str("mm\" height=\"");
        num(out, vh);
        out.push_str("mm\" viewBox=\"");
        for (i, v) in [vx, vy, vw, vh].into_iter().enumerate() {
            if i > 0 {
                out.push(' ');
            }
            num(out, v);
        }
        out.push_str("\">\n<title>");
        xml_escape(out, title);
        out.push_str("</title>\n<rect x=\"");
        num(out, vx);
        out.push_str("\" y=\"");
        num(out, vy);
        out.push_str("\" width=\"");
        num(out, vw);
        out.push_str("\" height=\"");
        num(out, vh);
        out.push_str("\" fill=\"#ffffff\"/>\n");
        out.push_str(
            "<g transform=\"scale(1,-1)\" fill=\"none\" stroke-linecap=\"round\" stroke-linejoin=\"round\">\n",
        );
        if frame {
            out.push_str("<rect x=\"");
            num(out, ext.min[0]);
            out.push_str("\" y=\"");
            num(out, ext.min[1]);
            out.push_str("\" width=\"");
            num(out, ext.size[0]);
            out.push_str("\" height=\"");
            num(out, ext.size[1]);
            out.push_str("\" stroke=\"#a0a0a0\" stroke-width=\"");
            num(out, frame_w);
            out.push_str("\"/>\n");
        }
        w.flush_buf()?;
        Ok(w)
    }

    fn flush_buf(&mut self) -> std::io::Result<()> {
        self.out.write_all(self.buf.as_bytes())?;
        self.buf.clear();
        Ok(())
    }

    /// Writes one stroke.
    pub fn stroke(&mut self, stroke: &Stroke) -> std::io::Result<()> {
        let out = &mut self.buf;
        let pts = &stroke.points;
        if pts.len() == 1 {
            if stroke.tool_on && finite(&pts[0]) {
                out.push_str("<circle class=\"dot\" cx=\"");
                num(out, pts[0][0]);
                out.push_str("\" cy=\"");
                num(out, pts[0][1]);
                out.push_str("\" r=\"");
                num(out, self.tool_w);
                out.push_str("\" fill=\"#141414\" stroke=\"none\"/>\n");
            }
            return self.flush_buf();
        }
        for run in pts.split(|p| !finite(p)).filter(|r| r.len() >= 2) {
            if stroke.tool_on {
                out.push_str("<polyline class=\"tool\" stroke=\"#141414\" stroke-width=\"");
                num(out, self.tool_w);
            } else {
                out.push_str(
                    "<polyline class=\"travel\" stroke=\"#4682e6\" stroke-opacity=\"0.55\" stroke-width=\"",
                );
                num(out, self.travel_w);
            }
            out.push_str("\" points=\"");
            for (i, p) in run.iter().enumerate() {
                if i > 0 {
                    out.push(' ');
                }
                num(out, p[0]);
                out.push(',');
                num(out, p[1]);
            }
            out.push_str("\"/>\n");
        }
        self.flush_buf()
    }

    /// The output. Each stroke has been written to it in full when
    /// [`SvgWriter::stroke`] returns, so it can be read back or copied
    /// between strokes: followed by [`SVG_END`], a whole document of the
    /// strokes so far.
    pub fn get_mut(&mut self) -> &mut W {
        &mut self.out
    }

    /// Ends the document; returns the output.
    pub fn finish(mut self) -> std::io::Result<W> {
        self.buf.push_str(SVG_END);
        self.flush_buf()?;
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Renders the strokes as SVG text, user units = mm (see [`SvgWriter`]).
///
/// Degenerate bounds cannot fail here: the bounding box of the finite points
/// (at least 1 mm wide) is used instead, and no frame is drawn.
pub fn render_svg(strokes: &[Stroke], spec: &RenderSpec) -> String {
    let valid = Extent::new(spec.bounds);
    let ext = valid.unwrap_or_else(|| fallback_extent(strokes));
    let npts: usize = strokes.iter().map(|s| s.points.len()).sum();
    let out = Vec::with_capacity(1024 + npts * 20 + strokes.len() * 96);
    // Writing into a Vec cannot fail.
    let written = SvgWriter::start(out, ext, valid.is_some(), &spec.title).and_then(|mut w| {
        for s in strokes {
            w.stroke(s)?;
        }
        w.finish()
    });
    String::from_utf8(written.unwrap_or_default()).unwrap_or_default()
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
