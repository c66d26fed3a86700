//! The real slicer files in bench/data parse whole with allow_unknown off,
//! with plausible command counts, ending where the last G0/G1 says.

use crate::common;

use std::io::Read;

use common::*;
use motet_planner::{AuxChannel, Command, MoveKind};

fn slicer_file(name: &str) -> String {
    let path = format!("{}/../../bench/data/{name}", env!("CARGO_MANIFEST_DIR"));
    let gz = std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut text = String::new();
    flate2::read::GzDecoder::new(&gz[..])
        .read_to_string(&mut text)
        .unwrap();
    text
}

/// What the file says, counted without the parser: G0/G1 lines with axis
/// words, lines of
/// the temperature and fan codes, and the X Y Z of the last G0/G1 words
/// (both files are absolute XYZ throughout and home with a plain G28).
struct Expect {
    motion_lines: usize,
    aux_lines: usize,
    xyz: [f64; 3],
}

fn expect(text: &str) -> Expect {
    let mut e = Expect {
        motion_lines: 0,
        aux_lines: 0,
        xyz: [START[0], START[1], START[2]],
    };
    for line in text.lines() {
        let code = line.split(';').next().unwrap_or("");
        let mut words = code.split_whitespace();
        let Some(first) = words.next() else { continue };
        match first {
            "G0" | "G1" => {
                let mut axes = false;
                for w in words {
                    let (l, v) = w.split_at(1);
                    let i = match l {
                        "X" => 0,
                        "Y" => 1,
                        "Z" => 2,
                        "E" => {
                            axes = true;
                            continue;
                        }
                        _ => continue,
                    };
                    axes = true;
                    e.xyz[i] = v.parse().unwrap();
                }
                e.motion_lines += usize::from(axes);
            }
            "G28" => e.xyz = [START[0], START[1], START[2]],
            "M104" | "M109" | "M140" | "M190" | "M106" | "M107" => e.aux_lines += 1,
            _ => {}
        }
    }
    e
}

fn check_file(name: &str) {
    let text = slicer_file(name);
    let want = expect(&text);
    let p = run_with(&text, &printer(), false).unwrap_or_else(|e| panic!("{name}:{e}"));
    let (mut moves, mut feed_moves, mut aux, mut other) = (0, 0, 0, 0);
    let mut last = None;
    for c in &p.commands {
        match c.item {
            Command::Move(m) => {
                moves += 1;
                if m.kind == MoveKind::Feed {
                    feed_moves += 1;
                }
                last = Some(m);
            }
            Command::Aux { channel, value, .. } => {
                aux += 1;
                match channel {
                    AuxChannel::Hotend(0) => assert!((0.0..=215.0).contains(&value)),
                    AuxChannel::Bed => assert!(value == 0.0 || value == 60.0),
                    AuxChannel::Fan(0) => assert!(value == 0.0 || value == 1.0),
                    other => panic!("{name}: unexpected channel {other:?}"),
                }
            }
            _ => other += 1,
        }
    }
    // Net filament: the machine E at the end (G92 E0 only shifts the program's E).
    let e_total = last.map_or(0.0, |m| m.target[3]);
    println!(
        "{name}: {} lines, {} commands ({moves} moves, {feed_moves} feed, {aux} aux, {other} other), {} warnings, {e_total:.0} mm filament",
        text.lines().count(),
        p.commands.len(),
        p.warnings.len()
    );
    for w in &p.warnings {
        println!("  {w}");
    }
    // Every G0/G1 line with axis words moves, except the few that repeat a
    // position; G28 adds one.
    assert!(
        moves <= want.motion_lines + 1,
        "{name}: {moves} moves of {}",
        want.motion_lines
    );
    assert!(
        moves * 100 >= want.motion_lines * 99,
        "{name}: {moves} moves of {}",
        want.motion_lines
    );
    assert!(feed_moves * 10 > moves * 9, "{name}: mostly G1");
    assert_eq!(aux, want.aux_lines, "{name}: temperature and fan commands");
    assert_eq!(other, 0, "{name}: no tool, dwell or pause commands");
    // About 12.6 to 12.9 m of filament for this model, net of retractions.
    assert!(
        (12_000.0..14_000.0).contains(&e_total),
        "{name}: {e_total} mm of filament"
    );
    let last = last.unwrap();
    for i in 0..3 {
        assert_eq!(
            last.target[i], want.xyz[i],
            "{name}: final position, axis {i}"
        );
    }
    // Folded warnings: a handful, one per accepted code.
    assert!(p.warnings.len() < 12, "{name}: {:#?}", p.warnings);
}

#[test]
fn prusaslicer_file_parses() {
    check_file("prusaslicer-twisted-vase.gcode.gz");
}

#[test]
fn cura_file_parses() {
    check_file("cura-twisted-vase.gcode.gz");
}
