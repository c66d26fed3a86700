//! `motet bench-net`: a job streamed through the whole network stack (links,
//! clock sync, windows and seals, batches, acknowledgements) to simulated
//! nodes on a simulated clock, measuring bytes on the wire per second of
//! motion and the nodes' true clock error, optionally under injected jitter
//! and faults.

use anyhow::{bail, Context, Result};
use motet_api::job::{parse_job, read_bytes};
use motet_api::{JobKind, JobOptions};
use motet_host::Machine;
use motet_link::fault::{FaultClock, FaultConfig, Faulty, SimClock};
use motet_link::Transport;
use motet_net::digest::Digest;
use motet_net::journal::{Journal, JournalWriter};
use motet_net::loopback::{Crystal, Loopback};
use motet_net::pairing_file::format_uid;
use motet_net::resume::{prove, Evidence};
use motet_net::run_record::{RunNode, RunRecord, RECORD_FORMAT};
use motet_net::{NetConfig, Phase, RunIdentity};
use motet_planner::ranges;
use motet_wire::frame::{self, Flags, Header, MAX_FRAME};
use motet_wire::service::{ServiceReply, ServiceRequest};
use motet_wire::{encode, MAX_MESSAGE};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[arg(long, default_value = "examples/printer.toml")]
    machine: PathBuf,
    #[arg(long, default_value = "bench/data/prusaslicer-twisted-vase.gcode.gz")]
    job: PathBuf,
    /// Replace every actuator chain's microstep value.
    #[arg(long, value_parser = crate::flags::count::<u32>(ranges::MICROSTEPS))]
    microsteps: Option<u32>,
    /// Seconds of motion to measure [default: the whole job].
    #[arg(long, value_parser = crate::flags::number(ranges::JOB_S))]
    seconds: Option<f64>,
    /// Extra delay of every frame, uniform in 0..=J µs, both ways.
    #[arg(long, default_value_t = 0, value_parser = crate::flags::count::<u64>(ranges::JITTER_US))]
    jitter_us: u64,
    /// Rate of each fault (corrupt, drop, duplicate, delay, reorder) per frame.
    #[arg(long, default_value_t = 0.0, value_parser = crate::flags::number(ranges::FAULT_RATE))]
    faults: f64,
    /// Clock exchanges with each node, ms apart [default: the run's default].
    #[arg(long, value_parser = crate::flags::number(ranges::SYNC_MS))]
    sync_ms: Option<f64>,
    /// Kill the host after this many seconds of motion, let the nodes come
    /// to rest, and time what `motet resume` checks before it moves: the
    /// journal read, the job planned again and compared, the nodes' answers.
    #[arg(long, value_name = "SECONDS")]
    kill_host_at: Option<f64>,
    /// Put the host and every node on one shared medium: seals and stops go
    /// to every node in one frame, and the nodes watch one another's
    /// heartbeats [default: one link per node].
    #[arg(long, value_enum)]
    bus: Option<Bus>,
    /// On `--bus`, a clock exchange with each node instead of one sync
    /// frame to every node (to compare the two).
    #[arg(long, requires = "bus")]
    sync_each: bool,
    /// Also print the host's traffic by what each frame carries (segment
    /// batches, seals, status, clock exchanges, acknowledgements, group
    /// frames), each way.
    #[arg(long)]
    traffic: bool,
    /// Write each node's true clock error and the host's bound on it, every
    /// 100 ms while streaming, to this CSV file (seconds, node, error µs,
    /// bound µs; then the host's estimate's own error and bound, and how far
    /// the model the node runs is from the estimate, µs).
    #[arg(long, value_name = "FILE")]
    clock_trace: Option<PathBuf>,
}

/// A shared medium for `--bus`.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum Bus {
    /// A simulated CAN-FD bus with arbitration.
    Can,
    /// A UDP multicast group on this computer's loopback, real sockets;
    /// the simulated clock waits for every frame to reach every member.
    Udp,
}

