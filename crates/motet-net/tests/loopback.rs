//! Jobs streamed over the network to simulated nodes on a simulated clock:
//! the executed steps must equal those of the in-process simulator, whatever
//! the link does, and a stop must leave every axis at rest on the path.

use motet_host::Machine;
use motet_link::fault::{FaultClock, FaultConfig, Faulty, SimClock};
use motet_link::{pair, Transport};
use motet_net::loopback::{Loopback, NodeClock};
use motet_net::{NetConfig, Phase};
use motet_planner::{Command, Located};
use std::path::Path;

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

fn load(machine: &str, job: &str) -> (Machine, Vec<Located<Command>>) {
    let m = Machine::load(&root().join(machine)).unwrap();
    let j = motet_api::load_job(&m, &root().join(job), &motet_api::JobOptions::default()).unwrap();
    (m, j.commands)
}

/// (steps, net position) per actuator from the in-process simulator.
fn simulated(m: &Machine, cmds: &[Located<Command>]) -> Vec<(u64, i64)> {
    let r = motet_sim::simulate(m, "job", cmds, &mut |_, _| {}).unwrap();
    r.report
        .actuators
        .iter()
        .map(|a| (a.steps, a.position))
        .collect()
}

/// (steps, net position) per actuator from the loopback nodes' boards.
fn executed(m: &Machine, lb: &Loopback) -> Vec<(u64, i64)> {
    let mut out = vec![(0, 0); m.actuators.len()];
    for (k, spec) in m.nodes.iter().enumerate() {
        let b = &lb.nodes[k].node.board;
        for (ch, &a) in spec.actuators.iter().enumerate() {
            out[a] = (b.steps[ch], b.position[ch]);
        }
    }
    out
}

type Links = Vec<(Box<dyn Transport + Send>, Box<dyn Transport + Send>)>;

fn clean_links(n: usize) -> Links {
    (0..n)
        .map(|k| {
            let (a, b) = pair(&format!("host{k}"), &format!("node{k}"));
            (
                Box::new(a) as Box<dyn Transport + Send>,
                Box::new(b) as Box<dyn Transport + Send>,
            )
        })
        .collect()
}

fn faulty_links(n: usize, clock: &SimClock, p: f64, seed: u64) -> Links {
    (0..n)
        .map(|k| {
            let (a, b) = pair(&format!("host{k}"), &format!("node{k}"));
            let cfg = |s| FaultConfig::all(seed * 100 + s, p);
            let a = Faulty::with_clock(a, cfg(2 * k as u64), FaultClock::Simulated(clock.clone()));
            let b = Faulty::with_clock(
                b,
                cfg(2 * k as u64 + 1),
                FaultClock::Simulated(clock.clone()),
            );
            (
                Box::new(a) as Box<dyn Transport + Send>,
                Box::new(b) as Box<dyn Transport + Send>,
            )
        })
        .collect()
}

fn clocks(n: usize) -> Vec<NodeClock> {
    // Crystals off by up to ±200 ppm, clocks started anywhere.
    (0..n)
        .map(|k| NodeClock {
            ppm: if k % 2 == 0 { 200.0 } else { -150.0 },
            offset_us: 123_456_789 * (k as u64 + 1),
        })
        .collect()
}

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
        let n = m.nodes.len();
        let mut lb = Loopback::new(
            &m,
            cmds,
            m.start,
            clean_links(n),
            &clocks(n),
            NetConfig::default(),
        );
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
}

/// Step position of every actuator with the machine at rest at `p`.
fn steps_at(m: &Machine, p: &motet_trajectory::Point) -> Vec<i64> {
    m.actuators
        .iter()
        .map(|a| {
            let v = m.joints[a.joint].map.value(p, 0.0) * a.steps_per_unit;
            // The half-step rule: halves round away from zero.
            if v >= 0.0 {
                (v + 0.5) as i64
            } else {
                (v - 0.5) as i64
            }
        })
        .collect()
}

/// The job's end on every node after a stop: (committed window end of each
/// node, stopped flags).
fn node_windows(lb: &Loopback) -> Vec<(u32, bool)> {
    lb.nodes
        .iter()
        .map(|n| {
            let s = n.node.endpoint.node().status();
            (s.committed, s.stopped)
        })
        .collect()
}

