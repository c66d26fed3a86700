//! Shapes drawn as the document says: straight and curved outlines within
//! tolerance, rounded corners, strokes on the page edges.

use crate::common;

use common::*;

use motet_svg::*;
use proptest::prelude::*;

#[test]
fn straight_shapes() {
    // (name, document, flip_y, expected machine polylines)
    type Case = (&'static str, String, bool, Vec<Vec<[f64; 2]>>);
    let cases: Vec<Case> = vec![
        (
            "line",
            mm_doc(100.0, 100.0, r#"<line x1="10" y1="20" x2="30" y2="40" stroke="black"/>"#),
            false,
            vec![vec![[10.0, 20.0], [30.0, 40.0]]],
        ),
        (
            "line flipped",
            mm_doc(100.0, 100.0, r#"<line x1="10" y1="20" x2="30" y2="40" stroke="black"/>"#),
            true,
            vec![vec![[10.0, 80.0], [30.0, 60.0]]],
        ),
        (
            "rect",
            mm_doc(100.0, 100.0, r#"<rect x="10" y="10" width="20" height="5"/>"#),
            false,
            vec![vec![
                [10.0, 10.0],
                [30.0, 10.0],
                [30.0, 15.0],
                [10.0, 15.0],
                [10.0, 10.0],
            ]],
        ),
        (
            "polyline stays open",
            mm_doc(
                100.0,
                100.0,
                r#"<polyline points="5,5 15,5 15,15" fill="none" stroke="red"/>"#,
            ),
            false,
            vec![vec![[5.0, 5.0], [15.0, 5.0], [15.0, 15.0]]],
        ),
        (
            "polygon closes",
            mm_doc(100.0, 100.0, r#"<polygon points="5,5 15,5 15,15"/>"#),
            false,
            vec![vec![[5.0, 5.0], [15.0, 5.0], [15.0, 15.0], [5.0, 5.0]]],
        ),
        (
            "path relative commands, two subpaths",
            mm_doc(
                100.0,
                100.0,
                r#"<path d="M 5 5 h 10 v 10 z m 20 0 l 5 5" stroke="black" fill="none"/>"#,
            ),
            false,
            vec![
                vec![[5.0, 5.0], [15.0, 5.0], [15.0, 15.0], [5.0, 5.0]],
                vec![[25.0, 5.0], [30.0, 10.0]],
            ],
        ),
        (
            "duplicate points dropped",
            mm_doc(
                100.0,
                100.0,
                r#"<polyline points="5,5 5,5 15,5 15,5 15,5 20,5" stroke="black"/>"#,
            ),
            false,
            vec![vec![[5.0, 5.0], [15.0, 5.0], [20.0, 5.0]]],
        ),
        (
            "nested translate and scale",
            mm_doc(
                100.0,
                100.0,
                r#"<g transform="translate(10,20)"><g transform="scale(2)"><line x1="0" y1="0" x2="5" y2="1" stroke="black"/></g></g>"#,
            ),
            false,
            vec![vec![[10.0, 20.0], [20.0, 22.0]]],
        ),
        (
            "rotate",
            mm_doc(
                100.0,
                100.0,
                r#"<g transform="translate(50,50)"><line transform="rotate(90)" x1="10" y1="0" x2="20" y2="0" stroke="black"/></g>"#,
            ),
            false,
            vec![vec![[50.0, 60.0], [50.0, 70.0]]],
        ),
        (
            "viewBox scaling with mm units",
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="50mm" viewBox="0 0 1000 500"><path d="M0 0 L1000 500" stroke="black"/></svg>"#.into(),
            false,
            vec![vec![[0.0, 0.0], [100.0, 50.0]]],
        ),
        (
            "viewBox scaling with mm units, flipped",
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="50mm" viewBox="0 0 1000 500"><path d="M0 0 L1000 500" stroke="black"/></svg>"#.into(),
            true,
            vec![vec![[0.0, 50.0], [100.0, 0.0]]],
        ),
        (
            "px at 96 dpi",
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="96" height="96"><path d="M0 96 L96 96" stroke="black"/></svg>"#.into(),
            false,
            vec![vec![[0.0, 25.4], [25.4, 25.4]]],
        ),
        (
            "inches",
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="2in" height="1in" viewBox="0 0 2 1"><path d="M1 0 L2 1" stroke="black"/></svg>"#.into(),
            false,
            vec![vec![[25.4, 0.0], [50.8, 25.4]]],
        ),
        (
            "no size at all: usvg's 100x100 px default",
            r#"<svg xmlns="http://www.w3.org/2000/svg"><path d="M0 0 L96 0" stroke="black"/></svg>"#.into(),
            true,
            vec![vec![[0.0, 100.0 * MM_PER_PX], [25.4, 100.0 * MM_PER_PX]]],
        ),
        (
            "document order, fill-only and stroke-only both drawn",
            mm_doc(
                100.0,
                100.0,
                r#"<line x1="1" y1="1" x2="2" y2="1" stroke="black"/><g><polyline points="3,3 4,3" fill="blue"/></g><line x1="5" y1="5" x2="6" y2="5" stroke="black"/>"#,
            ),
            false,
            vec![
                vec![[1.0, 1.0], [2.0, 1.0]],
                vec![[3.0, 3.0], [4.0, 3.0]],
                vec![[5.0, 5.0], [6.0, 5.0]],
            ],
        ),
        (
            "invisible things skipped",
            mm_doc(
                100.0,
                100.0,
                r#"<line x1="1" y1="1" x2="2" y2="1" stroke="black" visibility="hidden"/>
                   <line x1="1" y1="2" x2="2" y2="2" stroke="black" display="none"/>
                   <g style="display:none"><line x1="1" y1="3" x2="2" y2="3" stroke="black"/></g>
                   <line x1="1" y1="4" x2="2" y2="4" stroke="none" fill="none"/>
                   <defs><line id="d" x1="1" y1="5" x2="2" y2="5" stroke="black"/></defs>
                   <line x1="1" y1="6" x2="2" y2="6" stroke="black"/>"#,
            ),
            false,
            vec![vec![[1.0, 6.0], [2.0, 6.0]]],
        ),
        (
            "use instantiates defs",
            mm_doc(
                100.0,
                100.0,
                r##"<defs><line id="d" x1="0" y1="0" x2="1" y2="0" stroke="black"/></defs><use href="#d" x="10" y="10"/><use href="#d" x="20" y="20"/>""##,
            ),
            false,
            vec![vec![[10.0, 10.0], [11.0, 10.0]], vec![[20.0, 20.0], [21.0, 20.0]]],
        ),
        (
            "zero-length subpaths dropped",
            mm_doc(100.0, 100.0, r#"<path d="M 5 5 L 5 5 M 7 7 Z" stroke="black"/>"#),
            false,
            vec![],
        ),
        (
            "no xmlns",
            r#"<svg width="96" height="96"><line x1="0" y1="0" x2="96" y2="0" stroke="black"/></svg>"#.into(),
            false,
            vec![vec![[0.0, 0.0], [25.4, 0.0]]],
        ),
        (
            "empty document",
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"/>"#.into(),
            true,
            vec![],
        ),
        (
            "only defs",
            mm_doc(100.0, 100.0, r#"<defs><circle id="c" r="5"/></defs>"#),
            true,
            vec![],
        ),
    ];
    for (name, svg, flip_y, want) in cases {
        let opts = SvgOptions {
            flip_y,
            optimize: false,
            pens: PenSplit::Single,
            ..Default::default()
        };
        let cmds = run(&svg, &opts);
        assert_polylines(name, &polylines(&cmds), &want);
        if want.is_empty() {
            assert!(cmds.is_empty(), "{name}: {cmds:?}");
        }
    }
}

/// Distance from `p` to the polyline approximating a curve densely.
fn dist_to_curve(p: [f64; 2], curve: &[[f64; 2]]) -> f64 {
    curve
        .windows(2)
        .map(|w| seg_dist(p, w[0], w[1]))
        .fold(f64::INFINITY, f64::min)
}

fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 == 0.0 {
        0.0
    } else {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
    };
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

#[test]
fn curves_within_tolerance() {
    use std::f64::consts::{FRAC_PI_2, PI, TAU};
    // Dense samples of the true curve.
    fn sample(f: impl Fn(f64) -> [f64; 2]) -> Vec<[f64; 2]> {
        (0..=20_000).map(|i| f(i as f64 / 20_000.0)).collect()
    }
    fn arc(cx: f64, cy: f64, rx: f64, ry: f64, a0: f64, a1: f64) -> Vec<[f64; 2]> {
        sample(|t| {
            let a = a0 + (a1 - a0) * t;
            [cx + rx * a.cos(), cy + ry * a.sin()]
        })
    }
    fn cubic(p: [[f64; 2]; 4]) -> Vec<[f64; 2]> {
        sample(|t| {
            let u = 1.0 - t;
            let w = [u * u * u, 3.0 * u * u * t, 3.0 * u * t * t, t * t * t];
            [
                (0..4).map(|i| w[i] * p[i][0]).sum(),
                (0..4).map(|i| w[i] * p[i][1]).sum(),
            ]
        })
    }
    /// A 200 x 200 mm document with `k` mm per user unit.
    fn doc(k: f64, body: &str) -> String {
        let n = 200.0 / k;
        format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="200mm" height="200mm" viewBox="0 0 {n} {n}">{body}</svg>"#
        )
    }
    let rounded = [
        vec![[15.0, 10.0], [55.0, 10.0]],
        arc(55.0, 15.0, 5.0, 5.0, -FRAC_PI_2, 0.0),
        vec![[60.0, 15.0], [60.0, 35.0]],
        arc(55.0, 35.0, 5.0, 5.0, 0.0, FRAC_PI_2),
        vec![[55.0, 40.0], [15.0, 40.0]],
        arc(15.0, 35.0, 5.0, 5.0, FRAC_PI_2, PI),
        vec![[10.0, 35.0], [10.0, 15.0]],
        arc(15.0, 15.0, 5.0, 5.0, PI, 1.5 * PI),
    ]
    .concat();
    // (name, document, true curve, closed with vertices on the curve)
    let cases: Vec<(&str, String, Vec<[f64; 2]>, bool)> = vec![
        (
            "circle",
            doc(1.0, r#"<circle cx="100" cy="100" r="80"/>"#),
            arc(100.0, 100.0, 80.0, 80.0, 0.0, TAU),
            true,
        ),
        (
            "small circle",
            doc(
                1.0,
                r#"<circle cx="10" cy="10" r="0.5" stroke="black" fill="none"/>"#,
            ),
            arc(10.0, 10.0, 0.5, 0.5, 0.0, TAU),
            true,
        ),
        (
            "ellipse in coarse user units",
            doc(10.0, r#"<ellipse cx="10" cy="5" rx="9" ry="2"/>"#),
            arc(100.0, 50.0, 90.0, 20.0, 0.0, TAU),
            true,
        ),
        (
            "scaled circle becomes an ellipse",
            doc(
                1.0,
                r#"<g transform="translate(100 100) scale(3 1)"><circle r="20"/></g>"#,
            ),
            arc(100.0, 100.0, 60.0, 20.0, 0.0, TAU),
            true,
        ),
        (
            "cubic",
            doc(
                1.0,
                r#"<path d="M10 10 C 50 190, 150 -90, 190 100" stroke="black" fill="none"/>"#,
            ),
            cubic([[10.0, 10.0], [50.0, 190.0], [150.0, -90.0], [190.0, 100.0]]),
            false,
        ),
        (
            "quadratic",
            doc(
                1.0,
                r#"<path d="M10 10 Q 100 190 190 10" stroke="black" fill="none"/>"#,
            ),
            cubic([
                [10.0, 10.0],
                [10.0 + 2.0 / 3.0 * 90.0, 10.0 + 2.0 / 3.0 * 180.0],
                [190.0 - 2.0 / 3.0 * 90.0, 10.0 + 2.0 / 3.0 * 180.0],
                [190.0, 10.0],
            ]),
            false,
        ),
        (
            "arc command",
            doc(
                1.0,
                r#"<path d="M 20 100 A 80 80 0 0 1 180 100" stroke="black" fill="none"/>"#,
            ),
            arc(100.0, 100.0, 80.0, 80.0, PI, TAU),
            false,
        ),
        (
            "relative arc in coarse user units",
            doc(
                10.0,
                r#"<path d="M 2 10 a 8 8 0 1 0 16 0" stroke="black" fill="none"/>"#,
            ),
            arc(100.0, 100.0, 80.0, 80.0, PI, 0.0),
            false,
        ),
        (
            "rotated elliptical arc",
            doc(
                1.0,
                r#"<g transform="translate(100 100) rotate(30)"><path d="M -90 0 A 90 30 0 0 1 90 0" stroke="black" fill="none"/></g>"#,
            ),
            sample(|t| {
                let a = PI + PI * t;
                let (x, y) = (90.0 * a.cos(), 30.0 * a.sin());
                let (s, c) = (30f64.to_radians().sin(), 30f64.to_radians().cos());
                [100.0 + c * x - s * y, 100.0 + s * x + c * y]
            }),
            false,
        ),
        (
            "rounded rect in coarse user units",
            doc(
                5.0,
                r#"<rect x="2" y="2" width="10" height="6" rx="1" stroke="black" fill="none"/>"#,
            ),
            [rounded.clone(), vec![[15.0, 10.0]]].concat(),
            false,
        ),
    ];
    for (name, svg, truth, exact) in cases {
        let cmds = run(&svg, &no_flip());
        let lines = polylines(&cmds);
        assert_eq!(lines.len(), 1, "{name}: {lines:?}");
        let line = &lines[0];
        assert!(line.len() > 8, "{name}: only {} points", line.len());
        assert!(
            close(line[0], truth[0], EPS),
            "{name}: starts at {:?}",
            line[0]
        );
        let end = *line.last().unwrap();
        assert!(
            close(end, *truth.last().unwrap(), EPS),
            "{name}: ends at {end:?}"
        );
        for w in line.windows(2) {
            for f in [0.0, 0.25, 0.5, 0.75] {
                let p = [
                    w[0][0] + f * (w[1][0] - w[0][0]),
                    w[0][1] + f * (w[1][1] - w[0][1]),
                ];
                let d = dist_to_curve(p, &truth);
                assert!(d <= TOL + EPS, "{name}: {p:?} is {d} mm off");
            }
        }
        // Vertices on the curve itself for exact ellipses (kurbo's vertices
        // lie on its intermediate quadratics, not on cubics).
        if exact {
            assert!(close(end, line[0], 1e-9), "{name}: not closed");
            for &p in line {
                let d = dist_to_curve(p, &truth);
                assert!(d <= EPS, "{name}: vertex {p:?} is {d} mm off the curve");
            }
        }
    }
}

#[test]
fn rounded_rect_stays_in_its_box() {
    let cmds = run(
        &mm_doc(
            100.0,
            100.0,
            r#"<rect x="10" y="10" width="50" height="30" rx="5"/>"#,
        ),
        &no_flip(),
    );
    let lines = polylines(&cmds);
    assert_eq!(lines.len(), 1);
    let l = &lines[0];
    assert!(l.len() > 12);
    assert!(close(l[0], *l.last().unwrap(), 1e-9));
    for p in l {
        assert!((10.0 - EPS..=60.0 + EPS).contains(&p[0]), "{p:?}");
        assert!((10.0 - EPS..=40.0 + EPS).contains(&p[1]), "{p:?}");
    }
    // Straight edges are there.
    assert!(l.iter().any(|p| close(*p, [15.0, 10.0], EPS)));
    assert!(l.iter().any(|p| close(*p, [55.0, 40.0], EPS)));
}

/// Page sizes and viewBoxes whose f32 transforms put strokes along the page's
/// edges a few f32 steps beyond them (-0.00001 mm) before those were put
/// back on the edges.
#[test]
fn strokes_on_the_page_edges_stay_on_the_page() {
    for (w_mm, vb_w) in [
        (33.0, 7.0),
        (99.0, 1.0),
        (99.0, 7.0),
        (99.0, 10.0),
        (123.0, 17.0),
        (123.0, 1000.0),
        (151.0, 3.0),
        (151.0, 96.0),
        (151.0, 283.46),
        (210.0, 793.7),
    ] {
        let (h_mm, vb_h) = (w_mm * 0.7, vb_w * 0.7);
        let svg = format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w_mm}mm" height="{h_mm}mm" viewBox="0 0 {vb_w} {vb_h}">
            <path d="M0 {vb_h} L{vb_w} {vb_h} L{vb_w} 0 L0 0 Z" fill="none" stroke="black"/></svg>"#
        );
        for opts in [SvgOptions::default(), no_flip()] {
            let lines = polylines(&run(&svg, &opts));
            let pts: Vec<[f64; 2]> = lines.concat();
            let lo = |k: usize| pts.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min);
            let hi = |k: usize| pts.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max);
            let name = format!("{w_mm} mm over {vb_w} (flip {})", opts.flip_y);
            assert_eq!((lo(0), lo(1)), (0.0, 0.0), "{name}");
            assert!(
                (hi(0) - w_mm).abs() < EPS && (hi(1) - h_mm).abs() < EPS,
                "{name}"
            );
        }
    }
}

proptest! {
    #[test]
    fn polylines_round_trip(
        lines in proptest::collection::vec(
            proptest::collection::vec((0u32..8000, 0u32..8000), 2..12), 1..5),
        origin in (-500.0f64..500.0, -500.0f64..500.0),
        flip_y in any::<bool>(),
    ) {
        // Eighths of a px up to 1000 px: exact in f32, so only the f64 px->mm
        // step remains.
        let px = |v: u32| v as f64 / 8.0;
        let body: String = lines.iter().map(|l| {
            let pts: Vec<String> = l.iter().map(|&(x, y)| format!("{},{}", px(x), px(y))).collect();
            format!("<polyline points=\"{}\" fill=\"none\" stroke=\"black\"/>\n", pts.join(" "))
        }).collect();
        let svg = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"1000\" height=\"1000\">\n{body}</svg>");
        let opts = SvgOptions { origin: [origin.0, origin.1], flip_y, optimize: false, ..Default::default() };
        let cmds = run(&svg, &opts);
        let got = polylines(&cmds);
        // Expected: drawn polylines in order, duplicates dropped, connected
        // ones merged, degenerate ones gone.
        let mut want: Vec<Vec<[f64; 2]>> = Vec::new();
        let mut pen_at = [0.0, 0.0];
        for l in &lines {
            let mut pts: Vec<[f64; 2]> = Vec::new();
            for &(x, y) in l {
                let (x, y) = (px(x) * MM_PER_PX, px(y) * MM_PER_PX);
                let y = if flip_y { 1000.0 * MM_PER_PX - y } else { y };
                let p = [origin.0 + x, origin.1 + y];
                if pts.last() != Some(&p) {
                    pts.push(p);
                }
            }
            if pts.len() < 2 {
                continue;
            }
            match want.last_mut() {
                Some(prev) if pen_at == pts[0] => prev.extend_from_slice(&pts[1..]),
                _ => want.push(pts.clone()),
            }
            pen_at = *pts.last().unwrap();
        }
        prop_assert_eq!(got.len(), want.len(), "{:?} vs {:?}", got, want);
        for (g, w) in got.iter().zip(&want) {
            prop_assert_eq!(g.len(), w.len(), "{:?} vs {:?}", g, w);
            for (a, b) in g.iter().zip(w) {
                prop_assert!(close(*a, *b, 1e-6), "{:?} vs {:?}", a, b);
            }
        }
    }
}
