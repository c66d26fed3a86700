//! What a streamed run holds does not grow with the job (ARCHITECTURE.md,
//! "Constant memory"): the same job ten times longer holds the same counts of
//! segments and path points, a stroke longer than the recorder's piece is
//! handed out in joined pieces, and time passing without steps drops the
//! segments it passed.

use motet_host::Machine;
use motet_planner::{Command, Located, Move, MoveKind, SourceLoc};
use motet_render::Stroke;
use motet_sim::path::MAX_STROKE_POINTS;
use motet_sim::{simulate_stream, Held, NODE_QUEUE};
use std::convert::Infallible;
use std::path::Path;

fn printer() -> Machine {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/printer.toml");
    Machine::load(&path).unwrap()
}

fn feed(line: u32, target: [f64; 6], speed: f64) -> Located<Command> {
    Located {
        loc: SourceLoc { line, column: 0 },
        item: Command::Move(Move {
            target,
            feed: speed,
            kind: MoveKind::Feed,
        }),
    }
}

/// `layers` circles of radius 20 mm around (110, 110), 0.2 mm apart in z,
/// extruding all the way: one tool-on stroke from start to end.
fn layered_circles(layers: u32) -> impl Iterator<Item = Result<Located<Command>, Infallible>> {
    let n = 200;
    let mut e = 0.0;
    let mut line = 0;
    std::iter::once(feed(0, [130.0, 110.0, 0.2, 0.0, 0.0, 0.0], 100.0))
        .chain(
            (0..layers)
                .flat_map(move |layer| (1..=n).map(move |k| (layer, k)))
                .map(move |(layer, k)| {
                    let a = k as f64 / n as f64 * std::f64::consts::TAU;
                    e += 0.02;
                    line += 1;
                    let z = 0.2 * f64::from(layer + 1) + 0.2 * k as f64 / n as f64;
                    feed(
                        line,
                        [
                            110.0 + 20.0 * a.cos(),
                            110.0 + 20.0 * a.sin(),
                            z,
                            e,
                            0.0,
                            0.0,
                        ],
                        60.0,
                    )
                }),
        )
        .map(Ok)
}

fn run(
    m: &Machine,
    commands: impl Iterator<Item = Result<Located<Command>, Infallible>>,
) -> (Held, Vec<Stroke>) {
    let mut strokes = Vec::new();
    let r = simulate_stream(m, "job", commands, 0, &mut |_, _| {}, &mut |s| {
        strokes.push(s)
    })
    .unwrap();
    assert_eq!(r.report.underruns, 0);
    (r.held, strokes)
}

#[test]
fn a_job_ten_times_longer_holds_the_same() {
    let m = printer();
    // Ten circles already fill a stroke piece (about 11,000 points).
    let (once, _) = run(&m, layered_circles(10));
    let (ten, strokes) = run(&m, layered_circles(100));
    // Each count within a little of the short job's; any count that grew
    // with the job would be about ten times it.
    for (what, a, b) in [
        ("plant segments", once.plant_segments, ten.plant_segments),
        ("path points", once.path_points, ten.path_points),
        ("node segments", once.node_segments, ten.node_segments),
    ] {
        assert!(
            b <= a + a / 4 + 16,
            "{what}: {a} for the job, {b} for ten times it"
        );
    }
    assert!(ten.node_segments <= NODE_QUEUE * m.nodes.len());
    assert!(ten.path_points <= 2 * MAX_STROKE_POINTS);

    // 100 circles of 126 mm at about 0.11 mm a point are far more than one
    // piece: the stroke was handed out in pieces, each joined to the last.
    let tool: Vec<&Stroke> = strokes.iter().filter(|s| s.tool_on).collect();
    assert!(tool.len() >= 3, "{} tool-on pieces", tool.len());
    for w in strokes.windows(2) {
        assert_eq!(w[0].points.last(), w[1].points.first(), "pieces join");
    }
    assert!(strokes
        .iter()
        .all(|s| s.points.len() <= MAX_STROKE_POINTS + 1));
}

#[test]
fn time_without_steps_does_not_pile_up_segments() {
    // 30,000 moves of 1 µm back and forth: well under half a step (80
    // steps/mm), so no motor steps while the plan runs for minutes.
    let m = printer();
    let moves = (0..30_000u32).map(|k| {
        let x = 100.0 + 0.001 * f64::from(k % 2);
        Ok(feed(k, [x, 100.0, 0.0, 0.0, 0.0, 0.0], 1.0))
    });
    let start = std::iter::once(Ok(feed(0, [100.0, 100.0, 0.0, 0.0, 0.0, 0.0], 100.0)));
    let (held, _) = run(&m, start.chain(moves));
    assert!(
        held.plant_segments <= 2 * NODE_QUEUE * m.nodes.len(),
        "{} segments held",
        held.plant_segments
    );
}
