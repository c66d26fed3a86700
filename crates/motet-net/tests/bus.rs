//! Three nodes and the host on one simulated CAN-FD bus: seals and stops
//! go to every node in one frame, so whatever stops the run (the host
//! killed, one node's link cut, one node killed), every surviving node
//! rests at the same committed point, and resuming finishes the job.

mod common;

use common::*;
use motet_host::Machine;
use motet_link::Transport;
use motet_net::digest::Digest;
use motet_net::journal::{Journal, JournalWriter};
use motet_net::loopback::Loopback;
use motet_net::resume::{prove, Evidence, Resumption};
use motet_net::run_record::RunRecord;
use motet_net::{NetConfig, Phase, RunIdentity};
use motet_planner::{Command, Located};
use motet_wire::frame::{self, Flags, Header, BROADCAST, MAX_FRAME};
use motet_wire::group::{GroupError, GroupMessage, Member};
use motet_wire::service::port;
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;
use tempfile::TempDir;

const MACHINE: &str = "examples/gestalt-3axis.toml";
const JOB: &str = "examples/jobs/gestalt-3d.gcode";

/// A run on the bus with its journal and record, as `motet resume` reads them.
struct BusRun {
    m: Machine,
    cmds: Vec<Located<Command>>,
    machine_text: String,
    job_bytes: Vec<u8>,
    record: RunRecord,
    lb: Loopback,
    journal: std::path::PathBuf,
    _dir: TempDir,
}

impl BusRun {
    fn start() -> BusRun {
        BusRun::start_with(NetConfig::default())
    }

    fn start_with(cfg: NetConfig) -> BusRun {
        let (m, cmds) = load(MACHINE, JOB);
        let machine_text = std::fs::read_to_string(root().join(MACHINE)).unwrap();
        let job_bytes = motet_api::job::read_bytes(&root().join(JOB)).unwrap();
        let identity =
            RunIdentity::new(Digest::of(machine_text.as_bytes()), Digest::of(&job_bytes));
        let dir = tempfile::Builder::new()
            .prefix("motet-bus-")
            .tempdir()
            .unwrap();
        let journal = dir.path().join("journal");
        let mut lb = Loopback::on_bus(
            &m,
            cmds.clone(),
            m.start,
            &clocks(m.nodes.len()),
            cfg,
            Some(JournalWriter::create(&journal).unwrap()),
        );
        lb.run.set_identity(identity);
        let record = loopback_record(&m, root().join(MACHINE), root().join(JOB), identity, "can");
        BusRun {
            m,
            cmds,
            machine_text,
            job_bytes,
            record,
            lb,
            journal,
            _dir: dir,
        }
    }

    /// Streams until `t` µs of host time.
    fn until(&mut self, t: u64) {
        while self.lb.now < t {
            self.lb.step().unwrap();
        }
        assert_eq!(self.lb.run.phase(), &Phase::Streaming, "still streaming");
    }

    fn journal(&self) -> Journal {
        Journal::parse(&std::fs::read_to_string(&self.journal).unwrap(), "journal").unwrap()
    }

    fn prove(&self, assumed: Option<&[(usize, f64)]>) -> Resumption {
        let j = self.journal();
        prove(
            &Evidence {
                machine: &self.m,
                machine_sha256: Digest::of(self.machine_text.as_bytes()),
                job: &self.cmds,
                job_sha256: Digest::of(&self.job_bytes),
                record: &self.record,
                journal: &j,
                journal_path: "journal",
                nodes: &self.lb.seen(),
            },
            assumed,
        )
        .unwrap()
    }

    /// The nodes run on by themselves until every one is at rest.
    fn settle_nodes(&mut self) {
        self.lb.host_alive = false;
        self.lb.run_until_settled(30_000_000).unwrap();
    }

    /// Every node in `alive` rests stopped on the same committed end, on
    /// the end point of that end's segment as the journal has it: the
    /// committed end.
    fn same_rest(&self, alive: &[usize]) -> u32 {
        let w = node_windows(&self.lb);
        let end = w[alive[0]].0;
        for &k in alive {
            assert_eq!(w[k], (end, true), "node {k}: {w:?}");
            assert_eq!(
                self.lb.nodes[k].node.endpoint.node().queued(),
                0,
                "node {k} at rest"
            );
        }
        let rest = self.journal().segment(end - 1).unwrap().end;
        let want = steps_at(&self.m, &rest);
        let got = executed(&self.m, &self.lb);
        for &k in alive {
            for &a in &self.m.nodes[k].actuators {
                assert_eq!(got[a].1, want[a], "node {k} actuator {a}: not at {rest:?}");
            }
        }
        end
    }

