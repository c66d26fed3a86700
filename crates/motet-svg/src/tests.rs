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

/// Document order, y down: machine coordinates equal document mm.
fn no_flip() -> SvgOptions {
    SvgOptions {
        flip_y: false,
        optimize: false,
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
            Command::Pause { optional } => {
                assert!(!optional && !down, "pen change with the pen down");
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
        travel_feed: 50.0,
        ..no_flip()
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
        ..Default::default()
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

// ---------------------------------------------------------------------------
// Pens, ordering, hatch.

fn run_info(svg: &str, opts: &SvgOptions) -> (Vec<Located<Command>>, SvgInfo) {
    parse_with_info(svg.as_bytes(), &target(), opts).unwrap_or_else(|e| panic!("{e}\n{svg}"))
}

/// Pen-up travel actually commanded (sum of move lengths with the pen up).
fn commanded_travel(cmds: &[Located<Command>]) -> f64 {
    let start = target().start;
    let mut pos = [start[0], start[1]];
    let mut down = false;
    let mut sum = 0.0;
    for c in cmds {
        match c.item {
            Command::Tool { value, .. } => down = value > 0.0,
            Command::Move(m) => {
                let p = [m.target[0], m.target[1]];
                if !down {
                    sum += (p[0] - pos[0]).hypot(p[1] - pos[1]);
                }
                pos = p;
            }
            _ => {}
        }
    }
    sum
}

/// Drawn polylines split at pen changes.
fn per_pen(cmds: &[Located<Command>]) -> Vec<Vec<Vec<[f64; 2]>>> {
    let _ = polylines(cmds);
    let start = target().start;
    let mut pos = [start[0], start[1]];
    let mut down = false;
    let mut out: Vec<Vec<Vec<[f64; 2]>>> = vec![vec![]];
    for c in cmds {
        match c.item {
            Command::Pause { .. } => out.push(vec![]),
            Command::Tool { value, .. } => {
                down = value > 0.0;
                if down {
                    out.last_mut().unwrap().push(vec![pos]);
                }
            }
            Command::Move(m) => {
                pos = [m.target[0], m.target[1]];
                if down {
                    out.last_mut().unwrap().last_mut().unwrap().push(pos);
                }
            }
            _ => {}
        }
    }
    out
}

/// Undirected segments drawn, rounded to 1 µm, sorted.
fn segments(lines: &[Vec<[f64; 2]>]) -> Vec<[i64; 4]> {
    let r = |v: f64| (v * 1e6).round() as i64;
    let mut out: Vec<[i64; 4]> = lines
        .iter()
        .flat_map(|l| l.windows(2))
        .map(|w| {
            let (a, b) = ([r(w[0][0]), r(w[0][1])], [r(w[1][0]), r(w[1][1])]);
            let (a, b) = if a <= b { (a, b) } else { (b, a) };
            [a[0], a[1], b[0], b[1]]
        })
        .collect();
    out.sort_unstable();
    out
}

#[test]
fn pen_grouping() {
    let colours = mm_doc(
        100.0,
        100.0,
        r##"<line x1="1" y1="1" x2="2" y2="1" stroke="black"/>
            <line x1="1" y1="2" x2="2" y2="2" stroke="#ff0000"/>
            <line x1="1" y1="3" x2="2" y2="3" stroke="black"/>
            <circle cx="50" cy="50" r="5" stroke="red" fill="none"/>
            <rect x="10" y="10" width="5" height="5" fill="blue"/>
            <rect x="20" y="10" width="5" height="5" fill="blue" stroke="red"/>"##,
    );
    let layers = r##"<svg xmlns="http://www.w3.org/2000/svg"
        xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
        width="100mm" height="100mm" viewBox="0 0 100 100">
      <defs><line id="d" x1="0" y1="0" x2="1" y2="0" stroke="green"/></defs>
      <line x1="1" y1="90" x2="2" y2="90" stroke="black"/>
      <g inkscape:groupmode="layer" id="layer1" inkscape:label="Outline">
        <line x1="1" y1="1" x2="2" y2="1" stroke="black"/>
        <g><line x1="1" y1="2" x2="2" y2="2" stroke="red"/></g>
      </g>
      <g id="details"><use href="#d" x="5" y="5"/><rect x="10" y="10" width="5" height="5"/></g>
      <g><line x1="1" y1="3" x2="2" y2="3" stroke="black"/></g>
      <g inkscape:groupmode="layer" inkscape:label="Outline"><line x1="1" y1="4" x2="2" y2="4" stroke="black"/></g>
    </svg>"##;
    // (name, document, split, expected (pen name, paths, strokes))
    type Case<'a> = (&'a str, &'a str, PenSplit, Vec<(&'a str, usize, usize)>);
    let cases: Vec<Case> = vec![
        (
            "by colour",
            &colours,
            PenSplit::ByColour,
            vec![("#000000", 2, 2), ("#ff0000", 3, 3), ("#0000ff", 1, 1)],
        ),
        ("single", &colours, PenSplit::Single, vec![("pen", 6, 6)]),
        (
            "by layer",
            layers,
            PenSplit::ByLayer,
            vec![
                (NO_LAYER, 1, 1),
                ("Outline", 3, 3),
                ("details", 2, 2),
                ("layer 3", 1, 1),
            ],
        ),
        (
            "layers by colour",
            layers,
            PenSplit::ByColour,
            vec![("#000000", 5, 5), ("#ff0000", 1, 1), ("#008000", 1, 1)],
        ),
    ];
    for (name, svg, split, want) in cases {
        for optimize in [false, true] {
            let opts = SvgOptions {
                pens: split,
                optimize,
                ..no_flip()
            };
            let (cmds, info) = run_info(svg, &opts);
            let got: Vec<(&str, usize, usize)> = info
                .pens
                .iter()
                .map(|p| (p.name.as_str(), p.paths, p.strokes))
                .collect();
            assert_eq!(got, want, "{name} optimize={optimize}");
            let ev = events(&cmds);
            // Pauses only between pens, each after a pen-up.
            assert_eq!(ev.matches('P').count(), want.len() - 1, "{name}: {ev}");
            assert!(!ev.starts_with('P') && !ev.ends_with('P'), "{name}: {ev}");
            assert!(!ev.contains("DP") && !ev.contains("FP"), "{name}: {ev}");
            // Each pen's section draws exactly its strokes.
            let sections = per_pen(&cmds);
            assert_eq!(sections.len(), want.len(), "{name}");
            for (sec, pen) in sections.iter().zip(&info.pens) {
                let len: f64 = sec
                    .iter()
                    .flat_map(|l| l.windows(2))
                    .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
                    .sum();
                assert!(
                    (len - pen.drawn_mm).abs() < 1e-6,
                    "{name} {}: {len} vs {}",
                    pen.name,
                    pen.drawn_mm
                );
            }
            if split == PenSplit::ByColour && name == "by colour" {
                let red = &info.pens[1];
                assert_eq!(red.colour, Some([255, 0, 0]));
                // Two 1 mm lines' worth of black.
                assert!((info.pens[0].drawn_mm - 2.0).abs() < 1e-6);
            }
        }
    }
}

#[test]
fn pen_change_position() {
    let svg = mm_doc(
        100.0,
        100.0,
        r#"<line x1="10" y1="10" x2="20" y2="10" stroke="black"/>
           <line x1="30" y1="10" x2="40" y2="10" stroke="red"/>
           <line x1="50" y1="10" x2="60" y2="10" stroke="blue"/>"#,
    );
    // (change position, events, total travel)
    let d0 = 200f64.sqrt();
    let to = |x: f64, y: f64, p: [f64; 2]| (x - p[0]).hypot(y - p[1]);
    let park = [0.0, 90.0];
    let cases: Vec<(Option<[f64; 2]>, &str, f64)> = vec![
        (None, "URDFUPRDFUPRDFU", d0 + 10.0 + 10.0),
        (
            Some(park),
            "URDFURPRDFURPRDFU",
            d0 + to(20.0, 10.0, park)
                + to(30.0, 10.0, park)
                + to(40.0, 10.0, park)
                + to(50.0, 10.0, park),
        ),
    ];
    for (pos, want, travel) in cases {
        for optimize in [false, true] {
            let opts = SvgOptions {
                pen_change_position: pos,
                optimize,
                ..no_flip()
            };
            let (cmds, info) = run_info(&svg, &opts);
            assert_eq!(events(&cmds), want, "{pos:?}");
            assert!((info.travel_after_mm - travel).abs() < 1e-4, "{info:?}");
            assert!((commanded_travel(&cmds) - info.travel_after_mm).abs() < 1e-6);
            if let Some(p) = pos {
                // The move right before each pause goes to the park position.
                for (i, c) in cmds.iter().enumerate() {
                    if matches!(c.item, Command::Pause { .. }) {
                        let Command::Move(m) = cmds[i - 1].item else {
                            panic!("no move before the pause")
                        };
                        assert!(close([m.target[0], m.target[1]], p, 1e-9));
                        assert_eq!(m.kind, MoveKind::Rapid);
                    }
                }
            }
        }
    }
}

#[test]
fn ordering_cases() {
    // (name, document body, expected polylines in drawing order)
    type Case = (&'static str, &'static str, Vec<Vec<[f64; 2]>>);
    let cases: Vec<Case> = vec![
        (
            "open path drawn end to start",
            r#"<line x1="50" y1="50" x2="10" y2="10" stroke="black"/>"#,
            vec![vec![[10.0, 10.0], [50.0, 50.0]]],
        ),
        (
            "nearest first",
            r#"<line x1="80" y1="0" x2="90" y2="0" stroke="black"/>
               <line x1="40" y1="0" x2="50" y2="0" stroke="black"/>
               <line x1="10" y1="0" x2="20" y2="0" stroke="black"/>"#,
            vec![
                vec![[10.0, 0.0], [20.0, 0.0]],
                vec![[40.0, 0.0], [50.0, 0.0]],
                vec![[80.0, 0.0], [90.0, 0.0]],
            ],
        ),
        (
            "closed loop rotated to the nearest vertex",
            r#"<polygon points="50,50 60,50 60,60 50,60" stroke="black" fill="none"/>
               <line x1="1" y1="0" x2="70" y2="70" stroke="black"/>"#,
            vec![
                vec![[1.0, 0.0], [70.0, 70.0]],
                vec![
                    [60.0, 60.0],
                    [50.0, 60.0],
                    [50.0, 50.0],
                    [60.0, 50.0],
                    [60.0, 60.0],
                ],
            ],
        ),
        (
            "zig-zag by reversing every other line",
            r#"<line x1="0" y1="1" x2="30" y2="1" stroke="black"/>
               <line x1="0" y1="2" x2="30" y2="2" stroke="black"/>
               <line x1="0" y1="3" x2="30" y2="3" stroke="black"/>"#,
            vec![
                vec![[0.0, 1.0], [30.0, 1.0]],
                vec![[30.0, 2.0], [0.0, 2.0]],
                vec![[0.0, 3.0], [30.0, 3.0]],
            ],
        ),
    ];
    for (name, body, want) in cases {
        let svg = mm_doc(100.0, 100.0, body);
        let opts = SvgOptions {
            optimize: true,
            ..no_flip()
        };
        let (cmds, info) = run_info(&svg, &opts);
        let got = polylines(&cmds);
        assert_polylines(name, &got, &want);
        assert!(info.travel_after_mm <= info.travel_before_mm + 1e-9);
        assert!((commanded_travel(&cmds) - info.travel_after_mm).abs() < 1e-6);
        // The same segments as in document order.
        let doc = run(&svg, &no_flip());
        assert_eq!(segments(&got), segments(&polylines(&doc)), "{name}");
    }
}

/// Random stroke sets straight through the optimiser.
fn random_shapes(seed: u64, n: usize) -> Vec<(Vec<[f64; 2]>, bool)> {
    let mut x = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407)
        | 1;
    let mut rnd = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            let c = [rnd() * 500.0, rnd() * 500.0];
            let closed = rnd() < 0.5;
            let k = 2 + (rnd() * 6.0) as usize;
            let pts = (0..k)
                .map(|_| [c[0] + rnd() * 5.0, c[1] + rnd() * 5.0])
                .collect();
            (pts, closed)
        })
        .collect()
}

