//! `motet run --nodes spawn|paired` and `motet resume`: a job on networked
//! nodes, on the wall clock.

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use motet_api::job::{parse_job, read_bytes, Job, JobKind};
use motet_api::{job_name, scan_job, JobOptions, JobReader};
use motet_host::Machine;
use motet_net::admin::AdminError;
use motet_net::clock::{Clock, WallClock};
use motet_net::digest::Digest;
use motet_net::journal::{Journal, JournalWriter};
use motet_net::pairing_file::{format_uid, pairing_path};
use motet_net::resume::{parse_assumed, prove, Evidence, NodeSeen, ResumeError};
use motet_net::run_record::{RunNode, RunRecord, RECORD_FORMAT};
use motet_net::session::{locate, NodeAddr, Session, SessionError, Spawning};
use motet_net::{CommandSource, NetConfig, NetRun, Phase, RunIdentity, StopInfo};
use motet_planner::{Command, Located};
use motet_trajectory::Point;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Which nodes a run drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum NodesMode {
    /// Simulated nodes inside this process (no network).
    Sim,
    /// Simulated node processes started for this run, on UDP.
    Spawn,
    /// The nodes in the machine's pairing file (`motet nodes pair`).
    Paired,
}

pub struct NetArgs<'a> {
    pub machine_path: &'a Path,
    pub job_path: &'a Path,
    pub out: Option<PathBuf>,
    pub allow_unknown: bool,
    pub quiet: bool,
    pub mode: NodesMode,
    pub time_scale: f64,
    pub lead_ms: f64,
    pub sync_ms: f64,
    /// With `--nodes spawn`: the nodes share one medium (`--bus`).
    pub bus: Option<String>,
    /// `--start-late-clocks` ([`NetConfig::start_late_clocks`]).
    pub start_late_clocks: bool,
}

/// How far the host's and a node process's stamps of one sync frame may
/// lie apart, µs of wall time: each dates the system's stamp on its clock
/// to within 5 µs.
const REFERENCE_SLACK_WALL_US: f64 = 10.0;

/// The least lead of a run, ms of wall time (see [`cfg`]).
const WALL_LEAD_MS: f64 = 50.0;

fn cfg(r: &RunRecord) -> NetConfig {
    let (lead_ms, time_scale) = (r.lead_ms, r.time_scale);
    let mut c = NetConfig::default();
    // A host's stalls (a scheduler's turn, a disk's flush of the journal)
    // are in wall time: a run faster than real time reaches ahead by at
    // least WALL_LEAD_MS of it.
    c.lead_min_us = (lead_ms.max(WALL_LEAD_MS * time_scale) * 1000.0) as u64;
    c.sync_interval_us = (r.sync_ms.max(1.0) * 1000.0) as u64;
    // Timeouts are in the run's own (possibly scaled) time.
    c.node_timeout_us = (c.node_timeout_us as f64 * time_scale.max(1.0)) as u64;
    c.connect_timeout_us = (c.connect_timeout_us as f64 * time_scale.max(1.0)) as u64;
    c.start_late_clocks = r.start_late_clocks;
    // A busy computer's stalls are in wall time: the lead may grow to
    // cover a quarter second of them, however fast the run's time goes.
    c.lead_max_us = c.lead_max_us.max((250_000.0 * time_scale) as u64);
    c
}

/// The machine file and the job, each read once: what they say, where they
/// are (absolute, so a resume works from any folder) and their SHA-256.
struct Files {
    machine_path: PathBuf,
    machine: Machine,
    machine_sha256: Digest,
    job_path: PathBuf,
    job: Job,
    job_sha256: Digest,
}

fn absolute(p: &Path) -> Result<PathBuf> {
    std::fs::canonicalize(p).with_context(|| format!("cannot find {}", p.display()))
}

