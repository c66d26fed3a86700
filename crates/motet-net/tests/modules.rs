//! Live reconfiguration on one simulated CAN-FD bus: the reconfigurable
//! mill's five modules run its job while a module is removed, replaced or
//! plugged in. The watch notices each change, re-derives the machine and
//! re-checks it and the job; a machine no longer fit for the job stops on
//! its contingency tail, every surviving node at rest on the same committed
//! point with its tool off, and the report names exactly what changed; a
//! sensor plugged in changes nothing and the job finishes.

mod common;

use common::*;
use motet_host::module::{compose, load_description, machine_toml, Expected, ModuleAt, Place};
use motet_host::Machine;
use motet_link::{CanTransport, Crystal};
use motet_net::loopback::{Loopback, BUS_NODE_ID};
use motet_net::modules::{watch_run, ModuleWatch, WatchConfig, WatchReport};
use motet_net::sim_node::{sim_config, SimNode};
use motet_net::{NetConfig, Phase};
use motet_node::storage::{Persisted, RamStore};
use motet_planner::{Command, Located};
use motet_wire::describe::Description;
use std::path::Path;

/// The modules, by node (the machine file's nodes are in name order).
const NODES: [&str; 5] = ["a", "spindle", "x", "y", "z"];
/// Tool to workpiece.
const ORDER: [&str; 5] = ["spindle", "z", "y", "x", "a"];
const LINK: &str = "can";

fn desc(name: &str) -> Description {
    load_description(&root().join(format!("examples/modules/{name}.toml")))
        .unwrap_or_else(|e| panic!("{e}"))
}

fn uid(node: &str) -> u64 {
    // The loopback's nodes: uid 0x5157_0000 + their index.
    0x5157_0000 + NODES.iter().position(|n| *n == node).unwrap() as u64
}

/// The mill, composed from its modules as `motet machine from-scan` does,
/// and its job.
fn mill() -> (Machine, Vec<Located<Command>>) {
    let modules: Vec<ModuleAt> = ORDER
        .iter()
        .map(|n| ModuleAt {
            uid: uid(n),
            firmware: None,
            description: desc(n),
        })
        .collect();
    let text = machine_toml(&compose(&modules), "mill");
    let m = Machine::parse(&text, Path::new("mill.toml")).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = m.nodes.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names, NODES);
    let j = motet_api::load_job(
        &m,
        &root().join("examples/jobs/mill-4axis.gcode"),
        &motet_api::JobOptions::default(),
    )
    .unwrap();
    (m, j.commands)
}

struct Mill {
    m: Machine,
    lb: Loopback,
    watch: ModuleWatch,
    links: Vec<String>,
    /// Modules plugged in during the run.
    plugged: Vec<SimNode<RamStore>>,
    reports: Vec<WatchReport>,
}

impl Mill {
    fn start() -> Mill {
        let (m, cmds) = mill();
        // Moves planned in pieces of at most 0.25 s: a stop brakes soon
        // after it is asked (a 12 s cut would otherwise brake over itself).
        let cfg = NetConfig {
            max_move_us: 250_000,
            ..NetConfig::default()
        };
        let mut lb = Loopback::on_bus(&m, cmds.clone(), m.start, &clocks(m.nodes.len()), cfg, None);
        for (k, n) in NODES.iter().enumerate() {
            lb.nodes[k].node.endpoint.set_description(desc(n));
        }
        let expected = m
            .modules
            .iter()
            .map(|r| Expected {
                record: r.clone(),
                place: Place {
                    link: LINK.into(),
                    address: 2 + NODES.iter().position(|n| *n == r.node).unwrap() as u16,
                },
            })
            .collect();
        let mut needs = motet_host::module::JobNeeds::default();
        for c in &cmds {
            needs.take(&m, c);
        }
        let watch = ModuleWatch::new(expected, Some(needs), WatchConfig::default());
        Mill {
            links: vec![LINK.to_string(); m.nodes.len()],
            m,
            lb,
            watch,
            plugged: Vec::new(),
            reports: Vec::new(),
        }
    }