fn check_tour(start: [f64; 2], set: &[(Vec<[f64; 2]>, bool)]) -> (f64, f64) {
    let shapes: Vec<order::Shape> = set
        .iter()
        .map(|(p, c)| order::Shape { pts: p, closed: *c })
        .collect();
    let tour = order::optimize(start, &shapes);
    let mut seen: Vec<usize> = tour.iter().map(|p| p.index).collect();
    seen.sort_unstable();
    assert_eq!(
        seen,
        (0..set.len()).collect::<Vec<_>>(),
        "not a permutation"
    );
    for p in &tour {
        let s = &shapes[p.index];
        assert!(p.rotate < s.pts.len());
        assert!(!(s.closed && p.reversed));
        assert!(s.closed || p.rotate == 0);
    }
    let before = order::travel(start, &shapes, &order::identity(set.len())).0;
    let after = order::travel(start, &shapes, &tour).0;
    (before, after)
}

#[test]
fn ordering_many_paths() {
    for n in [1, 2, 3, 10, 1000, 10_000] {
        let set = random_shapes(n as u64, n);
        let t = std::time::Instant::now();
        let (before, after) = check_tour([0.0, 0.0], &set);
        println!(
            "{n} paths: travel {before:.0} -> {after:.0} mm in {:?}",
            t.elapsed()
        );
        assert!(after <= before + 1e-9);
        if n >= 1000 {
            assert!(after < 0.2 * before, "{before} -> {after}");
        }
    }
}

