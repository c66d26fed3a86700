//! A host on a busy computer, on a simulated clock: the host is not polled
//! for stretches of time while the nodes go on. It lengthens its lead to
//! ride out the stalls it has seen and finishes with the simulator's steps;
//! a stall longer than any lead it may keep stops the run on the nodes'
//! tails, saying how long the host had no turn.

mod common;

use common::*;
use motet_net::loopback::Loopback;
use motet_net::{NetConfig, Phase};

/// Steps the loopback with the host polled only `on_us` of every
/// `on_us + off_us` µs (the nodes always), until the run is done or
/// stopped, or `for_us` passed. Returns the phase and the host's notes.
fn stalled_for(lb: &mut Loopback, on_us: u64, off_us: u64, for_us: u64) -> (Phase, Vec<String>) {
    let mut notes = Vec::new();
    let end = lb.now + for_us;
    while lb.now < end {
        lb.host_alive = lb.now % (on_us + off_us) < on_us;
        lb.step().unwrap();
        notes.extend(lb.run.take_notes());
        if matches!(lb.run.phase(), Phase::Done | Phase::Stopped(_)) {
            break;
        }
    }
    lb.host_alive = true;
    (lb.run.phase().clone(), notes)
}

/// [`stalled_for`] until the run is done or stopped.
fn run_stalled(lb: &mut Loopback, on_us: u64, off_us: u64) -> (Phase, Vec<String>) {
    stalled_for(lb, on_us, off_us, 600_000_000)
}

fn gestalt() -> (
    motet_host::Machine,
    Vec<motet_planner::Located<motet_planner::Command>>,
) {
    load(
        "examples/gestalt-3axis.toml",
        "examples/jobs/gestalt-3d.gcode",
    )
}

/// The host has a turn for 40 ms of every 240 ms: stalls of 200 ms, twice
/// the least lead. It raises its lead and finishes exactly. Kept at the
/// least lead, stalls longer than a window reaches past it (1.2 s) stop
/// the run, and it says why.
#[test]
fn a_host_stalled_again_and_again_raises_its_lead_and_finishes() {
    let (m, cmds) = gestalt();
    let want = simulated(&m, &cmds);
    let mut lb = clean_loopback(&m, cmds.clone());
    let (phase, notes) = run_stalled(&mut lb, 40_000, 200_000);
    assert_eq!(phase, Phase::Done, "{notes:?}");
    assert_eq!(executed(&m, &lb), want);
    let pace = lb.run.pace();
    assert!(pace.worst_gap_us >= 200_000, "{pace:?}");
    // Twice the worst stall on top of the least lead.
    assert!(pace.lead_us >= 100_000 + 2 * 200_000, "{pace:?}");
    assert!(
        notes
            .iter()
            .any(|n| n.contains("the host fell behind") && n.contains("lead raised to")),
        "{notes:?}"
    );

    // Longer stalls with the lead held at its least.
    let n = m.nodes.len();
    let cfg = NetConfig {
        lead_max_us: 0,
        ..NetConfig::default()
    };
    let mut lb = Loopback::new(&m, cmds, m.start, clean_links(n), &clocks(n), cfg);
    let (phase, _) = run_stalled(&mut lb, 40_000, 1_200_000);
    let Phase::Stopped(info) = phase else {
        panic!("expected a stop, got {phase:?}: {:?}", lb.run.pace());
    };
    assert!(
        info.reason.contains("the host had no turn for")
            && info.reason.contains("(lead 100 ms)")
            && info.reason.contains("every node braked on its tail"),
        "{}",
        info.reason
    );
    assert!(info.lost.is_empty(), "{info:?}");
    settled_on_the_path(&m, &mut lb, &info);
}

