//! Resuming a stopped networked run: it resumes exactly when nothing
//! changed, and refuses, saying what differs, when the journal, the job, the
//! machine file or a node is not what the run left behind.

mod common;

use common::*;
use motet_host::Machine;
use motet_net::digest::Digest;
use motet_net::journal::{record_checksum, Journal, JournalWriter};
use motet_net::loopback::Loopback;
use motet_net::resume::{prove, Evidence, NodeSeen, ResumeError, Resumption};
use motet_net::run_record::RunRecord;
use motet_net::{NetConfig, Phase, RunIdentity};
use motet_planner::{Command, Located};
use proptest::prelude::*;
use std::path::PathBuf;
use tempfile::TempDir;

/// A scratch folder for one run's journal, removed when dropped.
fn temp_dir() -> TempDir {
    tempfile::Builder::new()
        .prefix("motet-resume-")
        .tempdir()
        .unwrap()
}

/// What a stopped run leaves: the files it was made from, its record and
/// journal, and the nodes (still running in the loopback).
struct Stopped {
    machine_text: String,
    job_bytes: Vec<u8>,
    m: Machine,
    cmds: Vec<Located<Command>>,
    record: RunRecord,
    journal: String,
    lb: Loopback,
    /// The folder its journal is written in, kept as long as the run.
    _dir: TempDir,
}

impl Stopped {
    fn journal(&self) -> Journal {
        Journal::parse(&self.journal, "journal").unwrap()
    }

    /// `prove` on the run's files, journal and nodes as they are.
    fn prove(&self, assumed: Option<&[(usize, f64)]>) -> Result<Resumption, ResumeError> {
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
    }
}

/// Starts `job` on `machine` with a journal; the caller stops it.
fn started(machine: &str, job: &str) -> (Stopped, PathBuf) {
    let (m, cmds) = load(machine, job);
    let machine_text = std::fs::read_to_string(root().join(machine)).unwrap();
    let job_path = root().join(job);
    let job_bytes = motet_api::job::read_bytes(&job_path).unwrap();
    let identity = RunIdentity::new(Digest::of(machine_text.as_bytes()), Digest::of(&job_bytes));
    let n = m.nodes.len();
    let dir = temp_dir();
    let jpath = dir.path().join("journal");
    let mut lb = Loopback::with_journal(
        &m,
        cmds.clone(),
        m.start,
        clean_links(n),
        &clocks(n),
        NetConfig::default(),
        Some(JournalWriter::create(&jpath).unwrap()),
    );
    lb.run.set_identity(identity);
    let record = loopback_record(&m, root().join(machine), job_path.clone(), identity, "mem");
    (
        Stopped {
            machine_text,
            job_bytes,
            m,
            cmds,
            record,
            journal: String::new(),
            lb,
            _dir: dir,
        },
        jpath,
    )
}

/// The run, its host killed at `kill_at` µs, its nodes at rest.
fn killed_host(machine: &str, job: &str, kill_at: u64) -> Stopped {
    let (mut s, jpath) = started(machine, job);
    while s.lb.now < kill_at {
        s.lb.step().unwrap();
    }
    assert_eq!(s.lb.run.phase(), &Phase::Streaming, "still running");
    s.lb.host_alive = false;
    s.lb.run_until_settled(60_000_000).unwrap();
    s.journal = std::fs::read_to_string(&jpath).unwrap();
    s
}

/// Runs the resumption on the loopback's nodes to the end.
fn finish(s: &mut Stopped, r: &Resumption) {
    let identity = RunIdentity::new(s.record.machine_sha256, s.record.job_sha256);
    s.lb.restart_host(&s.m, r.commands.clone(), r.from, NetConfig::default(), None);
    s.lb.run.set_identity(identity);
    let phase = s.lb.run_until_settled(3_600_000_000).unwrap();
    assert_eq!(phase, Phase::Done, "resumed run");
}

fn positions(m: &Machine, lb: &Loopback) -> Vec<i64> {
    executed(m, lb).iter().map(|&(_, p)| p).collect()
}

