//! Property tests: no input panics; random valid programs end where they say.

mod common;

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
        s in "([GMTXYZEABCIJKRFSPNQgmxyz0-9. +\\-;()*%\t\r]|\n|G2|G3|G4|G28|G92|M3|M83|M117|G38\\.2|\u{e9}){0,120}",
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