/// Wire size of a datagram carrying `m`.
fn frame_len<T: serde::Serialize>(m: &T) -> usize {
    let mut buf = [0u8; MAX_MESSAGE];
    let p = encode(m, &mut buf).map(|b| b.to_vec()).unwrap_or_default();
    let h = Header {
        dst: 2,
        src: 1,
        port: 7,
        flags: Flags::NONE,
        seq: 0,
        ack: 0,
    };
    let mut out = [0u8; MAX_FRAME];
    frame::encode(&h, &p, &mut out).unwrap_or(0)
}

/// A machine file (with `--microsteps` applied) and a job read for it.
struct Loaded {
    machine: Machine,
    /// The machine file's text as run (its digest names the run).
    text: String,
    /// The job file's bytes.
    data: Vec<u8>,
    commands: Vec<motet_planner::Located<motet_planner::Command>>,
}

pub fn bench_net(args: Args) -> Result<()> {
    let loaded = load(&args)?;
    let machine = &loaded.machine;
    let n = machine.nodes.len();
    let clock = SimClock::new();
    let traffic = crate::bench_net_traffic::Traffic::default();
    let tap = |t| {
        if args.traffic {
            traffic.tap(t)
        } else {
            t
        }
    };
    let links = faulty_links(n, &clock, &args)
        .into_iter()
        .map(|(h, node)| (tap(h), node))
        .collect();
    let clocks = node_clocks(n);
    let wall = std::time::Instant::now();
    let cfg = net_config(&args)?;
    let scratch = std::env::temp_dir().join(format!("motet-bench-net-{}", std::process::id()));
    let journal_path = scratch.join("journal");
    let journal = match args.kill_host_at {
        Some(s) if !(s.is_finite() && s > 0.0) => {
            bail!("--kill-host-at must be a positive number of seconds")
        }
        Some(_) => {
            std::fs::create_dir_all(&scratch)?;
            Some(JournalWriter::create(&journal_path)?)
        }
        None => None,
    };
    let identity = RunIdentity::new(Digest::of(loaded.text.as_bytes()), Digest::of(&loaded.data));
    if args.bus.is_some() && (args.jitter_us > 0 || args.faults > 0.0) {
        bail!("--bus takes no --jitter-us or --faults: the shared medium loses nothing");
    }
    let mut lb = match args.bus {
        Some(Bus::Udp) => Loopback::on_udp_group(
            machine,
            loaded.commands.clone(),
            machine.start,
            &clocks,
            cfg,
            journal,
            &tap,
        )
        .context("joining a UDP multicast group on 127.0.0.1")?,
        Some(Bus::Can) => Loopback::on_bus_with(
            machine,
            loaded.commands.clone(),
            machine.start,
            &clocks,
            cfg,
            journal,
            &tap,
        ),
        None => Loopback::with_journal(
            machine,
            loaded.commands.clone(),
            machine.start,
            links,
            &clocks,
            cfg,
            journal,
        ),
    }
    // The figures come from counters: a whole print's every step would
    // hold hundreds of MB.
    .untraced();
    lb.run.set_identity(identity);
    if args.jitter_us > 0 || args.faults > 0.0 {
        lb.max_step_us = 10;
    }
    let limit = args.kill_host_at.or(args.seconds).map(|s| (s * 1e6) as u64);
    let streamed = stream(&mut lb, &clock, limit)?;
    let motion = (lb.now - streamed.start_us) as f64 * 1e-6;
    if motion <= 0.0 {
        bail!("{}: the job has no motion to measure", args.job.display());
    }
    println!(
        "run: {} of motion streamed in {:.1} s wall ({:?})",
        fmt_s(motion),
        wall.elapsed().as_secs_f64(),
        match &streamed.phase {
            Phase::Done => "done".to_string(),
            Phase::Stopped(s) => format!("stopped: {}", s.reason),
            _ => "measured part".into(),
        }
    );
    print_wire(&lb, n, motion, &cfg, streamed.bytes_at_start);
    if args.traffic {
        traffic.print(motion);
    }
    if args.kill_host_at.is_some() {
        resume_figures(
            machine,
            &loaded.text,
            &loaded.data,
            &loaded.commands,
            identity,
            &mut lb,
            &journal_path,
        )?;
        let _ = std::fs::remove_dir_all(&scratch);
    }
    if let Some(path) = &args.clock_trace {
        write_trace(path, &streamed.samples, machine)?;
    }
    print_clock_errors(&streamed.samples, machine, &clocks, args.jitter_us);
    print_agreement(&streamed.samples, machine);
    print_drift(&lb, machine);
    Ok(())
}

