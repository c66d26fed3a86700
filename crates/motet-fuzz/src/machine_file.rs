//! Machine files: validated as `motet check` does; a machine that loads must
//! configure its nodes, and a tiny job on it is checked, planned and (when
//! short) run.

use crate::{plan, text};
use motet_host::{check_job, Machine};
use motet_planner::{Command, Located, Move, MoveKind, SourceLoc};
use motet_sim::SimMachine;
use std::path::Path;

/// Runs machine-file bytes through validation and, when they load, a job.
pub fn machine_file(data: &[u8]) {
    let Some(text) = text(data) else { return };
    let lines = text.split('\n').count();
    let machine = match Machine::parse(text, Path::new("fuzz.toml")) {
        Ok(m) => m,
        Err(e) => {
            assert!(
                (1..=lines + 1).contains(&e.line) && e.column >= 1,
                "machine file error placed at {}:{} of {lines} lines: {e}",
                e.line,
                e.column
            );
            assert!(!e.message.trim().is_empty(), "an empty machine file error");
            return;
        }
    };
    assert!(!machine.axes.is_empty(), "a machine without axes loaded");
    if let Err(e) = SimMachine::new(&machine) {
        panic!("a machine that loads was refused by its own nodes: {e}");
    }
    let mut job = tiny_job(&machine);
    if check_job(&machine, &mut job).is_ok() {
        plan::plan_and_run(&machine, &job);
    }
}

/// A unit towards the middle of the travel on every axis with the first tool
/// on, a short dwell, and back to the start at rapid speed.
fn tiny_job(m: &Machine) -> Vec<Located<Command>> {
    let mut mid = m.start;
    for (i, a) in m.axes.iter().enumerate() {
        let [lo, hi] = a.travel;
        if lo.is_finite() && hi.is_finite() {
            mid[i] += (lo + (hi - lo) / 2.0 - m.start[i]).clamp(-1.0, 1.0);
        }
    }
    let feed = if m.draw_feed.is_finite() && m.draw_feed > 0.0 {
        m.draw_feed
    } else {
        10.0
    };
    let mut cmds = Vec::new();
    if !m.tools.is_empty() {
        cmds.push(Command::Tool {
            tool: 0,
            value: 1.0,
        });
    }
    cmds.push(Command::Move(Move {
        target: mid,
        feed,
        kind: MoveKind::Feed,
    }));
    cmds.push(Command::Dwell { seconds: 0.01 });
    if !m.tools.is_empty() {
        cmds.push(Command::Tool {
            tool: 0,
            value: 0.0,
        });
    }
    cmds.push(Command::Move(Move {
        target: m.start,
        feed,
        kind: MoveKind::Rapid,
    }));
    cmds.into_iter()
        .enumerate()
        .map(|(i, item)| Located {
            loc: SourceLoc {
                line: i as u32 + 1,
                column: 1,
            },
            item,
        })
        .collect()
}
