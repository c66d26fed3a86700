//! Jobs streamed over the network to simulated nodes on a simulated clock:
//! the executed steps must equal those of the in-process simulator, whatever
//! the link does, and a stop must leave every axis at rest on the path.

mod common;

use common::*;
use motet_host::Machine;
use motet_link::fault::SimClock;
use motet_link::pair;
use motet_net::loopback::{Crystal, Loopback};
use motet_net::{NetConfig, Phase};
use motet_planner::{Command, Located};

#[test]
fn clean_run_steps_like_the_simulator() {
    for (machine, job) in [
        ("examples/plotter.toml", "examples/jobs/drawing.svg"),
        (
            "examples/gestalt-3axis.toml",
            "examples/jobs/gestalt-3d.gcode",
        ),
        ("examples/laser.toml", "examples/jobs/laser-badge.gcode"),
    ] {
        let (m, cmds) = load(machine, job);
        let want = simulated(&m, &cmds);
        let mut lb = clean_loopback(&m, cmds);
        let phase = lb.run_until_settled(3_600_000_000).unwrap();
        assert_eq!(phase, Phase::Done, "{machine} {job}");
        assert_eq!(executed(&m, &lb), want, "{machine} {job}");
        for n in &lb.nodes {
            assert_eq!(
                n.node.endpoint.node().status().underruns,
                0,
                "{machine} {job}"
            );
        }
    }
}

#[test]
fn one_percent_of_every_fault_changes_no_step() {
    let (m, cmds) = load(
        "examples/gestalt-3axis.toml",
        "examples/jobs/gestalt-3d.gcode",
    );
    let want = simulated(&m, &cmds);
    let n = m.nodes.len();
    let clock = SimClock::new();
    let mut lb = Loopback::new(
        &m,
        cmds,
        m.start,
        faulty_links(n, &clock, 0.01, 7),
        &clocks(n),
        NetConfig::default(),
    );
    let end = 3_600_000_000;
    let mut phase = Phase::Starting;
    while lb.now < end {
        clock.set(lb.now);
        lb.step().unwrap();
        phase = lb.run.phase().clone();
        if matches!(phase, Phase::Done | Phase::Stopped(_)) {
            break;
        }
    }
    assert_eq!(phase, Phase::Done);
    assert_eq!(executed(&m, &lb), want);
    let retransmits: u64 = lb
        .run
        .peers()
        .iter()
        .map(|p| p.link().stats().retransmits)
        .sum();
    assert!(retransmits > 0, "the faults must have cost retransmissions");
    // Every clock model sent was acknowledged through the lossy link, so
    // no node's bound still counts a model it may not run.
    for p in lb.run.peers() {
        assert!(
            p.sync.models_sent.0 >= 1,
            "{}: {:?}",
            p.name,
            p.sync.models_sent
        );
        assert_eq!(p.sync.models_unacknowledged(), 0, "{}", p.name);
    }
    // Each node's own measure of its drift (from the host's send times it
    // saw) finds its crystal.
    for n in &lb.nodes {
        let d = n.node.endpoint.services().status(0).drift;
        let d = d.expect("a node measures its drift over a run");
        assert!(
            (d.ppb as f64 * 1e-3 - n.ppm).abs() < 5.0 && d.span_s >= 5,
            "crystal {:+} ppm, the node's measure {d:?}",
            n.ppm
        );
    }
}

