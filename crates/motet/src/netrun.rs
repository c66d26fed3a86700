//! `motet run --nodes spawn|paired` and `motet resume`: a job on networked
//! nodes, on the wall clock.

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use motet_api::{job_name, load_job, JobOptions};
use motet_host::Machine;
use motet_net::clock::{Clock, WallClock};
use motet_net::journal::{Journal, JournalWriter};
use motet_net::pairing_file::{pairing_path, PairingFile};
use motet_net::resume::resume;
use motet_net::session::{probe, NodeAddr, Session};
use motet_net::{NetConfig, NetRun, Phase};
use motet_planner::{Command, Located};
use motet_trajectory::Point;
use motet_wire::NodeMessage;
use serde::{Deserialize, Serialize};
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
}

/// What `motet resume` needs: written when a networked run starts.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResumeFile {
    pub machine: PathBuf,
    pub job: PathBuf,
    pub allow_unknown: bool,
    pub time_scale: f64,
    pub lead_ms: f64,
    #[serde(default = "default_sync_ms")]
    pub sync_ms: f64,
    /// For a resumed run: the job command its journal's command 0.. after the
    /// prelude stand for, the prelude's length, and where the prelude went.
    #[serde(default)]
    pub base_command: usize,
    #[serde(default)]
    pub prelude: usize,
    #[serde(default)]
    pub prelude_to: Option<Vec<f64>>,
    pub nodes: Vec<ResumeNode>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResumeNode {
    pub name: String,
    pub link: String,
    pub address: u16,
}

fn default_sync_ms() -> f64 {
    NetConfig::default().sync_interval_us as f64 / 1000.0
}

fn cfg(r: &ResumeFile) -> NetConfig {
    let (lead_ms, time_scale) = (r.lead_ms, r.time_scale);
    let mut c = NetConfig::default();
    c.lead_min_us = (lead_ms * 1000.0) as u64;
    c.sync_interval_us = (r.sync_ms.max(1.0) * 1000.0) as u64;
    // Timeouts are in the run's own (possibly scaled) time.
    c.node_timeout_us = (c.node_timeout_us as f64 * time_scale.max(1.0)) as u64;
    c.connect_timeout_us = (c.connect_timeout_us as f64 * time_scale.max(1.0)) as u64;
    c
}

pub fn run(a: NetArgs) -> Result<()> {
    use motet_planner::ranges;
    ranges::TIME_SCALE.check("--time-scale", a.time_scale)?;
    ranges::SYNC_MS.check("--sync-ms", a.sync_ms)?;
    ranges::LEAD_MS.check("--lead-ms", a.lead_ms)?;
    let machine = Machine::load(a.machine_path)?;
    let loaded = load_job(
        &machine,
        a.job_path,
        &JobOptions {
            allow_unknown: a.allow_unknown,
        },
    )?;
    if !a.quiet {
        for w in &loaded.warnings {
            eprintln!("warning: {w}");
        }
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
                "60".to_string(),
                "--quiet".to_string(),
            ];
            Session::spawn(&machine, &exe, &extra)?
        }
        NodesMode::Paired => {
            let path = pairing_path(a.machine_path);
            if !path.exists() {
                bail!(
                    "{} does not exist: pair the nodes first with `motet nodes pair {} --link NODE=SPEC …`",
                    path.display(),
                    a.machine_path.display()
                );
            }
            Session::paired(&machine, &PairingFile::load(&path)?, &path)?
        }
        NodesMode::Sim => unreachable!("in-process runs do not come here"),
    };
    let resume_file = ResumeFile {
        machine: a.machine_path.to_path_buf(),
        job: a.job_path.to_path_buf(),
        allow_unknown: a.allow_unknown,
        time_scale: a.time_scale,
        lead_ms: a.lead_ms,
        sync_ms: a.sync_ms,
        base_command: 0,
        prelude: 0,
        prelude_to: None,
        nodes: session
            .nodes
            .iter()
            .map(|n| ResumeNode {
                name: n.name.clone(),
                link: n.link.clone(),
                address: n.address,
            })
            .collect(),
    };
    drive(
        &machine,
        loaded.commands,
        machine.start,
        session,
        resume_file,
        &out,
        a.quiet,
    )
}

