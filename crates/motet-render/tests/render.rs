//! Data-driven checks of the PNG and SVG output.

use motet_render::{render_png, render_svg, RenderError, RenderSpec, Stroke};
use proptest::prelude::*;
use tiny_skia::Pixmap;

type Bounds = [[f64; 2]; 2];

fn spec(bounds: Bounds, max_px: u32) -> RenderSpec {
    RenderSpec {
        bounds,
        max_px,
        title: "test".into(),
    }
}

fn stroke(points: &[[f64; 2]], tool_on: bool) -> Stroke {
    Stroke {
        points: points.to_vec(),
        tool_on,
    }
}

fn png(strokes: &[Stroke], spec: &RenderSpec) -> Pixmap {
    let bytes = render_png(strokes, spec).expect("render");
    assert_eq!(&bytes[1..4], b"PNG");
    Pixmap::decode_png(&bytes).expect("decodes")
}

/// Same mapping as the renderer documents: margin 2 % of max_px (≥ 2 px),
/// scale = (max_px - 2 margin) / longest side, y flipped.
fn to_px(p: [f64; 2], s: &RenderSpec) -> (u32, u32) {
    let long = f64::from(s.max_px);
    let margin = (long * 0.02).round().max(2.0);
    let ext = (s.bounds[1][0] - s.bounds[0][0]).max(s.bounds[1][1] - s.bounds[0][1]);
    let scale = (long - 2.0 * margin) / ext;
    let x = margin + (p[0] - s.bounds[0][0]) * scale;
    let y = margin + (s.bounds[1][1] - p[1]) * scale;
    (x.floor() as u32, y.floor() as u32)
}

/// "Dark" for a tool-on line: an anti-aliased 1.25 px line centred on a pixel
/// boundary covers each of two rows by about 60 %.
const DARK: u8 = 120;

/// Darkness 0 (white) ..= 255 (black) of the darkest pixel within `r` px.
fn darkness(pm: &Pixmap, (x, y): (u32, u32), r: u32) -> u8 {
    let mut best = 0u8;
    for yy in y.saturating_sub(r)..=(y + r).min(pm.height() - 1) {
        for xx in x.saturating_sub(r)..=(x + r).min(pm.width() - 1) {
            let c = pm.pixel(xx, yy).unwrap().demultiply();
            let lum =
                (u32::from(c.red()) * 299 + u32::from(c.green()) * 587 + u32::from(c.blue()) * 114)
                    / 1000;
            best = best.max(255 - lum as u8);
        }
    }
    best
}

#[test]
fn square_corners_dark_middle_white() {
    // (bounds, max_px, square corners)
    let cases: &[(Bounds, u32, [f64; 4])] = &[
        ([[0.0, 0.0], [100.0, 100.0]], 1600, [10.0, 10.0, 90.0, 90.0]),
        (
            [[0.0, 0.0], [220.0, 220.0]],
            800,
            [50.0, 60.0, 150.0, 160.0],
        ),
        (
            [[-50.0, -20.0], [150.0, 80.0]],
            1000,
            [-40.0, -10.0, 40.0, 70.0],
        ),
        (
            [[0.0, 0.0], [300.0, 600.0]],
            400,
            [100.0, 100.0, 200.0, 500.0],
        ),
    ];
    for &(bounds, max_px, [x0, y0, x1, y1]) in cases {
        let s = spec(bounds, max_px);
        let sq = [[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]];
        let pm = png(&[stroke(&sq, true)], &s);
        for c in &sq[..4] {
            let d = darkness(&pm, to_px(*c, &s), 1);
            assert!(d > DARK, "{bounds:?} corner {c:?}: darkness {d}");
        }
        let mid = [(x0 + x1) / 2.0, (y0 + y1) / 2.0];
        assert_eq!(darkness(&pm, to_px(mid, &s), 2), 0, "{bounds:?} middle");
        // mid-edge points are on the line too
        assert!(darkness(&pm, to_px([mid[0], y0], &s), 1) > DARK);
        assert!(darkness(&pm, to_px([x1, mid[1]], &s), 1) > DARK);
    }
}