/// Writes every sample's clock errors and bounds as CSV.
fn write_trace(path: &std::path::Path, samples: &[Sample], machine: &Machine) -> Result<()> {
    let mut out = String::from(
        "seconds,node,error_us,bound_us,estimate_error_us,estimate_bound_us,model_off_us\n",
    );
    for (i, s) in samples.iter().enumerate() {
        for (k, v) in s.nodes.iter().enumerate() {
            if let Some((e, b)) = v {
                let name = &machine.nodes[k].name;
                let (ee, eb, off) = s.estimates[k].unwrap_or((f64::NAN, f64::NAN, f64::NAN));
                out += &format!(
                    "{:.1},{name},{e:.3},{b:.3},{ee:.3},{eb:.3},{off:.3}\n",
                    i as f64 * 0.1
                );
            }
        }
    }
    std::fs::write(path, out).with_context(|| format!("writing {}", path.display()))
}

/// Prints each node's own measure of its drift (from the host's send times
/// it saw) beside its crystal's true error and the host's estimate.
fn print_drift(lb: &Loopback, machine: &Machine) {
    for (k, node) in machine.nodes.iter().enumerate() {
        let (Some(n), Some(p)) = (lb.nodes.get(k), lb.run.peers().get(k)) else {
            continue;
        };
        let own = n.node.endpoint.services().status(0).drift;
        let (taken, slow) = p.sync.counts();
        println!(
            "  node {}: drift {:+.3} ppm true, {:+.3} ppm the host's estimate ({} exchanges taken, {} too slow, {} rate changes found), {}",
            node.name,
            n.ppm,
            p.sync.model().skew * 1e6,
            taken,
            slow,
            p.sync.changes(),
            own.map_or("no measure of its own yet".to_string(), |d| format!(
                "{:+.3} ppm its own measure over {} s",
                d.ppb as f64 * 1e-3,
                d.span_s
            ))
        );
    }
}

/// Reads the machine (with `--microsteps` applied) and the job, and prints
/// the machine's steps per unit.
fn load(args: &Args) -> Result<Loaded> {
    let text = std::fs::read_to_string(&args.machine)
        .with_context(|| format!("reading {}", args.machine.display()))?;
    let text = match args.microsteps {
        Some(m) => crate::bench_wire::with_microsteps(&text, m),
        None => text,
    };
    let machine = Machine::parse(&text, &args.machine)?;
    let data = read_bytes(&args.job)?;
    let job = parse_job(
        &machine,
        &args.job,
        JobKind::of(&args.job)?,
        &data,
        &JobOptions {
            allow_unknown: true,
            ..Default::default()
        },
    )?;
    let steps: Vec<String> = machine
        .actuators
        .iter()
        .map(|a| format!("{} {:.1}", a.name, a.steps_per_unit))
        .collect();
    println!(
        "machine: {} (steps/unit: {})",
        args.machine.display(),
        steps.join(", ")
    );
    Ok(Loaded {
        machine,
        text,
        data,
        commands: job.commands,
    })
}