fn drive(
    machine: &Machine,
    commands: Vec<Located<Command>>,
    start: Point,
    mut session: Session,
    resume_file: ResumeFile,
    out: &Path,
    quiet: bool,
) -> Result<()> {
    std::fs::write(
        out.join("resume.toml"),
        toml::to_string_pretty(&resume_file)?,
    )?;
    let journal = JournalWriter::create(&out.join("journal"))?;
    let clock = WallClock::with(resume_file.time_scale, 0.0, 0);
    let peers = std::mem::take(&mut session.peers);
    let total = commands.len();
    let mut run = NetRun::new(
        machine,
        commands,
        peers,
        start,
        cfg(&resume_file),
        Some(journal),
    );
    let bar = if quiet || !std::io::stderr().is_terminal() {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::new(total as u64);
        b.set_style(
            ProgressStyle::with_template("{spinner} {msg} [{bar:40}] {pos}/{len} commands ({eta})")
                .expect("static template")
                .progress_chars("=> "),
        );
        b
    };
    let started = std::time::Instant::now();
    let phase = loop {
        let now = clock.now_us();
        let phase = run.poll(now)?.clone();
        bar.set_position(run.progress().0 as u64);
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
    let now = clock.now_us();
    let figures = run.figures(now);
    let report = serde_json::json!({
        "machine": machine.name,
        "commands": total,
        "segments": run.segments_sent,
        "windows": run.windows,
        "wall_s": started.elapsed().as_secs_f64(),
        "outcome": match &phase { Phase::Done => "done".to_string(), Phase::Stopped(s) => format!("stopped: {}", s.reason), _ => "?".into() },
        "nodes": figures.iter().enumerate().map(|(k, f)| serde_json::json!({
            "name": f.name,
            "rtt_us": f.rtt_us,
            "retransmits": f.retransmits,
            "crc_errors": f.crc_errors,
            "bytes_out": f.bytes_out,
            "bytes_in": f.bytes_in,
            "frames_out": f.frames_out,
            "frames_in": f.frames_in,
            "sync_error_us": f.sync_error_us,
            "skew_ppm": f.skew_ppm,
            "underruns": f.underruns,
            "window": window(run.node_status(k)),
        })).collect::<Vec<_>>(),
    });
    std::fs::write(
        out.join("net.json"),
        serde_json::to_string_pretty(&report)? + "\n",
    )?;
    if !quiet {
        for f in &figures {
            println!(
                "  node {}: rtt {:.2} ms, {} retransmits, {} CRC errors, {} B out / {} B in, clock ±{:.1} µs ({:+.1} ppm)",
                f.name,
                f.rtt_us as f64 / 1000.0,
                f.retransmits,
                f.crc_errors,
                f.bytes_out,
                f.bytes_in,
                f.sync_error_us,
                f.skew_ppm
            );
        }
    }
    match phase {
        Phase::Done => {
            if !quiet {
                println!(
                    "done: {} commands, {} segments in {} windows; wrote {}/net.json",
                    total,
                    run.segments_sent,
                    run.windows,
                    out.display()
                );
            }
            Ok(())
        }
        Phase::Stopped(s) => {
            let text = format!(
                "reason = {:?}\nwindow_end = {}\ntail_start = {}\npoint = {:?}\n",
                s.reason, s.window_end, s.tail_start, s.point
            );
            std::fs::write(out.join("stop.toml"), text)?;
            bail!(
                "stopped: {}\n  every node came to rest at {:?} (end of segment {}); continue with `motet resume {}`",
                s.reason,
                s.point,
                s.window_end.saturating_sub(1),
                out.display()
            )
        }
        _ => unreachable!("the loop ends only when done or stopped"),
    }
}

/// The node's committed window end and whether it stopped on its tail.
fn window(m: Option<&NodeMessage>) -> serde_json::Value {
    match m {
        Some(NodeMessage::Status {
            committed, stopped, ..
        }) => {
            serde_json::json!({ "committed": committed, "stopped": stopped })
        }
        _ => serde_json::Value::Null,
    }
}

/// `motet resume OUT`
pub fn resume_cmd(out: &Path, quiet: bool) -> Result<()> {
    let path = out.join("resume.toml");
    let text = std::fs::read_to_string(&path).with_context(|| {
        format!(
            "cannot read {}: is {} the output folder of a networked run?",
            path.display(),
            out.display()
        )
    })?;
    let rf: ResumeFile = toml::from_str(&text).with_context(|| format!("{}", path.display()))?;
    let machine = Machine::load(&rf.machine)?;
    let loaded = load_job(
        &machine,
        &rf.job,
        &JobOptions {
            allow_unknown: rf.allow_unknown,
        },
    )?;
    let mut journal = Journal::load(&out.join("journal"))?;
    let nodes: Vec<NodeAddr> = rf
        .nodes
        .iter()
        .map(|n| NodeAddr {
            name: n.name.clone(),
            link: n.link.clone(),
            address: n.address,
        })
        .collect();
    let mut session = Session::attach(&machine, &nodes)?;
    let clock = WallClock::with(rf.time_scale, 0.0, 0);
    let status = probe(&mut session.peers, &clock, Duration::from_secs(3));
    let mut window_end: Option<u32> = None;
    for (k, s) in status.into_iter().enumerate() {
        match s {
            Some(NodeMessage::Status {
                committed,
                stopped,
                segment_space,
                ..
            }) => {
                if !stopped && (segment_space as usize) < machine.nodes[k].queue {
                    bail!(
                        "node {} is still moving; wait for it to stop",
                        nodes[k].name
                    );
                }
                if machine.nodes[k].actuators.is_empty() {
                    continue;
                }
                match window_end {
                    None => window_end = Some(committed),
                    Some(w) if w != committed => bail!(
                        "the nodes disagree on where they stopped (segment {w} and {committed}); they did not stop together"
                    ),
                    _ => {}
                }
            }
            _ => bail!("node {} did not answer", nodes[k].name),
        }
    }
    let window_end = window_end.unwrap_or(0);
    // A resumed run's journal counts its own commands: map them to the job's.
    let raw: Vec<usize> = journal.segments.iter().map(|s| s.command).collect();
    if rf.base_command > 0 || rf.prelude > 0 {
        for s in journal.segments.iter_mut() {
            s.command = if s.command < rf.prelude {
                rf.base_command
            } else {
                rf.base_command + s.command - rf.prelude
            };
        }
    }
    // Stopped while going back for an earlier stop: go back to the same place.
    let in_prelude = journal
        .seal_ending(window_end)
        .and_then(|s| raw.get(s.tail as usize).copied())
        .is_some_and(|c| c < rf.prelude);
    let mut r = resume(&loaded.commands, &journal, window_end, machine.start)?;
    if in_prelude {
        if let Some(to) = rf
            .prelude_to
            .as_deref()
            .and_then(|v| <[f64; 6]>::try_from(v).ok())
        {
            r = motet_net::resume::resume_at(&loaded.commands, r.from, to, rf.base_command);
        }
    }
    if !quiet {
        println!(
            "resuming {}: the machine rests at {:?}; back to {:?}, then on from command {} of {}",
            rf.job.display(),
            &r.from[..machine.axes.len()],
            &r.to[..machine.axes.len()],
            r.command,
            loaded.commands.len()
        );
    }
    let prelude = r.commands.len() - (loaded.commands.len() - r.command);
    let next = ResumeFile {
        base_command: r.command,
        prelude,
        prelude_to: Some(r.to.to_vec()),
        ..rf.clone()
    };
    // Keep the stopped run's files beside the new ones.
    let _ = std::fs::rename(
        out.join("journal"),
        out.join(format!("journal.{window_end}")),
    );
    drive(&machine, r.commands, r.from, session, next, out, quiet)
}