#[test]
fn host_killed_mid_move_every_node_stops_together_on_the_path_and_resume_finishes() {
    let (m, cmds) = load("examples/plotter.toml", "examples/jobs/drawing.svg");
    let want_end = simulated(&m, &cmds);
    let dir = std::env::temp_dir().join(format!("motet-loopback-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (case, kill_at) in [7_300_000u64, 15_000_000, 21_700_000]
        .into_iter()
        .enumerate()
    {
        let n = m.nodes.len();
        let jpath = dir.join(format!("journal{case}"));
        let j = motet_net::journal::JournalWriter::create(&jpath).unwrap();
        let mut lb = Loopback::with_journal(
            &m,
            cmds.clone(),
            m.start,
            clean_links(n),
            &clocks(n),
            NetConfig::default(),
            Some(j),
        );
        while lb.now < kill_at {
            lb.step().unwrap();
        }
        assert_eq!(
            lb.run.phase(),
            &Phase::Streaming,
            "kill at {kill_at}: the job must still be running"
        );
        // Moving when the host dies.
        let moving = lb.nodes.iter().any(|n| n.node.endpoint.node().queued() > 0);
        assert!(moving, "kill at {kill_at}");
        let committed: Vec<(u32, motet_trajectory::Segment)> =
            lb.run.committed().map(|(i, s)| (i, *s)).collect();
        lb.host_alive = false;
        lb.run_until_settled(60_000_000).unwrap();
        let w = node_windows(&lb);
        let end = w[0].0;
        assert!(
            w.iter().all(|&(c, stopped)| c == end && stopped),
            "kill at {kill_at}: {w:?}"
        );
        let last = committed
            .iter()
            .find(|(i, _)| *i + 1 == end)
            .expect("window end committed")
            .1;
        let rest = executed(&m, &lb)
            .iter()
            .map(|&(_, p)| p)
            .collect::<Vec<_>>();
        assert_eq!(
            rest,
            steps_at(&m, &last.end),
            "kill at {kill_at}: at rest at the window's end point"
        );

        // `motet resume`: a new host finishes the job from there.
        let journal = motet_net::journal::Journal::load(&jpath).unwrap();
        let r = motet_net::resume::resume(&cmds, &journal, end, m.start).unwrap();
        assert_eq!(r.from, last.end);
        lb.restart_host(&m, r.commands, r.from, NetConfig::default(), None);
        let phase = lb.run_until_settled(3_600_000_000).unwrap();
        assert_eq!(phase, Phase::Done, "kill at {kill_at}: resumed run");
        let final_pos: Vec<i64> = executed(&m, &lb).iter().map(|&(_, p)| p).collect();
        let want_pos: Vec<i64> = want_end.iter().map(|&(_, p)| p).collect();
        assert_eq!(
            final_pos, want_pos,
            "kill at {kill_at}: the resumed job ends where the job ends"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_node_that_stops_answering_stops_the_others_with_it() {
    let (m, cmds) = load(
        "examples/gestalt-3axis.toml",
        "examples/jobs/gestalt-3d.gcode",
    );
    let n = m.nodes.len();
    let mut lb = Loopback::new(
        &m,
        cmds,
        m.start,
        clean_links(n),
        &clocks(n),
        NetConfig::default(),
    );
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
    assert_eq!(lb.run.position_at(info.rest_time + 1e6), info.point);
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
fn the_host_knows_where_the_machine_was_at_any_time() {
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
        &[NodeClock::default(); 3],
        NetConfig::default(),
    );
    assert_eq!(lb.run_until_settled(3_600_000_000).unwrap(), Phase::Done);
    let end = lb.run.committed_end();
    for k in 1..40 {
        let t = end * k as f64 / 40.0;
        let want = steps_at(&m, &lb.run.position_at(t));
        for (node, spec) in m.nodes.iter().enumerate() {
            for (ch, &a) in spec.actuators.iter().enumerate() {
                let got = start[a] + traced_at(&lb, node, ch as u8, t);
                assert!(
                    (got - want[a]).abs() <= 1,
                    "t={t} actuator {a}: steps {got}, history says {}",
                    want[a]
                );
            }
        }
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
    let n = m.nodes.len();
    let mut lb = Loopback::new(
        &m,
        cmds,
        m.start,
        clean_links(n),
        &clocks(n),
        NetConfig::default(),
    );
    assert_eq!(lb.run_until_settled(3_600_000_000).unwrap(), Phase::Done);
    assert_eq!(executed(&m, &lb), want);
    assert_eq!(lb.nodes[0].node.endpoint.node().status().underruns, 0);
    // Every window held at most the queue.
    assert!(lb.run.segments_sent as f64 / lb.run.windows as f64 <= 64.0);
}