    fn step(&mut self) {
        self.lb.step().unwrap();
        for n in &mut self.plugged {
            n.step(self.lb.now);
        }
        let medium = self.lb.medium.clone();
        if let Some(r) = watch_run(
            &mut self.watch,
            &mut self.lb.run,
            &self.links,
            medium.as_ref(),
            self.lb.now,
        ) {
            self.reports.push(r);
        }
    }

    /// Runs until `t` µs of host time, streaming.
    fn until(&mut self, t: u64) {
        while self.lb.now < t {
            self.step();
        }
        assert_eq!(self.lb.run.phase(), &Phase::Streaming, "{:?}", self.reports);
    }

    /// Runs until the run is done or stopped and every node at rest.
    fn settle(&mut self) -> Phase {
        let end = self.lb.now + 120_000_000;
        while self.lb.now < end {
            self.step();
            if matches!(self.lb.run.phase(), Phase::Done | Phase::Stopped(_)) {
                break;
            }
        }
        self.lb.run.phase().clone()
    }

    /// A module plugged into the bus at `address` (0: unpaired), which
    /// announces itself as it starts.
    fn plug(&mut self, d: Description, uid: u64, address: u16) {
        let bus = self.lb.bus.as_ref().unwrap();
        let id = BUS_NODE_ID + 0x40 + self.plugged.len() as u32;
        let t = CanTransport::with_clock(bus.attach(id, false).unwrap(), None, Crystal::default());
        let cfg = sim_config("stepper", uid).unwrap();
        let store = RamStore {
            record: (address != 0).then_some(Persisted {
                uid,
                address,
                firmware: cfg.firmware,
            }),
            saves: 0,
        };
        let mut node = SimNode::new(cfg, store, Box::new(t), self.lb.now);
        node.endpoint.set_description(d);
        node.endpoint.announce();
        self.plugged.push(node);
    }

    fn node(&self, name: &str) -> usize {
        NODES.iter().position(|n| *n == name).unwrap()
    }

    /// Every node but `gone` stopped on the same committed end, at rest at
    /// the stop's point (each motor's steps those of that point), every
    /// tool off.
    fn rests_on_the_tail(&self, gone: &[&str]) {
        let Phase::Stopped(info) = self.lb.run.phase() else {
            panic!("not stopped: {:?}", self.lb.run.phase())
        };
        // The nodes count steps from the start.
        let start = steps_at(&self.m, &self.m.start);
        let want: Vec<i64> = steps_at(&self.m, &info.point)
            .iter()
            .zip(&start)
            .map(|(p, s)| p - s)
            .collect();
        let got = executed(&self.m, &self.lb);
        for (k, spec) in self.m.nodes.iter().enumerate() {
            if gone.contains(&spec.name.as_str()) {
                continue;
            }
            let n = self.lb.nodes[k].node.endpoint.node();
            let s = n.status();
            if !spec.actuators.is_empty() {
                assert_eq!(
                    (s.committed, s.stopped, n.queued()),
                    (info.window_end, true, 0),
                    "node {}",
                    spec.name
                );
            }
            for &a in &spec.actuators {
                assert_eq!(got[a].1, want[a], "{}: not at {:?}", spec.name, info.point);
            }
            assert!(
                self.lb.nodes[k].node.board.tools.iter().all(|v| *v == 0.0),
                "{}: a tool still on",
                spec.name
            );
        }
        assert!(info.rest_time >= info.braking_at, "{info:?}");
    }

    fn report(&self) -> &WatchReport {
        self.reports.last().expect("a report")
    }
}

/// When the watch noticed, µs after `changed`, and what it said.
fn noticed(m: &Mill, changed: u64) -> (u64, String) {
    let r = m.report();
    (r.at_us - changed, r.text())
}

