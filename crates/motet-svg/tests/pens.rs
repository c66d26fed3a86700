//! Pens and order: pen-up/down events, grouping into pens, pen changes,
//! travel-optimised order against document order.

use crate::common;

use common::*;
use motet_planner::{Command, MoveKind, ToolInfo, ToolKind};
use motet_svg::*;
use proptest::prelude::*;

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
}