/// Host and node ends of one in-memory link per node, each end with its own
/// seeded faults (`--faults`, `--jitter-us`) on the simulated `clock`.
fn faulty_links(
    n: usize,
    clock: &SimClock,
    args: &Args,
) -> Vec<(Box<dyn Transport + Send>, Box<dyn Transport + Send>)> {
    let fault = |seed: u64| FaultConfig {
        jitter_us: args.jitter_us,
        ..FaultConfig::all(seed, args.faults)
    };
    let crystals = node_clocks(n);
    (0..n)
        .map(|k| {
            let (a, b) = motet_link::pair(&format!("host{k}"), &format!("node{k}"));
            let c = || FaultClock::Simulated(clock.clone());
            // Each end stamps frames on arrival, in its own clock, as a
            // network interface's receive timestamps would.
            let host =
                Faulty::with_clock(a, fault(2 * k as u64 + 1), c()).stamping(Crystal::default());
            let node = Faulty::with_clock(b, fault(2 * k as u64 + 2), c()).stamping(crystals[k]);
            (
                Box::new(host) as Box<dyn Transport + Send>,
                Box::new(node) as Box<dyn Transport + Send>,
            )
        })
        .collect()
}

/// The nodes' crystals, off by up to ±200 ppm, and far apart in offset.
fn node_clocks(n: usize) -> Vec<Crystal> {
    (0..n)
        .map(|k| Crystal {
            ppm: [200.0, -200.0, 120.0, -80.0][k % 4],
            offset_us: 987_654_321 * (k as u64 + 1),
        })
        .collect()
}

/// The run's configuration with `--sync-ms` (at least 1 ms) applied.
fn net_config(args: &Args) -> Result<NetConfig> {
    // Nothing moves before every clock is within its target: under heavy
    // jitter that takes longer than a person would wait at a prompt.
    let mut cfg = NetConfig {
        connect_timeout_us: 60_000_000,
        ..NetConfig::default()
    };
    if let Some(ms) = args.sync_ms {
        if !(ms.is_finite() && ms >= 1.0) {
            bail!("--sync-ms must be at least 1");
        }
        cfg.sync_interval_us = (ms * 1000.0) as u64;
    }
    cfg.sync_to_all = !args.sync_each;
    Ok(cfg)
}

/// How the streaming went.
struct Streamed {
    /// The phase the run ended in (or was in when the measurement stopped).
    phase: Phase,
    /// When streaming began, simulated µs.
    start_us: u64,
    /// Every 100 ms while streaming: each node's clock error (its idea of
    /// host time − host time, µs) and the host's bound on it.
    samples: Vec<Sample>,
    /// Bytes on the wire (both ways, all nodes) when streaming began.
    bytes_at_start: u64,
}

/// The nodes' clocks at one moment while streaming.
struct Sample {
    /// Per node: true error and the host's bound, µs (None: no model yet).
    nodes: Vec<Option<(f64, f64)>>,
    /// Per node, for the trace: the host's estimate's own error and bound,
    /// and how far the model the node runs is from it, µs.
    estimates: Vec<Option<(f64, f64, f64)>>,
    /// The planned path's speed at that moment, units/s.
    speed: f64,
}

/// Bytes on the wire, both ways, to and from every node.
fn wire_bytes(lb: &Loopback) -> u64 {
    lb.run
        .peers()
        .iter()
        .map(|p| p.transport().stats().bytes_out + p.transport().stats().bytes_in)
        .sum()
}

/// The planned path's speed at host time `t`, units/s (0 where unknown).
fn path_speed(lb: &Loopback, t: f64) -> f64 {
    match (lb.run.position_at(t - 1_000.0), lb.run.position_at(t)) {
        (Some(a), Some(b)) => {
            let d2: f64 = a.iter().zip(&b).map(|(x, y)| (x - y) * (x - y)).sum();
            d2.sqrt() / 1e-3
        }
        _ => 0.0,
    }
}

