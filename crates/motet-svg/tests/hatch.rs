//! Hatch fill: parallel lines inside filled shapes, by fill rule.

use crate::common;

use common::*;
use motet_svg::*;

/// Winding number of `p` around the closed rings.
fn winding(p: [f64; 2], rings: &[Vec<[f64; 2]>]) -> i32 {
    let mut w = 0;
    for r in rings {
        for i in 0..r.len() {
            let (a, b) = (r[i], r[(i + 1) % r.len()]);
            let cross = (b[0] - a[0]) * (p[1] - a[1]) - (p[0] - a[0]) * (b[1] - a[1]);
            if a[1] <= p[1] && b[1] > p[1] && cross > 0.0 {
                w += 1;
            } else if a[1] > p[1] && b[1] <= p[1] && cross < 0.0 {
                w -= 1;
            }
        }
    }
    w
}

#[test]
fn hatch_fill() {
    let square = |x: f64, y: f64, s: f64| vec![[x, y], [x + s, y], [x + s, y + s], [x, y + s]];
    let rev = |mut v: Vec<[f64; 2]>| {
        v.reverse();
        v
    };
    let circle: Vec<[f64; 2]> = (0..400)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / 400.0;
            [50.0 + 30.0 * a.cos(), 50.0 + 30.0 * a.sin()]
        })
        .collect();
    // (name, document body, outline rings for checking, even-odd, spacing,
    //  angle, expected hatch lines (None: don't check), covered area)
    type Case = (
        &'static str,
        &'static str,
        Vec<Vec<[f64; 2]>>,
        bool,
        f64,
        f64,
        Option<usize>,
        f64,
    );
    let cases: Vec<Case> = vec![
        (
            "square, horizontal",
            r#"<rect x="10" y="10" width="20" height="20" fill="black"/>"#,
            vec![square(10.0, 10.0, 20.0)],
            false,
            1.0,
            0.0,
            Some(20),
            400.0,
        ),
        (
            "square, vertical",
            r#"<rect x="10" y="10" width="20" height="20" fill="black"/>"#,
            vec![square(10.0, 10.0, 20.0)],
            false,
            2.0,
            90.0,
            Some(10),
            400.0,
        ),
        (
            "square, 30 degrees",
            r#"<rect x="10" y="10" width="20" height="20" fill="black"/>"#,
            vec![square(10.0, 10.0, 20.0)],
            false,
            0.5,
            30.0,
            None,
            400.0,
        ),
        (
            "ring, even-odd",
            r#"<path fill-rule="evenodd" d="M 10 10 H 50 V 50 H 10 Z M 20 20 H 40 V 40 H 20 Z"/>"#,
            vec![square(10.0, 10.0, 40.0), square(20.0, 20.0, 20.0)],
            true,
            1.0,
            0.0,
            Some(40 + 20),
            1600.0 - 400.0,
        ),
        (
            "ring, non-zero, same direction: hole filled",
            r#"<path d="M 10 10 H 50 V 50 H 10 Z M 20 20 H 40 V 40 H 20 Z"/>"#,
            vec![square(10.0, 10.0, 40.0), square(20.0, 20.0, 20.0)],
            false,
            1.0,
            0.0,
            Some(40),
            1600.0,
        ),
        (
            "ring, non-zero, opposite direction: hole kept",
            r#"<path d="M 10 10 H 50 V 50 H 10 Z M 20 20 V 40 H 40 V 20 Z"/>"#,
            vec![square(10.0, 10.0, 40.0), rev(square(20.0, 20.0, 20.0))],
            false,
            1.0,
            0.0,
            Some(60),
            1200.0,
        ),
        (
            "circle, 45 degrees",
            r#"<circle cx="50" cy="50" r="30" fill="red" stroke="black"/>"#,
            vec![circle.clone()],
            false,
            0.7,
            45.0,
            None,
            std::f64::consts::PI * 900.0,
        ),
    ];
    for (name, body, rings, even_odd, spacing, angle, count, area) in cases {
        let svg = mm_doc(100.0, 100.0, body);
        let opts = SvgOptions {
            hatch: Some(Hatch {
                spacing_mm: spacing,
                angle_deg: angle,
            }),
            pens: PenSplit::Single,
            ..no_flip()
        };
        let (cmds, info) = run_info(&svg, &opts);
        let lines = polylines(&cmds);
        // Outlines first (document order), then the hatch lines.
        let hatch = &lines[rings.len()..];
        assert_eq!(info.pens[0].hatch_lines, hatch.len(), "{name}");
        if let Some(n) = count {
            assert_eq!(hatch.len(), n, "{name}");
        }
        let (sin, cos) = angle.to_radians().sin_cos();
        let mut offsets: Vec<f64> = Vec::new();
        let mut covered = 0.0;
        for l in hatch {
            assert_eq!(l.len(), 2, "{name}: {l:?}");
            let (a, b) = (l[0], l[1]);
            let len = (b[0] - a[0]).hypot(b[1] - a[1]);
            covered += len * spacing;
            // Direction.
            let cross = ((b[0] - a[0]) * sin - (b[1] - a[1]) * cos) / len;
            assert!(cross.abs() < 1e-6, "{name}: {l:?} not at {angle}°");
            // Inside: sample points along the line.
            for f in [0.5, 0.01, 0.99, 0.25, 0.75] {
                let p = [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])];
                let w = winding(p, &rings);
                let inside = if even_odd { w % 2 != 0 } else { w != 0 };
                assert!(inside, "{name}: {p:?} of {l:?} outside (winding {w})");
            }
            offsets.push(-a[0] * sin + a[1] * cos);
        }
        // Spacing: offsets are on the grid (k + 1/2) * spacing, all present.
        offsets.sort_by(f64::total_cmp);
        offsets.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
        for w in offsets.windows(2) {
            assert!(
                (w[1] - w[0] - spacing).abs() < 1e-6,
                "{name}: gap {}",
                w[1] - w[0]
            );
        }
        for o in &offsets {
            let k = o / spacing - 0.5;
            assert!((k - k.round()).abs() < 1e-6, "{name}: offset {o}");
        }
        // Lines cover the area (each stands for a strip spacing wide).
        assert!(
            (covered - area).abs() < 0.03 * area,
            "{name}: covered {covered} of {area}"
        );
    }
}

#[test]
fn hatch_not_for_unfilled_and_pens_follow_fill() {
    let svg = mm_doc(
        100.0,
        100.0,
        r#"<rect x="10" y="10" width="20" height="20" fill="none" stroke="black"/>
           <rect x="40" y="10" width="20" height="20" fill="blue" stroke="red"/>"#,
    );
    let opts = SvgOptions {
        hatch: Some(Hatch {
            spacing_mm: 2.0,
            angle_deg: 0.0,
        }),
        ..no_flip()
    };
    let (_, info) = run_info(&svg, &opts);
    let got: Vec<(&str, usize, usize)> = info
        .pens
        .iter()
        .map(|p| (p.name.as_str(), p.strokes, p.hatch_lines))
        .collect();
    assert_eq!(
        got,
        [("#000000", 1, 0), ("#ff0000", 1, 0), ("#0000ff", 10, 10)]
    );
}