    /// Resumes from what the nodes and the journal say, to the job's end.
    fn finish(&mut self, r: &Resumption) {
        let identity = RunIdentity::new(self.record.machine_sha256, self.record.job_sha256);
        self.lb.restart_host(
            &self.m,
            r.commands.clone(),
            r.from,
            NetConfig::default(),
            None,
        );
        self.lb.run.set_identity(identity);
        let phase = self.lb.run_until_settled(3_600_000_000).unwrap();
        assert_eq!(phase, Phase::Done, "resumed run");
        let want: Vec<i64> = simulated(&self.m, &self.cmds)
            .iter()
            .map(|&(_, p)| p)
            .collect();
        let got: Vec<i64> = executed(&self.m, &self.lb)
            .iter()
            .map(|&(_, p)| p)
            .collect();
        assert_eq!(got, want, "the job ends where it should");
    }
}

#[test]
fn a_clean_run_on_the_bus_steps_like_the_simulator() {
    let mut b = BusRun::start();
    let phase = b.lb.run_until_settled(3_600_000_000).unwrap();
    assert_eq!(phase, Phase::Done);
    let want = simulated(&b.m, &b.cmds);
    assert_eq!(executed(&b.m, &b.lb), want);
    assert!(b.lb.run.windows > 3, "{} windows", b.lb.run.windows);
    for n in &b.lb.nodes {
        let s = n.node.endpoint.stats();
        assert_eq!((s.group_refused, s.silent), (0, None));
    }
}

#[test]
fn host_killed_every_node_rests_on_the_last_seal_and_resume_finishes() {
    // With windows 3 s long the nodes hear the host fall silent before
    // their committed windows end; with the default ones they may reach
    // their tails first. Either way no message stopped them.
    let long = NetConfig {
        window_us: 3_000_000,
        ..NetConfig::default()
    };
    let cases = [
        (NetConfig::default(), 6_000_000u64, None),
        (NetConfig::default(), 9_300_000, None),
        (long, 6_000_000, Some(1)),
    ];
    for (cfg, kill_at, heard) in cases {
        let mut b = BusRun::start_with(cfg);
        b.until(kill_at);
        if heard.is_some() {
            // Killed just after a seal: seconds of motion committed.
            let sealed = node_windows(&b.lb)[1].0;
            while node_windows(&b.lb)[1].0 == sealed {
                b.lb.step().unwrap();
            }
        }
        b.settle_nodes();
        let end = b.same_rest(&[0, 1, 2]);
        for n in &b.lb.nodes {
            let silent = n.node.endpoint.stats().silent;
            match heard {
                Some(host) => assert_eq!(silent, Some(host), "kill at {kill_at}"),
                None => assert!(
                    matches!(silent, None | Some(1)),
                    "kill at {kill_at}: {silent:?}"
                ),
            }
        }
        let r = b.prove(None);
        assert_eq!(r.window_end, end);
        assert!(r.assumed.is_empty(), "{r:?}");
        b.finish(&r);
    }
}

#[test]
fn one_link_cut_every_node_rests_on_one_committed_point() {
    let mut b = BusRun::start();
    b.until(9_000_000);
    // Node 1 neither hears nor is heard, and keeps running.
    let mut cable = std::mem::replace(
        &mut b.lb.nodes[1].node.transport,
        Box::new(motet_link::pair("x", "y").0),
    );
    let Phase::Stopped(info) = b.lb.run_until_settled(60_000_000).unwrap() else {
        panic!("the run must stop")
    };
    assert_eq!(
        info.lost.iter().map(|l| l.name.clone()).collect::<Vec<_>>(),
        vec![b.m.nodes[1].name.clone()],
        "{info:?}"
    );
    assert!(info.reason.contains("y_node"), "{}", info.reason);
    b.settle_nodes();
    let end = b.same_rest(&[0, 1, 2]);
    let mut confirmed = info.confirmed.clone();
    confirmed.sort();
    assert_eq!(confirmed, vec![(0, end), (2, end)], "{info:?}");
    // The cable back: what went by while it was out is gone.
    while cable.recv(None).unwrap().is_some() {}
    b.lb.nodes[1].node.transport = cable;
    let r = b.prove(None);
    assert_eq!(r.window_end, end);
    assert!(r.assumed.is_empty(), "{r:?}");
    b.finish(&r);
}