#[test]
fn host_killed_mid_move_resume_proves_the_run_and_finishes_exactly() {
    let (m, cmds) = load("examples/plotter.toml", "examples/jobs/drawing.svg");
    let want: Vec<i64> = simulated(&m, &cmds).iter().map(|&(_, p)| p).collect();
    for kill_at in [7_300_000u64, 15_000_000, 21_700_000] {
        let mut s = killed_host(
            "examples/plotter.toml",
            "examples/jobs/drawing.svg",
            kill_at,
        );
        let w = node_windows(&s.lb);
        let end = w[0].0;
        assert!(
            w.iter().all(|&(c, stopped)| c == end && stopped),
            "kill at {kill_at}: {w:?}"
        );
        let r = s.prove(None).unwrap();
        let j = s.journal();
        let rest = j.segment(end - 1).unwrap().end;
        assert_eq!((r.window_end, r.from), (end, rest), "kill at {kill_at}");
        assert_eq!(positions(&m, &s.lb), steps_at(&m, &rest), "at rest there");
        assert!(r.assumed.is_empty() && r.notes.is_empty(), "{r:?}");
        // It continues at the first segment the tail slowed down (or, for
        // a window that already ended at rest, at the next one, which
        // starts there).
        let tail = j.seal_ending(end).unwrap().tail;
        assert_eq!(r.segment, tail);
        assert_eq!(r.to, j.segment(tail).map_or(rest, |s| s.start));
        finish(&mut s, &r);
        assert_eq!(
            positions(&m, &s.lb),
            want,
            "kill at {kill_at}: ends where the job ends"
        );
    }
}

/// A resumed run stopped in its turn, at every stage: before it reached the
/// nodes, while configuring them, while travelling back, in the job.
#[test]
fn a_resumed_run_stopped_again_resumes_from_its_own_journal() {
    let (m, cmds) = load("examples/plotter.toml", "examples/jobs/drawing.svg");
    let want: Vec<i64> = simulated(&m, &cmds).iter().map(|&(_, p)| p).collect();
    let mut seen_stages = Vec::new();
    for kill_after in [0u64, 50_000, 1_000_000, 3_000_000, 3_300_000, 10_000_000] {
        let mut t = killed_host(
            "examples/plotter.toml",
            "examples/jobs/drawing.svg",
            9_000_000,
        );
        let r = t.prove(None).unwrap();
        let dir = temp_dir();
        let jpath = dir.path().join("journal");
        let identity = RunIdentity::new(t.record.machine_sha256, t.record.job_sha256);
        t.lb.restart_host(
            &t.m,
            r.commands.clone(),
            r.from,
            NetConfig::default(),
            Some(JournalWriter::create(&jpath).unwrap()),
        );
        t.lb.run.set_identity(identity);
        t.record.run = format!("{:08x}", identity.run);
        t.record.continues = Some(r.continues.clone());
        let until = t.lb.now + kill_after;
        while t.lb.now < until {
            t.lb.step().unwrap();
        }
        t.lb.host_alive = false;
        t.lb.run_until_settled(60_000_000).unwrap();
        t.journal = std::fs::read_to_string(&jpath).unwrap();
        let j = t.journal();
        let node_run = t.lb.nodes[0].node.endpoint.node().status().run;
        seen_stages.push((
            node_run == identity.run,
            j.header.is_some(),
            j.committed() > 0,
        ));
        let r2 = t.prove(None).unwrap();
        assert!(r2.command >= r.command, "{} < {}", r2.command, r.command);
        finish(&mut t, &r2);
        assert_eq!(positions(&m, &t.lb), want, "stopped {kill_after} µs in");
    }
    // Every stage was met: nodes not yet reconfigured, configured with no
    // trajectory yet, and stopped with windows committed.
    for stage in [
        (false, false, false),
        (true, false, false),
        (true, true, true),
    ] {
        assert!(
            seen_stages.contains(&stage),
            "{stage:?} not in {seen_stages:?}"
        );
    }
}