/// Steps the loopback run until it is done or stopped, or until `limit_us`
/// of streaming has passed, sampling the nodes' clock errors.
fn stream(lb: &mut Loopback, clock: &SimClock, limit_us: Option<u64>) -> Result<Streamed> {
    let mut streaming_at = None;
    let mut bytes_at_start = 0;
    let mut samples = Vec::new();
    let mut next_sample = 0u64;
    let phase = loop {
        clock.set(lb.now);
        lb.step()?;
        let phase = lb.run.phase().clone();
        if matches!(phase, Phase::Done | Phase::Stopped(_)) {
            break phase;
        }
        if phase == Phase::Streaming && streaming_at.is_none() {
            streaming_at = Some(lb.now);
            bytes_at_start = wire_bytes(lb);
        }
        if let Some(s) = streaming_at {
            if lb.now >= next_sample {
                next_sample = lb.now + 100_000;
                let now = lb.now as f64;
                let nodes = lb
                    .nodes
                    .iter()
                    .zip(lb.run.peers())
                    .map(|(node, p)| {
                        let local = node.offset_us as f64 + now * (1.0 + node.ppm * 1e-6);
                        let services = node.node.endpoint.services();
                        services
                            .host_time(local)
                            .map(|h| (h - now, p.sync.error_bound(now)))
                    })
                    .collect();
                let estimates = lb
                    .nodes
                    .iter()
                    .zip(lb.run.peers())
                    .map(|(node, p)| {
                        let local = node.offset_us as f64 + now * (1.0 + node.ppm * 1e-6);
                        let (off, bound) = p.sync.model_off(now)?;
                        Some((p.sync.model().host(local) - now, bound, off))
                    })
                    .collect();
                samples.push(Sample {
                    nodes,
                    estimates,
                    speed: path_speed(lb, now),
                });
            }
            if limit_us.is_some_and(|l| lb.now > s + l) {
                break phase;
            }
        }
        if lb.now > 100 * 3_600_000_000 {
            bail!("the run did not finish in 100 simulated hours");
        }
    };
    Ok(Streamed {
        phase,
        start_us: streaming_at.context("the run never started streaming")?,
        samples,
        bytes_at_start,
    })
}

/// Prints the bytes and frames on the wire to and from the `n` nodes per
/// second of `motion` (s), the
/// clock exchanges' share, windows, segments and retransmits.
fn print_wire(lb: &Loopback, n: usize, motion: f64, cfg: &NetConfig, bytes_at_start: u64) {
    let request = motet_net::peer::datagram(2, &ServiceRequest::TimeGet { t1: u64::MAX / 3 }).len();
    let reply = frame_len(&ServiceReply::Time {
        t1: u64::MAX / 3,
        t2: u64::MAX / 3,
        t3: u64::MAX / 3,
    });
    let (mut out, mut inb, mut frames) = (0u64, 0u64, 0u64);
    for p in lb.run.peers() {
        let t = p.transport().stats();
        out += t.bytes_out;
        inb += t.bytes_in;
        frames += t.frames_out + t.frames_in;
    }
    // One sync frame serves every node on a shared medium.
    let asked = lb.run.peers().iter().map(|p| p.exchanges.0);
    let requests = if lb.run.shared_medium() && cfg.sync_to_all {
        asked.max().unwrap_or(0)
    } else {
        asked.sum()
    };
    let answered: u64 = lb.run.peers().iter().map(|p| p.exchanges.1).sum();
    let sync = requests * request as u64 + answered * reply as u64;
    let total = out + inb;
    println!(
        "wire, all {} node(s) together: {:.3} KB/s ({:.0} B/s host→nodes, {:.0} B/s nodes→host, {:.1} frames/s)",
        n,
        total as f64 / motion / 1000.0,
        out as f64 / motion,
        inb as f64 / motion,
        frames as f64 / motion
    );
    println!(
        "  per node {:.3} KB/s; while streaming (the start's clock exchanges left out) {:.3} KB/s, per node {:.3} KB/s",
        total as f64 / motion / 1000.0 / n as f64,
        total.saturating_sub(bytes_at_start) as f64 / motion / 1000.0,
        total.saturating_sub(bytes_at_start) as f64 / motion / 1000.0 / n as f64,
    );
    let models: u64 = lb.run.peers().iter().map(|p| p.sync.models_sent.0).sum();
    let references: u64 = lb.run.peers().iter().map(|p| p.references).sum();
    println!(
        "  clock exchanges: {} requests, {} answers ({:.2}/s per node, at most {} ms apart; {} B a request, {} B an answer; {} of the answers reference samples), {:.0} B/s; clock models sent: {}",
        requests,
        answered,
        answered as f64 / motion / n as f64,
        cfg.sync_interval_us / 1000,
        request,
        reply,
        references,
        sync as f64 / motion,
        models
    );
    println!(
        "  {} windows sealed ({:.2}/s), {} segments ({:.1}/s), {} retransmits",
        lb.run.windows,
        lb.run.windows as f64 / motion,
        lb.run.segments_sent,
        lb.run.segments_sent as f64 / motion,
        lb.run
            .peers()
            .iter()
            .map(|p| p.link().stats().retransmits)
            .sum::<u64>()
    );
}