fn read_files(machine_path: &Path, job_path: &Path, allow_unknown: bool) -> Result<Files> {
    let machine_path = absolute(machine_path)?;
    let text = std::fs::read_to_string(&machine_path)
        .with_context(|| format!("cannot read machine file {}", machine_path.display()))?;
    let machine = Machine::parse(&text, &machine_path)?;
    let job_path = absolute(job_path)?;
    let bytes = read_bytes(&job_path)?;
    let job = parse_job(
        &machine,
        &job_path,
        JobKind::of(&job_path)?,
        &bytes,
        &JobOptions {
            allow_unknown,
            ..Default::default()
        },
    )?;
    Ok(Files {
        machine_sha256: Digest::of(text.as_bytes()),
        machine_path,
        machine,
        job_path,
        job,
        job_sha256: Digest::of(&bytes),
    })
}

/// A job for a run, checked and planned through once but not kept: its
/// commands are read again as the run goes ([`stream_job`]).
struct Scanned {
    machine_path: PathBuf,
    machine: Machine,
    machine_sha256: Digest,
    job_path: PathBuf,
    job_sha256: Digest,
    commands: usize,
    warnings: Vec<String>,
    /// What the job asks of the machine (a machine from modules checks it).
    needs: motet_host::module::JobNeeds,
}

fn scan_files(machine_path: &Path, job_path: &Path, opts: &JobOptions) -> Result<Scanned> {
    let machine_path = absolute(machine_path)?;
    let text = std::fs::read_to_string(&machine_path)
        .with_context(|| format!("cannot read machine file {}", machine_path.display()))?;
    let machine = Machine::parse(&text, &machine_path)?;
    let job_path = absolute(job_path)?;
    let job_sha256 = Digest::of_file(&job_path)
        .with_context(|| format!("cannot read job {}", job_path.display()))?;
    let scan = scan_job(JobReader::open(&machine, &job_path, opts)?, &mut |_, _| {})?;
    Ok(Scanned {
        machine_sha256: Digest::of(text.as_bytes()),
        machine_path,
        machine,
        job_path,
        job_sha256,
        commands: scan.commands,
        warnings: scan.warnings,
        needs: scan.needs,
    })
}

/// The job's commands as a run reads them: sent by a reader thread through
/// a bounded channel, so the run holds a few thousand of them at most.
struct Streamed(std::sync::mpsc::Receiver<Result<Located<Command>, String>>);

impl CommandSource for Streamed {
    fn next_command(&mut self) -> Option<Result<Located<Command>, String>> {
        // The reader ends (and the channel with it) at the job's end.
        self.0.recv().ok()
    }
}

/// Commands read ahead of the run at most.
const READ_AHEAD: usize = 4096;

/// Reads the job again on a thread of `scope`, for the run to take as it
/// plans; the thread ends at the job's end, or when the run lets go.
fn stream_job<'scope>(
    scope: &'scope std::thread::Scope<'scope, '_>,
    machine: &'scope Machine,
    path: &'scope Path,
    opts: JobOptions,
) -> Streamed {
    let (tx, rx) = std::sync::mpsc::sync_channel(READ_AHEAD);
    scope.spawn(move || {
        let reader = match JobReader::open(machine, path, &opts) {
            Ok(r) => r,
            Err(e) => {
                let _ = tx.send(Err(format!("reading the job again: {e}")));
                return;
            }
        };
        for c in reader {
            let c = c.map_err(|e| format!("reading the job again: {e}"));
            let failed = c.is_err();
            if tx.send(c).is_err() || failed {
                break;
            }
        }
    });
    Streamed(rx)
}

fn record_nodes(session: &Session) -> Vec<RunNode> {
    session
        .nodes
        .iter()
        .zip(&session.infos)
        .enumerate()
        .map(|(k, (n, i))| RunNode {
            name: n.name.clone(),
            link: n.link.clone(),
            address: n.address,
            uid: format_uid(i.uid),
            firmware: i.firmware.to_string(),
            pid: session.spawned.get(k).map(|p| p.pid()),
        })
        .collect()
}

