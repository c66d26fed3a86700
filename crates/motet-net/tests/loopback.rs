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
