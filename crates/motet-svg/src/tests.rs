use super::*;
use motet_planner::{AxisInfo, ToolInfo, ToolKind};
use proptest::prelude::*;

const TOL: f64 = 0.01;
/// f32 noise after usvg's unit conversions, mm.
const EPS: f64 = 2e-4;

fn target_with(tools: Vec<ToolInfo>) -> JobTarget {
    let axis = |name: &str| AxisInfo {
        name: name.into(),
        travel: [0.0, 300.0],
        path: true,
    };
    JobTarget {
        axes: vec![axis("x"), axis("y"), axis("z")],
        tools,
        start: [0.0, 0.0, 5.0, 0.0, 0.0, 0.0],
        tolerance: TOL,
        draw_feed: 20.0,
    }
}

fn target() -> JobTarget {
    target_with(vec![ToolInfo {
        name: "pen".into(),
        kind: ToolKind::Pen,
        on_value: 1.0,
    }])
}

fn no_flip() -> SvgOptions {
    SvgOptions {
        flip_y: false,
        ..Default::default()
    }
}

/// A document whose user unit is 1 mm.
fn mm_doc(w: f64, h: f64, body: &str) -> String {
    format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}mm" height="{h}mm" viewBox="0 0 {w} {h}">{body}</svg>"#
    )
}

fn run(svg: &str, opts: &SvgOptions) -> Vec<Located<Command>> {
    parse(svg.as_bytes(), &target(), opts).unwrap_or_else(|e| panic!("{e}\n{svg}"))
}

/// The polylines drawn with the pen down, in machine x/y, checking that
/// other axes never move.
fn polylines(cmds: &[Located<Command>]) -> Vec<Vec<[f64; 2]>> {
    let start = target().start;
    let mut pos = [start[0], start[1]];
    let mut down = false;
    let mut out: Vec<Vec<[f64; 2]>> = Vec::new();
    for c in cmds {
        match c.item {
            Command::Tool { value, .. } => {
                down = value > 0.0;
                if down {
                    out.push(vec![pos]);
                }
            }
            Command::Move(m) => {
                assert_eq!(m.target[2..], start[2..], "only x and y move");
                pos = [m.target[0], m.target[1]];
                if m.kind == MoveKind::Feed && m.feed == 20.0 {
                    assert!(down, "drawing with the pen up");
                    out.last_mut().unwrap().push(pos);
                } else {
                    assert!(!down, "travel with the pen down");
                }
            }
            other => panic!("unexpected {other:?}"),
        }
    }
    out
}

/// Compact event sequence: U/D pen, R rapid, T finite-feed travel, F draw.
fn events(cmds: &[Located<Command>]) -> String {
    cmds.iter()
        .map(|c| match c.item {
            Command::Tool { value, .. } if value > 0.0 => 'D',
            Command::Tool { .. } => 'U',
            Command::Move(m) if m.kind == MoveKind::Rapid => 'R',
            Command::Move(m) if m.feed == 20.0 => 'F',
            Command::Move(_) => 'T',
            Command::Dwell { .. } => 'W',
            Command::Pause { .. } => 'P',
            _ => '?',
        })
        .collect()
}

fn close(a: [f64; 2], b: [f64; 2], eps: f64) -> bool {
    (a[0] - b[0]).abs() <= eps && (a[1] - b[1]).abs() <= eps
}

fn assert_polylines(name: &str, got: &[Vec<[f64; 2]>], want: &[Vec<[f64; 2]>]) {
    let ok = got.len() == want.len()
        && got
            .iter()
            .zip(want)
            .all(|(g, w)| g.len() == w.len() && g.iter().zip(w).all(|(a, b)| close(*a, *b, EPS)));
    assert!(ok, "{name}:\n got {got:?}\nwant {want:?}");
}

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