pub fn run(a: NetArgs) -> Result<()> {
    use motet_planner::ranges;
    ranges::TIME_SCALE.check("--time-scale", a.time_scale)?;
    ranges::SYNC_MS.check("--sync-ms", a.sync_ms)?;
    ranges::LEAD_MS.check("--lead-ms", a.lead_ms)?;
    if a.bus.is_some() && a.mode != NodesMode::Spawn {
        bail!("--bus is for --nodes spawn (paired nodes share a medium when their pairing names one link)");
    }
    let group = a
        .bus
        .as_deref()
        .map(crate::bus_arg::bus_group)
        .transpose()?;
    let opts = JobOptions {
        allow_unknown: a.allow_unknown,
        ..Default::default()
    };
    // Every error is found before anything moves; the commands are read
    // again as the run goes, so a job of any length runs in the same memory.
    let files = scan_files(a.machine_path, a.job_path, &opts)?;
    let machine = &files.machine;
    if !a.quiet {
        for w in &files.warnings {
            eprintln!("warning: {w}");
        }
    }
    // A machine composed from modules runs only what fits it, on the
    // modules it was composed from.
    let composed = crate::modules::check_machine(machine, !a.quiet)?;
    if let Some(c) = &composed {
        crate::modules::check_fit(c, &files.needs, a.job_path, crate::modules::MODULES)?;
    }
    let name = job_name(a.job_path);
    let out = a.out.unwrap_or_else(|| PathBuf::from("out").join(&name));
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let session = match a.mode {
        NodesMode::Spawn => {
            let exe = std::env::current_exe().context("cannot find the motet executable")?;
            let extra = vec![
                "--time-scale".to_string(),
                a.time_scale.to_string(),
                "--idle-exit".to_string(),
                SPAWNED_IDLE_S.to_string(),
                "--quiet".to_string(),
            ];
            let each = crate::modules::spawn_args(machine, &out, &extra)?;
            let clock = motet_net::clock::wall();
            let how = Spawning {
                group: group.as_deref(),
                logs: Some(&out),
            };
            Session::spawn_with(machine, &exe, &each, &clock, how)?
        }
        NodesMode::Paired => {
            let pairing = match composed {
                Some(_) => crate::modules::check_the_bus(machine, a.machine_path)?.1,
                None => crate::nodes::paired(a.machine_path)?,
            };
            Session::paired(
                machine,
                &pairing,
                &pairing_path(a.machine_path),
                &motet_net::clock::wall(),
            )?
        }
        NodesMode::Sim => unreachable!("in-process runs do not come here"),
    };
    let identity = RunIdentity::new(files.machine_sha256, files.job_sha256);
    let record = RunRecord {
        format: RECORD_FORMAT,
        run: format!("{:08x}", identity.run),
        machine: files.machine_path.clone(),
        machine_sha256: files.machine_sha256,
        job: files.job_path.clone(),
        job_sha256: files.job_sha256,
        allow_unknown: a.allow_unknown,
        time_scale: a.time_scale,
        lead_ms: a.lead_ms,
        sync_ms: a.sync_ms,
        // Simulated nodes share this computer's cores with the host: how
        // well their clocks are known says how busy it is, not whether a
        // machine is safe.
        start_late_clocks: a.start_late_clocks || a.mode == NodesMode::Spawn,
        continues: None,
        nodes: record_nodes(&session),
    };
    let watch = crate::modules::run_watch(machine, &session, files.needs);
    std::thread::scope(|scope| {
        let source = stream_job(scope, machine, &files.job_path, opts);
        drive(
            machine,
            RunJob::Streamed(Box::new(source), files.commands),
            machine.start,
            session,
            record,
            identity,
            &out,
            a.quiet,
            watch,
        )
    })
}

/// What a run runs: commands in hand (a resume's), or a job read as the
/// run goes, with its length.
enum RunJob {
    Given(Vec<Located<Command>>),
    Streamed(Box<dyn CommandSource>, usize),
}

