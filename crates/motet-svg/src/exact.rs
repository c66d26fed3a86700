//! Arcs rebuilt exactly from the source: usvg approximates arcs by cubics
//! to 0.1 user units, too coarse for a drawing in cm, so `A` commands of
//! path data and rounded `rect` corners are re-read here.

use kurbo::{BezPath, PathEl, Point as KPoint};
use usvg::tiny_skia_path::PathSegment;

use crate::geometry::{kp, usvg_bez};

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
pub(crate) fn path_with_arcs(d: &str, tol: f64) -> Option<BezPath> {
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
pub(crate) fn same_starts(bez: &BezPath, data: &usvg::tiny_skia_path::Path) -> bool {
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
pub(crate) fn rounded_rect_of(data: &usvg::tiny_skia_path::Path, tol: f64) -> Option<BezPath> {
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
mod tests {
    use super::*;

    fn close(a: [f64; 2], b: [f64; 2], eps: f64) -> bool {
        (a[0] - b[0]).abs() <= eps && (a[1] - b[1]).abs() <= eps
    }

    /// The path-data reader used for exact arcs agrees with usvg's on
    /// everything else.
    #[test]
    fn path_data_matches_usvg() {
        let cases = [
            "M 10 10 L 20 20 H 30 V 40 Z",
            "m 10 10 l 10 10 h 10 v 20 z m 5 5 l 1 1",
            "M10,10 20,20 30,10",
            "m10 10 20 20 30-10",
            "M 10 10 C 20 0 30 0 40 10 S 60 20 70 10 s 10 10 20 0",
            "M 10 10 Q 20 0 30 10 T 50 10 t 20 0 Q 80 0 90 10",
            "M 10 10 S 20 20 30 10",
            "M 10 10 T 30 10",
            "M 10 10 L 20 10 Z L 30 30",
            "M 10 10 L 20 10 z l 5 5",
            "M 10 10 L 20 10 Z M 40 40 L 50 50 Z",
            "M 10 10 L 20 10 L x 5",
            "M 10 10 M 20 20 L 30 30",
            "M1e1.5.5-1l2e-1 3",
        ];
        for d in cases {
            let svg = format!(
                r#"<svg xmlns="http://www.w3.org/2000/svg" width="100" height="100"><path d="{d}" stroke="black"/></svg>"#
            );
            let tree = usvg::Tree::from_str(&svg, &usvg::Options::default()).unwrap();
            let usvg::Node::Path(p) = &tree.root().children()[0] else {
                panic!("{d}: no path");
            };
            let ours = path_with_arcs(d, 0.01).unwrap();
            let theirs = usvg_bez(p.data());
            let pts = |b: &BezPath| -> Vec<(u8, [f64; 2])> {
                b.elements()
                    .iter()
                    .flat_map(|el| {
                        let (k, ps): (u8, Vec<KPoint>) = match *el {
                            PathEl::MoveTo(p) => (0, vec![p]),
                            PathEl::LineTo(p) => (1, vec![p]),
                            PathEl::QuadTo(a, p) => (2, vec![a, p]),
                            PathEl::CurveTo(a, b, p) => (3, vec![a, b, p]),
                            PathEl::ClosePath => (4, vec![KPoint::ZERO]),
                        };
                        ps.into_iter().map(move |p| (k, [p.x, p.y]))
                    })
                    .collect()
            };
            let (a, b) = (pts(&ours), pts(&theirs));
            // tiny-skia drops a MoveTo that is followed by another one.
            let a: Vec<_> = a
                .iter()
                .enumerate()
                .filter(|(i, (k, _))| !(*k == 0 && a.get(i + 1).is_some_and(|n| n.0 == 0)))
                .map(|(_, x)| *x)
                .collect();
            assert_eq!(a.len(), b.len(), "{d}:\n ours {a:?}\ntheirs {b:?}");
            for (x, y) in a.iter().zip(&b) {
                assert!(
                    x.0 == y.0 && close(x.1, y.1, 1e-5),
                    "{d}:\n ours {a:?}\ntheirs {b:?}"
                );
            }
            assert!(same_starts(&ours, p.data()), "{d}");
        }
    }
}