/// Prints each node's clock error while streaming (overall, and after the
/// first minute) and how often the host's bound held.
fn print_clock_errors(samples: &[Sample], machine: &Machine, clocks: &[Crystal], jitter_us: u64) {
    for (k, node) in machine.nodes.iter().enumerate() {
        let e: Vec<(f64, f64)> = samples.iter().filter_map(|s| s.nodes[k]).collect();
        if e.is_empty() {
            continue;
        }
        let max = e.iter().fold(0.0f64, |m, v| m.max(v.0.abs()));
        let rms = (e.iter().map(|v| v.0 * v.0).sum::<f64>() / e.len() as f64).sqrt();
        // After the first minute (samples every 100 ms).
        let late = &e[e.len().min(600)..];
        let late_max = late.iter().fold(0.0f64, |m, v| m.max(v.0.abs()));
        let outside = e.iter().filter(|v| v.0.abs() > v.1).count();
        let bound_max = e.iter().fold(0.0f64, |m, v| m.max(v.1));
        println!(
            "  node {} ({:+} ppm): clock error while streaming max {:.1} µs, rms {:.1} µs; after the first minute max {:.1} µs ({} samples, jitter {} µs); host's bound at most {:.1} µs, exceeded in {} samples",
            node.name,
            clocks[k].ppm,
            max,
            rms,
            late_max,
            e.len(),
            jitter_us,
            bound_max,
            outside
        );
    }
}

/// Prints the largest difference between any two nodes' clocks while
/// streaming, and the path error it makes at the path's speed then.
fn print_agreement(samples: &[Sample], machine: &Machine) {
    if machine.nodes.len() < 2 {
        return;
    }
    let (mut worst, mut worst_late, mut path) = (0.0f64, 0.0f64, 0.0f64);
    for (i, s) in samples.iter().enumerate() {
        let errs: Vec<f64> = s.nodes.iter().flatten().map(|v| v.0).collect();
        let spread = errs.iter().fold(f64::NEG_INFINITY, |m, &v| m.max(v))
            - errs.iter().fold(f64::INFINITY, |m, &v| m.min(v));
        if errs.len() < 2 {
            continue;
        }
        worst = worst.max(spread);
        if i >= 600 {
            worst_late = worst_late.max(spread);
        }
        path = path.max(spread * 1e-6 * s.speed);
    }
    println!(
        "  any two nodes' clocks apart while streaming: at most {worst:.1} µs ({worst_late:.1} µs after the first minute); path error from it at the path's speed then: at most {:.3} µm",
        path * 1e3
    );
}

fn fmt_s(s: f64) -> String {
    if s > 120.0 {
        format!("{:.1} min", s / 60.0)
    } else {
        format!("{s:.1} s")
    }
}