/// Gestalt's machine: one node per axis. Node `y` dies mid-job (its
/// process killed); the host reports it lost, the others stop on their tail.
/// Restarted, it holds no run: resume refuses until the person says where y
/// is, then continues from the last segment every node had finished.
#[test]
fn a_node_that_crashed_is_lost_and_resumes_only_from_a_given_position() {
    let machine = "examples/gestalt-3axis.toml";
    let job = "examples/jobs/gestalt-3d.gcode";
    let (m, cmds) = load(machine, job);
    let want: Vec<i64> = simulated(&m, &cmds).iter().map(|&(_, p)| p).collect();
    let (mut s, jpath) = started(machine, job);
    while s.lb.now < 9_000_000 {
        s.lb.step().unwrap();
    }
    s.lb.nodes[1].alive = false;
    let Phase::Stopped(info) = s.lb.run_until_settled(60_000_000).unwrap() else {
        panic!("the run must stop")
    };
    assert_eq!(
        info.lost.iter().map(|l| l.node).collect::<Vec<_>>(),
        vec![1],
        "{info:?}"
    );
    let mut confirmed: Vec<usize> = info.confirmed.iter().map(|c| c.0).collect();
    confirmed.sort();
    assert_eq!(confirmed, vec![0, 2], "the others said they rest");
    assert!(!info.all_at_rest());
    s.journal = std::fs::read_to_string(&jpath).unwrap();
    let j = s.journal();
    assert_eq!(j.stop.as_ref().map(|x| x.lost.clone()), Some(vec![1]));

    // Silent: nothing can be resumed.
    assert!(
        matches!(s.prove(None), Err(ResumeError::Silent { ref node, .. }) if node == &m.nodes[1].name)
    );
    // Restarted from its store: it answers, but knows nothing of the run.
    s.lb.restart_node(1);
    let e = s.prove(None).unwrap_err();
    assert!(
        matches!(e, ResumeError::Unknown { ref axes, .. } if axes == "y"),
        "{e}"
    );
    let text = e.to_string();
    assert!(
        text.contains("restarted") && text.contains("--assume-position y=…"),
        "{text}"
    );
    // The person measures y where the motor stopped.
    let y = m.axes.iter().position(|a| a.name == "y").unwrap();
    let a = m.nodes[1].actuators[0];
    let at = s.lb.nodes[1].node.board.position[0] as f64 / m.actuators[a].steps_per_unit;
    let r = s.prove(Some(&[(y, at)])).unwrap();
    assert_eq!(r.assumed, vec![m.nodes[1].name.clone()]);
    assert_eq!(r.from[y], at);
    assert!(
        r.segment <= j.done() && r.segment < info.window_end,
        "{r:?}"
    );
    assert!(
        r.notes.iter().any(|n| n.contains("may run twice")),
        "{:?}",
        r.notes
    );
    finish(&mut s, &r);
    assert_eq!(positions(&m, &s.lb), want, "the job ends where it should");
}

/// A node cut off from the host runs on to its tail's end: the host calls it
/// lost, but asked afterwards it proves where it is, and nothing more is
/// needed to resume.
#[test]
fn a_node_cut_off_but_running_on_resumes_without_help() {
    let machine = "examples/gestalt-3axis.toml";
    let job = "examples/jobs/gestalt-3d.gcode";
    let (m, cmds) = load(machine, job);
    let want: Vec<i64> = simulated(&m, &cmds).iter().map(|&(_, p)| p).collect();
    let (mut s, jpath) = started(machine, job);
    while s.lb.now < 9_000_000 {
        s.lb.step().unwrap();
    }
    let cut = std::mem::replace(
        &mut s.lb.nodes[1].node.transport,
        Box::new(motet_link::pair("x", "y").0),
    );
    drop(cut);
    let Phase::Stopped(info) = s.lb.run_until_settled(60_000_000).unwrap() else {
        panic!("the run must stop")
    };
    assert_eq!(info.lost.len(), 1, "{info:?}");
    s.lb.host_alive = false;
    s.lb.run_until_settled(10_000_000).unwrap();
    s.journal = std::fs::read_to_string(&jpath).unwrap();
    let r = s.prove(None).unwrap();
    assert!(r.assumed.is_empty() && r.notes.is_empty(), "{r:?}");
    assert_eq!(r.window_end, info.window_end);
    finish(&mut s, &r);
    assert_eq!(positions(&m, &s.lb), want);
}

/// The pieces `motet resume` reads, as text and bytes, to alter.
#[derive(Clone)]
struct Evidence0 {
    machine_text: String,
    job_bytes: Vec<u8>,
    record: RunRecord,
    journal: String,
    seen: Vec<NodeSeen>,
}

impl Evidence0 {
    fn of(s: &Stopped) -> Evidence0 {
        Evidence0 {
            machine_text: s.machine_text.clone(),
            job_bytes: s.job_bytes.clone(),
            record: s.record.clone(),
            journal: s.journal.clone(),
            seen: s.lb.seen(),
        }
    }

