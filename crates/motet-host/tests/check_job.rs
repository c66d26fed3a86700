//! `check_job`: moves beyond travel and polar moves too close to the centre are
//! refused with the offending command's place; coordinates beyond travel by
//! less than half a step are clamped onto it and counted; everything else
//! passes unchanged.

use motet_host::{check_job, Clamps, Machine};
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
    outcome: Outcome,
}

#[derive(Clone, Copy)]
enum Outcome {
    /// Accepted as it is.
    Accepted,
    /// Accepted with this many moves clamped, by at most this much.
    Clamped(usize, f64),
    /// Refused at this step, with this part in the message.
    Refused(usize, &'static str),
}

use Outcome::{Accepted, Clamped, Refused};
use Step::{Dwell, Move as M, Tool};

const NAN: f64 = f64::NAN;

const CASES: &[Case] = &[
    // ---- travel ----------------------------------------------------------------
    Case {
        what: "printer: corners of the travel are reachable",
        machine: "printer.toml",
        steps: &[M(&[("x", 220.0)]), M(&[("y", 220.0)]), M(&[("z", 250.0)]), M(&[("x", 0.0), ("y", 0.0), ("z", 0.0)])],
        outcome: Accepted,
    },
    Case {
        what: "printer: rounding just past the end is clamped",
        machine: "printer.toml",
        steps: &[M(&[("x", 220.0 + 1e-7)]), M(&[("z", -1e-9)])],
        outcome: Clamped(2, (220.0 + 1e-7) - 220.0),
    },
    Case {
        what: "printer: x beyond max",
        machine: "printer.toml",
        steps: &[M(&[("x", 10.0)]), Dwell, M(&[("x", 230.0)]), M(&[("x", 240.0)])],
        outcome: Refused(2, "move to x=230 is 10 beyond the axis's travel [0, 220] (half a step is 0.00625)"),
    },
    Case {
        what: "printer: z below min",
        machine: "printer.toml",
        steps: &[M(&[("x", 10.0), ("z", 5.0)]), M(&[("z", -0.1)])],
        outcome: Refused(1, "move to z=-0.1 is 0.1 beyond the axis's travel [0, 250] (half a step is 0.00125)"),
    },
    Case {
        what: "printer: y just too far",
        machine: "printer.toml",
        steps: &[M(&[("y", 220.01)])],
        outcome: Refused(0, "y=220.01 is 0.01 beyond"),
    },
    Case {
        what: "printer: extruder without travel is unlimited",
        machine: "printer.toml",
        steps: &[M(&[("e", 1.0e6)]), M(&[("x", 100.0), ("e", -1.0e6)]), Tool, M(&[("e", 0.0)])],
        outcome: Accepted,
    },
    Case {
        what: "printer: extruder must still be a number",
        machine: "printer.toml",
        steps: &[M(&[("e", 5.0)]), M(&[("e", NAN)])],
        outcome: Refused(1, "e=NaN: not a number"),
    },
    Case {
        what: "printer: NaN on a limited axis",
        machine: "printer.toml",
        steps: &[M(&[("x", NAN)])],
        outcome: Refused(0, "x=NaN: not a number"),
    },
    Case {
        what: "printer: infinity on a limited axis",
        machine: "printer.toml",
        steps: &[M(&[("y", f64::INFINITY)])],
        outcome: Refused(0, "y=inf: not a number"),
    },
    Case {
        what: "printer: cartesian moves through the origin are fine",
        machine: "printer.toml",
        steps: &[M(&[("x", 100.0), ("y", 100.0)]), M(&[("x", 0.0), ("y", 0.0)]), M(&[("x", 1.0), ("y", 0.5)])],
        outcome: Accepted,
    },
    Case {
        what: "plotter: negative x",
        machine: "plotter.toml",
        steps: &[Tool, M(&[("x", 100.0), ("y", 100.0)]), Tool, M(&[("x", -1.0)])],
        outcome: Refused(3, "x=-1 is 1 beyond the axis's travel [0, 300]"),
    },
    Case {
        what: "plotter: whole sheet",
        machine: "plotter.toml",
        steps: &[M(&[("x", 300.0), ("y", 218.0)]), M(&[("x", 0.0)]), M(&[("y", 0.0)])],
        outcome: Accepted,
    },
    Case {
        what: "laser: y beyond its 300 mm",
        machine: "laser.toml",
        steps: &[M(&[("x", 400.0), ("y", 300.0)]), M(&[("y", 301.0)])],
        outcome: Refused(1, "y=301 is 1 beyond"),
    },
    Case {
        what: "gestalt: z may go negative down to -20",
        machine: "gestalt-3axis.toml",
        steps: &[M(&[("z", -20.0)]), M(&[("z", 30.0)])],
        outcome: Accepted,
    },
    Case {
        what: "gestalt: z below -20",
        machine: "gestalt-3axis.toml",
        steps: &[M(&[("z", -20.5)])],
        outcome: Refused(0, "z=-20.5 is 0.5 beyond the axis's travel [-20, 30]"),
    },
    // ---- within half a step of travel: clamped -----------------------------------
    Case {
        what: "plotter: a stroke 0.0031 mm left of the sheet (half a step is 0.0044 mm)",
        machine: "plotter.toml",
        steps: &[M(&[("x", 10.0), ("y", 10.0)]), M(&[("x", -0.0031)]), M(&[("y", 20.0)]), M(&[("x", 10.0)])],
        outcome: Clamped(2, 0.0031),
    },
    Case {
        what: "plotter: y a hair below the sheet",
        machine: "plotter.toml",
        steps: &[M(&[("y", -1e-5), ("x", 5.0)]), M(&[("x", 10.0)])],
        outcome: Clamped(2, 1e-5),
    },
    Case {
        what: "plotter: half a step beyond is refused",
        machine: "plotter.toml",
        steps: &[M(&[("x", 300.0045)])],
        outcome: Refused(0, "x=300.005 is 0.0045 beyond the axis's travel [0, 300] (half a step is 0.00441786)"),
    },
    Case {
        what: "printer: z 0.001 below the bed (half a step of its leadscrew is 0.00125)",
        machine: "printer.toml",
        steps: &[M(&[("z", -0.001)])],
        outcome: Clamped(1, 0.001),
    },
    Case {
        what: "clay: the radius's half step counts on the plane's axes",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", 150.0 + 1e-4)])],
        outcome: Clamped(1, 1e-4),
    },
    // ---- polar centre (clay printer: min_radius 2 mm, starts at x = 100) -------------
    Case {
        what: "clay: quarter turn stays far from the centre",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", 0.0), ("y", 100.0)]), M(&[("x", -100.0), ("y", 0.0)]), M(&[("x", 0.0), ("y", -100.0)])],
        outcome: Accepted,
    },
    Case {
        what: "clay: straight through the centre",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", -100.0)])],
        outcome: Refused(0, "passes 0.000 mm from the polar centre"),
    },
    Case {
        what: "clay: chord passing 1.95 mm from the centre",
        machine: "clay-printer.toml",
        // Line from (100, 0) to (-100, 3.9): distance 390 / |(-200, 3.9)| ≈ 1.950.
        steps: &[M(&[("z", 5.0)]), M(&[("x", -100.0), ("y", 3.9)])],
        outcome: Refused(1, "passes 1.950 mm from the polar centre; the turntable cannot follow closer than min_radius = 2 mm"),
    },
    Case {
        what: "clay: chord passing 2.05 mm from the centre",
        machine: "clay-printer.toml",
        // 410 / |(-200, 4.1)| ≈ 2.0496.
        steps: &[M(&[("x", -100.0), ("y", 4.1)])],
        outcome: Accepted,
    },
    Case {
        what: "clay: ending inside min_radius",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", 1.0)])],
        outcome: Refused(0, "passes 1.000 mm"),
    },
    Case {
        what: "clay: ending exactly at min_radius",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", 2.0)]), M(&[("y", 5.0)])],
        outcome: Accepted,
    },
    Case {
        what: "clay: chord between two points on the min_radius circle cuts inside it",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", 2.0)]), M(&[("x", 0.0), ("y", 2.0)])],
        outcome: Refused(1, "passes 1.414 mm"),
    },
    Case {
        what: "clay: the second move crosses the centre",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", 0.0), ("y", 50.0)]), Dwell, M(&[("y", -50.0)])],
        outcome: Refused(2, "from the polar centre"),
    },
    Case {
        what: "clay: moving away from the centre along a ray is fine",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", 3.0)]), M(&[("x", 150.0)]), M(&[("x", 2.5), ("y", 0.0)])],
        outcome: Accepted,
    },
    Case {
        what: "clay: z and e alone do not move in the plane",
        machine: "clay-printer.toml",
        steps: &[M(&[("z", 10.0)]), M(&[("e", 100.0)]), M(&[("z", 0.0), ("e", -5.0)])],
        outcome: Accepted,
    },
    Case {
        what: "clay: travel is checked before the centre",
        machine: "clay-printer.toml",
        steps: &[M(&[("x", -151.0)])],
        outcome: Refused(0, "x=-151 is 1 beyond"),
    },
    // ---- arms' reach (scara: l1 150, l2 120, starts at (150, 80)) -------------------
    Case {
        what: "scara: across the reach, around the shoulder",
        machine: "scara.toml",
        steps: &[M(&[("x", 100.0), ("y", 200.0)]), M(&[("x", -150.0), ("y", 80.0)])],
        outcome: Accepted,
    },
    Case {
        what: "scara: a line through the shoulder folds the arm first",
        machine: "scara.toml",
        steps: &[M(&[("x", -150.0), ("y", -80.0)])],
        outcome: Refused(0, "move passes (26.4706, 14.1176), too near a singularity (arms stretched or folded) of the scara kinematics"),
    },
    Case {
        what: "scara: the arm stretched straight",
        machine: "scara.toml",
        steps: &[M(&[("x", 100.0)]), M(&[("x", 270.0), ("y", 0.0)])],
        outcome: Refused(1, "too near a singularity (arms stretched or folded) of the scara kinematics"),
    },
    // ---- delta (radius 105, rods 215, starts at the centre) ---------------------------
    Case {
        what: "delta: a circle of 80 mm radius and up",
        machine: "delta.toml",
        steps: &[M(&[("x", 80.0)]), M(&[("x", 0.0), ("y", 80.0)]), M(&[("x", -80.0), ("y", 0.0), ("z", 150.0)]), M(&[("x", 0.0), ("y", -80.0)])],
        outcome: Accepted,
    },
    Case {
        what: "delta: toward a corner of the travel box, beyond what the rods reach",
        machine: "delta.toml",
        steps: &[M(&[("z", 5.0)]), M(&[("x", 85.0), ("y", 85.0)])],
        outcome: Refused(1, "move passes (70.2479, 70.2479, 5), too near a singularity (arms stretched or folded) of the delta kinematics"),
    },
    Case {
        what: "delta: a rod almost flat",
        machine: "delta.toml",
        steps: &[M(&[("x", 80.0), ("y", 60.0)])],
        outcome: Refused(0, "too near a singularity (arms stretched or folded) of the delta kinematics"),
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
    let original = job(&m, c.steps);
    let mut commands = original.clone();
    match (check_job(&m, &mut commands), c.outcome) {
        (Ok(clamps), Accepted) if clamps == Clamps::default() && commands == original => Ok(()),
        (Ok(clamps), Clamped(n, max)) => {
            let inside = commands.iter().all(|c| match c.item {
                Command::Move(mv) => m
                    .axes
                    .iter()
                    .enumerate()
                    .all(|(i, a)| a.travel[0] <= mv.target[i] && mv.target[i] <= a.travel[1]),
                _ => true,
            });
            if clamps.moves == n && (clamps.max_mm - max).abs() <= 1e-9 * max && inside {
                Ok(())
            } else {
                Err(format!(
                    "{}: clamped {clamps:?} (all within travel: {inside}), expected {n} moves by {max}",
                    c.what
                ))
            }
        }
        (Ok(clamps), _) => Err(format!("{}: accepted with {clamps:?}", c.what)),
        (Err(e), Accepted | Clamped(..)) => Err(format!("{}: refused: {e}", c.what)),
        (Err(e), Refused(i, part)) => {
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
        assert_eq!(check_job(&m, &mut []), Ok(Clamps::default()));
        assert_eq!(
            check_job(&m, &mut job(&m, &[Dwell, Tool, Dwell])),
            Ok(Clamps::default())
        );
    }
}

#[test]
fn rapids_are_checked_like_feeds() {
    let m = machine("printer.toml");
    let mut target = m.start;
    target[0] = 500.0;
    let mut commands = [Located {
        loc: SourceLoc { line: 3, column: 0 },
        item: Command::Move(Move {
            target,
            feed: 0.0,
            kind: MoveKind::Rapid,
        }),
    }];
    let err = check_job(&m, &mut commands).unwrap_err();
    assert_eq!(err.loc, SourceLoc { line: 3, column: 0 });
    assert_eq!(
        err.to_string(),
        "3: move to x=500 is 280 beyond the axis's travel [0, 220] (half a step is 0.00625)"
    );
}