#[test]
fn one_node_killed_the_others_rest_on_one_committed_point() {
    let mut b = BusRun::start();
    b.until(9_000_000);
    b.lb.nodes[1].alive = false;
    let Phase::Stopped(info) = b.lb.run_until_settled(60_000_000).unwrap() else {
        panic!("the run must stop")
    };
    assert_eq!(
        info.lost.iter().map(|l| l.node).collect::<Vec<_>>(),
        vec![1],
        "{info:?}"
    );
    assert!(info.reason.contains("y_node"), "{}", info.reason);
    b.settle_nodes();
    let end = b.same_rest(&[0, 2]);
    let mut confirmed = info.confirmed.clone();
    confirmed.sort();
    assert_eq!(confirmed, vec![(0, end), (2, end)], "{info:?}");
    // Back, it holds no run: the person says where its axis is.
    b.lb.restart_node(1);
    let y = b.m.axes.iter().position(|a| a.name == "y").unwrap();
    let a = b.m.nodes[1].actuators[0];
    let at = b.lb.nodes[1].node.board.position[0] as f64 / b.m.actuators[a].steps_per_unit;
    let r = b.prove(Some(&[(y, at)]));
    b.finish(&r);
}

/// Windows seconds apart: a node killed between two seals is noticed by the
/// others from its silence, long before the host's next seal, and each
/// brakes on the committed tail by itself, all on the same one.
#[test]
fn the_others_hear_a_node_fall_silent_and_brake_on_the_same_tail() {
    let cfg = NetConfig {
        window_us: 3_000_000,
        ..NetConfig::default()
    };
    let mut b = BusRun::start_with(cfg);
    b.until(6_000_000);
    // Killed just after a seal, so the next one is seconds away.
    let sealed = node_windows(&b.lb)[1].0;
    while node_windows(&b.lb)[1].0 == sealed {
        b.lb.step().unwrap();
    }
    b.lb.nodes[1].alive = false;
    let Phase::Stopped(info) = b.lb.run_until_settled(60_000_000).unwrap() else {
        panic!("the run must stop")
    };
    assert_eq!(
        info.lost.iter().map(|l| l.node).collect::<Vec<_>>(),
        vec![1]
    );
    b.settle_nodes();
    b.same_rest(&[0, 2]);
    for k in [0, 2] {
        assert_eq!(
            b.lb.nodes[k].node.endpoint.stats().silent,
            Some(3),
            "node {k}"
        );
    }
}

/// A group seal from a node's address (or any but the host's) is refused by
/// every node, named and counted; the run goes on as if it never came.
#[test]
fn a_seal_from_the_wrong_address_is_refused_and_changes_nothing() {
    let mut b = BusRun::start();
    b.until(6_000_000);
    let bus = b.lb.bus.clone().unwrap();
    let mut forger = motet_link::CanTransport::new(bus.attach(0x7F0, false).unwrap(), None);
    let committed: Vec<u32> = node_windows(&b.lb).iter().map(|w| w.0).collect();
    // Node 3 (machine node 1's neighbour) "seals" far ahead for everyone.
    let msg = GroupMessage::Seal {
        run: b.lb.run.identity().run,
        window: 99,
        members: (0..3)
            .map(|k| Member {
                address: 2 + k,
                next_seq: committed[k as usize] + 50,
            })
            .collect(),
    };
    let mut buf = [0u8; 192];
    let payload = motet_wire::encode(&msg, &mut buf).unwrap();
    let h = Header {
        dst: BROADCAST,
        src: 3,
        port: port::GROUP,
        flags: Flags::NONE,
        seq: 0,
        ack: 0,
    };
    let mut out = [0u8; MAX_FRAME];
    let n = frame::encode(&h, payload, &mut out).unwrap();
    forger.send(&out[..n]).unwrap();
    b.lb.step().unwrap();
    for (k, n) in b.lb.nodes.iter().enumerate() {
        let s = n.node.endpoint.stats();
        // Node 3 does not hear its own address from another sender as itself.
        assert_eq!(s.group_refused, 1, "node {k}");
        assert_eq!(
            s.last_group_refusal,
            Some((3, GroupError::NotFromHost { src: 3 }))
        );
        assert!(GroupError::NotFromHost { src: 3 }
            .to_string()
            .contains("from address 3"),);
    }
    let phase = b.lb.run_until_settled(3_600_000_000).unwrap();
    assert_eq!(phase, Phase::Done);
    assert_eq!(executed(&b.m, &b.lb), simulated(&b.m, &b.cmds));
}