#[test]
fn a_module_removed_while_the_mill_runs_stops_it_on_its_tail() {
    let mut m = Mill::start();
    m.until(4_000_000);
    let changed = m.lb.now;
    let a = m.node("a");
    m.lb.nodes[a].alive = false;
    let phase = m.settle();
    let (after, text) = noticed(&m, changed);
    println!(
        "removed: noticed {after} µs after, {text}; settled at {} after",
        m.lb.now - changed
    );
    assert!(
        text.contains("a (uid 0000000051570000) is missing"),
        "{text}"
    );
    assert!(
        text.contains("moves a, which no module drives (the machine's axes: x, y, z)"),
        "{text}"
    );
    assert!(m.report().stop);
    // The run may have stopped first on its own (the node did not take its
    // segments): either way on the tail, and the watch says what changed.
    assert!(matches!(phase, Phase::Stopped(_)), "{phase:?}");
    assert_eq!(m.reports.len(), 1, "{:?}", m.reports);
    m.rests_on_the_tail(&["a"]);
}

#[test]
fn a_module_replaced_by_one_the_job_does_not_fit_stops_the_mill() {
    let mut m = Mill::start();
    m.until(4_000_000);
    let changed = m.lb.now;
    // The X module swapped for the short rail, at its address.
    let x = m.node("x");
    m.lb.nodes[x].alive = false;
    m.plug(desc("x-short"), 0xfeed, 2 + x as u16);
    m.settle();
    let (after, text) = noticed(&m, changed);
    println!("replaced: noticed {after} µs after, {text}");
    for want in [
        "x (uid 0000000051570002) was replaced by x (uid 000000000000feed) at address 4 on can",
        "x: limits.travel changed: [0, 400] → [0, 150]",
        "job 9:1: moves x to 200, beyond module x (uid 000000000000feed)'s travel [0, 150]",
    ] {
        assert!(text.contains(want), "{want}\n{text}");
    }
    m.rests_on_the_tail(&["x"]);
}

#[test]
fn a_second_module_on_one_axis_stops_the_mill() {
    let mut m = Mill::start();
    m.until(4_000_000);
    let changed = m.lb.now;
    let mut x2 = desc("x-short");
    x2.identity.name = "x2".try_into().unwrap();
    m.plug(x2, 0xbeef, 0);
    m.settle();
    let (after, text) = noticed(&m, changed);
    println!("added: noticed {after} µs after, {text}");
    assert!(
        text.contains("extra module x2 (stepper-axis, uid 000000000000beef) at address 0 on can"),
        "{text}"
    );
    assert!(
        text.contains(
            "modules x (uid 0000000051570002) and x2 (uid 000000000000beef) both drive x"
        ),
        "{text}"
    );
    m.rests_on_the_tail(&[]);
}

#[test]
fn a_sensor_plugged_in_changes_nothing_and_the_job_finishes() {
    let mut m = Mill::start();
    m.until(4_000_000);
    let probe = motet_host::module::parse_description(
        "kind = \"sensor\"\nname = \"probe\"\n[[channels]]\ndrives = \"probe\"\nsensor = { quantity = \"force\", unit = \"N\", rate_hz = 100 }\n",
        "probe.toml",
    )
    .unwrap();
    m.plug(probe, 0xabc, 0);
    assert_eq!(m.settle(), Phase::Done);
    assert_eq!(m.reports.len(), 1, "{:?}", m.reports);
    let r = m.report();
    assert!(!r.stop);
    assert_eq!(r.differences, ["extra module probe (sensor, uid 0000000000000abc) at address 0 on can: the machine file does not know it"]);
    assert!(
        r.text()
            .ends_with("the machine is still viable for the job"),
        "{}",
        r.text()
    );
    // And the job ran to its end, every step the simulator's (which counts
    // positions from 0, where the nodes count from the start).
    let (sim_m, cmds) = mill();
    let start = steps_at(&m.m, &m.m.start);
    let got: Vec<(u64, i64)> = executed(&m.m, &m.lb)
        .iter()
        .zip(&start)
        .map(|(&(steps, at), s)| (steps, at + s))
        .collect();
    assert_eq!(got, simulated(&sim_m, &cmds));
}
