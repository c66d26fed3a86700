//! What the network tests share: example machines and jobs, links, clocks,
//! and the steps the machine took.
#![allow(dead_code)]

use motet_host::Machine;
use motet_link::fault::{FaultClock, FaultConfig, Faulty, SimClock};
use motet_link::{pair, Transport};
use motet_net::loopback::{Crystal, Loopback};
use motet_planner::{Command, Located};
use std::path::Path;

pub fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

pub fn load(machine: &str, job: &str) -> (Machine, Vec<Located<Command>>) {
    let m = Machine::load(&root().join(machine)).unwrap();
    let j = motet_api::load_job(&m, &root().join(job), &motet_api::JobOptions::default()).unwrap();
    (m, j.commands)
}

/// (steps, net position) per actuator from the in-process simulator.
pub fn simulated(m: &Machine, cmds: &[Located<Command>]) -> Vec<(u64, i64)> {
    let r = motet_sim::simulate(m, "job", cmds, &mut |_, _| {}).unwrap();
    r.report
        .actuators
        .iter()
        .map(|a| (a.steps, a.position))
        .collect()
}

/// (steps, net position) per actuator from the loopback nodes' boards.
pub fn executed(m: &Machine, lb: &Loopback) -> Vec<(u64, i64)> {
    let mut out = vec![(0, 0); m.actuators.len()];
    for (k, spec) in m.nodes.iter().enumerate() {
        let b = &lb.nodes[k].node.board;
        for (ch, &a) in spec.actuators.iter().enumerate() {
            out[a] = (b.steps[ch], b.position[ch]);
        }
    }
    out
}

pub type Links = Vec<(Box<dyn Transport + Send>, Box<dyn Transport + Send>)>;

pub fn clean_links(n: usize) -> Links {
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

/// `n` links with up to `jitter_us` of delay on every frame, uniform and
/// independent, each way, on the simulated `clock`, for nodes whose
/// crystals [`clocks`] gives: clocks learnt slowly, each exchange telling
/// little.
pub fn jittered_links(n: usize, clock: &SimClock, jitter_us: u64) -> Links {
    (0..n)
        .map(|k| {
            let (a, b) = pair(&format!("host{k}"), &format!("node{k}"));
            let side = |t, seed: u64| {
                Faulty::with_clock(
                    t,
                    FaultConfig::jitter(seed, jitter_us),
                    FaultClock::Simulated(clock.clone()),
                )
            };
            (
                Box::new(side(a, 2 * k as u64).stamping(Crystal::default()))
                    as Box<dyn Transport + Send>,
                Box::new(side(b, 2 * k as u64 + 1).stamping(clocks(n)[k]))
                    as Box<dyn Transport + Send>,
            )
        })
        .collect()
}

/// `n` links with `p` of every fault, on the simulated `clock`, for nodes
/// whose crystals [`clocks`] gives.
pub fn faulty_links(n: usize, clock: &SimClock, p: f64, seed: u64) -> Links {
    (0..n)
        .map(|k| {
            let (a, b) = pair(&format!("host{k}"), &format!("node{k}"));
            let cfg = |s| FaultConfig::all(seed * 100 + s, p);
            // Each end stamps frames on arrival, in its own clock.
            let a = Faulty::with_clock(a, cfg(2 * k as u64), FaultClock::Simulated(clock.clone()))
                .stamping(Crystal::default());
            let b = Faulty::with_clock(
                b,
                cfg(2 * k as u64 + 1),
                FaultClock::Simulated(clock.clone()),
            )
            .stamping(clocks(n)[k]);
            (
                Box::new(a) as Box<dyn Transport + Send>,
                Box::new(b) as Box<dyn Transport + Send>,
            )
        })
        .collect()
}

/// A loopback run of `cmds` on `m` from its start, over clean links, its
/// nodes' crystals as [`clocks`] gives them, with the default settings.
pub fn clean_loopback(m: &Machine, cmds: Vec<Located<Command>>) -> Loopback {
    let n = m.nodes.len();
    Loopback::new(
        m,
        cmds,
        m.start,
        clean_links(n),
        &clocks(n),
        motet_net::NetConfig::default(),
    )
}

pub fn clocks(n: usize) -> Vec<Crystal> {
    // Crystals off by up to ±200 ppm, clocks started anywhere.
    (0..n)
        .map(|k| Crystal {
            ppm: if k % 2 == 0 { 200.0 } else { -150.0 },
            offset_us: 123_456_789 * (k as u64 + 1),
        })
        .collect()
}

/// Step position of every actuator with the machine at rest at `p`.
pub fn steps_at(m: &Machine, p: &motet_trajectory::Point) -> Vec<i64> {
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
pub fn node_windows(lb: &Loopback) -> Vec<(u32, bool)> {
    lb.nodes
        .iter()
        .map(|n| {
            let s = n.node.endpoint.node().status();
            (s.committed, s.stopped)
        })
        .collect()
}

/// The run record `motet run` writes, for a loopback run of `m` with
/// identity `identity`; node `k`'s link is named `{link}{k}`.
pub fn loopback_record(
    m: &Machine,
    machine: std::path::PathBuf,
    job: std::path::PathBuf,
    identity: motet_net::RunIdentity,
    link: &str,
) -> motet_net::run_record::RunRecord {
    motet_net::run_record::RunRecord {
        format: motet_net::run_record::RECORD_FORMAT,
        run: format!("{:08x}", identity.run),
        machine,
        machine_sha256: identity.machine,
        job,
        job_sha256: identity.job,
        allow_unknown: false,
        time_scale: 1.0,
        lead_ms: 100.0,
        sync_ms: 400.0,
        start_late_clocks: false,
        continues: None,
        nodes: m
            .nodes
            .iter()
            .enumerate()
            .map(|(k, spec)| motet_net::run_record::RunNode {
                name: spec.name.clone(),
                link: format!("{link}{k}"),
                address: 2 + k as u16,
                uid: motet_net::pairing_file::format_uid(0x5157_0000 + k as u64),
                firmware: motet_net::sim_node::sim_firmware().to_string(),
                pid: None,
            })
            .collect(),
    }
}