#[test]
fn a_node_that_stops_answering_stops_the_others_with_it() {
    let (m, cmds) = load(
        "examples/gestalt-3axis.toml",
        "examples/jobs/gestalt-3d.gcode",
    );
    let mut lb = clean_loopback(&m, cmds);
    while lb.now < 9_000_000 {
        lb.step().unwrap();
    }
    assert_eq!(lb.run.phase(), &Phase::Streaming);
    // The link to node 1 is cut: it neither hears nor answers, but keeps running.
    let cut = std::mem::replace(&mut lb.nodes[1].node.transport, Box::new(pair("x", "y").0));
    drop(cut);
    let phase = lb.run_until_settled(60_000_000).unwrap();
    let Phase::Stopped(info) = phase else {
        panic!("expected a stop, got {phase:?}");
    };
    assert!(
        info.reason.contains("y_node") || info.reason.contains(&m.nodes[1].name),
        "{}",
        info.reason
    );
    // The host's record follows the tail to the same rest.
    assert_eq!(lb.run.position_at(info.rest_time + 1e6), Some(info.point));
    // Let every node finish its tail.
    lb.host_alive = false;
    lb.run_until_settled(10_000_000).unwrap();
    let w = node_windows(&lb);
    assert!(
        w.iter().all(|&(c, s)| c == info.window_end && s),
        "{w:?} vs {info:?}"
    );
    let rest: Vec<i64> = executed(&m, &lb).iter().map(|&(_, p)| p).collect();
    assert_eq!(rest, steps_at(&m, &info.point));
}

/// A node's step position of channel `ch` at host time `t`, from its trace.
fn traced_at(lb: &Loopback, node: usize, ch: u8, t: f64) -> i64 {
    let trace = lb.nodes[node].node.board.trace.as_ref().unwrap();
    trace
        .iter()
        .take_while(|s| s.0 <= t)
        .filter(|s| s.1 == ch)
        .map(|s| if s.2 { 1 } else { -1 })
        .sum()
}

#[test]
fn the_host_knows_where_the_machine_was_in_the_last_second_and_will_be() {
    let (m, cmds) = load(
        "examples/gestalt-3axis.toml",
        "examples/jobs/gestalt-3d.gcode",
    );
    let n = m.nodes.len();
    let start = steps_at(&m, &m.start);
    let mut lb = Loopback::new(
        &m,
        cmds,
        m.start,
        clean_links(n),
        &[Crystal::default(); 3],
        NetConfig::default(),
    );
    // Asked as the run streams, half a second of host time apart: just
    // under a second ago, now, and ahead within the committed window.
    let mut asked = Vec::new();
    let mut next = 0;
    while lb.now < 3_600_000_000 {
        lb.step().unwrap();
        if matches!(lb.run.phase(), Phase::Done | Phase::Stopped(_)) {
            break;
        }
        if lb.run.phase() == &Phase::Streaming && lb.now >= next {
            let now = lb.now as f64;
            for t in [now - 0.9e6, now, 0.5 * (now + lb.run.committed_end())] {
                let p = lb.run.position_at(t);
                asked.push((t, p.unwrap_or_else(|| panic!("t={t} at {now}: forgotten"))));
            }
            next = lb.now + 500_000;
        }
    }
    assert_eq!(lb.run.phase(), &Phase::Done);
    assert!(asked.len() > 30, "{} questions", asked.len());
    // Long before the end is no longer kept.
    assert_eq!(lb.run.position_at(0.0), None);
    for (t, p) in asked {
        let want = steps_at(&m, &p);
        for (node, spec) in m.nodes.iter().enumerate() {
            for (ch, &a) in spec.actuators.iter().enumerate() {
                let got = start[a] + traced_at(&lb, node, ch as u8, t);
                assert!(
                    (got - want[a]).abs() <= 1,
                    "t={t} actuator {a}: steps {got}, the host says {}",
                    want[a]
                );
            }
        }
    }
}

