//! Quantities against time as a PNG: panels stacked over one time axis,
//! each with its lines, ticks and labels, and a legend. The report's plots
//! (a heater's temperature and target over its power) are drawn with it.
//!
//! Labels are drawn in an 8×8 bitmap font (`font8x8`, public-domain
//! glyphs) scaled up, so the plot needs no font installed. Points that are
//! not finite break a line, as in the path renders.

use crate::RenderError;
use tiny_skia::{Color, FillRule, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform};

/// One line of a panel.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// Its name in the legend.
    pub name: String,
    /// Colour, RGB.
    pub rgb: [u8; 3],
    /// (time, value) in time order.
    pub points: Vec<[f64; 2]>,
}

/// One panel: its lines over a value axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    /// The value axis's label (with its unit).
    pub label: String,
    /// Its share of the plot's height, relative to the other panels'.
    pub weight: f32,
    /// The value range drawn; `None`: the lines' own, with a margin.
    pub range: Option<[f64; 2]>,
    /// Its lines.
    pub lines: Vec<Line>,
}

/// A plot: a title, panels over one time axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Plot {
    /// Written above the panels.
    pub title: String,
    /// The time axis's label (with its unit).
    pub x_label: String,
    /// Top to bottom.
    pub panels: Vec<Panel>,
}

/// Pixels of a glyph's side at the scale labels are drawn.
const SCALE: f32 = 2.0;
const GLYPH: f32 = 8.0 * SCALE;
const LEFT: f32 = 110.0;
const RIGHT: f32 = 30.0;
const TOP: f32 = 64.0;
const BOTTOM: f32 = 60.0;
const GAP: f32 = 40.0;

/// The plot as the bytes of a PNG of `width` × `height` pixels (each
/// within 200 to 8192).
pub fn render_plot(plot: &Plot, width: u32, height: u32) -> Result<Vec<u8>, RenderError> {
    if !(200..=8192).contains(&width) || !(200..=8192).contains(&height) {
        return Err(RenderError::InvalidSize {
            max_px: width.max(height),
        });
    }
    let mut pm = Pixmap::new(width, height).ok_or(RenderError::InvalidSize { max_px: width })?;
    pm.fill(Color::WHITE);
    let (w, h) = (width as f32, height as f32);
    text(&mut pm, &plot.title, LEFT, 14.0, [0, 0, 0]);
    let x_range = nice_range(
        plot.panels
            .iter()
            .flat_map(|p| p.lines.iter())
            .flat_map(|l| l.points.iter().map(|p| p[0])),
        0.0,
    );
    let weights: f32 = plot.panels.iter().map(|p| p.weight.max(0.01)).sum();
    let n = plot.panels.len() as f32;
    let usable = h - TOP - BOTTOM - GAP * (n - 1.0).max(0.0);
    let mut top = TOP;
    for panel in &plot.panels {
        let ph = usable * panel.weight.max(0.01) / weights.max(0.01);
        let frame = Frame {
            x0: LEFT,
            x1: w - RIGHT,
            y0: top,
            y1: top + ph,
            x: x_range,
            y: panel.range.unwrap_or_else(|| {
                nice_range(
                    panel
                        .lines
                        .iter()
                        .flat_map(|l| l.points.iter().map(|p| p[1])),
                    0.05,
                )
            }),
        };
        draw_panel(&mut pm, panel, &frame);
        top += ph + GAP;
    }
    // The time axis's ticks under the last panel.
    let last = top - GAP;
    let (x0, x1) = (LEFT, w - RIGHT);
    for v in ticks(x_range) {
        let x = x0 + ((v - x_range[0]) / (x_range[1] - x_range[0])) as f32 * (x1 - x0);
        let label = number(v);
        let tw = label.chars().count() as f32 * GLYPH;
        text(&mut pm, &label, x - tw / 2.0, last + 8.0, [60, 60, 60]);
    }
    let tw = plot.x_label.chars().count() as f32 * GLYPH;
    text(
        &mut pm,
        &plot.x_label,
        (x0 + x1 - tw) / 2.0,
        last + 32.0,
        [0, 0, 0],
    );
    crate::png::encode_pixmap(pm)
}

