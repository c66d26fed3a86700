//! `motet bench-wire`: bytes on the wire per second of motion for a job, with
//! compact segment batches and with one plain segment message per segment.

use anyhow::{Context, Result};
use motet_api::job::{parse_job, read_bytes};
use motet_api::{JobKind, JobOptions};
use motet_host::{Distributor, Machine};
use motet_planner::{ranges, Planned, Planner};
use motet_wire::frame::OVERHEAD;
use motet_wire::{encode, HostMessage, MAX_MESSAGE};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Machine file (TOML).
    machine: PathBuf,
    /// Job (G-code, optionally .gz, or SVG).
    job: PathBuf,
    /// Replace every actuator chain's microstep value.
    #[arg(long, value_parser = crate::flags::count::<u32>(ranges::MICROSTEPS))]
    microsteps: Option<u32>,
}

/// Host → node traffic of one encoding.
#[derive(Default)]
struct Traffic {
    messages: u64,
    payload: u64,
}

impl Traffic {
    fn add(&mut self, m: &HostMessage) -> Result<()> {
        let mut buf = [0u8; MAX_MESSAGE];
        self.payload += encode(m, &mut buf)
            .map_err(|e| anyhow::anyhow!("{e}"))?
            .len() as u64;
        self.messages += 1;
        Ok(())
    }

    fn print(&self, what: &str, seconds: f64) {
        // One frame per message, and one pure-ack frame back for each.
        let frames = self.messages;
        let wire = self.payload + 2 * frames * OVERHEAD as u64;
        println!(
            "{what}: {:.2} messages/s, {:.2} frames/s, payload {:.1} B/s, wire {:.1} B/s ({:.3} KB/s) incl. {} B frame overhead and a {} B ack per frame",
            self.messages as f64 / seconds,
            frames as f64 / seconds,
            self.payload as f64 / seconds,
            wire as f64 / seconds,
            wire as f64 / seconds / 1000.0,
            OVERHEAD,
            OVERHEAD,
        );
    }
}

/// The machine file's text with every `microstep = N` set to `m`.
pub(crate) fn with_microsteps(text: &str, m: u32) -> String {
    let key = "microstep";
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find(key) {
        let (head, tail) = rest.split_at(i + key.len());
        out.push_str(head);
        let after = tail.trim_start_matches([' ', '=']);
        let digits = after.len() - after.trim_start_matches(|c: char| c.is_ascii_digit()).len();
        if after.len() < tail.len() && digits > 0 {
            out.push_str(&format!(" = {m}"));
            rest = &after[digits..];
        } else {
            rest = tail;
        }
    }
    out.push_str(rest);
    out
}

pub fn bench_wire(args: Args) -> Result<()> {
    let text = std::fs::read_to_string(&args.machine)
        .with_context(|| format!("reading {}", args.machine.display()))?;
    let text = match args.microsteps {
        Some(m) => with_microsteps(&text, m),
        None => text,
    };
    let machine = Machine::parse(&text, &args.machine)?;
    let steps: Vec<String> = machine
        .actuators
        .iter()
        .map(|a| format!("{} {:.2}", a.name, a.steps_per_unit))
        .collect();
    println!(
        "machine: {} (steps/unit: {})",
        args.machine.display(),
        steps.join(", ")
    );
    let data = read_bytes(&args.job)?;
    let kind = JobKind::of(&args.job)?;
    let job = parse_job(
        &machine,
        &args.job,
        kind,
        &data,
        &JobOptions {
            allow_unknown: true,
            ..Default::default()
        },
    )?;
    let (batched, plain, seconds, segments) = measure(&machine, &job.commands)?;
    if seconds <= 0.0 {
        anyhow::bail!("{}: the job has no motion to measure", args.job.display());
    }
    println!(
        "job: {} — {:.0} s of motion, {} segments ({:.1}/s)",
        args.job.display(),
        seconds,
        segments,
        segments as f64 / seconds
    );
    batched.print("batched segments", seconds);
    plain.print("plain segments  ", seconds);
    Ok(())
}

fn measure(
    machine: &Machine,
    commands: &[motet_planner::Located<motet_planner::Command>],
) -> Result<(Traffic, Traffic, f64, u64)> {
    let (mut batched, mut plain) = (Traffic::default(), Traffic::default());
    let mut dist = Distributor::new(machine);
    let mut old = Distributor::new(machine);
    for msgs in dist.stream_setup(machine, &machine.start) {
        for m in &msgs {
            batched.add(m)?;
        }
    }
    for k in 0..machine.nodes.len() {
        for m in &old.setup(machine, k, &machine.start) {
            plain.add(m)?;
        }
    }
    let mut planner = Planner::new(machine.limits(), machine.start, 0.0);
    let mut segments = 0u64;
    let mut item = |x: Planned| -> Result<()> {
        segments += matches!(x, Planned::Segment(_)) as u64;
        let q = dist.quantize(&x);
        for k in 0..machine.nodes.len() {
            for out in dist.route_batched(k, &q)? {
                batched.add(&out.message)?;
            }
            if let Some(m) = old.route(k, &x) {
                plain.add(&m)?;
            }
        }
        Ok(())
    };
    for c in commands {
        planner.push(&c.item)?;
        while let Some(x) = planner.pop() {
            item(x)?;
        }
    }
    planner.finish();
    while let Some(x) = planner.pop() {
        item(x)?;
    }
    for k in 0..machine.nodes.len() {
        if let Some(out) = dist.flush(k) {
            batched.add(&out.message)?;
        }
    }
    Ok((batched, plain, planner.clock() * 1e-6, segments))
}

#[cfg(test)]
mod tests {
    #[test]
    fn microsteps_are_rewritten() {
        let t = "chain = [{ stepper = {} }, { microstep = 16 }]\n# microstep\nx = { microstep=8 }";
        assert_eq!(
            super::with_microsteps(t, 128),
            "chain = [{ stepper = {} }, { microstep = 128 }]\n# microstep\nx = { microstep = 128 }"
        );
    }
}