/// One stall of 5 s, longer than any lead the run may keep (2 s): the nodes
/// brake on their tails; the host stops at once with why, loses no node
/// (they were silent only while it was not listening), and the record and
/// every node agree where the machine rests.
#[test]
fn a_stall_longer_than_any_lead_stops_on_the_tails_and_says_why() {
    let (m, cmds) = gestalt();
    let mut lb = clean_loopback(&m, cmds);
    while lb.now < 9_000_000 {
        lb.step().unwrap();
    }
    assert_eq!(lb.run.phase(), &Phase::Streaming);
    let stalled_at = lb.now;
    lb.host_alive = false;
    while lb.now < stalled_at + 5_000_000 {
        lb.step().unwrap();
    }
    lb.host_alive = true;
    let phase = lb.run_until_settled(60_000_000).unwrap();
    let Phase::Stopped(info) = phase else {
        panic!("expected a stop, got {phase:?}");
    };
    assert!(
        info.reason.starts_with("the host had no turn for 500")
            && info.reason.contains("every node braked on its tail"),
        "{}",
        info.reason
    );
    assert!(info.lost.is_empty(), "{info:?}");
    settled_on_the_path(&m, &mut lb, &info);
}

/// Every node confirmed its rest at the committed window's end, stopped on
/// its tail, and its steps are those of that point.
fn settled_on_the_path(m: &motet_host::Machine, lb: &mut Loopback, info: &motet_net::StopInfo) {
    assert!(info.all_at_rest(), "{info:?}");
    assert_eq!(lb.run.position_at(info.rest_time + 1e6), Some(info.point));
    lb.host_alive = false;
    lb.run_until_settled(10_000_000).unwrap();
    let w = node_windows(lb);
    assert!(
        w.iter().all(|&(c, s)| c == info.window_end && s),
        "{w:?} vs {info:?}"
    );
    let rest: Vec<i64> = executed(m, lb).iter().map(|&(_, p)| p).collect();
    assert_eq!(rest, steps_at(m, &info.point));
}

/// 0.02 mm moves on an arc: the nodes' queues hold a fraction of a second.
fn tiny_moves(n: u32) -> Vec<motet_planner::Located<motet_planner::Command>> {
    let r = 0.02 / 1e-4;
    (1..=n)
        .map(|k| {
            let a = k as f64 * 1e-4;
            motet_planner::Located {
                loc: motet_planner::SourceLoc { line: k, column: 0 },
                item: motet_planner::Command::Move(motet_planner::Move {
                    target: [r * a.sin(), r * (1.0 - a.cos()), 0.0, 0.0, 0.0, 0.0],
                    feed: 250.0,
                    kind: motet_planner::MoveKind::Feed,
                }),
            }
        })
        .collect()
}

/// Tiny moves, and the host stalled longer and longer once the job runs
/// (60 ms, then 120 ms, then 200 ms of every 240 ms): the queues cannot
/// reach the longer lead, so the moves not yet planned are slowed; the job
/// finishes with the simulator's steps.
#[test]
fn full_queues_short_of_the_lead_slow_the_moves_not_yet_planned() {
    let m = motet_host::Machine::load(&root().join("examples/printer.toml")).unwrap();
    let cmds = tiny_moves(3_000);
    let want = simulated(&m, &cmds);
    let mut lb = clean_loopback(&m, cmds);
    while lb.run.progress().0 < 100 {
        lb.step().unwrap();
    }
    let mut notes = Vec::new();
    for off in [60_000, 120_000] {
        let (phase, n) = stalled_for(&mut lb, 240_000 - off, off, 3_000_000);
        assert_eq!(phase, Phase::Streaming, "{n:?}");
        notes.extend(n);
    }
    let (phase, n) = run_stalled(&mut lb, 40_000, 200_000);
    notes.extend(n);
    assert_eq!(phase, Phase::Done, "{notes:?}");
    assert_eq!(executed(&m, &lb), want);
    assert!(
        notes.iter().any(|n| n.contains("short moves from job line")
            && n.contains("are slowed to take at least")),
        "{notes:?}"
    );
}