/// The host's record of the trajectory holds the segments of the last
/// second and those queued, whatever the job's length: `moves` chords of
/// `chord` mm round a circle at `feed` mm/s, each a segment no shorter than
/// `chord / feed`. A job read as the run goes (`NetRun::reading`) is held
/// a command at a time, and runs the same steps as the job given whole.
#[test]
fn the_host_keeps_a_window_of_the_trajectory_not_the_job() {
    // (machine, centre, radius, moves, chord mm, feed mm/s)
    let cases = [
        (
            "examples/plotter.toml",
            [150.0, 109.0],
            60.0,
            3000,
            1.0,
            100.0,
        ),
        (
            "examples/printer.toml",
            [110.0, 110.0],
            80.0,
            2000,
            2.0,
            150.0,
        ),
    ];
    for (machine, centre, radius, moves, chord, feed) in cases {
        let m = Machine::load(&root().join(machine)).unwrap();
        let cmds = circle(&m, centre, radius, moves, chord, feed);
        // The same job given whole, and read as the run goes: the same
        // steps, and only the second holds a bounded part of the job.
        let mut given = clean_loopback(&m, cmds.clone());
        given.run_until_settled(3_600_000_000).unwrap();
        let mut lb = clean_loopback(&m, Vec::new());
        lb.run.reading(Box::new(Listed(cmds.into_iter())), moves);
        let (mut most, mut most_commands) = (0, 0);
        while lb.now < 3_600_000_000 {
            lb.step().unwrap();
            most = most.max(lb.run.history_len());
            most_commands = most_commands.max(lb.run.commands_held());
            if matches!(lb.run.phase(), Phase::Done | Phase::Stopped(_)) {
                break;
            }
        }
        assert_eq!(lb.run.phase(), &Phase::Done, "{machine}");
        assert_eq!(executed(&m, &lb), executed(&m, &given), "{machine}");
        assert_eq!(lb.run.progress(), (moves, moves), "{machine}");
        assert!(
            most_commands <= 1,
            "{machine}: {most_commands} commands held"
        );
        // A second's segments, a queue's, and one more of each for the
        // polls between.
        let queue = m.nodes.iter().map(|n| n.queue).max().unwrap();
        let bound = (1.0 / (chord / feed)) as usize + queue + 2;
        assert!(
            most <= bound,
            "{machine}: {most} segments kept of {} (bound {bound})",
            lb.run.segments_sent
        );
        assert!(lb.run.segments_sent >= moves as u64, "{machine}");
    }
}

/// `moves` chords of `chord` mm around a circle at `feed` mm/s.
fn circle(
    m: &Machine,
    centre: [f64; 2],
    radius: f64,
    moves: usize,
    chord: f64,
    feed: f64,
) -> Vec<Located<Command>> {
    let step = chord / radius;
    (0..moves)
        .map(|k| {
            let a = k as f64 * step;
            let mut target = m.start;
            target[0] = centre[0] + radius * a.cos();
            target[1] = centre[1] + radius * a.sin();
            Located {
                loc: motet_planner::SourceLoc {
                    line: k as u32 + 1,
                    column: 0,
                },
                item: Command::Move(motet_planner::Move {
                    target,
                    feed,
                    kind: motet_planner::MoveKind::Feed,
                }),
            }
        })
        .collect()
}

/// Commands handed to a run one at a time, as a job file read again is.
struct Listed(std::vec::IntoIter<Located<Command>>);

impl motet_net::CommandSource for Listed {
    fn next_command(&mut self) -> Option<Result<Located<Command>, String>> {
        self.0.next().map(Ok)
    }
}

/// Ten thousand moves of 0.02 mm asked for at 250 mm/s: a 64-segment queue
/// holds 1.3 mm, far less than the machine needs to stop from that speed.
/// The planner slows down (its stop horizon) so that every sealed window can
/// stop within the queue: the networked run finishes with no stop, no
/// underrun, and the simulator's steps.
#[test]
fn tiny_fast_moves_slow_down_instead_of_stopping_the_network() {
    let m = Machine::load(&root().join("examples/printer.toml")).unwrap();
    let r = 0.02 / 1e-4;
    let cmds: Vec<Located<Command>> = (1..=10_000)
        .map(|k| {
            let a = k as f64 * 1e-4;
            Located {
                loc: motet_planner::SourceLoc { line: k, column: 0 },
                item: Command::Move(motet_planner::Move {
                    target: [r * a.sin(), r * (1.0 - a.cos()), 0.0, 0.0, 0.0, 0.0],
                    feed: 250.0,
                    kind: motet_planner::MoveKind::Feed,
                }),
            }
        })
        .collect();
    let want = simulated(&m, &cmds);
    let mut lb = clean_loopback(&m, cmds);
    assert_eq!(lb.run_until_settled(3_600_000_000).unwrap(), Phase::Done);
    assert_eq!(executed(&m, &lb), want);
    assert_eq!(lb.nodes[0].node.endpoint.node().status().underruns, 0);
    // Every window held at most the queue.
    assert!(lb.run.segments_sent as f64 / lb.run.windows as f64 <= 64.0);
}