    /// What `motet resume` would do with these: each piece read as the
    /// command line reads it, then proved.
    fn attempt(&self, assumed: Option<&[(usize, f64)]>) -> Result<Resumption, String> {
        let path = root().join("examples/plotter.toml");
        let m = Machine::parse(&self.machine_text, &path).map_err(|e| e.to_string())?;
        let job = motet_api::job::parse_job(
            &m,
            &root().join("examples/jobs/drawing.svg"),
            motet_api::JobKind::Svg,
            &self.job_bytes,
            &motet_api::JobOptions::default(),
        )
        .map_err(|e| e.to_string())?;
        let j = Journal::parse(&self.journal, "journal").map_err(|e| e.to_string())?;
        prove(
            &Evidence {
                machine: &m,
                machine_sha256: Digest::of(self.machine_text.as_bytes()),
                job: &job.commands,
                job_sha256: Digest::of(&self.job_bytes),
                record: &self.record,
                journal: &j,
                journal_path: "journal",
                nodes: &self.seen,
            },
            assumed,
        )
        .map_err(|e| e.to_string())
    }

    /// Replaces line `i` of the journal (0-based) by `f(line text)` and
    /// signs every record again, as a forger would.
    fn forge_line(&mut self, i: usize, f: impl Fn(&str) -> String) {
        let mut chain = 0;
        let mut out = String::new();
        for (k, l) in self.journal.lines().enumerate() {
            let text = l.rsplit_once(" *").map_or(l, |(t, _)| t);
            let text = if k == i { f(text) } else { text.to_string() };
            chain = record_checksum(chain, &text);
            out += &format!("{text} *{chain:08x}\n");
        }
        self.journal = out;
    }

    /// Makes the files say `machine_text` and `job_bytes` everywhere: the
    /// record's digests and the journal's header, signed again.
    fn forge_files(&mut self, machine_text: String, job_bytes: Vec<u8>) {
        let (old_m, old_j) = (self.record.machine_sha256, self.record.job_sha256);
        self.machine_text = machine_text;
        self.job_bytes = job_bytes;
        let (new_m, new_j) = (
            Digest::of(self.machine_text.as_bytes()),
            Digest::of(&self.job_bytes),
        );
        self.record.machine_sha256 = new_m;
        self.record.job_sha256 = new_j;
        self.forge_line(0, |t| {
            t.replace(&old_m.to_string(), &new_m.to_string())
                .replace(&old_j.to_string(), &new_j.to_string())
        });
    }

    fn line_of(&self, prefix: &str, nth_from_end: usize) -> usize {
        let v: Vec<usize> = self
            .journal
            .lines()
            .enumerate()
            .filter(|(_, l)| l.starts_with(prefix))
            .map(|(i, _)| i)
            .collect();
        v[v.len() - 1 - nth_from_end]
    }
}

fn plotter_stopped() -> Stopped {
    killed_host(
        "examples/plotter.toml",
        "examples/jobs/drawing.svg",
        15_000_000,
    )
}

type Alter = fn(&mut Evidence0);