/// Host time on node `k`'s clock right now, by its crystal, and the time
/// its clock model gives for it: the node's error, µs.
fn clock_error(lb: &Loopback, k: usize) -> Option<f64> {
    let n = &lb.nodes[k];
    let now = lb.now as f64;
    let local = n.offset_us as f64 + now * (1.0 + n.ppm * 1e-6);
    Some(n.node.endpoint.services().host_time(local)? - now)
}

/// One sync frame to every node: the host hears its own frame back at the
/// instant every node heard it, so each answer is an exact sample of that
/// node's clock (reference broadcast), and every node stays within 2 µs
/// of the host's time while the job streams, whatever its crystal and
/// however busy the bus.
#[test]
fn one_sync_frame_holds_every_node_within_2_us() {
    let mut b = BusRun::start();
    let mut worst = (0.0f64, 0);
    let mut next = 0;
    while !matches!(b.lb.run.phase(), Phase::Done | Phase::Stopped(_)) {
        b.lb.step().unwrap();
        if b.lb.run.phase() == &Phase::Streaming && b.lb.now >= next {
            next = b.lb.now + 10_000;
            for k in 0..b.lb.nodes.len() {
                let e = clock_error(&b.lb, k).expect("a clock model while streaming");
                if e.abs() > worst.0 {
                    worst = (e.abs(), b.lb.now);
                }
            }
        }
    }
    assert_eq!(b.lb.run.phase(), &Phase::Done);
    assert!(worst.0 <= 2.0, "{worst:?}");
    for p in b.lb.run.peers() {
        let (asked, answered) = p.exchanges;
        assert!(
            answered > 10 && answered <= asked,
            "{}: {:?}",
            p.name,
            p.exchanges
        );
        assert_eq!(
            p.references, answered,
            "{}: every answer a reference sample",
            p.name
        );
    }
    assert_eq!(executed(&b.m, &b.lb), simulated(&b.m, &b.cmds));
}

/// A clock exchange to every node as the frame `src` sends.
fn sync_frame(src: u16, t1: u64) -> Vec<u8> {
    let mut buf = [0u8; 64];
    let req = motet_wire::service::ServiceRequest::TimeGet { t1 };
    let payload = motet_wire::encode(&req, &mut buf).unwrap();
    let h = Header {
        dst: BROADCAST,
        src,
        port: port::TIME,
        flags: Flags::NONE,
        seq: 0,
        ack: 0,
    };
    let mut out = [0u8; MAX_FRAME];
    let n = frame::encode(&h, payload, &mut out).unwrap();
    out[..n].to_vec()
}

/// Sync frames someone else sends: from a node's address every node
/// refuses it and counts it; in the host's name (a node cannot tell) the
/// host takes no sample from the answers, since it never asked. Nobody's
/// clock moves and the job runs to its end.
#[test]
fn a_sync_frame_not_from_the_host_changes_no_clock() {
    let mut b = BusRun::start();
    b.until(6_000_000);
    let bus = b.lb.bus.clone().unwrap();
    let mut forger = motet_link::CanTransport::new(bus.attach(0x7F1, false).unwrap(), None);
    forger.send(&sync_frame(3, 0)).unwrap();
    forger.send(&sync_frame(1, b.lb.now - 3_000_000)).unwrap();
    let until = b.lb.now + 20_000;
    while b.lb.now < until {
        b.lb.step().unwrap();
    }
    for (k, n) in b.lb.nodes.iter().enumerate() {
        assert_eq!(n.node.endpoint.stats().sync_refused, 1, "node {k}");
    }
    for p in b.lb.run.peers() {
        assert_eq!(p.unasked, 1, "{}", p.name);
        assert_eq!(p.sync.fault(), None, "{}", p.name);
    }
    let phase = b.lb.run_until_settled(3_600_000_000).unwrap();
    assert_eq!(phase, Phase::Done);
    assert_eq!(executed(&b.m, &b.lb), simulated(&b.m, &b.cmds));
}