#[test]
fn image_size_follows_aspect_ratio() {
    let cases: &[(Bounds, u32, (u32, u32))] = &[
        ([[0.0, 0.0], [100.0, 100.0]], 1600, (1600, 1600)),
        ([[0.0, 0.0], [200.0, 100.0]], 1600, (1600, 832)),
        ([[0.0, 0.0], [100.0, 200.0]], 1000, (520, 1000)),
        ([[0.0, 0.0], [1000.0, 0.001]], 100, (100, 4)),
    ];
    for &(bounds, max_px, want) in cases {
        let pm = png(&[], &spec(bounds, max_px));
        assert_eq!((pm.width(), pm.height()), want, "{bounds:?}");
    }
}

#[test]
fn travel_is_lighter_than_tool_on() {
    let s = spec([[0.0, 0.0], [100.0, 100.0]], 1600);
    let line = [[10.0, 50.0], [90.0, 50.0]];
    for probe in [[30.0, 50.0], [50.0, 50.0], [70.0, 50.0]] {
        let on = darkness(&png(&[stroke(&line, true)], &s), to_px(probe, &s), 1);
        let off = darkness(&png(&[stroke(&line, false)], &s), to_px(probe, &s), 1);
        assert!(off > 0, "travel is visible");
        assert!(on > off + 60, "tool-on {on} vs travel {off}");
    }
}

#[test]
fn y_axis_points_up() {
    let s = spec([[0.0, 0.0], [100.0, 100.0]], 1600);
    // (machine y of a horizontal line, expected pixel row band)
    let cases: &[(f64, std::ops::Range<u32>)] = &[
        (100.0, 28..37),   // max y: near the top (margin is 32 px)
        (0.0, 1564..1573), // min y: near the bottom
        (75.0, 410..420),  // 32 + 25 * 15.36 = 416
    ];
    for (y, rows) in cases {
        let pm = png(&[stroke(&[[20.0, *y], [80.0, *y]], true)], &s);
        let col = to_px([50.0, 0.0], &s).0;
        let dark: Vec<u32> = (0..pm.height())
            .filter(|&r| darkness(&pm, (col, r), 0) > DARK)
            .collect();
        assert!(!dark.is_empty(), "y={y}: line drawn");
        assert!(
            dark.iter().all(|r| rows.contains(r)),
            "y={y}: dark rows {dark:?} outside {rows:?}"
        );
    }
}

#[test]
fn degenerate_bounds_and_sizes_are_errors() {
    let pts = [stroke(&[[0.0, 0.0], [1.0, 1.0]], true)];
    let bad_bounds: &[[[f64; 2]; 2]] = &[
        [[0.0, 0.0], [0.0, 10.0]],
        [[0.0, 0.0], [10.0, 0.0]],
        [[10.0, 10.0], [0.0, 0.0]],
        [[f64::NAN, 0.0], [10.0, 10.0]],
        [[0.0, 0.0], [10.0, f64::NAN]],
        [[0.0, 0.0], [f64::INFINITY, 10.0]],
        [[f64::NEG_INFINITY, 0.0], [10.0, 10.0]],
        [[-1e308, 0.0], [1e308, 10.0]], // width overflows to inf
    ];
    for &b in bad_bounds {
        let r = render_png(&pts, &spec(b, 200));
        assert!(
            matches!(r, Err(RenderError::InvalidBounds { .. })),
            "{b:?}: {r:?}"
        );
        // SVG never fails; it falls back to the points' box.
        let svg = render_svg(&pts, &spec(b, 200));
        assert!(svg.contains("<polyline") && !svg.contains("NaN") && !svg.contains("inf"));
    }
    for max_px in [0, 1, 15, 16385, u32::MAX] {
        let r = render_png(&pts, &spec([[0.0, 0.0], [10.0, 10.0]], max_px));
        assert!(
            matches!(r, Err(RenderError::InvalidSize { .. })),
            "{max_px}: {r:?}"
        );
    }
    let e = render_png(&pts, &spec([[0.0; 2]; 2], 100)).unwrap_err();
    assert!(e.to_string().contains("invalid bounds"));
}