#[test]
fn every_refusal_says_what_differs() {
    let s = plotter_stopped();
    let base = Evidence0::of(&s);
    let good = base.attempt(None).unwrap();
    let cases: Vec<(&str, Alter, &str)> = vec![
        (
            "machine file edited",
            |e| {
                e.machine_text =
                    e.machine_text
                        .replacen("max_velocity = 250", "max_velocity = 260", 1)
            },
            "the machine file",
        ),
        (
            "job replaced (or resume.toml's `job` pointing elsewhere)",
            |e| {
                e.job_bytes =
                    motet_api::job::read_bytes(&root().join("examples/jobs/two-pens.svg")).unwrap()
            },
            "the job",
        ),
        (
            "a coordinate in the journal, checksum left",
            |e| {
                let i = e.line_of("seg", 3);
                let lines: Vec<String> = e.journal.lines().map(String::from).collect();
                let mut l = lines.clone();
                let (text, crc) = l[i].rsplit_once(" *").unwrap();
                let mut w: Vec<&str> = text.split(' ').collect();
                w[6] = "921.2689";
                l[i] = format!("{} *{crc}", w.join(" "));
                e.journal = l.join("\n") + "\n";
            },
            "checksum",
        ),
        (
            "a coordinate in the journal, signed again",
            |e| {
                let i = e.line_of("seg", 3);
                e.forge_line(i, |t| {
                    let mut w: Vec<&str> = t.split(' ').collect();
                    w[12] = "921.2689";
                    w.join(" ")
                });
            },
            "end has x=921.2689",
        ),
        (
            "the journal of another run",
            |e| {
                e.forge_line(0, |t| {
                    let (a, b) = t.split_once("run=").unwrap();
                    format!("{a}run=0badcafe{}", &b[8..])
                })
            },
            "its run is 0badcafe",
        ),
        (
            "another job, with every digest made to match",
            |e| {
                let job =
                    motet_api::job::read_bytes(&root().join("examples/jobs/two-pens.svg")).unwrap();
                let m = e.machine_text.clone();
                e.forge_files(m, job);
            },
            "is not the one the job plans",
        ),
        (
            "another machine, with every digest made to match",
            |e| {
                let m = e.machine_text.replacen(
                    "max_acceleration = 2000",
                    "max_acceleration = 1500",
                    1,
                );
                let j = e.job_bytes.clone();
                e.forge_files(m, j);
            },
            "is not the one the job plans",
        ),
        (
            "a window's tail moved",
            |e| {
                let i = e.line_of("seal", 2);
                e.forge_line(i, |t| {
                    let w: Vec<&str> = t.split(' ').collect();
                    let end: u32 = w[1].parse().unwrap();
                    format!("seal {end} {end} {} {}", w[3], w[4])
                });
            },
            "has its tail from segment",
        ),
        (
            "more segments claimed finished than could be",
            |e| {
                let i = e.line_of("seal", 0);
                e.forge_line(i, |t| {
                    let w: Vec<&str> = t.split(' ').collect();
                    format!("seal {} {} {} {}", w[1], w[2], w[1], w[4])
                });
            },
            "segments were finished at",
        ),
        (
            "resume.toml names another run",
            |e| e.record.run = "0badcafe".into(),
            "its run is",
        ),
        (
            "a node is another board",
            |e| {
                if let NodeSeen::Answered { uid, .. } = &mut e.seen[0] {
                    *uid ^= 1;
                }
            },
            "is uid",
        ),
        (
            "a node is silent",
            |e| e.seen[0] = NodeSeen::Silent,
            "does not answer",
        ),
        (
            "a node is still moving",
            |e| {
                if let NodeSeen::Answered {
                    position: Some(p), ..
                } = &mut e.seen[0]
                {
                    p.queued = 3;
                }
            },
            "still moving",
        ),
        (
            "a node rests elsewhere",
            |e| {
                if let NodeSeen::Answered {
                    position: Some(p), ..
                } = &mut e.seen[0]
                {
                    p.at[0] += 0.5;
                }
            },
            "the node and the journal disagree",
        ),
        (
            "a node ran another job since",
            |e| {
                if let NodeSeen::Answered {
                    position: Some(p), ..
                } = &mut e.seen[0]
                {
                    p.run = 0x1234;
                }
            },
            "ran another job since",
        ),
        (
            "a node ahead of the journal",
            |e| {
                if let NodeSeen::Answered {
                    position: Some(p), ..
                } = &mut e.seen[0]
                {
                    p.committed += 40;
                }
            },
            "the journal is not the run's latest",
        ),
    ];
    for (what, alter, want) in cases {
        let mut e = base.clone();
        alter(&mut e);
        match e.attempt(None) {
            Ok(r) => panic!("{what}: resumed at command {}", r.command),
            Err(msg) => assert!(msg.contains(want), "{what}: want {want:?} in: {msg}"),
        }
    }
    // Said to be somewhere while every node knows where it is.
    let e = base.attempt(Some(&[(0, 1.0)])).unwrap_err();
    assert!(e.contains("is not needed"), "{e}");
    // Nothing altered: the same resumption every time.
    assert_eq!(base.attempt(None).unwrap(), good);
}

