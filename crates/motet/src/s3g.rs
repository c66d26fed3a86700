//! S3G bots from the command line: `motet run MACHINE JOB --nodes
//! s3g:PORT[@BAUD]` runs a job on a MakerBot-style bot on a serial port
//! (motet plans, the bot runs queued points), and `motet node --sim --type
//! s3g --listen pty` is a simulated bot on a pseudo-terminal.

use anyhow::{bail, Context, Result};
use motet_api::{job_name, scan_job, JobOptions, JobReader};
use motet_host::Machine;
use motet_s3g::bot::faults::Faults;
use motet_s3g::bot::serve::{serve, Served};
use motet_s3g::bot::{Bot, BUFFER_BYTES};
use motet_s3g::driver::{Driver, DriverConfig};
use serialport::SerialPort;
use std::io::{BufRead, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// `--nodes`: a mode, or `s3g:PORT[@BAUD]` (the whole machine is one S3G
/// bot on that serial port).
#[derive(Clone, Debug)]
pub enum NodesArg {
    /// Simulated, spawned or paired motet nodes.
    Mode(crate::netrun::NodesMode),
    /// An S3G bot: the port and its baud rate.
    S3g(String, u32),
}

/// Parses `--nodes`.
pub fn nodes_arg(s: &str) -> Result<NodesArg, String> {
    use clap::ValueEnum;
    if let Some(spec) = s.strip_prefix("s3g:") {
        let (path, baud) = match spec.rsplit_once('@') {
            Some((p, b)) => (
                p,
                b.parse::<u32>()
                    .ok()
                    .filter(|b| (300..=4_000_000).contains(b))
                    .ok_or_else(|| {
                        format!("`{s}`: the baud rate after @ must be 300 to 4000000")
                    })?,
            ),
            None => (spec, 115_200),
        };
        if path.is_empty() {
            return Err(format!(
                "`{s}`: expected s3g:PORT[@BAUD], e.g. s3g:/dev/ttyACM0"
            ));
        }
        return Ok(NodesArg::S3g(path.to_string(), baud));
    }
    crate::netrun::NodesMode::from_str(s, true)
        .map(NodesArg::Mode)
        .map_err(|_| format!("`{s}`: expected sim, spawn, paired or s3g:PORT[@BAUD]"))
}

/// Runs a job on an S3G bot.
pub fn run(
    machine_path: &Path,
    job_path: &Path,
    out: Option<PathBuf>,
    allow_unknown: bool,
    quiet: bool,
    (port_path, baud): (&str, u32),
) -> Result<()> {
    let machine = Machine::load(machine_path)?;
    motet_s3g::points::AxisMap::of(&machine)
        .with_context(|| format!("{}: not an S3G bot", machine_path.display()))?;
    let opts = JobOptions {
        allow_unknown,
        ..Default::default()
    };
    // Every error is found before the bot moves.
    let scan = scan_job(JobReader::open(&machine, job_path, &opts)?, &mut |_, _| {})?;
    if !quiet {
        for w in &scan.warnings {
            eprintln!("warning: {w}");
        }
    }
    let out = out.unwrap_or_else(|| PathBuf::from("out").join(job_name(job_path)));
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let port = serialport::new(port_path, baud)
        .timeout(Duration::from_millis(10))
        .open()
        .with_context(|| format!("--nodes s3g:{port_path}: cannot open the serial port"))?;
    let started = Instant::now();
    let mut driver = Driver::connect(port, &machine, DriverConfig::default())
        .with_context(|| format!("--nodes s3g:{port_path}"))?;
    driver.on_pause(Box::new(pause));
    let mut reader = JobReader::open(&machine, job_path, &opts)?;
    for c in reader.by_ref() {
        let c = c?;
        driver.push(&c.item).with_context(|| {
            format!(
                "{}:{}: on the bot at s3g:{port_path}",
                job_path.display(),
                c.loc
            )
        })?;
    }
    let s = driver
        .finish()
        .with_context(|| format!("--nodes s3g:{port_path}: finishing the job"))?;
    let report = serde_json::json!({
        "machine": machine.name,
        "bot": format!("s3g:{port_path}@{baud}"),
        "commands": scan.commands,
        "points": s.points,
        "actions": s.actions,
        "planned_s": s.planned_s,
        "bot_s": s.bot_s,
        "wall_s": started.elapsed().as_secs_f64(),
        "link": {
            "packets": s.link.packets,
            "resends": s.link.resends,
            "buffer_full": s.link.buffer_full,
            "buffer_polls": s.link.polls,
            "crc_errors": s.link.crc_errors,
            "noise_bytes": s.link.noise_bytes,
        },
        "temperatures": s.temperatures.iter().map(|(k, r)| (k.clone(), serde_json::json!({
            "temp_c": r.temp, "target_c": r.target, "peak_c": r.peak,
        }))).collect::<serde_json::Map<_, _>>(),
    });
    std::fs::write(
        out.join("report.json"),
        serde_json::to_string_pretty(&report)? + "\n",
    )?;
    if !quiet {
        println!(
            "{}: {} points, {} actions on s3g:{port_path}; {:.1} s of motion in {:.1} s; {} resends, {} buffer-full waits",
            job_path.display(),
            s.points,
            s.actions,
            s.planned_s,
            started.elapsed().as_secs_f64(),
            s.link.resends,
            s.link.buffer_full
        );
        println!("  wrote {}/report.json", out.display());
    }
    Ok(())
}

/// A pause in the job: the bot is at rest; M0 waits for Enter, M1 (optional)
/// goes on.
fn pause(optional: bool) {
    if optional || !std::io::stdin().is_terminal() {
        eprintln!(
            "pause{}: going on",
            if optional {
                " (optional)"
            } else {
                " (no terminal to wait on)"
            }
        );
        return;
    }
    eprint!("paused: press Enter to go on ");
    let _ = std::io::stderr().flush();
    let _ = std::io::stdin().lock().read_line(&mut String::new());
}

/// `motet node --sim --type s3g`.
pub struct BotArgs {
    pub listen: String,
    pub announce: bool,
    pub time_scale: f64,
    pub idle_exit: Option<f64>,
    pub faults: Option<String>,
    pub record: Option<PathBuf>,
    pub quiet: bool,
}

/// Runs a simulated S3G bot on a new pseudo-terminal.
pub fn bot(a: BotArgs) -> Result<()> {
    if a.listen != "pty" {
        bail!(
            "--listen {:?}: an S3G bot listens on a pseudo-terminal only (`--listen pty`)",
            a.listen
        );
    }
    let faults = Faults::parse(a.faults.as_deref().unwrap_or("")).context("--faults")?;
    let mut record = match &a.record {
        Some(p) => Some(std::io::BufWriter::new(
            std::fs::File::create(p).with_context(|| format!("--record {}", p.display()))?,
        )),
        None => None,
    };
    let (mut master, slave) =
        serialport::TTYPort::pair().context("cannot open a pseudo-terminal")?;
    master.set_timeout(Duration::from_millis(2))?;
    let name = slave.name().context("the pseudo-terminal has no name")?;
    // The far end stays open here too, so the master never reads EOF
    // between host sessions.
    std::mem::forget(slave);
    if a.announce {
        println!(
            "{}",
            motet_net::spawn::announce_line(&format!("s3g:{name}"), 0)
        );
    } else {
        println!(
            "motet node: simulated S3G bot, {BUFFER_BYTES}-byte buffer, listening on s3g:{name}"
        );
    }
    std::io::stdout().flush()?;
    let mut served = Served::new(Bot::new(BUFFER_BYTES, 3.0), faults);
    let t0 = Instant::now();
    let scale = a.time_scale;
    let mut now = || t0.elapsed().as_secs_f64() * 1e6 * scale;
    let (mut last_packets, mut last_seen) = (0, Instant::now());
    let mut report = |e: &motet_s3g::bot::Executed, _: &Served| -> std::io::Result<()> {
        if let Some(w) = record.as_mut() {
            let s = e.steps;
            writeln!(
                w,
                "{},{},{},{},{},{},{}",
                e.n, e.clock_us, s[0], s[1], s[2], s[3], s[4]
            )?;
            w.flush()?;
        }
        Ok(())
    };
    let idle = a.idle_exit;
    serve(
        &mut served,
        &mut master,
        &mut now,
        &mut report,
        &mut |s: &Served| {
            if s.stats.packets != last_packets {
                last_packets = s.stats.packets;
                last_seen = Instant::now();
            }
            idle.is_none_or(|i| last_seen.elapsed().as_secs_f64() < i || !s.bot.finished())
        },
    )?;
    if !a.quiet {
        eprintln!(
            "no host for {} s: exiting; {} points received, {} run, {} times the queue ran dry after a point, {} good packets, {} CRC errors, {} faults injected",
            idle.unwrap_or(0.0),
            served.bot.points_received,
            served.bot.points_run,
            served.bot.underruns,
            served.stats.packets,
            served.stats.crc_errors,
            served.stats.faults
        );
    }
    Ok(())
}
