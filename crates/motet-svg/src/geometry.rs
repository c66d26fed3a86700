//! Geometry in machine mm: usvg paths as kurbo paths, flattening within a
//! tolerance after transforms, exact ellipses, the page's edges.

use kurbo::{Affine, BezPath, PathEl, Point as KPoint};
use usvg::tiny_skia_path::PathSegment;

/// Upper bound on the number of chords for one ellipse.
const MAX_ELLIPSE_STEPS: f64 = 1e6;

/// One flattened subpath in document mm (y down).
pub(crate) struct Subpath {
    pub(crate) points: Vec<KPoint>,
    pub(crate) closed: bool,
}

/// A page point (mm, origin at the corner the machine's origin goes to)
/// with coordinates within rounding of the page's edges put on them. usvg
/// computes in `f32`, the page size and the transforms each rounded on
/// their own, so a stroke along the bottom of a page can come out a few
/// `f32` steps beyond it (-0.00001 mm): off the page, and off a travel
/// that starts where the page does.
pub(crate) fn on_page_edges(p: [f64; 2], size: [f64; 2]) -> [f64; 2] {
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

pub(crate) fn kp(p: usvg::tiny_skia_path::Point) -> KPoint {
    KPoint::new(p.x as f64, p.y as f64)
}

/// usvg path data as a kurbo path.
pub(crate) fn usvg_bez(data: &usvg::tiny_skia_path::Path) -> BezPath {
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
pub(crate) fn stretch(m: Affine) -> f64 {
    let [a, b, c, d, _, _] = m.as_coeffs();
    let s = a * a + b * b + c * c + d * d;
    let det = a * d - b * c;
    ((s + (s * s - 4.0 * det * det).max(0.0).sqrt()) / 2.0).sqrt()
}

/// Flatten `bez` (path coordinates), mapped by `to_mm`, into polylines
/// within `tol` mm.
pub(crate) fn flatten(bez: &BezPath, to_mm: Affine, tol: f64) -> Vec<Subpath> {
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
pub(crate) fn ellipse_of(data: &usvg::tiny_skia_path::Path) -> Option<[f64; 4]> {
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
pub(crate) fn sample_ellipse([cx, cy, rx, ry]: [f64; 4], to_mm: Affine, tol: f64) -> Subpath {
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
