//! Time plots as PNG: one or more panels stacked over a shared time axis,
//! each with its lines (and shaded bands, a decimated trace's least and
//! most), its value range and grid labelled, a title and a legend. The
//! report's plots of planned against measured motion (servos, sensors,
//! heaters) are drawn with it.
//!
//! Text is the public-domain 8×8 bitmap font of `font8x8`, drawn pixel by
//! pixel: no font files, the same image on every machine.

use font8x8::UnicodeFonts;
use tiny_skia::{Color, FillRule, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform};

/// One line of a panel.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// Legend text.
    pub label: String,
    /// RGB.
    pub color: [u8; 3],
    /// (time s, value) in time order; non-finite values break the line.
    pub points: Vec<(f64, f64)>,
    /// A band (time s, least, most) drawn translucent under the line.
    pub band: Vec<(f64, f64, f64)>,
}

/// One panel: lines over the shared time axis.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Panel {
    /// The value axis's label (with its unit).
    pub label: String,
    /// Its lines.
    pub lines: Vec<Line>,
}

/// A plot: a title, panels stacked top to bottom.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Plot {
    /// Written at the top.
    pub title: String,
    /// Top to bottom.
    pub panels: Vec<Panel>,
}

/// Why a plot could not be written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// Nothing to draw.
    #[error("the plot has no panel")]
    Empty,
    /// The PNG could not be encoded or written.
    #[error("cannot write the plot: {0}")]
    Write(String),
}

const WIDTH: u32 = 1200;
const PANEL_H: u32 = 260;
const LEFT: f32 = 90.0;
const RIGHT: f32 = 20.0;
const TOP: f32 = 34.0;
const GAP: f32 = 40.0;

/// Draws `plot` as a PNG image, its bytes.
pub fn plot_png(plot: &Plot) -> Result<Vec<u8>, PlotError> {
    if plot.panels.is_empty() {
        return Err(PlotError::Empty);
    }
    let n = plot.panels.len() as u32;
    let height = TOP as u32 + n * PANEL_H + (n - 1) * GAP as u32 + 40;
    let mut px = Pixmap::new(WIDTH, height).ok_or(PlotError::Empty)?;
    px.fill(Color::WHITE);
    let (t0, t1) = time_range(plot);
    text(&mut px, 10.0, 10.0, &plot.title, [20, 20, 20], 2);
    for (i, panel) in plot.panels.iter().enumerate() {
        let top = TOP + i as f32 * (PANEL_H as f32 + GAP);
        draw_panel(&mut px, panel, top, (t0, t1), i + 1 == plot.panels.len());
    }
    px.encode_png().map_err(|e| PlotError::Write(e.to_string()))
}

/// Draws `plot` into the file `path`.
pub fn write_plot(plot: &Plot, path: &std::path::Path) -> Result<(), PlotError> {
    let bytes = plot_png(plot)?;
    std::fs::write(path, bytes).map_err(|e| PlotError::Write(format!("{}: {e}", path.display())))
}

fn time_range(plot: &Plot) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for l in plot.panels.iter().flat_map(|p| &p.lines) {
        for &(t, _) in &l.points {
            lo = lo.min(t);
            hi = hi.max(t);
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-9 {
        (lo, lo + 1.0)
    } else {
        (lo, hi)
    }
}

fn value_range(panel: &Panel) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for l in &panel.lines {
        let vs = l
            .points
            .iter()
            .map(|p| p.1)
            .chain(l.band.iter().flat_map(|b| [b.1, b.2]));
        for v in vs.filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-9);
    (lo - pad, hi + pad)
}

/// A round step of about a fifth of `span`.
fn nice_step(span: f64) -> f64 {
    let raw = span / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let f = raw / mag;
    let f = if f < 1.5 {
        1.0
    } else if f < 3.5 {
        2.0
    } else if f < 7.5 {
        5.0
    } else {
        10.0
    };
    f * mag
}

fn label_of(v: f64, step: f64) -> String {
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
    };
    format!("{v:.decimals$}")
}