impl RunJob {
    /// The run of this job through `peers`, and its length in commands.
    fn run(
        self,
        machine: &Machine,
        peers: Vec<motet_net::peer::Peer>,
        start: Point,
        cfg: NetConfig,
        journal: JournalWriter,
    ) -> (NetRun, usize) {
        match self {
            RunJob::Given(commands) => {
                let total = commands.len();
                let run = NetRun::new(machine, commands, peers, start, cfg, Some(journal));
                (run, total)
            }
            RunJob::Streamed(source, total) => {
                let mut run = NetRun::new(machine, Vec::new(), peers, start, cfg, Some(journal));
                run.reading(source, total);
                (run, total)
            }
        }
    }
}

/// How long a simulated node a run started waits, s, once it hears no
/// host: a stopped run's nodes wait that long for `motet resume`.
const SPAWNED_IDLE_S: u32 = 60;

/// How long a finished run still listens for the loops' samples, host µs:
/// a node sends a source's batch once it is a second old
/// (`motet_node::control::samples::MAX_BATCH_AGE_US`), and a frame's way.
const SAMPLES_DRAIN_US: u64 = 1_200_000;

#[allow(clippy::too_many_arguments)]
fn drive(
    machine: &Machine,
    job: RunJob,
    start: Point,
    mut session: Session,
    record: RunRecord,
    identity: RunIdentity,
    out: &Path,
    quiet: bool,
    mut watch: Option<(motet_net::modules::ModuleWatch, Vec<String>)>,
) -> Result<()> {
    record.save(out)?;
    let journal = JournalWriter::create(&out.join("journal"))?;
    let clock = WallClock::with(record.time_scale, 0.0, 0);
    let peers = std::mem::take(&mut session.peers);
    let (run, total) = job.run(machine, peers, start, cfg(&record), journal);
    let mut run = run.with_identity(identity);
    // One frame seals and stops every node; each watches the others.
    if session.shared_medium && !run.on_shared_medium() && !quiet {
        eprintln!("warning: more nodes than one group frame lists: each is sealed on its own");
    }
    // Answers stamped as they arrive: a host that runs late (a loaded
    // computer) would otherwise count its own wait as the path's, one way.
    run.stamp_arrivals(clock);
    // Each process dates a datagram's stamp on its own clock to within a
    // few µs of wall time (`motet_link` reads its two clocks at once).
    run.reference_slack_us((REFERENCE_SLACK_WALL_US * record.time_scale).ceil() as u64);
    let bar = progress_bar(total, quiet);
    let started = std::time::Instant::now();
    let phase = loop {
        let now = clock.now_us();
        run.poll(now)?;
        if let Some((w, links)) = watch.as_mut() {
            // A module added, removed or replaced: said at once, and a
            // machine no longer fit for the job stops on its tail.
            if let Some(r) = motet_net::modules::watch_run(w, &mut run, links, None, now) {
                bar.suspend(|| eprintln!("{}", r.text()));
            }
        }
        let phase = run.phase().clone();
        bar.set_position(run.progress().0 as u64);
        for note in run.take_notes().into_iter().filter(|_| !quiet) {
            bar.suspend(|| eprintln!("warning: {note}"));
        }
        bar.set_message(match phase {
            Phase::Starting => "connecting",
            Phase::Streaming => "streaming",
            Phase::Draining => "finishing",
            _ => "stopping",
        });
        if matches!(phase, Phase::Done | Phase::Stopped(_)) {
            break phase;
        }
        let wake = run.next_wakeup(now);
        let wait = wake.saturating_sub(clock.now_us()).min(1_000);
        if wait > 20 {
            std::thread::sleep(clock.real(wait));
        }
    };
    bar.finish_and_clear();
    if matches!(phase, Phase::Done) {
        drain_samples(&mut run, &clock)?;
    }
    let now = clock.now_us();
    let figures = run.figures(now);
    let tallies = run.tallies();
    let plots = crate::net_report::write_loop_plots(machine, &run, out)?;
    let report = serde_json::json!({
        "machine": machine.name,
        "plots": plots,
        "loops": crate::net_report::loops_json(machine, &run),
        "heaters": crate::net_report::heaters_json(&run),
        "commands": total,
        "segments": run.segments_sent,
        "windows": run.windows,
        "wall_s": started.elapsed().as_secs_f64(),
        "outcome": match &phase { Phase::Done => "done".to_string(), Phase::Stopped(s) => format!("stopped: {}", s.reason), _ => "?".into() },
        "pace": pace_json(run.pace()),
        "lost": match &phase { Phase::Stopped(s) => s.lost.iter().map(|l| serde_json::json!({ "node": l.name, "why": l.why })).collect::<Vec<_>>(), _ => Vec::new() },
        "nodes": crate::net_report::nodes_json(&run, &figures, &tallies),
    });
    std::fs::write(
        out.join("net.json"),
        serde_json::to_string_pretty(&report)? + "\n",
    )?;
    if !quiet {
        crate::net_report::print_figures(&figures);
    }
    match phase {
        Phase::Done => {
            if !quiet {
                let files: String = plots.iter().map(|p| format!(", {p}")).collect();
                println!(
                    "done: {} commands, {} segments in {} windows; wrote {}/{{net.json{files}}}",
                    total,
                    run.segments_sent,
                    run.windows,
                    out.display()
                );
            }
            Ok(())
        }
        Phase::Stopped(s) => {
            std::fs::write(out.join("stop.toml"), stop_summary(machine, &s))?;
            let mut text = stop_message(machine, &s, out);
            // The simulated nodes this run started stay where they came to
            // rest, for `motet resume`, until they hear no host for a while.
            if !session.spawned.is_empty() {
                for n in session.spawned.drain(..) {
                    n.detach();
                }
                text += &format!("\n  the simulated nodes wait {SPAWNED_IDLE_S} s for it");
            }
            bail!("{text}")
        }
        _ => unreachable!("the loop ends only when done or stopped"),
    }
}

