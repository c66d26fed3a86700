//! Heaters a node drives, in a networked run (host and nodes in one
//! process, the nodes' heaters simulated on their boards): a wait (M109)
//! holds the trajectory at rest until the node reports the heater ready,
//! a piece at a time, each journaled; a host killed after the wait is
//! resumed with the plan proved identical, holds and all; a heater that
//! runs away stops the run on its tail with an error naming it.

mod common;

use common::*;
use motet_host::heater_loop::{HeaterFault, HeaterFaultKind};
use motet_host::Machine;
use motet_net::digest::Digest;
use motet_net::journal::{Journal, JournalWriter};
use motet_net::loopback::Loopback;
use motet_net::resume::{prove, Evidence};
use motet_net::{NetConfig, Phase, RunIdentity};

const MACHINE: &str = "examples/printer-heated.toml";
const JOB: &str = "examples/jobs/printer-heat-wait.gcode";

/// The job on `m` over clean links, journaled into `dir`.
fn started(m: &Machine, dir: &tempfile::TempDir, id: RunIdentity) -> Loopback {
    let (_, cmds) = load(MACHINE, JOB);
    let n = m.nodes.len();
    let mut lb = Loopback::with_journal(
        m,
        cmds,
        m.start,
        clean_links(n),
        &clocks(n),
        NetConfig::default(),
        Some(JournalWriter::create(&dir.path().join("journal")).unwrap()),
    );
    lb.run.set_identity(id);
    lb
}

fn identity() -> RunIdentity {
    let machine = std::fs::read(root().join(MACHINE)).unwrap();
    let job = std::fs::read(root().join(JOB)).unwrap();
    RunIdentity::new(Digest::of(&machine), Digest::of(&job))
}

#[test]
fn a_wait_holds_until_ready_and_resumes_on_the_same_plan() {
    let (m, cmds) = load(MACHINE, JOB);
    let dir = tempfile::tempdir().unwrap();
    let id = identity();
    let mut lb = started(&m, &dir, id);
    // Until the hold is over and the square is under way (a second after),
    // then the host dies.
    let mut waited = false;
    let mut over = None;
    while over.is_none_or(|t| lb.now < t + 1_000_000) {
        lb.step().unwrap();
        waited |= lb.run.waiting_for_heater();
        if waited && over.is_none() && !lb.run.waiting_for_heater() {
            over = Some(lb.now);
        }
        assert!(lb.now < 400_000_000, "no end to the wait");
        assert!(
            matches!(
                lb.run.phase(),
                Phase::Starting | Phase::Streaming | Phase::Draining
            ),
            "{:?}",
            lb.run.phase()
        );
    }
    let (pieces, held_s) = lb.run.heater_holds();
    lb.host_alive = false;
    lb.run_until_settled(60_000_000).unwrap();
    let text = std::fs::read_to_string(dir.path().join("journal")).unwrap();
    let j = Journal::parse(&text, "journal").unwrap();
    // Heating from the room takes over a minute: held in pieces, each
    // journaled.
    assert!(held_s > 60.0, "{held_s} s");
    assert_eq!(j.holds.len() as u64, pieces);
    let hold_segments: Vec<_> = j
        .segments
        .iter()
        .filter(|s| s.start == s.end && s.t1 - s.t0 > 0.0)
        .collect();
    assert!(hold_segments.len() as u64 >= pieces);
    // The first motion after the hold starts after the node's heater was
    // within its window for its residency: the hot end's reading then.
    let last_hold = j.holds.last().map(|h| h.command).unwrap();
    let after: Vec<_> = j
        .segments
        .iter()
        .filter(|s| s.command > last_hold && s.start != s.end)
        .collect();
    assert!(!after.is_empty(), "the square was under way");
    let h = m.heaters.iter().position(|h| h.name == "hotend").unwrap();
    let &(_, ready, _) = lb
        .run
        .heaters_ready()
        .iter()
        .find(|r| r.0 == h && r.2 == 200.0)
        .expect("the node said when it was ready");
    let moved = after[0].t0;
    assert!(
        moved >= ready && moved - ready < 2e6,
        "motion at {moved} µs, the heater ready at {ready} µs"
    );
    // Resume proves every journaled segment is the plan's, the holds
    // planned again at the same place, bit for bit.
    let record = loopback_record(&m, root().join(MACHINE), root().join(JOB), id, "mem");
    let machine_text = std::fs::read(root().join(MACHINE)).unwrap();
    let job_bytes = std::fs::read(root().join(JOB)).unwrap();
    let proved = prove(
        &Evidence {
            machine: &m,
            machine_sha256: Digest::of(&machine_text),
            job: &cmds,
            job_sha256: Digest::of(&job_bytes),
            record: &record,
            journal: &j,
            journal_path: "journal",
            nodes: &lb.seen(),
        },
        None,
    );
    assert!(proved.is_ok(), "{:?}", proved.err());
    // Without its holds the journal is not the plan: the proof depends on
    // them.
    let mut bare = j.clone();
    bare.holds.clear();
    let refused = prove(
        &Evidence {
            machine: &m,
            machine_sha256: Digest::of(&machine_text),
            job: &cmds,
            job_sha256: Digest::of(&job_bytes),
            record: &record,
            journal: &bare,
            journal_path: "journal",
            nodes: &lb.seen(),
        },
        None,
    );
    assert!(refused.is_err());
}

#[test]
fn a_heater_that_runs_away_stops_the_run_naming_it() {
    let mut m = Machine::load(&root().join(MACHINE)).unwrap();
    let h = m.heaters.iter().position(|h| h.name == "hotend").unwrap();
    m.heaters[h].node_loop.as_mut().unwrap().fault = Some(HeaterFault {
        kind: HeaterFaultKind::Disconnected,
        at_s: 30.0,
    });
    let dir = tempfile::tempdir().unwrap();
    let mut lb = started(&m, &dir, identity());
    let phase = lb.run_until_settled(200_000_000).unwrap();
    let Phase::Stopped(info) = phase else {
        panic!("ran on: {phase:?}");
    };
    let why = format!("{info:?}");
    assert!(
        why.contains("node mainboard: heater hotend: thermal runaway"),
        "{why}"
    );
    assert!(lb.nodes.iter().all(|n| n.node.endpoint.node().closed()));
}