#[test]
fn pen_events() {
    let two = mm_doc(
        100.0,
        100.0,
        r#"<line x1="1" y1="1" x2="2" y2="1" stroke="black"/><polyline points="5,5 6,5 6,6" stroke="black"/>"#,
    );
    let connected = mm_doc(
        100.0,
        100.0,
        r#"<line x1="1" y1="1" x2="2" y2="1" stroke="black"/><line x1="2" y1="1" x2="2" y2="3" stroke="black"/>"#,
    );
    let at_start = mm_doc(
        100.0,
        100.0,
        r#"<line x1="0" y1="0" x2="2" y2="0" stroke="black"/>"#,
    );
    let slow = SvgOptions {
        flip_y: false,
        travel_feed: 50.0,
        ..Default::default()
    };
    let pen = target().tools;
    // (name, document, options, tools, expected events)
    let cases: Vec<(&str, &str, SvgOptions, Vec<ToolInfo>, &str)> = vec![
        ("two paths", &two, no_flip(), pen.clone(), "URDFURDFFU"),
        (
            "connected paths keep the pen down",
            &connected,
            no_flip(),
            pen.clone(),
            "URDFFU",
        ),
        (
            "start at the machine position",
            &at_start,
            no_flip(),
            pen.clone(),
            "DFU",
        ),
        (
            "finite travel feed",
            &two,
            slow.clone(),
            pen.clone(),
            "UTDFUTDFFU",
        ),
        ("no tool", &two, no_flip(), vec![], "RFRFF"),
    ];
    for (name, svg, opts, tools, want) in cases {
        let cmds = parse(svg.as_bytes(), &target_with(tools), &opts).unwrap();
        assert_eq!(events(&cmds), want, "{name}");
    }

    let cmds = run(&two, &slow);
    for c in &cmds {
        match c.item {
            Command::Move(m) if m.kind == MoveKind::Feed && m.feed != 20.0 => {
                assert_eq!(m.feed, 50.0)
            }
            Command::Move(m) => assert_eq!(m.kind, MoveKind::Feed),
            Command::Tool { tool, value } => {
                assert_eq!(tool, 0);
                assert!(value == 0.0 || value == 1.0);
            }
            _ => {}
        }
    }
    let cmds = run(&two, &no_flip());
    for c in &cmds {
        if let Command::Move(m) = c.item {
            if m.kind == MoveKind::Rapid {
                assert_eq!(m.feed, f64::INFINITY);
            }
        }
    }
}

#[test]
fn laser_power_and_origin() {
    let laser = vec![ToolInfo {
        name: "laser".into(),
        kind: ToolKind::Laser,
        on_value: 0.8,
    }];
    let opts = SvgOptions {
        origin: [100.0, 50.0],
        flip_y: true,
        travel_feed: f64::INFINITY,
    };
    let svg = mm_doc(
        20.0,
        10.0,
        r#"<line x1="1" y1="1" x2="2" y2="1" stroke="black"/>"#,
    );
    let cmds = parse(svg.as_bytes(), &target_with(laser), &opts).unwrap();
    let on: Vec<f32> = cmds
        .iter()
        .filter_map(|c| match c.item {
            Command::Tool { value, .. } => Some(value),
            _ => None,
        })
        .collect();
    assert_eq!(on, vec![0.0, 0.8, 0.0]);
    let ends: Vec<[f64; 2]> = cmds
        .iter()
        .filter_map(|c| match c.item {
            Command::Move(m) => Some([m.target[0], m.target[1]]),
            _ => None,
        })
        .collect();
    assert_eq!(ends.len(), 2);
    assert!(close(ends[0], [101.0, 59.0], EPS), "{ends:?}");
    assert!(close(ends[1], [102.0, 59.0], EPS), "{ends:?}");
}