/// Keeps the stopped run `run`'s record and journal beside the new ones.
fn keep_stopped_run(out: &Path, run: &str) -> Result<()> {
    for (name, kept) in [
        ("journal", format!("journal.{run}")),
        ("resume.toml", format!("resume.{run}.toml")),
        ("stop.toml", format!("stop.{run}.toml")),
    ] {
        if out.join(name).exists() {
            std::fs::rename(out.join(name), out.join(&kept))
                .with_context(|| format!("cannot keep {} as {kept}", out.join(name).display()))?;
        }
    }
    Ok(())
}

/// The loops' last samples leave their nodes within a batch's age of the
/// end: heard before the plots are drawn.
fn drain_samples(run: &mut NetRun, clock: &WallClock) -> Result<()> {
    if run.samples().series.is_empty() && run.heater_traces().next().is_none() {
        return Ok(());
    }
    let until = clock.now_us() + SAMPLES_DRAIN_US;
    while clock.now_us() < until {
        run.poll(clock.now_us())?;
        std::thread::sleep(clock.real(1_000));
    }
    Ok(())
}

/// The run's progress bar on a terminal (hidden with `-q` or when stderr
/// is not one).
fn progress_bar(total: usize, quiet: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new(total as u64);
    b.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{bar:40}] {pos}/{len} commands ({eta})")
            .expect("static template")
            .progress_chars("=> "),
    );
    b
}

/// How late the host ran (ms of the run's time) and the lead it ended with.
fn pace_json(pace: motet_net::run::PaceFigures) -> serde_json::Value {
    let least = pace
        .least_margin_us
        .is_finite()
        .then_some(pace.least_margin_us / 1000.0);
    serde_json::json!({
        "worst_gap_ms": pace.worst_gap_us as f64 / 1000.0,
        "worst_seal_late_ms": pace.worst_seal_late_us as f64 / 1000.0,
        "least_margin_ms": least,
        "lead_ms": pace.lead_us as f64 / 1000.0,
    })
}