#[test]
fn two_pens_example() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/jobs/two-pens.svg"
    );
    let data = std::fs::read(path).unwrap();
    assert!(data.len() < 50_000);
    for hatch in [
        None,
        Some(Hatch {
            spacing_mm: 1.5,
            angle_deg: 45.0,
        }),
    ] {
        let opts = SvgOptions {
            hatch,
            ..Default::default()
        };
        let (cmds, info) = parse_with_info(&data, &target(), &opts).unwrap();
        let names: Vec<&str> = info.pens.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["#000000", "#ff0000"], "{info:?}");
        assert_eq!(events(&cmds).matches('P').count(), 1);
        let doc = parse(
            &data,
            &target(),
            &SvgOptions {
                optimize: false,
                ..opts.clone()
            },
        )
        .unwrap();
        assert_eq!(segments(&polylines(&cmds)), segments(&polylines(&doc)));
        assert!((commanded_travel(&cmds) - info.travel_after_mm).abs() < 1e-6);
        assert!((commanded_travel(&doc) - info.travel_before_mm).abs() < 1e-6);
        println!(
            "two-pens.svg hatch={hatch:?}: pen-up travel {:.0} -> {:.0} mm ({:.0}% less)",
            info.travel_before_mm,
            info.travel_after_mm,
            100.0 * (1.0 - info.travel_after_mm / info.travel_before_mm)
        );
        for p in &info.pens {
            println!(
                "  {}: {} paths, {} strokes ({} hatch), {:.0} mm drawn, travel {:.0} -> {:.0} mm",
                p.name,
                p.paths,
                p.strokes,
                p.hatch_lines,
                p.drawn_mm,
                p.travel_before_mm,
                p.travel_after_mm
            );
        }
        assert!(info.travel_after_mm < 0.5 * info.travel_before_mm);
        assert_eq!(hatch.is_some(), info.pens.iter().any(|p| p.hatch_lines > 0));
    }
}