/// A node's cable that loses group seals: with `mode` 1 every one, with 2
/// the first, and from then on everything (the cable pulled just as that
/// seal went by, after the segments it seals had arrived).
struct Gate {
    inner: Box<dyn Transport + Send>,
    mode: u8,
    dropped: Arc<AtomicU8>,
    cut: bool,
}

impl Gate {
    fn is_group_seal(bytes: &[u8]) -> bool {
        let mut raw = [0u8; frame::MAX_RAW];
        let Ok(f) = frame::decode(bytes, &mut raw) else {
            return false;
        };
        let h = f.header;
        h.dst == BROADCAST
            && h.port == port::GROUP
            && matches!(
                motet_wire::decode::<GroupMessage>(f.payload),
                Ok(GroupMessage::Seal { .. })
            )
    }
}

impl Transport for Gate {
    fn name(&self) -> &str {
        "gate"
    }
    fn send(&mut self, frame: &[u8]) -> std::io::Result<()> {
        if self.cut {
            return Ok(());
        }
        self.inner.send(frame)
    }
    fn recv(&mut self, t: Option<std::time::Duration>) -> std::io::Result<Option<Vec<u8>>> {
        while let Some(f) = self.inner.recv(t)? {
            if self.cut {
                continue;
            }
            if self.mode > 0 && Gate::is_group_seal(&f) {
                self.dropped.fetch_add(1, Ordering::Relaxed);
                self.cut = self.mode == 2;
                continue;
            }
            return Ok(Some(f));
        }
        Ok(None)
    }
    fn stats(&self) -> &motet_link::LinkStats {
        self.inner.stats()
    }
    fn last_stamp(&self) -> Option<motet_link::Stamp> {
        self.inner.last_stamp()
    }
}

/// Puts node 1 behind a [`Gate`] in `mode`; returns its count of seals lost.
fn gate(b: &mut BusRun, mode: u8) -> Arc<AtomicU8> {
    let dropped = Arc::new(AtomicU8::new(0));
    let inner = std::mem::replace(
        &mut b.lb.nodes[1].node.transport,
        Box::new(motet_link::pair("x", "y").0),
    );
    b.lb.nodes[1].node.transport = Box::new(Gate {
        inner,
        mode,
        dropped: dropped.clone(),
        cut: false,
    });
    dropped
}

/// A node that misses every group seal gets each again through its own
/// link, in time: the job runs to its end as if nothing were lost.
#[test]
fn a_node_that_misses_the_seal_frames_is_repaired_through_its_link() {
    let mut b = BusRun::start();
    let dropped = gate(&mut b, 1);
    let phase = b.lb.run_until_settled(3_600_000_000).unwrap();
    assert_eq!(phase, Phase::Done);
    assert!(dropped.load(Ordering::Relaxed) >= 2, "seals lost");
    assert_eq!(executed(&b.m, &b.lb), simulated(&b.m, &b.cmds));
}

/// The other nodes took a seal one node never got (its cable pulled just
/// then): the host takes that window back from them before the tail
/// before it starts, and all three brake on that tail.
#[test]
fn a_window_one_node_missed_is_taken_back_from_the_others() {
    let mut b = BusRun::start();
    b.until(6_000_000);
    let dropped = gate(&mut b, 2);
    let Phase::Stopped(info) = b.lb.run_until_settled(60_000_000).unwrap() else {
        panic!("the run must stop")
    };
    assert_eq!(dropped.load(Ordering::Relaxed), 1);
    assert!(info.reason.contains("did not confirm"), "{}", info.reason);
    assert_eq!(b.lb.run.windows_taken_back(), 1, "{info:?}");
    b.settle_nodes();
    let end = b.same_rest(&[0, 1, 2]);
    assert_eq!(end, info.window_end, "{info:?}");
    // The journal has the window taken back: its last seal is beyond.
    assert!(b.journal().committed() > end);
    let r = b.prove(None);
    assert_eq!(r.window_end, end);
    // The cable back for the resumed run.
    let bus = b.lb.bus.clone().unwrap();
    let node = bus.attach(0x1F0, false).unwrap();
    // Its controller stamps frames in the node's own clock.
    let crystal = b.lb.nodes[1].crystal();
    b.lb.nodes[1].node.transport =
        Box::new(motet_link::CanTransport::with_clock(node, None, crystal));
    b.finish(&r);
}