/// A node that restarted needs the machine's position; one outside travel
/// is refused before anything moves.
#[test]
fn a_given_position_is_checked_against_travel() {
    let s = plotter_stopped();
    let mut e = Evidence0::of(&s);
    if let NodeSeen::Answered {
        position: Some(p), ..
    } = &mut e.seen[0]
    {
        p.run = 0;
    }
    let msg = e.attempt(None).unwrap_err();
    assert!(
        msg.contains("restarted and holds no run") && msg.contains("x=…,y=…"),
        "{msg}"
    );
    let msg = e.attempt(Some(&[(0, 921.0), (1, 50.0)])).unwrap_err();
    assert!(
        msg.contains("resume would start from x=921") && msg.contains("travel"),
        "{msg}"
    );
    let msg = e.attempt(Some(&[(0, 10.0)])).unwrap_err();
    assert!(msg.contains("where y is cannot be known"), "{msg}");
    let r = e.attempt(Some(&[(0, 10.0), (1, 20.0)])).unwrap();
    assert_eq!(&r.from[..2], &[10.0, 20.0]);
}

proptest! {
    // 96 cases by default; PROPTEST_CASES runs more.
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|c| c.parse().ok()).unwrap_or(96),
        ..Default::default()
    })]

    /// Any byte of the journal, the job or the machine file flipped:
    /// refused. Any field of the journal that the plan fixes (a segment's
    /// command, times and coordinates, a window's end and tail, the header)
    /// changed and every record signed again: refused, unless the plan is
    /// bit for bit what it was (then the same resumption). Nothing changed:
    /// the same resumption, exactly.
    #[test]
    fn an_altered_journal_job_or_machine_file_is_refused(
        which in 0usize..4,
        at in any::<proptest::sample::Index>(),
        word in any::<proptest::sample::Index>(),
        bit in 0u8..8,
        delta in prop_oneof![Just(1i64), Just(-1), Just(7), Just(1000)],
    ) {
        let base = BASE.with(|b| b.clone());
        let want = base.attempt(None).unwrap();
        let mut e = base.clone();
        match which {
            0 => {
                let mut b = e.journal.clone().into_bytes();
                let i = at.index(b.len() - 1); // the last newline: see journal.rs
                b[i] ^= 1 << bit;
                e.journal = String::from_utf8_lossy(&b).into_owned();
            }
            1 => {
                let i = at.index(e.job_bytes.len());
                e.job_bytes[i] ^= 1 << bit;
            }
            2 => {
                let mut b = e.machine_text.clone().into_bytes();
                let i = at.index(b.len());
                b[i] ^= 1 << bit;
                e.machine_text = String::from_utf8_lossy(&b).into_owned();
            }
            _ => {
                // A field the plan fixes, changed, everything signed again.
                let lines: Vec<String> = e.journal.lines().map(String::from).collect();
                let i = at.index(lines.len());
                let text = lines[i].rsplit_once(" *").unwrap().0.to_string();
                let words: Vec<&str> = text.split(' ').collect();
                let fields: Vec<usize> = match words[0] {
                    "seg" => (1..words.len()).filter(|&k| words[k] != "|").collect(),
                    "seal" | "stop" => vec![1, 2],
                    _ => (2..words.len()).collect(),
                };
                let k = fields[word.index(fields.len())];
                let changed = change(words[k], delta);
                let mut w: Vec<String> = words.iter().map(|s| s.to_string()).collect();
                w[k] = changed;
                let new = w.join(" ");
                e.forge_line(i, move |_| new.clone());
            }
        }
        let got = e.attempt(None);
        if which < 3 {
            prop_assert!(got.is_err(), "flipped ({which}) and resumed at {:?}", got.map(|r| r.command));
        } else {
            // A plan input changed so little that not one segment of the plan
            // moves (the shortest move time by one ulp, with no move that
            // short) changes nothing: the same resumption. Anything else is
            // refused.
            prop_assert!(
                got.as_ref().is_err() || got.as_ref().ok() == Some(&want),
                "edited and resumed differently, at {:?}", got.map(|r| r.command)
            );
        }
        prop_assert_eq!(base.attempt(None).unwrap(), want);
    }
}