#[test]
fn drawing_example_is_one_pen() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/jobs/drawing.svg"
    );
    let data = std::fs::read(path).unwrap();
    let (cmds, info) = parse_with_info(&data, &target(), &SvgOptions::default()).unwrap();
    assert_eq!(info.pens.len(), 1, "{info:?}");
    assert!(!events(&cmds).contains('P'));
    assert!(info.travel_after_mm <= info.travel_before_mm);
    println!(
        "drawing.svg: pen-up travel {:.0} -> {:.0} mm",
        info.travel_before_mm, info.travel_after_mm
    );
}

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

#[test]
fn bad_options() {
    let svg = mm_doc(10.0, 10.0, r#"<rect width="5" height="5"/>"#);
    let hatch = |spacing_mm, angle_deg| SvgOptions {
        hatch: Some(Hatch {
            spacing_mm,
            angle_deg,
        }),
        ..Default::default()
    };
    let cases = [
        (hatch(0.0, 0.0), "spacing"),
        (hatch(-1.0, 0.0), "spacing"),
        (hatch(f64::NAN, 0.0), "spacing"),
        (hatch(1.0, f64::INFINITY), "angle"),
        (hatch(1e-9, 0.0), "too dense"),
        (
            SvgOptions {
                pen_change_position: Some([f64::NAN, 0.0]),
                ..Default::default()
            },
            "pen change",
        ),
    ];
    for (opts, want) in cases {
        let e = parse(svg.as_bytes(), &target(), &opts).unwrap_err();
        assert!(e.message.contains(want), "{want}: {e}");
    }
}

proptest! {
    #[test]
    fn optimized_order_covers_everything_and_travels_less(
        paths in proptest::collection::vec(
            (proptest::collection::vec((0u32..400, 0u32..400), 2..6), any::<bool>(), 0usize..3),
            1..25),
        start in (0u32..400, 0u32..400),
    ) {
        let body: String = paths.iter().map(|(pts, closed, colour)| {
            let pts: Vec<String> = pts.iter().map(|&(x, y)| format!("{},{}", x / 4, y / 4)).collect();
            let tag = if *closed { "polygon" } else { "polyline" };
            let colour = ["black", "red", "blue"][*colour];
            format!("<{tag} points=\"{}\" fill=\"none\" stroke=\"{colour}\"/>\n", pts.join(" "))
        }).collect();
        let svg = mm_doc(100.0, 100.0, &body);
        let mut t = target();
        t.start[0] = start.0 as f64 / 4.0;
        t.start[1] = start.1 as f64 / 4.0;
        let opts = |optimize| SvgOptions { optimize, ..no_flip() };
        let (a, ia) = parse_with_info(svg.as_bytes(), &t, &opts(true)).unwrap();
        let (b, ib) = parse_with_info(svg.as_bytes(), &t, &opts(false)).unwrap();
        prop_assert!(ia.travel_after_mm <= ia.travel_before_mm + 1e-9);
        prop_assert!((ia.travel_before_mm - ib.travel_after_mm).abs() < 1e-6);
        prop_assert_eq!(ia.pens.len(), ib.pens.len());
        for (pa, pb) in ia.pens.iter().zip(&ib.pens) {
            prop_assert_eq!(&pa.name, &pb.name);
        }
        // Same segments per pen, every closed path still closed.
        let (sa, sb) = (per_pen(&a), per_pen(&b));
        prop_assert_eq!(sa.len(), sb.len());
        for (x, y) in sa.iter().zip(&sb) {
            prop_assert_eq!(segments(x), segments(y));
        }
    }

    #[test]
    fn optimizer_never_worse(seed in any::<u64>(), n in 1usize..60, start in (0.0f64..500.0, 0.0f64..500.0)) {
        let set = random_shapes(seed, n);
        let (before, after) = check_tour([start.0, start.1], &set);
        prop_assert!(after <= before + 1e-9, "{} -> {}", before, after);
    }

    #[test]
    fn options_soup_never_panics(parts in proptest::collection::vec(prop_oneof![
        Just("<svg xmlns=\"http://www.w3.org/2000/svg\""), Just(">"), Just("</svg>"),
        Just("<g transform=\""), Just("\">"), Just("</g>"), Just("<path d=\""),
        Just("\"/>"), Just(" width=\""), Just(" viewBox=\""), Just("M"), Just("L"),
        Just("C"), Just("A"), Just("Z"), Just(" "), Just("-"), Just("1e9"), Just("0"),
        Just("3.5"), Just("rotate("), Just(")"), Just("<circle r=\""), Just("<use href=\"#a\"/>"),
        Just(" id=\"a\""), Just("<rect rx=\""), Just(" height=\""), Just("scale("),
        Just(" fill=\"red\""), Just(" stroke=\"blue\""), Just(" fill-rule=\"evenodd\""),
        Just("<g>"), Just("7"), Just("20"),
    ], 0..40), spacing in 0.05f64..5.0, angle in -400.0f64..400.0, split in 0..3usize,
       optimize in any::<bool>(), park in any::<bool>()) {
        let doc: String = parts.concat();
        let opts = SvgOptions {
            hatch: Some(Hatch { spacing_mm: spacing, angle_deg: angle }),
            pens: [PenSplit::ByColour, PenSplit::ByLayer, PenSplit::Single][split],
            optimize,
            pen_change_position: park.then_some([1.0, 2.0]),
            ..Default::default()
        };
        if let Ok((cmds, info)) = parse_with_info(doc.as_bytes(), &target(), &opts) {
            let _ = polylines(&cmds);
            prop_assert!(info.travel_after_mm <= info.travel_before_mm + 1e-6);
        }
    }
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

#[test]
fn deep_nesting_is_refused_with_its_depth_in_linear_time() {
    // 200,000 nested groups: refused at the first group too deep, without
    // reading the rest.
    let n = 200_000;
    let svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10mm\" height=\"10mm\">\n{}<path d=\"M0 0 L1 1\" stroke=\"black\"/>{}</svg>",
        "<g>".repeat(n),
        "</g>".repeat(n)
    );
    let e = parse(svg.as_bytes(), &target(), &SvgOptions::default()).unwrap_err();
    assert!(
        e.message.contains("elements nest more than 256 deep here"),
        "{e}"
    );
    // The svg element is level 1; the 256th group is level 257.
    assert_eq!((e.loc.line, e.loc.column), (2, 255 * 3 + 1), "{e}");
    // As deep as allowed still draws.
    let ok = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10mm\" height=\"10mm\">{}<path d=\"M0 0 L1 1\" stroke=\"black\"/>{}</svg>",
        "<g>".repeat(254),
        "</g>".repeat(254)
    );
    assert_eq!(polylines(&run(&ok, &SvgOptions::default())).len(), 1);
}

#[test]
fn entities_cannot_nest_deeper_than_the_text_shows() {
    // Each entity opens 100 groups around the one before; the text itself
    // nests one level.
    let g100 = |inner: &str| format!("{}{inner}{}", "<g>".repeat(100), "</g>".repeat(100));
    let doc = |body: &str| {
        format!(
            "<!DOCTYPE svg [<!ENTITY e \"{}\"><!ENTITY f \"{}\"><!ENTITY h \"{}\">]>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10mm\" height=\"10mm\">{body}</svg>",
            g100("<path d='M0 0 L1 1' stroke='black'/>"),
            g100("&e;"),
            g100("&f;")
        )
    };
    // 1 + 200 + the path: fits.
    assert_eq!(
        polylines(&run(&doc("&f;"), &SvgOptions::default())).len(),
        1
    );
    // 1 + 300: refused.
    let e = parse(doc("&h;").as_bytes(), &target(), &SvgOptions::default()).unwrap_err();
    assert!(
        e.message.contains("elements nest more than 256 deep"),
        "{e}"
    );
}
