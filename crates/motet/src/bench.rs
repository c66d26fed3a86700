//! `motet bench`: parse, plan and simulate a real slicer's G-code and print the
//! figures the project tracks.

use crate::bench_memory::{repeated_job, run_peak_mib, Scratch};
use crate::run::load_machine;
use anyhow::{Context, Result};
use motet_api::job::Job;
use motet_api::job::{parse_job, read_bytes};
use motet_api::{job_name, JobKind, JobOptions};
use motet_planner::{Command, Located, Planned, Planner};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A script's session: 10,000 `move_to` calls around a circle, streamed as
/// they come. Prints the longest call and how often the machine had to stop.
fn interactive(machine: motet_host::Machine) -> Result<()> {
    let mut m = motet_api::Machine::new(machine)?;
    m.move_to(&[("x", 100.0), ("y", 100.0)], Some(200.0))?;
    let (mut longest, start) = (0.0f64, Instant::now());
    let n = 10_000;
    for k in 0..n {
        let a = k as f64 * 0.05;
        let t = Instant::now();
        m.move_to(
            &[("x", 110.0 + 40.0 * a.cos()), ("y", 110.0 + 40.0 * a.sin())],
            Some(150.0),
        )?;
        longest = longest.max(t.elapsed().as_secs_f64());
    }
    // Measured times are never 0, so every rate below is a finite number.
    let calls = start.elapsed().as_secs_f64().max(1e-9);
    m.wait()?;
    let r = m.report();
    println!(
        "interactive: {n} move_to calls in {:.3} s ({:.1} µs each, longest {:.3} ms); {:.1} s of motion, {} stops at rest between moves, {} underruns",
        calls,
        calls / n as f64 * 1e6,
        longest * 1e3,
        r.duration_s,
        r.rests.saturating_sub(1),
        r.underruns
    );
    Ok(())
}

pub fn bench(
    machine_path: &Path,
    job_path: &Path,
    repeat: usize,
    no_sim: bool,
    microsteps: Option<u32>,
    long: usize,
    instructions: Option<usize>,
) -> Result<()> {
    let scratch = Scratch::new()?;
    let (machine, run_machine) = bench_machine(machine_path, microsteps, &scratch)?;
    let data = read_bytes(job_path)?;
    let lines = data.iter().filter(|b| **b == b'\n').count();
    let repeat = repeat.max(1);
    let (loaded, parse_s) = parsing(&machine, job_path, &data, lines, repeat)?;
    planning(&machine, &loaded.commands, repeat, parse_s)?;
    interactive(machine.clone())?;
    if !no_sim {
        simulation(&machine, job_path, loaded)?;
        let once = run_peak_mib(&run_machine, job_path, &scratch.0.join("once"))?;
        println!("peak memory: {once:.1} MiB for `motet run` on the job (its own process)");
        if let Some(n) = instructions {
            match crate::bench_instructions::measure(&run_machine, &data, n, &scratch)? {
                Some(p) => println!(
                    "instructions per step (callgrind, `motet run` on the first {n} lines, {} steps): nodes {:.0} (of which the step solve {:.0}), observer {:.0}, whole run {:.0}",
                    p.steps, p.node, p.solve, p.observer, p.whole
                ),
                None => println!(
                    "instructions per step: valgrind is not installed (Debian: apt-get install valgrind)"
                ),
            }
        }
        if long > 1 {
            long_memory(&run_machine, job_path, data, lines, long, once, &scratch)?;
        }
    }
    Ok(())
}

/// The machine, and the file `motet run` is measured on: the machine file,
/// or its copy with `microsteps` in every actuator chain.
fn bench_machine(
    machine_path: &Path,
    microsteps: Option<u32>,
    scratch: &Scratch,
) -> Result<(motet_host::Machine, PathBuf)> {
    Ok(match microsteps {
        None => (load_machine(machine_path)?, machine_path.to_path_buf()),
        Some(m) => {
            let text = std::fs::read_to_string(machine_path)
                .with_context(|| format!("reading {}", machine_path.display()))?;
            let edited = crate::bench_wire::with_microsteps(&text, m);
            let copy = scratch.0.join("machine.toml");
            std::fs::write(&copy, &edited)?;
            (motet_host::Machine::parse(&edited, machine_path)?, copy)
        }
    })
}