/// Kills the host, lets the nodes rest, and times `motet resume`'s checks.
fn resume_figures(
    machine: &Machine,
    machine_text: &str,
    job_bytes: &[u8],
    commands: &[motet_planner::Located<motet_planner::Command>],
    identity: RunIdentity,
    lb: &mut Loopback,
    journal_path: &std::path::Path,
) -> Result<()> {
    lb.host_alive = false;
    lb.run_until_settled(600_000_000)?;
    print_rest(lb, machine);
    let record = RunRecord {
        format: RECORD_FORMAT,
        run: format!("{:08x}", identity.run),
        machine: PathBuf::from("machine"),
        machine_sha256: identity.machine,
        job: PathBuf::from("job"),
        job_sha256: identity.job,
        allow_unknown: true,
        time_scale: 1.0,
        lead_ms: 100.0,
        sync_ms: 10_000.0,
        start_late_clocks: false,
        continues: None,
        nodes: lb
            .nodes
            .iter()
            .enumerate()
            .map(|(k, n)| {
                let i = n.node.endpoint.services().info();
                RunNode {
                    name: machine.nodes[k].name.clone(),
                    link: format!("mem{k}"),
                    address: i.address,
                    uid: format_uid(i.uid),
                    firmware: i.firmware.to_string(),
                    pid: None,
                }
            })
            .collect(),
    };
    let t = std::time::Instant::now();
    let journal = Journal::load(journal_path)?;
    let read = t.elapsed().as_secs_f64();
    let seen = lb.seen();
    let r = prove(
        &Evidence {
            machine,
            machine_sha256: Digest::of(machine_text.as_bytes()),
            job: commands,
            job_sha256: Digest::of(job_bytes),
            record: &record,
            journal: &journal,
            journal_path: &journal_path.display().to_string(),
            nodes: &seen,
        },
        None,
    )?;
    let all = t.elapsed().as_secs_f64();
    let size = std::fs::metadata(journal_path).map_or(0, |m| m.len());
    println!(
        "resume after the host was killed: journal {} segments, {} windows, {:.1} MB read in {:.2} s; whole check (job planned again and compared, tails, nodes) {:.2} s; the job continues at command {} of {}",
        journal.segments.len(),
        journal.seals.len(),
        size as f64 / 1e6,
        read,
        all,
        r.command,
        commands.len()
    );
    Ok(())
}

/// Where every node came to rest after the host was killed: its committed
/// end, whether it stopped on its tail, and its axes, as the node itself
/// reports them.
fn print_rest(lb: &Loopback, machine: &Machine) {
    let mut ends = Vec::new();
    for (k, n) in lb.nodes.iter().enumerate() {
        let node = n.node.endpoint.node();
        let s = node.status();
        let motet_wire::NodeMessage::Position { at, .. } = node.position() else {
            continue;
        };
        // Each of its joints where the node's trajectory ends, and where
        // its board's steps put it.
        let joints: Vec<String> = machine.nodes[k]
            .actuators
            .iter()
            .enumerate()
            .map(|(ch, &a)| {
                let act = &machine.actuators[a];
                let joint = &machine.joints[act.joint];
                let stepped = n.node.board.position[ch] as f64 / act.steps_per_unit;
                format!(
                    "{}={:.3} (steps: {:.3})",
                    joint.name,
                    joint.map.value(&at, 0.0),
                    stepped
                )
            })
            .collect();
        println!(
            "  {}: at rest after segment {} ({}), {}, {} queued",
            machine.nodes[k].name,
            s.committed,
            if s.stopped {
                "braked on its tail"
            } else {
                "at its end"
            },
            joints.join(" "),
            node.queued()
        );
        ends.push(s.committed);
    }
    let same = ends.windows(2).all(|w| w[0] == w[1]);
    println!(
        "nodes after the host was killed: {} ({})",
        if same {
            "every node on the same committed point"
        } else {
            "NOT on one committed point"
        },
        if lb.bus.is_some() {
            "one bus, seals in one frame"
        } else {
            "one link per node"
        }
    );
}