#[test]
fn other_axis_names_and_missing_axes() {
    let svg = mm_doc(
        20.0,
        10.0,
        r#"<line x1="1" y1="1" x2="2" y2="1" stroke="black"/>"#,
    );
    // y before x, plus an extra axis that must keep its start value.
    let mut t = target();
    t.axes.swap(0, 1);
    t.start = [7.0, 8.0, 9.0, 0.0, 0.0, 0.0];
    let cmds = parse(svg.as_bytes(), &t, &no_flip()).unwrap();
    let Command::Move(m) = cmds
        .iter()
        .rev()
        .find(|c| matches!(c.item, Command::Move(_)))
        .unwrap()
        .item
    else {
        unreachable!()
    };
    assert!(close([m.target[1], m.target[0]], [2.0, 1.0], EPS));
    assert_eq!(m.target[2], 9.0);

    for missing in ["x", "y"] {
        let mut t = target();
        t.axes.retain(|a| a.name != missing);
        let e = parse(svg.as_bytes(), &t, &no_flip()).unwrap_err();
        assert!(e.message.contains(&format!("{missing} axis")), "{e}");
    }
}

#[test]
fn locations() {
    let mixed = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"100mm\" height=\"100mm\" viewBox=\"0 0 100 100\">\n\
               \x20 <line x1=\"1\" y1=\"1\" x2=\"2\" y2=\"1\" stroke=\"black\"/>\n\
               \x20 <g id=\"grp\">\n\
               \x20   <path id=\"p\" d=\"M5 5 L6 6\" stroke=\"black\"/>\n\
               \x20   <circle cx=\"50\" cy=\"50\" r=\"3\"/>\n\
               \x20 </g>\n\
               <defs><rect id=\"r\" width=\"1\" height=\"1\"/></defs>\n\
               \x20<use href=\"#r\" x=\"20\"/>\n\
               <polyline points=\"70,70 80,80\" stroke=\"red\" marker-end=\"url(#m)\"/>\n\
               </svg>";
    let all_ids = "<svg id=\"s\" xmlns=\"http://www.w3.org/2000/svg\">\n\
                   <g id=\"g\"><path id=\"a\" d=\"M1 1 L2 2\"/>\n\
                   \x20   <path id=\"b\" d=\"M3 1 L2 2\"/></g></svg>";
    let clash = "<svg xmlns=\"http://www.w3.org/2000/svg\">\n<path id=\"motet-svg-0\" d=\"M1 1 L2 2\"/>\n<path d=\"M3 1 L2 2\"/></svg>";
    let multibyte =
        "<svg xmlns=\"http://www.w3.org/2000/svg\"><!-- äöü€ --><path d=\"M1 1 L2 2\"/></svg>";
    // (name, document, distinct locations in command order)
    type Case<'a> = (&'a str, &'a str, Vec<(u32, u32)>);
    let cases: Vec<Case> = vec![
        ("mixed", mixed, vec![(2, 3), (4, 5), (5, 5), (8, 2), (9, 1)]),
        ("all elements have ids", all_ids, vec![(2, 11), (3, 5)]),
        ("ids that look generated", clash, vec![(2, 1), (3, 1)]),
        ("columns count characters", multibyte, vec![(1, 54)]),
    ];
    for (name, svg, want) in cases {
        let cmds = run(svg, &no_flip());
        let mut locs: Vec<(u32, u32)> = cmds.iter().map(|c| (c.loc.line, c.loc.column)).collect();
        locs.dedup();
        assert_eq!(locs, want, "{name}: {cmds:?}");
    }
}

