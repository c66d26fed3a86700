//! What the live module watch costs and how fast it notices, on the
//! reconfigurable mill (examples/modules) running its job on one simulated
//! CAN-FD bus: for a module removed, replaced by a shorter rail, a second X
//! module plugged in and a sensor plugged in, the simulated time from the
//! change to the watch's report and, when the run stops, to the machine at
//! rest; and the bytes the watch adds on the bus per second while nothing
//! changes.
//!
//! `cargo run --release -p motet-net --example module_watch`

use motet_host::module::{
    compose, load_description, machine_toml, Expected, JobNeeds, ModuleAt, Place,
};
use motet_host::Machine;
use motet_link::{CanTransport, Crystal};
use motet_net::loopback::{Loopback, BUS_NODE_ID};
use motet_net::modules::{watch_run, ModuleWatch, WatchConfig, WatchReport};
use motet_net::sim_node::{sim_config, SimNode};
use motet_net::{NetConfig, Phase};
use motet_node::storage::{Persisted, RamStore};
use motet_planner::{Command, Located};
use motet_wire::describe::Description;
use std::path::{Path, PathBuf};

const NODES: [&str; 5] = ["a", "spindle", "x", "y", "z"];
const ORDER: [&str; 5] = ["spindle", "z", "y", "x", "a"];
/// When the change comes, µs of host time (the job is cutting).
const CHANGE_AT: u64 = 4_000_000;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn desc(name: &str) -> Description {
    load_description(&root().join(format!("examples/modules/{name}.toml"))).expect("an example")
}

fn mill() -> (Machine, Vec<Located<Command>>) {
    let uid = |n: &str| 0x5157_0000 + NODES.iter().position(|x| *x == n).unwrap() as u64;
    let modules: Vec<ModuleAt> = ORDER
        .iter()
        .map(|n| ModuleAt {
            uid: uid(n),
            firmware: None,
            description: desc(n),
        })
        .collect();
    let text = machine_toml(&compose(&modules), "mill");
    let m = Machine::parse(&text, Path::new("mill.toml")).expect("the mill");
    let job = motet_api::load_job(
        &m,
        &root().join("examples/jobs/mill-4axis.gcode"),
        &motet_api::JobOptions::default(),
    )
    .expect("the mill's job");
    (m, job.commands)
}