fn draw_panel(px: &mut Pixmap, panel: &Panel, top: f32, t: (f64, f64), last: bool) {
    let (x0, x1) = (LEFT, WIDTH as f32 - RIGHT);
    let (y0, y1) = (top, top + PANEL_H as f32);
    let (v0, v1) = value_range(panel);
    let sx = |tt: f64| x0 + ((tt - t.0) / (t.1 - t.0)) as f32 * (x1 - x0);
    let sy = |v: f64| y1 - ((v - v0) / (v1 - v0)) as f32 * (y1 - y0);
    let grid = [225, 225, 225];
    let vstep = nice_step(v1 - v0);
    let mut v = (v0 / vstep).ceil() * vstep;
    while v <= v1 {
        let y = sy(v);
        line(px, &[(x0, y), (x1, y)], grid, 1.0);
        let s = label_of(v, vstep);
        text(
            px,
            x0 - 6.0 - 8.0 * s.len() as f32,
            y - 4.0,
            &s,
            [60, 60, 60],
            1,
        );
        v += vstep;
    }
    let tstep = nice_step(t.1 - t.0);
    let mut tt = (t.0 / tstep).ceil() * tstep;
    while tt <= t.1 {
        let x = sx(tt);
        line(px, &[(x, y0), (x, y1)], grid, 1.0);
        let s = label_of(tt, tstep);
        text(px, x - 4.0 * s.len() as f32, y1 + 6.0, &s, [60, 60, 60], 1);
        tt += tstep;
    }
    if last {
        text(px, x1 - 80.0, y1 + 20.0, "time, s", [60, 60, 60], 1);
    }
    line(
        px,
        &[(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)],
        [120, 120, 120],
        1.0,
    );
    text(px, x0 + 6.0, y0 + 6.0, &panel.label, [20, 20, 20], 1);
    for (k, l) in panel.lines.iter().enumerate() {
        if l.band.len() >= 2 {
            band(px, &l.band, &sx, &sy, l.color);
        }
        let mut run: Vec<(f32, f32)> = Vec::new();
        for &(tt, v) in &l.points {
            if v.is_finite() {
                run.push((sx(tt), sy(v.clamp(v0, v1))));
            } else if !run.is_empty() {
                line(px, &run, l.color, 1.5);
                run.clear();
            }
        }
        line(px, &run, l.color, 1.5);
        // Legend, top right.
        let ly = y0 + 8.0 + 14.0 * k as f32;
        let lx = x1 - 10.0 - 8.0 * l.label.len() as f32;
        line(
            px,
            &[(lx - 26.0, ly + 4.0), (lx - 6.0, ly + 4.0)],
            l.color,
            3.0,
        );
        text(px, lx, ly, &l.label, [20, 20, 20], 1);
    }
}

fn band(
    px: &mut Pixmap,
    b: &[(f64, f64, f64)],
    sx: &dyn Fn(f64) -> f32,
    sy: &dyn Fn(f64) -> f32,
    color: [u8; 3],
) {
    let mut pb = PathBuilder::new();
    pb.move_to(sx(b[0].0), sy(b[0].2));
    for p in &b[1..] {
        pb.line_to(sx(p.0), sy(p.2));
    }
    for p in b.iter().rev() {
        pb.line_to(sx(p.0), sy(p.1));
    }
    pb.close();
    if let Some(path) = pb.finish() {
        let mut paint = Paint::default();
        paint.set_color_rgba8(color[0], color[1], color[2], 70);
        px.fill_path(
            &path,
            &paint,
            FillRule::Winding,
            Transform::identity(),
            None,
        );
    }
}

fn line(px: &mut Pixmap, pts: &[(f32, f32)], color: [u8; 3], width: f32) {
    if pts.len() < 2 {
        return;
    }
    let mut pb = PathBuilder::new();
    pb.move_to(pts[0].0, pts[0].1);
    for p in &pts[1..] {
        pb.line_to(p.0, p.1);
    }
    if let Some(path) = pb.finish() {
        let mut paint = Paint::default();
        paint.set_color_rgba8(color[0], color[1], color[2], 255);
        paint.anti_alias = true;
        let stroke = Stroke {
            width,
            ..Stroke::default()
        };
        px.stroke_path(&path, &paint, &stroke, Transform::identity(), None);
    }
}

/// `s` at (x, y), top left, in the 8×8 font scaled by `scale`.
fn text(px: &mut Pixmap, x: f32, y: f32, s: &str, color: [u8; 3], scale: u32) {
    let mut paint = Paint::default();
    paint.set_color_rgba8(color[0], color[1], color[2], 255);
    let k = scale as f32;
    for (i, c) in s.chars().enumerate() {
        let glyph = font8x8::BASIC_FONTS
            .get(c)
            .or_else(|| font8x8::LATIN_FONTS.get(c))
            .or_else(|| font8x8::GREEK_FONTS.get(c))
            .unwrap_or([0; 8]);
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                if bits & (1 << col) != 0 {
                    let gx = x + (i as f32 * 8.0 + col as f32) * k;
                    let gy = y + row as f32 * k;
                    if let Some(r) = Rect::from_xywh(gx, gy, k, k) {
                        px.fill_rect(r, &paint, Transform::identity(), None);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plots_encode_and_refuse_nothing_to_draw() {
        assert!(matches!(plot_png(&Plot::default()), Err(PlotError::Empty)));
        let plot = Plot {
            title: "servo x: position".into(),
            panels: vec![Panel {
                label: "position, mm".into(),
                lines: vec![Line {
                    label: "planned".into(),
                    color: [30, 90, 200],
                    points: (0..100)
                        .map(|i| (i as f64 * 0.01, (i as f64).sin()))
                        .collect(),
                    band: (0..100)
                        .map(|i| (i as f64 * 0.01, -0.1, 0.1 + i as f64 * 1e-3))
                        .collect(),
                }],
            }],
        };
        let png = plot_png(&plot).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        // Something was drawn besides the white background.
        let px = Pixmap::decode_png(&png).unwrap();
        let dark = px.pixels().iter().filter(|p| p.red() < 100).count();
        assert!(dark > 500, "{dark}");
    }
}