/// Parses the job (`data`, `lines` lines) `repeat` times and prints the
/// best time; returns the job and that time, s.
fn parsing(
    machine: &motet_host::Machine,
    job_path: &Path,
    data: &[u8],
    lines: usize,
    repeat: usize,
) -> Result<(Job, f64)> {
    let kind = JobKind::of(job_path)?;
    let opts = JobOptions {
        allow_unknown: true,
        ..Default::default()
    };
    let mut parse_best = f64::INFINITY;
    let mut loaded = None;
    for _ in 0..repeat {
        let t = Instant::now();
        let job = parse_job(machine, job_path, kind, data, &opts)?;
        parse_best = parse_best.min(t.elapsed().as_secs_f64());
        loaded = Some(job);
    }
    let loaded = loaded.expect("at least one parse");
    let parse_best = parse_best.max(1e-9);
    println!(
        "job: {} ({} lines, {:.1} MB, {} commands)",
        job_path.display(),
        lines,
        data.len() as f64 / 1e6,
        loaded.commands.len()
    );
    println!(
        "parsing: {:.3} s: {:.0} MB/s (text to checked commands, best of {})",
        parse_best,
        data.len() as f64 / 1e6 / parse_best,
        repeat
    );
    Ok((loaded, parse_best))
}

/// Plans `commands` `repeat` times and prints the best rate, the rate from
/// file to trajectory (with `parse_s`, the parsing time) and the job's
/// duration.
fn planning(
    machine: &motet_host::Machine,
    commands: &[Located<Command>],
    repeat: usize,
    parse_s: f64,
) -> Result<()> {
    let mut best = f64::INFINITY;
    let mut segments = 0;
    let mut duration = 0.0;
    for _ in 0..repeat {
        let t = Instant::now();
        let mut p = Planner::new(machine.limits(), machine.start, 0.0);
        let mut n = 0usize;
        for c in commands {
            p.push(&c.item)?;
            while let Some(x) = p.pop() {
                n += matches!(x, Planned::Segment(_)) as usize;
            }
        }
        p.finish();
        while let Some(x) = p.pop() {
            n += matches!(x, Planned::Segment(_)) as usize;
        }
        best = best.min(t.elapsed().as_secs_f64().max(1e-9));
        segments = n;
        duration = p.clock() * 1e-6;
    }
    let moves = commands.len();
    println!(
        "planning: {} commands -> {} segments in {:.3} s: {:.2} M moves/s (best of {})",
        moves,
        segments,
        best,
        moves as f64 / best / 1e6,
        repeat
    );
    println!(
        "file to trajectory: {:.3} s: {:.2} M moves/s (parsing plus planning)",
        parse_s + best,
        moves as f64 / (parse_s + best) / 1e6
    );
    println!(
        "job duration: {:.0} s ({:.2} h)",
        duration,
        duration / 3600.0
    );
    Ok(())
}

/// Simulates the whole job and prints its speed and accuracy; the job and
/// the simulation's results are dropped on return, before memory is
/// measured.
fn simulation(machine: &motet_host::Machine, job_path: &Path, loaded: Job) -> Result<()> {
    let r = motet_sim::simulate(
        machine,
        &job_name(job_path),
        &loaded.commands,
        &mut |_, _| {},
    )?;
    let steps: u64 = r.report.actuators.iter().map(|a| a.steps).sum();
    let wall = r.report.wall_s.max(1e-6);
    println!(
        "simulation: {:.0} s of motion in {:.2} s wall: {:.0}x real time; {} steps ({:.1} M steps/s)",
        r.report.duration_s,
        r.report.wall_s,
        r.report.speed_factor,
        steps,
        steps as f64 / wall / 1e6
    );
    println!(
        "accuracy: step-time error {:.4} µs max, executed path within {:.4} mm ({:.3} steps) of the commanded path",
        r.report.max_step_time_error_us, r.report.max_path_deviation_mm, r.report.max_deviation_steps
    );
    Ok(())
}

/// `motet run`'s peak memory on the job (`data`, `lines` lines) written
/// `long` times over into one file, against `once_mib` for the job once.
fn long_memory(
    run_machine: &Path,
    job_path: &Path,
    data: Vec<u8>,
    lines: usize,
    long: usize,
    once_mib: f64,
    scratch: &Scratch,
) -> Result<()> {
    let name = format!("{}-x{long}.gcode", job_name(job_path));
    let long_job = scratch.0.join(name);
    repeated_job(&data, long, &long_job)?;
    drop(data);
    let peak = run_peak_mib(run_machine, &long_job, &scratch.0.join("long"))?;
    println!(
        "peak memory: {peak:.1} MiB for the job {long} times over ({} lines): {:+.1} % against once",
        lines * long,
        (peak / once_mib - 1.0) * 100.0
    );
    Ok(())
}