enum Change {
    Nothing,
    Remove(&'static str),
    Replace(&'static str, &'static str),
    Plug(Box<Description>),
}

struct Outcome {
    report: Option<(u64, WatchReport)>,
    phase: Phase,
    bytes: u64,
    seconds: f64,
}

fn run(change: Change, watched: bool) -> Outcome {
    let (m, cmds) = mill();
    let cfg = NetConfig {
        max_move_us: 250_000,
        ..NetConfig::default()
    };
    let clocks: Vec<Crystal> = (0..5).map(|_| Crystal::default()).collect();
    let mut lb = Loopback::on_bus(&m, cmds.clone(), m.start, &clocks, cfg, None);
    for (k, n) in NODES.iter().enumerate() {
        lb.nodes[k].node.endpoint.set_description(desc(n));
    }
    let expected = m
        .modules
        .iter()
        .map(|r| Expected {
            record: r.clone(),
            place: Place {
                link: "can".into(),
                address: 2 + NODES.iter().position(|n| *n == r.node).unwrap() as u16,
            },
        })
        .collect();
    let mut needs = JobNeeds::default();
    for c in &cmds {
        needs.take(&m, c);
    }
    let mut watch = ModuleWatch::new(expected, Some(needs), WatchConfig::default());
    let links = vec!["can".to_string(); 5];
    let mut plugged: Vec<SimNode<RamStore>> = Vec::new();
    let mut change = Some(change);
    let mut report = None;
    let end = 120_000_000;
    while lb.now < end {
        lb.step().expect("a loopback step");
        for n in &mut plugged {
            n.step(lb.now);
        }
        if lb.now >= CHANGE_AT {
            let plug = |lb: &Loopback, d: Description, uid: u64, address: u16| {
                let bus = lb.bus.as_ref().expect("a bus");
                let t = CanTransport::with_clock(
                    bus.attach(BUS_NODE_ID + 0x40, false).expect("an id"),
                    None,
                    Crystal::default(),
                );
                let cfg = sim_config("stepper", uid).expect("a kind");
                let store = RamStore {
                    record: (address != 0).then_some(Persisted {
                        uid,
                        address,
                        firmware: cfg.firmware,
                    }),
                    saves: 0,
                };
                let mut n = SimNode::new(cfg, store, Box::new(t), lb.now);
                n.endpoint.set_description(d);
                n.endpoint.announce();
                n
            };
            match change.take() {
                Some(Change::Remove(n)) => {
                    lb.nodes[NODES.iter().position(|x| *x == n).unwrap()].alive = false
                }
                Some(Change::Replace(n, with)) => {
                    let k = NODES.iter().position(|x| *x == n).unwrap();
                    lb.nodes[k].alive = false;
                    plugged.push(plug(&lb, desc(with), 0xfeed, 2 + k as u16));
                }
                Some(Change::Plug(d)) => plugged.push(plug(&lb, *d, 0xbeef, 0)),
                _ => {}
            }
        }
        if watched {
            let medium = lb.medium.clone();
            if let Some(r) = watch_run(&mut watch, &mut lb.run, &links, medium.as_ref(), lb.now) {
                report.get_or_insert((lb.now, r));
            }
        }
        if matches!(lb.run.phase(), Phase::Done | Phase::Stopped(_)) {
            break;
        }
    }
    let bytes = lb
        .run
        .figures(lb.now)
        .iter()
        .map(|f| f.bytes_out + f.bytes_in)
        .sum();
    Outcome {
        report,
        phase: lb.run.phase().clone(),
        bytes,
        seconds: lb.now as f64 * 1e-6,
    }
}

fn main() {
    let quiet = run(Change::Nothing, false);
    let watched = run(Change::Nothing, true);
    println!(
        "the mill's whole job on one bus ({:.1} s): {:.0} B/s without the watch, {:.0} B/s with it (+{:.0} B/s: a probe every 150 ms and five heads back)",
        watched.seconds,
        quiet.bytes as f64 / quiet.seconds,
        watched.bytes as f64 / watched.seconds,
        (watched.bytes as f64 / watched.seconds) - (quiet.bytes as f64 / quiet.seconds)
    );
    let mut x2 = desc("x-short");
    x2.identity.name = "x2".try_into().expect("a short name");
    let probe = motet_host::module::parse_description(
        "kind = \"sensor\"\nname = \"probe\"\n[[channels]]\ndrives = \"probe\"\nsensor = { quantity = \"force\", unit = \"N\", rate_hz = 100 }\n",
        "probe.toml",
    )
    .expect("a sensor");
    for (what, change) in [
        ("module a removed", Change::Remove("a")),
        (
            "x replaced by the short rail",
            Change::Replace("x", "x-short"),
        ),
        ("a second X module plugged in", Change::Plug(Box::new(x2))),
        ("a sensor plugged in", Change::Plug(Box::new(probe))),
    ] {
        let o = run(change, true);
        let Some((at, r)) = &o.report else {
            println!("{what}: not noticed");
            continue;
        };
        let rest = match &o.phase {
            Phase::Stopped(s) => format!(
                "stopped on the committed window's tail: braking {:.3} s after the change, at rest {:.3} s after it",
                (s.braking_at - CHANGE_AT as f64) * 1e-6,
                (s.rest_time - CHANGE_AT as f64) * 1e-6
            ),
            p => format!("{p:?} (the job went on)"),
        };
        println!(
            "{what}: noticed {:.1} ms after the change ({}), {rest}",
            (at - CHANGE_AT) as f64 * 1e-3,
            if r.stop {
                "the machine no longer fits the job"
            } else {
                "still viable"
            }
        );
    }
}