/// What every node's outputs did in a networked run equals the run replayed
/// in this process from its journal's header: the same steps, at the same
/// times, in the same order.
#[test]
fn each_node_tallies_what_the_replay_computes() {
    for (machine, job) in [
        ("examples/plotter.toml", "examples/jobs/drawing.svg"),
        ("examples/laser.toml", "examples/jobs/laser-badge.gcode"),
    ] {
        let (m, cmds) = load(machine, job);
        let n = m.nodes.len();
        let dir = tempfile::Builder::new()
            .prefix("motet-tally-")
            .tempdir()
            .unwrap();
        let jpath = dir.path().join(format!("journal-{}", m.name.len()));
        let mut lb = Loopback::with_journal(
            &m,
            cmds.clone(),
            m.start,
            clean_links(n),
            &clocks(n),
            NetConfig::default(),
            Some(motet_net::journal::JournalWriter::create(&jpath).unwrap()),
        );
        assert_eq!(lb.run_until_settled(3_600_000_000).unwrap(), Phase::Done);
        let got: Vec<_> = lb.run.tallies().into_iter().map(Option::unwrap).collect();
        let journal = motet_net::journal::Journal::load(&jpath).unwrap();
        let header = journal.header.unwrap();
        let journaled = (&journal.paces[..], &journal.holds[..]);
        let want = motet_net::replay::replay(&m, cmds, &header, journaled).unwrap();
        assert_eq!(got, want, "{machine} {job}");
        assert!(got.iter().any(|t| t.steps.iter().sum::<u32>() > 1000));
    }
}

/// A job that cannot be read further while it runs (its file changed or
/// went between the check and the run): the machine stops on the path, as
/// for a node's trouble, the reason naming where the reading failed.
#[test]
fn a_job_that_fails_to_read_mid_run_stops_the_machine_on_the_path() {
    let m = Machine::load(&root().join("examples/printer.toml")).unwrap();
    let cmds = circle(&m, [110.0, 110.0], 80.0, 2000, 2.0, 150.0);
    let mut lb = clean_loopback(&m, Vec::new());
    struct Failing(std::vec::IntoIter<Located<Command>>);
    impl motet_net::CommandSource for Failing {
        fn next_command(&mut self) -> Option<Result<Located<Command>, String>> {
            Some(
                self.0
                    .next()
                    .ok_or_else(|| "job.gcode:801: gone".to_string()),
            )
        }
    }
    let first: Vec<_> = cmds.into_iter().take(800).collect();
    lb.run.reading(Box::new(Failing(first.into_iter())), 2000);
    let Phase::Stopped(info) = lb.run_until_settled(3_600_000_000).unwrap() else {
        panic!("the run must stop: {:?}", lb.run.phase())
    };
    assert!(
        info.reason.contains("job.gcode:801: gone"),
        "{}",
        info.reason
    );
    assert!(info.next_command <= 800, "{info:?}");
    lb.host_alive = false;
    lb.run_until_settled(30_000_000).unwrap();
    let got: Vec<i64> = executed(&m, &lb).iter().map(|&(_, p)| p).collect();
    assert_eq!(got, steps_at(&m, &info.point), "{info:?}");
}
