//! Tiny fast moves on a node with a 64-segment queue: the planner's stop
//! horizon slows the machine down so it can always stop within half the
//! queue, and the run never leaves a node without segments.

use motet_host::Machine;
use motet_planner::{Command, Located, Move, MoveKind, SourceLoc};
use std::path::Path;

#[test]
fn ten_thousand_tiny_fast_moves_run_without_underruns() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/printer.toml");
    let machine = Machine::load(&path).unwrap();
    assert_eq!(machine.stop_horizon, 32, "the machine file default");
    assert!(machine.nodes.iter().all(|n| n.queue == 64));
    // 10,000 moves of 0.02 mm around a gentle curve from the start point,
    // asked for at 250 mm/s.
    let r = 0.02 / 1e-4;
    let commands: Vec<Located<Command>> = (1..=10_000)
        .map(|k| {
            let a = k as f64 * 1e-4;
            Located {
                loc: SourceLoc { line: k, column: 0 },
                item: Command::Move(Move {
                    target: [r * a.sin(), r * (1.0 - a.cos()), 0.0, 0.0, 0.0, 0.0],
                    feed: 250.0,
                    kind: MoveKind::Feed,
                }),
            }
        })
        .collect();
    let result = motet_sim::simulate(&machine, "tiny", &commands, &mut |_, _| {}).unwrap();
    let rep = result.report;
    assert_eq!(rep.segments, 10_000);
    assert_eq!(rep.underruns, 0);
    assert!(
        rep.max_deviation_steps <= 0.5 + 1e-6,
        "{}",
        rep.max_deviation_steps
    );
    // It slowed down rather than stopping: one rest, at the end.
    assert_eq!(rep.rests, 1);
    // Stopping within 32 moves of 0.02 mm at 3000 mm/s² allows √(2·3000·0.64)
    // ≈ 62 mm/s, well under the feed.
    let speed = rep.axes[0].peak_velocity.hypot(rep.axes[1].peak_velocity);
    assert!(speed < 2.0 * 62.0, "{speed}");
    assert!(rep.duration_s > 200.0 / 250.0 * 2.0, "{}", rep.duration_s);
}