/// Where a panel is on the image and what it shows.
struct Frame {
    x0: f32,
    x1: f32,
    y0: f32,
    y1: f32,
    x: [f64; 2],
    y: [f64; 2],
}

impl Frame {
    fn at(&self, p: [f64; 2]) -> (f32, f32) {
        let fx = (p[0] - self.x[0]) / (self.x[1] - self.x[0]);
        let fy = (p[1] - self.y[0]) / (self.y[1] - self.y[0]);
        (
            self.x0 + fx as f32 * (self.x1 - self.x0),
            self.y1 - fy as f32 * (self.y1 - self.y0),
        )
    }
}

fn paint(rgb: [u8; 3]) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color_rgba8(rgb[0], rgb[1], rgb[2], 255);
    p.anti_alias = true;
    p
}

fn draw_panel(pm: &mut Pixmap, panel: &Panel, f: &Frame) {
    let grid = paint([225, 225, 225]);
    let hair = Stroke {
        width: 1.0,
        ..Stroke::default()
    };
    for v in ticks(f.y) {
        let (_, y) = f.at([f.x[0], v]);
        segment(pm, (f.x0, y), (f.x1, y), &grid, &hair);
        let label = number(v);
        let tw = label.chars().count() as f32 * GLYPH;
        text(pm, &label, f.x0 - tw - 8.0, y - GLYPH / 2.0, [60, 60, 60]);
    }
    for v in ticks(f.x) {
        let (x, _) = f.at([v, f.y[0]]);
        segment(pm, (x, f.y0), (x, f.y1), &grid, &hair);
    }
    if let Some(r) = Rect::from_ltrb(f.x0, f.y0, f.x1, f.y1) {
        let path = PathBuilder::from_rect(r);
        pm.stroke_path(
            &path,
            &paint([120, 120, 120]),
            &hair,
            Transform::identity(),
            None,
        );
    }
    // The value axis's label above the panel, the legend after it.
    text(pm, &panel.label, f.x0, f.y0 - GLYPH - 4.0, [0, 0, 0]);
    let mut lx = f.x0 + (panel.label.chars().count() as f32 + 2.0) * GLYPH;
    for line in &panel.lines {
        let c = paint(line.rgb);
        let y = f.y0 - GLYPH / 2.0 - 4.0;
        segment(pm, (lx, y), (lx + 2.0 * GLYPH, y), &c, &thick());
        lx += 2.5 * GLYPH;
        text(pm, &line.name, lx, f.y0 - GLYPH - 4.0, [0, 0, 0]);
        lx += (line.name.chars().count() as f32 + 2.0) * GLYPH;
    }
    let clip = Rect::from_ltrb(f.x0, f.y0, f.x1, f.y1);
    for line in &panel.lines {
        let mut pb = PathBuilder::new();
        let mut open = false;
        for p in &line.points {
            if !(p[0].is_finite() && p[1].is_finite()) {
                open = false;
                continue;
            }
            let (x, y) = f.at(*p);
            let y = y.clamp(f.y0 - 1.0, f.y1 + 1.0);
            if open {
                pb.line_to(x, y);
            } else {
                pb.move_to(x, y);
                open = true;
            }
        }
        if let (Some(path), Some(_)) = (pb.finish(), clip) {
            pm.stroke_path(
                &path,
                &paint(line.rgb),
                &thick(),
                Transform::identity(),
                None,
            );
        }
    }
}

fn thick() -> Stroke {
    Stroke {
        width: 2.0,
        ..Stroke::default()
    }
}

fn segment(pm: &mut Pixmap, a: (f32, f32), b: (f32, f32), p: &Paint, s: &Stroke) {
    let mut pb = PathBuilder::new();
    pb.move_to(a.0, a.1);
    pb.line_to(b.0, b.1);
    if let Some(path) = pb.finish() {
        pm.stroke_path(&path, p, s, Transform::identity(), None);
    }
}