/// What `stop.toml` says: the stop as a person reads it.
fn stop_summary(machine: &Machine, s: &StopInfo) -> String {
    let names = |v: &mut dyn Iterator<Item = usize>| -> Vec<String> {
        v.map(|k| machine.nodes[k].name.clone()).collect()
    };
    let mut t = toml::Table::new();
    t.insert("reason".into(), s.reason.clone().into());
    t.insert("window_end".into(), i64::from(s.window_end).into());
    t.insert("tail_start".into(), i64::from(s.tail_start).into());
    t.insert("done".into(), i64::from(s.done).into());
    t.insert(
        "point".into(),
        s.point[..machine.axes.len()].to_vec().into(),
    );
    t.insert(
        "at_rest".into(),
        names(&mut s.confirmed.iter().map(|c| c.0)).into(),
    );
    t.insert(
        "lost".into(),
        names(&mut s.lost.iter().map(|l| l.node)).into(),
    );
    toml::to_string(&t).unwrap_or_default()
}

/// The error a stopped run ends with: why, which nodes rest where, which
/// were lost, and how to go on.
fn stop_message(machine: &Machine, s: &StopInfo, out: &Path) -> String {
    let mut text = format!("stopped: {}", s.reason);
    let at_end: Vec<&str> = s
        .confirmed
        .iter()
        .filter(|c| c.1 == s.window_end)
        .map(|c| machine.nodes[c.0].name.as_str())
        .collect();
    if !at_end.is_empty() {
        text += &format!(
            "\n  {} came to rest at {} (end of segment {})",
            plural_nodes(&at_end),
            show_point(machine, &s.point),
            s.window_end.saturating_sub(1)
        );
    }
    for &(k, end) in s.confirmed.iter().filter(|c| c.1 != s.window_end) {
        text += &format!(
            "\n  node {} came to rest at the end of segment {} (it missed the last window)",
            machine.nodes[k].name,
            end.saturating_sub(1)
        );
    }
    for l in &s.lost {
        // The reason may already say why.
        let why = if s.reason.contains(&l.why) {
            String::new()
        } else {
            format!(" ({})", l.why)
        };
        text += &format!(
            "\n  node {} was lost{why}: where it is is not known",
            l.name
        );
    }
    text += &format!("\ncontinue with `motet resume {}`", out.display());
    if !s.lost.is_empty() {
        text += " once every node answers again (a node that restarted needs --assume-position)";
    }
    text
}

/// Where the nodes that know their run rest, one line for each committed
/// point: one line when they all stopped on the same window's tail.
fn rest_lines(
    machine: &Machine,
    positions: &[Option<motet_net::resume::NodePosition>],
) -> Vec<String> {
    let mut by_end: std::collections::BTreeMap<u32, Vec<&str>> = Default::default();
    for (k, p) in positions.iter().enumerate() {
        if let Some(p) = p.as_ref().filter(|p| p.run != 0 && p.queued == 0) {
            by_end
                .entry(p.committed)
                .or_default()
                .push(machine.nodes[k].name.as_str());
        }
    }
    by_end
        .into_iter()
        .map(|(end, names)| {
            format!(
                "{} {} at rest at the end of committed segment {}",
                plural_nodes(&names),
                if names.len() == 1 { "is" } else { "are" },
                end.saturating_sub(1)
            )
        })
        .collect()
}

fn plural_nodes(names: &[&str]) -> String {
    match names {
        [one] => format!("node {one}"),
        _ => format!("nodes {}", names.join(", ")),
    }
}