#[test]
fn outside_points_are_clipped_and_nonfinite_points_break_lines() {
    let s = spec([[0.0, 0.0], [100.0, 100.0]], 800);
    // A line from far outside through the middle still shows inside.
    let far = [[-1e9, 50.0], [1e9, 50.0]];
    let pm = png(&[stroke(&far, true)], &s);
    assert!(darkness(&pm, to_px([50.0, 50.0], &s), 1) > DARK);
    assert!(darkness(&pm, to_px([1.0, 50.0], &s), 1) > DARK);

    // A NaN point splits a stroke: no line across the gap.
    let split = [
        [10.0, 20.0],
        [40.0, 20.0],
        [f64::NAN, 0.0],
        [60.0, 20.0],
        [90.0, 20.0],
    ];
    let pm = png(&[stroke(&split, true)], &s);
    assert!(darkness(&pm, to_px([25.0, 20.0], &s), 1) > DARK);
    assert!(darkness(&pm, to_px([75.0, 20.0], &s), 1) > DARK);
    assert_eq!(darkness(&pm, to_px([50.0, 20.0], &s), 1), 0);
}

#[test]
fn short_strokes() {
    let s = spec([[0.0, 0.0], [100.0, 100.0]], 800);
    let p = [[30.0, 70.0]];
    // single-point tool-on stroke: a dot; travel: nothing; empty: nothing
    let pm = png(&[stroke(&p, true)], &s);
    assert!(darkness(&pm, to_px(p[0], &s), 1) > DARK);
    let pm = png(&[stroke(&p, false), stroke(&[], true)], &s);
    assert_eq!(darkness(&pm, to_px(p[0], &s), 2), 0);
}

// ------------------------------------------------------------ SVG ----

/// Minimal XML-ish scan: every `<name attr="v" .../>` element, in order.
fn elements(svg: &str) -> Vec<(String, Vec<(String, String)>)> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(i) = rest.find('<') {
        let j = rest[i..].find('>').expect("unterminated tag") + i;
        let tag = &rest[i + 1..j];
        rest = &rest[j + 1..];
        if tag.starts_with('/') || tag.starts_with('?') {
            continue;
        }
        let tag = tag.trim_end_matches('/');
        let (name, mut attrs_src) = tag.split_once(' ').unwrap_or((tag, ""));
        let mut attrs = Vec::new();
        while let Some(eq) = attrs_src.find("=\"") {
            let key = attrs_src[..eq].trim().to_string();
            let end = attrs_src[eq + 2..].find('"').expect("unterminated attr") + eq + 2;
            attrs.push((key, attrs_src[eq + 2..end].to_string()));
            attrs_src = &attrs_src[end + 1..];
        }
        out.push((name.to_string(), attrs));
    }
    out
}

fn attr<'a>(e: &'a (String, Vec<(String, String)>), k: &str) -> &'a str {
    &e.1.iter().find(|(key, _)| key == k).unwrap().1
}

fn parse_points(s: &str) -> Vec<[f64; 2]> {
    s.split(' ')
        .map(|xy| {
            let (x, y) = xy.split_once(',').unwrap();
            [x.parse().unwrap(), y.parse().unwrap()]
        })
        .collect()
}

#[test]
fn svg_has_one_polyline_per_stroke_with_coordinates() {
    let strokes = vec![
        stroke(&[[0.0, 0.0], [10.5, 20.25], [-3.0, 7.125]], true),
        stroke(&[[1.0, 2.0], [3.0, 4.0]], false),
        stroke(
            &[[100.0, 200.0], [150.123456, 210.0], [0.1, 0.2], [5.0, 5.0]],
            true,
        ),
        stroke(&[[7.0, 7.0]], false), // skipped
    ];
    let s = RenderSpec {
        title: "vase <test> & \"more\"".into(),
        ..spec([[-10.0, -10.0], [190.0, 240.0]], 1600)
    };
    let svg = render_svg(&strokes, &s);
    assert!(svg.starts_with("<?xml"));
    assert!(svg.trim_end().ends_with("</svg>"));
    assert!(svg.contains("<title>vase &lt;test&gt; &amp; &quot;more&quot;</title>"));
    assert_eq!(svg.matches("<g").count(), svg.matches("</g>").count());

    let els = elements(&svg);
    let root = &els[0];
    assert_eq!(root.0, "svg");
    // 250 mm tall bounds, margin 2 % of 250 = 5 mm
    assert_eq!(attr(root, "viewBox"), "-15 -245 210 260");
    assert_eq!(attr(root, "width"), "210mm");
    assert!(els
        .iter()
        .any(|e| e.0 == "g" && attr(e, "transform") == "scale(1,-1)"));

    let polys: Vec<_> = els.iter().filter(|e| e.0 == "polyline").collect();
    assert_eq!(polys.len(), 3);
    for (p, st) in polys.iter().zip(&strokes) {
        let got = parse_points(attr(p, "points"));
        assert_eq!(got.len(), st.points.len());
        for (g, w) in got.iter().zip(&st.points) {
            assert!(
                (g[0] - w[0]).abs() < 1e-4 && (g[1] - w[1]).abs() < 1e-4,
                "{g:?} vs {w:?}"
            );
        }
        let width: f64 = attr(p, "stroke-width").parse().unwrap();
        // 1.5 px / 0.75 px at 1600 px over 250 mm
        let want = if st.tool_on { 1.5 } else { 0.75 } * 250.0 / 1600.0;
        assert!((width - want).abs() < 1e-4, "{width} vs {want}");
    }
    assert_eq!(attr(polys[0], "class"), "tool");
    assert_eq!(attr(polys[1], "class"), "travel");
}

