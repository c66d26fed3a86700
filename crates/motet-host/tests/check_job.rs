//! `check_job`: moves beyond travel and polar moves too close to the centre are
//! refused with the offending command's place; everything else passes.

use motet_host::{check_job, Machine};
use motet_planner::{Command, Located, Move, MoveKind, SourceLoc};
use std::path::PathBuf;

fn machine(file: &str) -> Machine {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(file);
    Machine::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// One job step: a move given by the axes it changes (others keep their last
/// target), or another command that the check must skip.
#[derive(Clone, Copy)]
enum Step {
    Move(&'static [(&'static str, f64)]),
    Dwell,
    Tool,
}

struct Case {
    what: &'static str,
    machine: &'static str,
    steps: &'static [Step],
    /// `None`: accepted. `Some((step index, message part))`: refused at that step.
    refused: Option<(usize, &'static str)>,
}

use Step::{Dwell, Move as M, Tool};

const NAN: f64 = f64::NAN;

const CASES: &[Case] = &[
    // ---- travel ----------------------------------------------------------------
    Case {
        what: "printer: corners of the travel are reachable",
        machine: "printer.toml",
        steps: &[M(&[("x", 220.0)]), M(&[("y", 220.0)]), M(&[("z", 250.0)]), M(&[("x", 0.0), ("y", 0.0), ("z", 0.0)])],
        refused: None,
    },
    Case {
        what: "printer: rounding just past the end is tolerated",
        machine: "printer.toml",
        steps: &[M(&[("x", 220.0 + 1e-7)]), M(&[("z", -1e-9)])],
        refused: None,
    },
    Case {
        what: "printer: x beyond max",
        machine: "printer.toml",
        steps: &[M(&[("x", 10.0)]), Dwell, M(&[("x", 230.0)]), M(&[("x", 240.0)])],
        refused: Some((2, "move to x=230.0000 is beyond the axis's travel [0, 220]")),
    },
    Case {
        what: "printer: z below min",
        machine: "printer.toml",
        steps: &[M(&[("x", 10.0), ("z", 5.0)]), M(&[("z", -0.1)])],
        refused: Some((1, "move to z=-0.1000 is beyond the axis's travel [0, 250]")),
    },
    Case {
        what: "printer: y just too far",
        machine: "printer.toml",
        steps: &[M(&[("y", 220.01)])],
        refused: Some((0, "y=220.0100")),
    },
    Case {
        what: "printer: extruder without travel is unlimited",
        machine: "printer.toml",
        steps: &[M(&[("e", 1.0e6)]), M(&[("x", 100.0), ("e", -1.0e6)]), Tool, M(&[("e", 0.0)])],
        refused: None,
    },
    Case {
        what: "printer: extruder must still be a number",
        machine: "printer.toml",
        steps: &[M(&[("e", 5.0)]), M(&[("e", NAN)])],
        refused: Some((1, "e=NaN")),
    },
    Case {
        what: "printer: NaN on a limited axis",
        machine: "printer.toml",
        steps: &[M(&[("x", NAN)])],
        refused: Some((0, "x=NaN")),
    },
    Case {
        what: "printer: infinity on a limited axis",
        machine: "printer.toml",
        steps: &[M(&[("y", f64::INFINITY)])],
        refused: Some((0, "y=inf")),
    },
    Case {
        what: "printer: cartesian moves through the origin are fine",
        machine: "printer.toml",
        steps: &[M(&[("x", 100.0), ("y", 100.0)]), M(&[("x", 0.0), ("y", 0.0)]), M(&[("x", 1.0), ("y", 0.5)])],
        refused: None,
    },
    Case {
        what: "plotter: negative x",
        machine: "plotter.toml",
        steps: &[Tool, M(&[("x", 100.0), ("y", 100.0)]), Tool, M(&[("x", -1.0)])],
        refused: Some((3, "x=-1.0000 is beyond the axis's travel [0, 300]")),
    },
    Case {
        what: "plotter: whole sheet",
        machine: "plotter.toml",
        steps: &[M(&[("x", 300.0), ("y", 218.0)]), M(&[("x", 0.0)]), M(&[("y", 0.0)])],
        refused: None,
    },
    Case {
        what: "laser: y beyond its 300 mm",
        machine: "laser.toml",
        steps: &[M(&[("x", 400.0), ("y", 300.0)]), M(&[("y", 301.0)])],
        refused: Some((1, "y=301.0000")),
    },
    Case {
        what: "gestalt: z may go negative down to -20",
        machine: "gestalt-3axis.toml",
        steps: &[M(&[("z", -20.0)]), M(&[("z", 30.0)])],
        refused: None,
    },
    Case {
        what: "gestalt: z below -20",
        machine: "gestalt-3axis.toml",
        steps: &[M(&[("z", -20.5)])],
        refused: Some((0, "z=-20.5000 is beyond the axis's travel [-20, 30]")),
    },
    // ---- polar centre (clay printer: min_radius 2 mm, starts at x = 100) -------------
    Case {
        what: "clay: quarter turn stays far from the centre",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", 0.0), ("y", 100.0)]), M(&[("x", -100.0), ("y", 0.0)]), M(&[("x", 0.0), ("y", -100.0)])],
        refused: None,
    },
    Case {
        what: "clay: straight through the centre",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", -100.0)])],
        refused: Some((0, "passes 0.000 mm from the polar centre")),
    },
    Case {
        what: "clay: chord passing 1.95 mm from the centre",
        machine: "clay-printer.toml",
        // Line from (100, 0) to (-100, 3.9): distance 390 / |(-200, 3.9)| ≈ 1.950.
        steps: &[M(&[("z", 5.0)]), M(&[("x", -100.0), ("y", 3.9)])],
        refused: Some((1, "passes 1.950 mm from the polar centre; the turntable cannot follow closer than min_radius = 2 mm")),
    },
    Case {
        what: "clay: chord passing 2.05 mm from the centre",
        machine: "clay-printer.toml",
        // 410 / |(-200, 4.1)| ≈ 2.0496.
        steps: &[M(&[("x", -100.0), ("y", 4.1)])],
        refused: None,
    },
    Case {
        what: "clay: ending inside min_radius",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", 1.0)])],
        refused: Some((0, "passes 1.000 mm")),
    },
    Case {
        what: "clay: ending exactly at min_radius",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", 2.0)]), M(&[("y", 5.0)])],
        refused: None,
    },
    Case {
        what: "clay: chord between two points on the min_radius circle cuts inside it",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", 2.0)]), M(&[("x", 0.0), ("y", 2.0)])],
        refused: Some((1, "passes 1.414 mm")),
    },
    Case {
        what: "clay: the second move crosses the centre",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", 0.0), ("y", 50.0)]), Dwell, M(&[("y", -50.0)])],
        refused: Some((2, "from the polar centre")),
    },
    Case {
        what: "clay: moving away from the centre along a ray is fine",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", 3.0)]), M(&[("x", 150.0)]), M(&[("x", 2.5), ("y", 0.0)])],
        refused: None,
    },
    Case {
        what: "clay: z and e alone do not move in the plane",
        machine: "clay-printer.toml",
        steps: &[M(&[("z", 10.0)]), M(&[("e", 100.0)]), M(&[("z", 0.0), ("e", -5.0)])],
        refused: None,
    },
    Case {
        what: "clay: travel is checked before the centre",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", -151.0)])],
        refused: Some((0, "x=-151.0000 is beyond")),
    },
];

/// Builds the job of a case: step i is on line 10 + i, column i + 1.
fn job(m: &Machine, steps: &[Step]) -> Vec<Located<Command>> {
    let mut target = m.start;
    steps
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let item = match *s {
                Step::Move(set) => {
                    for (axis, v) in set {
                        target[m.axis(axis).unwrap_or_else(|| panic!("no axis {axis}"))] = *v;
                    }
                    Command::Move(Move {
                        target,
                        feed: 10.0,
                        kind: MoveKind::Feed,
                    })
                }
                Step::Dwell => Command::Dwell { seconds: 0.5 },
                Step::Tool => Command::Tool {
                    tool: 0,
                    value: 1.0,
                },
            };
            Located { loc: loc(i), item }
        })
        .collect()
}