#[test]
fn bad_inputs() {
    // (name, input, expected location if the parser knows it)
    type Case = (&'static str, &'static [u8], Option<(u32, u32)>);
    let cases: Vec<Case> = vec![
        ("empty", b"", None),
        ("garbage bytes", b"\xff\xfe\x00\x01garbage", Some((1, 1))),
        ("not UTF-8 later on", b"<svg>\n  \xff</svg>", Some((2, 3))),
        ("plain text", b"hello world", Some((1, 1))),
        (
            "truncated",
            b"<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10\"",
            None,
        ),
        (
            "unclosed tag",
            b"<svg xmlns=\"http://www.w3.org/2000/svg\">\n<g>\n<path d=\"M0 0 L1 1\"/>\n</svg>",
            Some((4, 1)),
        ),
        ("mismatched quotes", b"<svg width=\"10'/>", None),
        ("gzip", b"\x1f\x8b\x08\x00\x00", None),
        ("not svg root", b"<html/>", Some((1, 1))),
        (
            "zero size",
            b"\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"0\" height=\"10\"/>",
            Some((2, 1)),
        ),
    ];
    for (name, input, loc) in cases {
        let e = parse(input, &target(), &SvgOptions::default()).unwrap_err();
        assert!(e.message.starts_with("invalid SVG: "), "{name}: {e}");
        if let Some((line, column)) = loc {
            assert_eq!((e.loc.line, e.loc.column), (line, column), "{name}: {e}");
        } else if name != "gzip" {
            assert!(e.loc.line > 0, "{name}: {e}");
        }
    }
}

#[test]
fn odd_but_valid_inputs() {
    let cases: Vec<(&str, &str)> = vec![
        ("bom", "\u{feff}<svg xmlns=\"http://www.w3.org/2000/svg\"/>"),
        ("text only", "<svg xmlns=\"http://www.w3.org/2000/svg\"><text>hi</text></svg>"),
        (
            "image",
            "<svg xmlns=\"http://www.w3.org/2000/svg\"><image href=\"/etc/passwd\" width=\"5\" height=\"5\"/></svg>",
        ),
        (
            "dtd entity",
            "<!DOCTYPE svg [<!ENTITY l \"<line x1='0' y1='0' x2='5' y2='5' stroke='black'/>\">]>\
             <svg xmlns=\"http://www.w3.org/2000/svg\">&l;</svg>",
        ),
        (
            "bad path data",
            "<svg xmlns=\"http://www.w3.org/2000/svg\"><path d=\"M 1 1 L x\" stroke=\"black\"/></svg>",
        ),
        (
            "huge transform",
            "<svg xmlns=\"http://www.w3.org/2000/svg\"><path transform=\"scale(1e30)\" d=\"M 0 0 C 1 1 2 0 3 1\" stroke=\"black\"/></svg>",
        ),
    ];
    for &(name, svg) in &cases {
        // Must not panic; errors are allowed only for the huge transform.
        match parse(svg.as_bytes(), &target(), &SvgOptions::default()) {
            Ok(cmds) => {
                let _ = polylines(&cmds);
            }
            Err(e) => assert_eq!(name, "huge transform", "{e}"),
        }
    }
    // The entity-made line is still drawn.
    let entity = cases.iter().find(|c| c.0 == "dtd entity").unwrap().1;
    let cmds = run(entity, &no_flip());
    assert_eq!(polylines(&cmds).len(), 1);
}

proptest! {
    #[test]
    fn arbitrary_bytes_never_panic(data in proptest::collection::vec(any::<u8>(), 0..300)) {
        let _ = parse(&data, &target(), &SvgOptions::default());
    }

    #[test]
    fn svgish_soup_never_panics(parts in proptest::collection::vec(prop_oneof![
        Just("<svg xmlns=\"http://www.w3.org/2000/svg\""), Just(">"), Just("</svg>"),
        Just("<g transform=\""), Just("\">"), Just("</g>"), Just("<path d=\""),
        Just("\"/>"), Just(" width=\""), Just(" viewBox=\""), Just("M"), Just("L"),
        Just("C"), Just("A"), Just("Z"), Just(" "), Just("-"), Just("1e9"), Just("0"),
        Just("3.5"), Just("rotate("), Just(")"), Just("<circle r=\""), Just("<use href=\"#a\"/>"),
        Just(" id=\"a\""), Just("<rect rx=\""), Just(" height=\""), Just("scale("),
    ], 0..40)) {
        let doc: String = parts.concat();
        let _ = parse(doc.as_bytes(), &target(), &SvgOptions::default());
    }

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
        let opts = SvgOptions { origin: [origin.0, origin.1], flip_y, ..Default::default() };
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
