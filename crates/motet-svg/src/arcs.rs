//! Arcs too large to draw, refused before usvg sees them: usvg (through
//! svgtypes and kurbo) splits an arc into a number of curves that grows with
//! its radius and then takes them one by one from the front of a vector, so
//! one arc of radius 1e40 keeps it busy for hours.

use crate::error::invalid;
use crate::source::ElemInfo;
use motet_planner::SourceError;
use std::collections::HashMap;
use svgtypes::{PathParser, PathSegment};

/// Largest arc radius or end point, in user units: far beyond any drawing
/// (and still only about 150 curves per turn).
pub const MAX_ARC: f64 = 1e12;

/// Refuses the first path whose data holds an arc larger than [`MAX_ARC`].
pub(crate) fn check(index: &HashMap<String, ElemInfo>) -> Result<(), SourceError> {
    let mut paths: Vec<&ElemInfo> = index.values().filter(|i| i.d.is_some()).collect();
    paths.sort_by_key(|i| i.loc);
    for info in paths {
        if let Some(v) = largest_arc(info.d.as_deref().unwrap_or_default()) {
            return Err(invalid(
                info.loc,
                format!("an arc reaches {v:e} user units in this path's data; arcs are limited to {MAX_ARC:e}"),
            ));
        }
    }
    Ok(())
}

/// The size of the first arc beyond [`MAX_ARC`], following the current
/// point as usvg will (errors in the data are usvg's to report).
fn largest_arc(d: &str) -> Option<f64> {
    let (mut x, mut y) = (0.0f64, 0.0f64);
    let (mut mx, mut my) = (0.0f64, 0.0f64);
    for seg in PathParser::from(d) {
        let Ok(seg) = seg else { return None };
        let (abs, nx, ny) = match seg {
            PathSegment::MoveTo { abs, x, y }
            | PathSegment::LineTo { abs, x, y }
            | PathSegment::CurveTo { abs, x, y, .. }
            | PathSegment::SmoothCurveTo { abs, x, y, .. }
            | PathSegment::Quadratic { abs, x, y, .. }
            | PathSegment::SmoothQuadratic { abs, x, y } => (abs, x, y),
            PathSegment::HorizontalLineTo { abs, x: nx } => (abs, nx, if abs { y } else { 0.0 }),
            PathSegment::VerticalLineTo { abs, y: ny } => (abs, if abs { x } else { 0.0 }, ny),
            PathSegment::EllipticalArc {
                abs,
                rx,
                ry,
                x: ax,
                y: ay,
                ..
            } => {
                let (tx, ty) = if abs { (ax, ay) } else { (x + ax, y + ay) };
                let size = [rx, ry, x, y, tx, ty]
                    .iter()
                    .fold(0.0f64, |m, v| m.max(v.abs()));
                // NaN cannot reach here (the parser reads numbers only).
                if size > MAX_ARC {
                    return Some(size);
                }
                (true, tx, ty)
            }
            PathSegment::ClosePath { .. } => (true, mx, my),
        };
        (x, y) = if abs { (nx, ny) } else { (x + nx, y + ny) };
        if let PathSegment::MoveTo { .. } = seg {
            (mx, my) = (x, y);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arcs_beyond_the_limit_are_found() {
        let cases = [
            ("M0 0 a4 4 0 0 1 8 0", None),
            (
                "M355 100 m0 0 a4 4 0 0 1 8 0 a8 8 0 0 1 -101e38 180",
                Some(1.01e40),
            ),
            ("M0 0 A1e13 1e13 0 0 1 1 1", Some(1e13)),
            ("M0 0 h1e13 a1 1 0 0 1 1 1", Some(1e13 + 1.0)),
            ("M1e11 0 l1e11 0 l1e11 0 a1 1 0 0 1 0 0", None),
            ("M0 0 L5e12 0 Z a1 1 0 0 1 1 1", None),
        ];
        for (d, want) in cases {
            assert_eq!(largest_arc(d), want, "{d}");
        }
    }
}