fn loc(i: usize) -> SourceLoc {
    SourceLoc {
        line: 10 + i as u32,
        column: 1 + i as u32,
    }
}

fn check(c: &Case) -> Result<(), String> {
    let m = machine(c.machine);
    let commands = job(&m, c.steps);
    match (check_job(&m, &commands), c.refused) {
        (Ok(()), None) => Ok(()),
        (Ok(()), Some((i, _))) => Err(format!(
            "{}: accepted, expected refusal at step {i}",
            c.what
        )),
        (Err(e), None) => Err(format!("{}: refused: {e}", c.what)),
        (Err(e), Some((i, part))) => {
            if e.loc != loc(i) {
                Err(format!(
                    "{}: refused at {}, expected {} ({e})",
                    c.what,
                    e.loc,
                    loc(i)
                ))
            } else if !e.message.contains(part) {
                Err(format!(
                    "{}: message {:?} lacks {part:?}",
                    c.what, e.message
                ))
            } else if e.to_string() != format!("{}: {}", loc(i), e.message) {
                Err(format!("{}: displayed as {e}", c.what))
            } else {
                Ok(())
            }
        }
    }
}

#[test]
fn jobs_are_checked_against_the_machine() {
    let failures: Vec<String> = CASES.iter().filter_map(|c| check(c).err()).collect();
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        CASES.len(),
        failures.join("\n")
    );
}

#[test]
fn an_empty_job_and_a_job_without_moves_pass() {
    for file in ["printer.toml", "clay-printer.toml"] {
        let m = machine(file);
        assert_eq!(check_job(&m, &[]), Ok(()));
        assert_eq!(check_job(&m, &job(&m, &[Dwell, Tool, Dwell])), Ok(()));
    }
}

#[test]
fn rapids_are_checked_like_feeds() {
    let m = machine("printer.toml");
    let mut target = m.start;
    target[0] = 500.0;
    let commands = [Located {
        loc: SourceLoc { line: 3, column: 0 },
        item: Command::Move(Move {
            target,
            feed: 0.0,
            kind: MoveKind::Rapid,
        }),
    }];
    let err = check_job(&m, &commands).unwrap_err();
    assert_eq!(err.loc, SourceLoc { line: 3, column: 0 });
    assert_eq!(
        err.to_string(),
        "3: move to x=500.0000 is beyond the axis's travel [0, 220]"
    );
}