#[test]
fn svg_splits_at_nonfinite_and_draws_dots() {
    let strokes = vec![
        stroke(
            &[
                [0.0, 0.0],
                [1.0, 1.0],
                [f64::INFINITY, 2.0],
                [3.0, 3.0],
                [4.0, 4.0],
            ],
            true,
        ),
        stroke(&[[5.0, 5.0]], true),
    ];
    let svg = render_svg(&strokes, &spec([[0.0, 0.0], [10.0, 10.0]], 1600));
    let els = elements(&svg);
    let polys: Vec<_> = els.iter().filter(|e| e.0 == "polyline").collect();
    assert_eq!(polys.len(), 2);
    assert_eq!(attr(polys[0], "points"), "0,0 1,1");
    assert_eq!(attr(polys[1], "points"), "3,3 4,4");
    let dot = els.iter().find(|e| e.0 == "circle").unwrap();
    assert_eq!((attr(dot, "cx"), attr(dot, "cy")), ("5", "5"));
}

// ---------------------------------------------------- scale and fuzz ----

#[test]
fn a_million_points_render() {
    // 100 strokes of 10,000 points: a spiral-ish zigzag over a 200 mm bed.
    let strokes: Vec<Stroke> = (0..100)
        .map(|k| Stroke {
            tool_on: k % 4 != 0,
            points: (0..10_000)
                .map(|i| {
                    let t = i as f64 * 0.01 + k as f64;
                    let r = 20.0 + 70.0 * (i as f64 / 10_000.0);
                    [100.0 + r * t.cos(), 100.0 + r * t.sin()]
                })
                .collect(),
        })
        .collect();
    let s = spec([[0.0, 0.0], [200.0, 200.0]], 1600);
    let bytes = render_png(&strokes, &s).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");
    let svg = render_svg(&strokes, &s);
    assert_eq!(svg.matches("<polyline").count(), 100);
}

fn coord() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => -300.0..300.0f64,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => -1e300..1e300f64,
        1 => Just(0.0),
    ]
}

fn strokes() -> impl Strategy<Value = Vec<Stroke>> {
    prop::collection::vec(
        (
            prop::collection::vec([coord(), coord()], 0..20),
            any::<bool>(),
        )
            .prop_map(|(points, tool_on)| Stroke { points, tool_on }),
        0..8,
    )
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 128,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn random_input_never_panics(
        strokes in strokes(),
        b in [[coord(), coord()], [coord(), coord()]],
        max_px in 0u32..300,
    ) {
        let s = RenderSpec { bounds: b, max_px, title: "fuzz".into() };
        if let Ok(bytes) = render_png(&strokes, &s) {
            prop_assert!(Pixmap::decode_png(&bytes).is_ok());
        }
        let svg = render_svg(&strokes, &s);
        prop_assert!(svg.ends_with("</svg>\n"));
        prop_assert!(!svg.contains("NaN") && !svg.contains("inf"));
    }

    #[test]
    fn random_strokes_in_valid_bounds_render(strokes in strokes(), max_px in 16u32..300) {
        let s = spec([[0.0, 0.0], [220.0, 220.0]], max_px);
        let bytes = render_png(&strokes, &s).unwrap();
        prop_assert!(Pixmap::decode_png(&bytes).is_ok());
    }
}
