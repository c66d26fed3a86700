//! Targets, documents and readers of the commands shared by the tests.
#![allow(dead_code)]

use motet_planner::{AxisInfo, Command, JobTarget, Located, MoveKind, ToolInfo, ToolKind};
use motet_svg::{parse, parse_with_info, SvgInfo, SvgOptions};

pub const TOL: f64 = 0.01;

/// f32 noise after usvg's unit conversions, mm.
pub const EPS: f64 = 2e-4;

pub fn target_with(tools: Vec<ToolInfo>) -> JobTarget {
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

pub fn target() -> JobTarget {
    target_with(vec![ToolInfo {
        name: "pen".into(),
        kind: ToolKind::Pen,
        on_value: 1.0,
    }])
}

/// Document order, y down: machine coordinates equal document mm.
pub fn no_flip() -> SvgOptions {
    SvgOptions {
        flip_y: false,
        optimize: false,
        ..Default::default()
    }
}

/// A document whose user unit is 1 mm.
pub fn mm_doc(w: f64, h: f64, body: &str) -> String {
    format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}mm" height="{h}mm" viewBox="0 0 {w} {h}">{body}</svg>"#
    )
}

pub fn run(svg: &str, opts: &SvgOptions) -> Vec<Located<Command>> {
    parse(svg.as_bytes(), &target(), opts).unwrap_or_else(|e| panic!("{e}\n{svg}"))
}

/// The polylines drawn with the pen down, in machine x/y, checking that
/// other axes never move.
pub fn polylines(cmds: &[Located<Command>]) -> Vec<Vec<[f64; 2]>> {
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
pub fn events(cmds: &[Located<Command>]) -> String {
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

pub fn close(a: [f64; 2], b: [f64; 2], eps: f64) -> bool {
    (a[0] - b[0]).abs() <= eps && (a[1] - b[1]).abs() <= eps
}

pub fn assert_polylines(name: &str, got: &[Vec<[f64; 2]>], want: &[Vec<[f64; 2]>]) {
    let ok = got.len() == want.len()
        && got
            .iter()
            .zip(want)
            .all(|(g, w)| g.len() == w.len() && g.iter().zip(w).all(|(a, b)| close(*a, *b, EPS)));
    assert!(ok, "{name}:\n got {got:?}\nwant {want:?}");
}

pub fn run_info(svg: &str, opts: &SvgOptions) -> (Vec<Located<Command>>, SvgInfo) {
    parse_with_info(svg.as_bytes(), &target(), opts).unwrap_or_else(|e| panic!("{e}\n{svg}"))
}

/// Pen-up travel actually commanded (sum of move lengths with the pen up).
pub fn commanded_travel(cmds: &[Located<Command>]) -> f64 {
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
pub fn per_pen(cmds: &[Located<Command>]) -> Vec<Vec<Vec<[f64; 2]>>> {
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
pub fn segments(lines: &[Vec<[f64; 2]>]) -> Vec<[i64; 4]> {
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
