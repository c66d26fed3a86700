//! Property tests: no input panics; random valid programs end where they say.

use crate::common;

use common::*;
use motet_planner::{Command, MoveKind};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_text_never_panics(s in any::<String>(), allow in any::<bool>()) {
        let _ = run_with(&s, &printer(), allow);
        let _ = run_with(&s, &no_tools(), allow);
    }

    #[test]
    fn gcode_like_text_never_panics(
        s in "([GMTXYZEABCIJKRFSPLNQgmxyz0-9. +\\-;()*%\t\r]|\n|G2|G3|G4|G10 L2|G10|G11|G18|G19|G28|G28\\.1|G53|G54|G90\\.1|G92|G93|M3|M4|M2|M83|M104|M106|M117|G38\\.2|\u{e9}){0,120}",
        allow in any::<bool>(),
    ) {
        if let Ok(p) = run_with(&s, &printer(), allow) {
            for c in &p.commands {
                if let Command::Move(m) = c.item {
                    prop_assert!(m.target.iter().all(|v| v.is_finite()), "{s:?}: {m:?}");
                    prop_assert!(m.feed > 0.0);
                }
            }
        }
        let _ = run_with(&s, &plotter(), allow);
    }
}

/// One random move: G0 or G1, and up to three axis values in various number spellings.
fn word_value() -> impl Strategy<Value = (i32, u8)> {
    (-100_000i32..100_000, 0u8..4)
}

fn spell(v: i32, style: u8) -> String {
    let x = f64::from(v) / 1000.0;
    match style {
        0 => format!("{x}"),
        1 => format!("{x:.3}"),
        2 => {
            // .5 / -.5 style when |x| < 1
            let s = format!("{x:.3}");
            if let Some(rest) = s.strip_prefix("0.") {
                format!(".{rest}")
            } else if let Some(rest) = s.strip_prefix("-0.") {
                format!("-.{rest}")
            } else {
                s
            }
        }
        _ => {
            if x >= 0.0 {
                format!("+{x}")
            } else {
                format!("{x}")
            }
        }
    }
}

type RandMove = (
    bool,
    Option<(i32, u8)>,
    Option<(i32, u8)>,
    Option<(i32, u8)>,
);

fn moves() -> impl Strategy<Value = Vec<RandMove>> {
    prop::collection::vec(
        (
            any::<bool>(),
            prop::option::of(word_value()),
            prop::option::of(word_value()),
            prop::option::of(word_value()),
        ),
        1..40,
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 500, ..ProptestConfig::default() })]

    #[test]
    fn final_move_is_last_target(prog in moves(), relative in any::<bool>(), compact in any::<bool>()) {
        let mut src = String::from(if relative { "G91 F1200\n" } else { "G90 F1200\n" });
        let mut pos = [START[0], START[1], START[2]];
        for (rapid, x, y, z) in &prog {
            src.push_str(if *rapid { "G0" } else { "G1" });
            for (letter, w, i) in [('X', x, 0), ('Y', y, 1), ('Z', z, 2)] {
                if let Some((v, style)) = w {
                    let text = spell(*v, *style);
                    let parsed: f64 = text.parse().unwrap();
                    if !compact {
                        src.push(' ');
                    }
                    src.push(letter);
                    src.push_str(&text);
                    pos[i] = if relative { pos[i] + parsed } else { parsed };
                }
            }
            src.push_str(if compact { "\n" } else { " ; comment\r\n" });
        }
        let p = run(&src).map_err(|e| TestCaseError::fail(format!("{src}: {e}")))?;
        let last = p.commands.iter().rev().find_map(|c| match c.item {
            Command::Move(m) => Some(m),
            _ => None,
        });
        let end = last.map_or(START, |m| m.target);
        for i in 0..3 {
            if relative {
                prop_assert!((end[i] - pos[i]).abs() < 1e-9, "{src}: axis {i}: {} != {}", end[i], pos[i]);
            } else {
                prop_assert_eq!(end[i], pos[i], "{}: axis {}", src, i);
            }
        }
        // Kinds and feeds follow the words.
        for c in &p.commands {
            if let Command::Move(m) = c.item {
                match m.kind {
                    MoveKind::Rapid => prop_assert_eq!(m.feed, f64::INFINITY),
                    MoveKind::Feed => prop_assert!((m.feed - 20.0).abs() < 1e-12),
                }
            }
        }
    }

    #[test]
    fn random_ijk_arcs_end_exactly_on_target(
        sx in -100i32..100, sy in -100i32..100,
        ci in -5000i32..5000, cj in -5000i32..5000,
        angle in 0.0f64..core::f64::consts::TAU, cw in any::<bool>(),
    ) {
        let (i, j) = (f64::from(ci) / 100.0, f64::from(cj) / 100.0);
        prop_assume!(i.hypot(j) > 0.5);
        let (cx, cy) = (f64::from(sx) + i, f64::from(sy) + j);
        let r = i.hypot(j);
        let a0 = (-j).atan2(-i);
        let ex = format!("{:.4}", cx + r * (a0 + angle).cos());
        let ey = format!("{:.4}", cy + r * (a0 + angle).sin());
        let src = format!("G0 X{sx} Y{sy}\n{} X{ex} Y{ey} I{i} J{j} F600", if cw { "G2" } else { "G3" });
        let p = run(&src).map_err(|e| TestCaseError::fail(format!("{src}: {e}")))?;
        let moves: Vec<_> = p.commands.iter().filter_map(|c| match c.item {
            Command::Move(m) => Some(m.target),
            _ => None,
        }).collect();
        let last = moves.last().unwrap();
        prop_assert_eq!(last[0], ex.parse::<f64>().unwrap());
        prop_assert_eq!(last[1], ey.parse::<f64>().unwrap());
        for t in &moves[1..] {
            let d = (t[0] - cx).hypot(t[1] - cy);
            prop_assert!((d - r).abs() < 0.002, "{src}: point off the circle by {}", d - r);
        }
    }
}

