//! The pantograph dance: a five-bar stylus through a 2D scaling filter adds
//! to a planned job that two trajectory readers follow. Here the job is a
//! small square built by hand (the example's own job is an SVG, checked by
//! `motet`'s tests).

use motet_graph::GraphFile;
use motet_host::Machine;
use motet_node::graph::FiveBarForward;
use motet_planner::{Command, Located, Move, MoveKind, SourceLoc};
use motet_sim::dance::{run_dance_with_job, CsvTrace, InputSource, PlannedJob};
use motet_trajectory::MAX_AXES;
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/dance/pantograph")
}

/// Radians per encoder count (graph.toml).
const RAD: f64 = 0.001533980787885641;

fn square() -> Vec<Located<Command>> {
    let corners = [
        (0.0, 0.0),
        (40.0, 0.0),
        (40.0, 30.0),
        (0.0, 30.0),
        (0.0, 0.0),
        (25.0, 15.0),
    ];
    corners
        .iter()
        .map(|&(x, y)| {
            let mut target = [0.0; MAX_AXES];
            target[0] = x;
            target[1] = y;
            Located {
                loc: SourceLoc::default(),
                item: Command::Move(Move {
                    target,
                    feed: 20.0,
                    kind: MoveKind::Feed,
                }),
            }
        })
        .collect()
}

/// Runs for `seconds` and checks both belts against the planned point at the
/// last frame plus half the stylus's motion since it rested, within half a
/// step. Returns the hand's share (x, y), mm.
fn check(m: &Machine, g: &GraphFile, trace: &CsvTrace, job: &PlannedJob, seconds: f64) -> [f64; 2] {
    let mut t = trace.clone();
    let r = run_dance_with_job(m, g, &mut t, Some(job), seconds, &mut |_| {})
        .unwrap()
        .report;
    let frame = g.frame_us;
    let n = (seconds * 1e6 / frame).round();
    let last = (n - 1.0) * frame;
    let p = job.position_at(last).unwrap();
    // The stylus's point from the encoder counts, at rest and at the last frame.
    let arm = FiveBarForward::new(50.0, 60.0, 60.0, 100.0, 100.0);
    let mut v = [0.0; 2];
    let mut at = |ts: f64| {
        t.values(ts, &mut v);
        arm.stylus(v[0].round() * RAD, v[1].round() * RAD).unwrap()
    };
    let rest = at(0.0);
    let now = at(last * 1e-6);
    let hand = [0.5 * (now.0 - rest.0), 0.5 * (now.1 - rest.1)];
    let (x, y) = (p[0] + hand[0], p[1] + hand[1]);
    let per_mm = 3200.0 / (std::f64::consts::PI * 9.0);
    for (name, want) in [("ch_a", x + y), ("ch_b", x - y)] {
        let c = r.channels.iter().find(|c| c.name == name).unwrap();
        assert!(
            (c.position_steps - want * per_mm).abs() <= 0.5,
            "{seconds} s: {name} at {}, planned + hand {}",
            c.position_steps,
            want * per_mm
        );
        assert!(c.error_steps.abs() <= 0.5, "{c:?}");
    }
    assert!(r.job_segments > 0);
    hand
}

#[test]
fn pantograph_at_rest_follows_the_planned_job() {
    let m = Machine::load(&dir().join("machine.toml")).unwrap();
    let g = GraphFile::load(&dir().join("graph.toml")).unwrap();
    let still = CsvTrace::parse(
        "time_s,shoulder_l,shoulder_r\n0,1418,630\n",
        "still.csv",
        &g,
    )
    .unwrap();
    let job = PlannedJob::plan(&m, &square()).unwrap();
    let end = job.end_us * 1e-6;
    assert!(end > 7.0 && end < 12.0, "{end}");
    for s in [0.3, 1.7, 2.5, 4.1, 6.0, 7.3, end + 0.5] {
        let hand = check(&m, &g, &still, &job, s);
        assert_eq!(hand, [0.0, 0.0]);
    }
}

#[test]
fn pantograph_adds_the_stylus_to_the_job() {
    let m = Machine::load(&dir().join("machine.toml")).unwrap();
    let g = GraphFile::load(&dir().join("graph.toml")).unwrap();
    let trace = CsvTrace::load(&dir().join("inputs.csv"), &g).unwrap();
    let job = PlannedJob::plan(&m, &square()).unwrap();
    let mut moved = 0.0f64;
    for s in [1.0, 2.3, 3.7, 5.1, trace.end()] {
        let hand = check(&m, &g, &trace, &job, s);
        moved = moved.max(hand[1].abs());
    }
    // The waves lift the pen a few mm off the plan.
    assert!(moved > 1.0, "{moved}");
}
