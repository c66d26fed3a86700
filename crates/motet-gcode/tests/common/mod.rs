#![allow(dead_code)]

use motet_gcode::{parse, GcodeOptions, Parsed};
use motet_planner::{
    AuxChannel, AxisInfo, Command, JobTarget, MoveKind, SourceError, ToolInfo, ToolKind,
};

pub const START: [f64; 6] = [1.0, 2.0, 3.0, 0.0, 0.0, 0.0];

fn axis(name: &str, path: bool) -> AxisInfo {
    AxisInfo {
        name: name.into(),
        travel: [-1000.0, 1000.0],
        path,
    }
}

/// x y z e, a laser with on_value 0.8, start at (1, 2, 3, 0).
pub fn printer() -> JobTarget {
    JobTarget {
        axes: vec![
            axis("x", true),
            axis("y", true),
            axis("z", true),
            axis("e", false),
        ],
        tools: vec![ToolInfo {
            name: "laser".into(),
            kind: ToolKind::Laser,
            on_value: 0.8,
        }],
        start: START,
        tolerance: 0.01,
        draw_feed: 10.0,
    }
}

pub fn plotter() -> JobTarget {
    JobTarget {
        axes: vec![axis("x", true), axis("y", true)],
        tools: vec![ToolInfo {
            name: "pen".into(),
            kind: ToolKind::Pen,
            on_value: 0.75,
        }],
        start: [0.0; 6],
        tolerance: 0.05,
        draw_feed: 10.0,
    }
}

pub fn no_tools() -> JobTarget {
    JobTarget {
        axes: vec![axis("x", true), axis("y", true), axis("z", true)],
        tools: vec![],
        start: [0.0; 6],
        tolerance: 0.01,
        draw_feed: 10.0,
    }
}

pub fn run(src: &str) -> Result<Parsed, SourceError> {
    parse(src, &printer(), &GcodeOptions::default())
}

pub fn run_with(src: &str, target: &JobTarget, allow_unknown: bool) -> Result<Parsed, SourceError> {
    parse(
        src,
        target,
        &GcodeOptions {
            allow_unknown,
            ..GcodeOptions::default()
        },
    )
}

/// An expected command, compact: R/F moves give x y z e and feed (mm/s).
#[derive(Clone, Copy, Debug)]
pub enum Want {
    R([f64; 4]),
    F([f64; 4], f64),
    D(f64),
    T(f32),
    /// ToolPerSpeed: value, feed (units/s).
    Ps(f32, f64),
    /// Aux: channel, value, wait.
    A(AuxChannel, f32, bool),
    /// Pause: optional.
    P(bool),
    Sync,
}

pub fn check(src: &str, parsed: &Parsed, want: &[Want]) {
    let got = &parsed.commands;
    assert_eq!(
        got.len(),
        want.len(),
        "{src:?}: command count\n got: {:#?}",
        got.iter().map(|c| c.item).collect::<Vec<_>>()
    );
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        let ok = match (g.item, *w) {
            (Command::Move(m), Want::R(p)) => {
                m.kind == MoveKind::Rapid && m.feed == f64::INFINITY && close4(&m.target, &p)
            }
            (Command::Move(m), Want::F(p, f)) => {
                m.kind == MoveKind::Feed && (m.feed - f).abs() < 1e-9 && close4(&m.target, &p)
            }
            (Command::Dwell { seconds }, Want::D(s)) => (seconds - s).abs() < 1e-12,
            (Command::Tool { tool, value }, Want::T(v)) => tool == 0 && (value - v).abs() < 1e-6,
            (Command::ToolPerSpeed { tool, value, feed }, Want::Ps(v, f)) => {
                tool == 0 && (value - v).abs() < 1e-6 && (feed - f).abs() < 1e-9
            }
            (
                Command::Aux {
                    channel,
                    value,
                    wait,
                },
                Want::A(c, v, wt),
            ) => channel == c && (value - v).abs() < 1e-6 && wait == wt,
            (Command::Pause { optional }, Want::P(o)) => optional == o,
            (Command::Sync, Want::Sync) => true,
            _ => false,
        };
        assert!(ok, "{src:?}: command {k}: got {:?}, want {w:?}", g.item);
        assert!(
            g.loc.line >= 1 && g.loc.column >= 1,
            "{src:?}: bad loc {:?}",
            g.loc
        );
    }
}

fn close4(a: &[f64; 6], b: &[f64; 4]) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9) && a[4] == 0.0 && a[5] == 0.0
}

/// `line*checksum` as a Marlin host would send it.
pub fn with_checksum(line: &str) -> String {
    let cs = line.bytes().fold(0u8, |a, b| a ^ b);
    format!("{line}*{cs}")
}