/// One line of a random program using the wider set of codes, from a template
/// index and four random numbers.
fn new_code_line(kind: usize, a: i32, b: i32, c: i32, n: u8) -> String {
    let (x, y, z) = (
        f64::from(a) / 100.0,
        f64::from(b) / 100.0,
        f64::from(c) / 100.0,
    );
    let m = n % 7;
    match kind {
        0 => format!("G0 X{x} Y{y}"),
        1 => format!(
            "G1 X{x} Y{y} Z{z} E{} F{}",
            f64::from(n) / 10.0,
            60 + u32::from(n) * 10
        ),
        2 => format!("G2 X{x} Y{y} R{}", z.abs() + 0.5),
        3 => format!("G3 X{x} Y{y} I{z} J{} F600", f64::from(n) - 100.0),
        4 => ["G17", "G18", "G19"][usize::from(n % 3)].into(),
        5 => {
            ["G90", "G91", "G90.1", "G91.1", "G20", "G21", "M82", "M83"][usize::from(n % 8)].into()
        }
        6 => ["G93", "G94"][usize::from(n % 2)].into(),
        7 => format!("G{}", 54 + n % 6),
        8 => format!("G10 L2 P{m} X{x} Z{z}"),
        9 => format!("G10 L20 P{m} Y{y} E0"),
        10 => ["G10", "G11"][usize::from(n % 2)].into(),
        11 => ["G28", "G28.1", "G92.1"][usize::from(n % 3)].into(),
        12 => format!("G28 X{x} Y"),
        13 => format!("G53 G0 X{x} Z{z}"),
        14 => format!("G53 G1 Y{y} F{}", 1 + u32::from(n)),
        15 => format!("G92 X{x} E0"),
        16 => format!(
            "{} S{}",
            ["M3", "M4", "M5"][usize::from(n % 3)],
            a.rem_euclid(1200)
        ),
        17 => {
            ["M7", "M8", "M9", "M400", "M0", "M1", "M114", "M84", "M105"][usize::from(n % 9)].into()
        }
        18 => format!("M104 S{} T{}", b.rem_euclid(300), n % 3),
        19 => format!("M109 S{}", b.rem_euclid(300)),
        20 => format!(
            "{} S{}",
            ["M140", "M190", "M141", "M191"][usize::from(n % 4)],
            c.rem_euclid(120)
        ),
        21 => format!("M106 P{} S{}", n % 3, a.rem_euclid(300)),
        22 => "M107".into(),
        23 => format!("T{}", n % 4),
        24 => format!("G4 P{}", n),
        25 => format!("G93 G1 X{x} Y{y} F{}", 1 + u32::from(n)),
        26 => format!("G18 G2 Z{z} X{x} K{} F600", y),
        27 => format!("G19 G3 Y{y} Z{z} R{} F600", -(x.abs() + 0.5)),
        28 => format!("S{} F{}", a.rem_euclid(1000), 1 + u32::from(n)),
        _ => ["M2", "M30"][usize::from(n % 2)].into(),
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, ..ProptestConfig::default() })]

    #[test]
    fn random_programs_with_new_codes_never_panic(
        lines in prop::collection::vec(
            (0usize..30, -20_000i32..20_000, -20_000i32..20_000, -20_000i32..20_000, any::<u8>()),
            1..60,
        ),
        allow in any::<bool>(),
    ) {
        let mut src = String::from("G21 G90 G94 F600\n");
        for (kind, a, b, c, n) in lines {
            src.push_str(&new_code_line(kind, a, b, c, n));
            src.push('\n');
        }
        for target in [printer(), plotter(), no_tools()] {
            if let Ok(p) = run_with(&src, &target, allow) {
                for c in &p.commands {
                    match c.item {
                        Command::Move(m) => {
                            prop_assert!(m.target.iter().all(|v| v.is_finite()), "{src}: {m:?}");
                            prop_assert!(m.feed > 0.0, "{src}: {m:?}");
                            if m.kind == MoveKind::Feed {
                                prop_assert!(m.feed.is_finite(), "{src}: {m:?}");
                            }
                        }
                        Command::ToolPerSpeed { value, feed, .. } => {
                            prop_assert!(feed.is_finite() && feed > 0.0, "{src}: {feed}");
                            prop_assert!((0.0..=1.0).contains(&value));
                        }
                        Command::Tool { value, .. } => prop_assert!((0.0..=1.0).contains(&value)),
                        Command::Aux { value, .. } => prop_assert!(value.is_finite()),
                        Command::Dwell { seconds } => prop_assert!(seconds >= 0.0),
                        Command::Pause { .. } | Command::Sync => {}
                    }
                    prop_assert!(c.loc.line >= 1);
                }
            }
        }
    }
}