/// `s` with its top-left at (`x`, `y`), in the bitmap font.
fn text(pm: &mut Pixmap, s: &str, x: f32, y: f32, rgb: [u8; 3]) {
    let mut p = paint(rgb);
    p.anti_alias = false;
    let mut pb = PathBuilder::new();
    for (k, c) in s.chars().enumerate() {
        let rows = glyph(c);
        let cx = x + k as f32 * GLYPH;
        for (r, bits) in rows.iter().enumerate() {
            for b in 0..8 {
                // Bit 0 is the glyph's leftmost pixel.
                if bits & (1 << b) != 0 {
                    let px = cx + b as f32 * SCALE;
                    let py = y + r as f32 * SCALE;
                    if let Some(rect) = Rect::from_xywh(px, py, SCALE, SCALE) {
                        pb.push_rect(rect);
                    }
                }
            }
        }
    }
    if let Some(path) = pb.finish() {
        pm.fill_path(&path, &p, FillRule::Winding, Transform::identity(), None);
    }
}

/// The font's rows for `c` (a blank for what it has no glyph of).
fn glyph(c: char) -> [u8; 8] {
    use font8x8::legacy::{BASIC_LEGACY, LATIN_LEGACY};
    let u = c as usize;
    match u {
        0..=127 => BASIC_LEGACY[u],
        0xA0..=0xFF => LATIN_LEGACY[u - 0xA0],
        _ => [0; 8],
    }
}

/// The least and most of `values` (finite ones), widened by `margin` of
/// the span either way; a single value or none gives a unit range.
fn nice_range(values: impl Iterator<Item = f64>, margin: f64) -> [f64; 2] {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !(lo.is_finite() && hi.is_finite()) {
        return [0.0, 1.0];
    }
    if hi - lo < 1e-9 {
        return [lo - 0.5, hi + 0.5];
    }
    let m = (hi - lo) * margin;
    [lo - m, hi + m]
}

/// Round values within `r`, about five of them, 1, 2 or 5 times a power
/// of ten apart.
fn ticks(r: [f64; 2]) -> Vec<f64> {
    let span = r[1] - r[0];
    if !(span.is_finite() && span > 0.0) {
        return vec![];
    }
    let raw = span / 5.0;
    let p = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * p);
    let first = (r[0] / step).ceil() as i64;
    let last = (r[1] / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

/// A tick's label: as few digits as it needs.
fn number(v: f64) -> String {
    let r = (v * 1000.0).round() / 1000.0;
    let s = format!("{r}");
    if s == "-0" {
        "0".into()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_within() {
        // (range, ticks)
        let cases: [([f64; 2], &[f64]); 3] = [
            ([0.0, 100.0], &[0.0, 20.0, 40.0, 60.0, 80.0, 100.0]),
            ([19.5, 231.0], &[50.0, 100.0, 150.0, 200.0]),
            ([-0.04, 1.04], &[0.0, 0.5, 1.0]),
        ];
        for (r, want) in cases {
            let got = ticks(r);
            assert_eq!(got.len(), want.len(), "{r:?}: {got:?}");
            for (g, w) in got.iter().zip(want) {
                assert!((g - w).abs() < 1e-9, "{r:?}: {got:?}");
            }
        }
        assert!(ticks([1.0, 1.0]).is_empty());
    }

    /// The lines are drawn where their values are, in their colours, and
    /// the labels leave ink.
    #[test]
    fn lines_land_where_their_values_are() {
        let plot = Plot {
            title: "heater hotend: 215 °C".into(),
            x_label: "time, s".into(),
            panels: vec![Panel {
                label: "°C".into(),
                weight: 1.0,
                range: Some([0.0, 100.0]),
                lines: vec![Line {
                    name: "reading".into(),
                    rgb: [200, 0, 0],
                    points: vec![[0.0, 50.0], [10.0, 50.0]],
                }],
            }],
        };
        let png = render_plot(&plot, 400, 300).unwrap();
        let img = Pixmap::decode_png(&png).unwrap();
        // The panel spans y 64..240; 50 °C is at its middle, 152.
        let px = img.pixel(250, 152).unwrap();
        assert!(px.red() > 150 && px.green() < 80, "{px:?}");
        let blank = img.pixel(250, 100).unwrap();
        assert_eq!(blank.red(), 255, "{blank:?}");
        // The title's ink at its place.
        let inked =
            (14..30).any(|y| (LEFT as u32..300).any(|x| img.pixel(x, y).unwrap().red() < 100));
        assert!(inked);
        assert!(render_plot(&plot, 100, 300).is_err());
    }
}