/// A field's text changed: numbers by `delta` (in their last digit for
/// decimals), anything else by a character.
fn change(w: &str, delta: i64) -> String {
    if let Some((k, v)) = w.split_once('=') {
        return format!("{k}={}", change(v, delta));
    }
    if let Ok(n) = w.parse::<i64>() {
        let m = if n + delta >= 0 {
            n + delta
        } else {
            n + delta.abs()
        };
        return m.to_string();
    }
    if let Ok(x) = w.parse::<f64>() {
        let y = f64::from_bits((x.to_bits() as i64 + delta) as u64);
        return format!("{y:?}");
    }
    let mut c: Vec<char> = w.chars().collect();
    c[0] = if c[0] == '0' { '1' } else { '0' };
    c.into_iter().collect()
}

thread_local! {
    /// One stopped run for the property test (a stopped plotter job).
    static BASE: Evidence0 = Evidence0::of(&plotter_stopped());
}

/// A host that had no turn for longer than its lead: the nodes braked on
/// their tails, the host stopped saying why, and the run resumes from its
/// journal to the job's end.
#[test]
fn a_run_stopped_by_a_stalled_host_resumes_exactly() {
    let machine = "examples/gestalt-3axis.toml";
    let job = "examples/jobs/gestalt-3d.gcode";
    let (mut s, jpath) = started(machine, job);
    let want: Vec<i64> = simulated(&s.m, &s.cmds).iter().map(|&(_, p)| p).collect();
    while s.lb.now < 9_000_000 {
        s.lb.step().unwrap();
    }
    assert_eq!(s.lb.run.phase(), &Phase::Streaming);
    s.lb.host_alive = false;
    while s.lb.now < 14_000_000 {
        s.lb.step().unwrap();
    }
    s.lb.host_alive = true;
    let Phase::Stopped(info) = s.lb.run_until_settled(60_000_000).unwrap() else {
        panic!("expected a stop");
    };
    assert!(info.reason.contains("the host had no turn"), "{info:?}");
    assert!(info.all_at_rest(), "{info:?}");
    s.journal = std::fs::read_to_string(&jpath).unwrap();
    assert!(s.journal().stop.is_some());
    let r = s.prove(None).unwrap();
    assert_eq!(r.window_end, info.window_end);
    finish(&mut s, &r);
    assert_eq!(positions(&s.m, &s.lb), want);
}

/// Tiny moves, and a host stalled longer and longer: the run slows the
/// moves it has not planned yet (journaled), then a stall longer than any
/// lead stops it. Resume plans the job again with the same slowdowns, bit
/// for bit, and finishes it.
#[test]
fn a_slowed_run_resumes_with_the_same_slowdowns() {
    let dir = temp_dir();
    let job = dir.path().join("arc.gcode");
    let r = 0.02 / 1e-4;
    let text: String = (1..=2_000)
        .map(|k| {
            let a = k as f64 * 1e-4;
            format!("G1 X{:.4} Y{:.4} F250\n", r * a.sin(), r * (1.0 - a.cos()))
        })
        .collect();
    std::fs::write(&job, text).unwrap();
    let (mut s, jpath) = started("examples/printer.toml", job.to_str().unwrap());
    let want: Vec<i64> = simulated(&s.m, &s.cmds).iter().map(|&(_, p)| p).collect();
    while s.lb.run.progress().0 < 100 {
        s.lb.step().unwrap();
    }
    let mut slowed = false;
    for off in [60_000u64, 120_000, 200_000] {
        let end = s.lb.now + 3_000_000;
        while s.lb.now < end {
            s.lb.host_alive = s.lb.now % 240_000 < 240_000 - off;
            s.lb.step().unwrap();
            slowed |= s.lb.run.take_notes().iter().any(|n| n.contains("slowed"));
        }
        s.lb.host_alive = true;
        assert_eq!(s.lb.run.phase(), &Phase::Streaming);
    }
    assert!(slowed);
    s.lb.host_alive = false;
    let end = s.lb.now + 5_000_000;
    while s.lb.now < end {
        s.lb.step().unwrap();
    }
    s.lb.host_alive = true;
    let Phase::Stopped(info) = s.lb.run_until_settled(60_000_000).unwrap() else {
        panic!("expected a stop");
    };
    assert!(info.all_at_rest(), "{info:?}");
    s.journal = std::fs::read_to_string(&jpath).unwrap();
    assert!(!s.journal().paces.is_empty());
    let r = s.prove(None).unwrap();
    assert_eq!(r.window_end, info.window_end);
    finish(&mut s, &r);
    assert_eq!(positions(&s.m, &s.lb), want);
}