fn show_point(machine: &Machine, p: &Point) -> String {
    machine
        .axes
        .iter()
        .zip(p)
        .map(|(a, v)| format!("{}={v}", a.name))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The stopped run's nodes, each the device the run had; on a shared
/// medium one that restarted is given its address again by its uid.
fn attach_recorded(machine: &Machine, record: &RunRecord) -> Result<Session> {
    let nodes: Vec<NodeAddr> = record
        .nodes
        .iter()
        .map(|n| NodeAddr {
            name: n.name.clone(),
            link: n.link.clone(),
            address: n.address,
        })
        .collect();
    // Each the device the run had; on a shared medium one that restarted
    // is given its address again by its uid.
    let uids: Vec<Option<u64>> = record
        .nodes
        .iter()
        .map(|n| {
            let shared = motet_net::session::is_shared(&n.link, &nodes);
            shared
                .then(|| motet_net::pairing_file::parse_uid(&n.uid))
                .flatten()
        })
        .collect();
    let clock = motet_net::clock::wall();
    match Session::attach_checked(machine, &nodes, &uids, &clock) {
        Ok(s) => Ok(s),
        Err(SessionError::Admin {
            node,
            source: AdminError::NoAnswer { link, .. },
        }) => bail!("{}", ResumeError::Silent { node, link }),
        Err(e) => Err(e.into()),
    }
}

/// `motet resume OUT`
pub struct ResumeArgs<'a> {
    pub out: &'a Path,
    pub quiet: bool,
    /// `x=…,y=…`: where the machine is, for nodes that lost their position.
    pub assume_position: Option<&'a str>,
    /// The machine file and job if they moved since the run (checked by SHA-256).
    pub machine: Option<&'a Path>,
    pub job: Option<&'a Path>,
}

pub fn resume_cmd(a: ResumeArgs) -> Result<()> {
    let out = a.out;
    let record = RunRecord::load(out)?;
    let files = read_files(
        a.machine.unwrap_or(&record.machine),
        a.job.unwrap_or(&record.job),
        record.allow_unknown,
    )?;
    let machine = &files.machine;
    let journal_path = out.join("journal");
    let journal = Journal::load(&journal_path)?;
    if record.nodes.len() != machine.nodes.len() {
        bail!(
            "{}: the run had {} nodes, the machine has {}",
            out.join("resume.toml").display(),
            record.nodes.len(),
            machine.nodes.len()
        );
    }
    let mut session = attach_recorded(machine, &record)?;
    let clock = WallClock::with(record.time_scale, 0.0, 0);
    let positions = locate(&mut session.peers, &clock, Duration::from_secs(3));
    let rests = rest_lines(machine, &positions);
    let seen: Vec<NodeSeen> = session
        .infos
        .iter()
        .zip(positions)
        .map(|(i, p)| NodeSeen::Answered {
            uid: i.uid,
            firmware: i.firmware,
            position: p,
        })
        .collect();
    let assumed = a
        .assume_position
        .map(|t| parse_assumed(machine, t))
        .transpose()
        .map_err(|e| anyhow::anyhow!("--assume-position: {e}"))?;
    let r = prove(
        &Evidence {
            machine,
            machine_sha256: files.machine_sha256,
            job: &files.job.commands,
            job_sha256: files.job_sha256,
            record: &record,
            journal: &journal,
            journal_path: &journal_path.display().to_string(),
            nodes: &seen,
        },
        assumed.as_deref(),
    )?;
    if !a.quiet {
        if journal.torn_tail {
            println!("note: the journal's last line was cut short (the host died writing it); it held nothing the nodes had");
        }
        println!(
            "resuming {}: the machine rests at {}; back to {}, then on from command {} of {}",
            files.job_path.display(),
            show_point(machine, &r.from),
            show_point(machine, &r.to),
            r.command,
            files.job.commands.len()
        );
        for line in &rests {
            println!("  {line}");
        }
        if !r.assumed.is_empty() {
            println!(
                "  where {} {} was given with --assume-position",
                plural_nodes(&r.assumed.iter().map(String::as_str).collect::<Vec<_>>()),
                if r.assumed.len() == 1 { "is" } else { "are" }
            );
        }
        for n in &r.notes {
            println!("  {n}");
        }
    }
    let identity = RunIdentity::new(files.machine_sha256, files.job_sha256);
    let next = RunRecord {
        run: format!("{:08x}", identity.run),
        machine: files.machine_path.clone(),
        job: files.job_path.clone(),
        continues: Some(r.continues.clone()),
        nodes: record_nodes(&session),
        ..record.clone()
    };
    keep_stopped_run(out, &record.run)?;
    drive(
        machine,
        RunJob::Given(r.commands),
        r.from,
        session,
        next,
        identity,
        out,
        a.quiet,
        None,
    )
}
