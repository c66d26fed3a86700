//! The `motet` command line. Thin: it reads files, calls the libraries, and
//! prints; all behaviour lives in the crates.

mod bench;
mod bench_wire;
mod dance;
mod run;

use clap::{Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "motet",
    version,
    about = "Describe a machine, drive it from G-code and SVG, on simulated nodes"
)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Run a job (G-code or SVG) on the simulated machine and write a render and a report.
    Run {
        /// Machine file (TOML).
        machine: PathBuf,
        /// Job: G-code (.gcode/.nc/.g, optionally .gz), SVG, or a photo (.png/.jpg).
        job: PathBuf,
        /// Output folder [default: out/<job name>].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Skip unsupported G-codes with a warning instead of refusing the job.
        #[arg(long)]
        allow_unknown: bool,
        /// No progress bar or summary.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Check a machine file and a job without running it.
    Check {
        machine: PathBuf,
        job: Option<PathBuf>,
        #[arg(long)]
        allow_unknown: bool,
    },
    /// Run a dataflow graph (graph file) on a simulated node, driven by a CSV
    /// input trace or two pendulums, and render its channels through a machine.
    Dance {
        /// Machine file (TOML): kinematics and steps per unit of the render.
        machine: PathBuf,
        /// Graph file (TOML).
        graph: PathBuf,
        /// Input trace: time_s, then one column per input named in the graph.
        #[arg(long, conflicts_with = "pendulums")]
        inputs: Option<PathBuf>,
        /// Drive the encoders with the graph's [[pendulum]]s (harmonograph).
        #[arg(long)]
        pendulums: bool,
        /// Live inputs: `-` for stdin or ADDR:PORT to listen on (lines
        /// `name=value`, optionally `t=SECONDS`); the run keeps real time.
        #[arg(long, conflicts_with_all = ["inputs", "pendulums"])]
        live: Option<String>,
        /// With --live: replay `t=` stamps as fast as possible instead of
        /// pacing to real time.
        #[arg(long, requires = "live")]
        stamped: bool,
        /// A job (G-code or SVG) planned on the machine and sent to the node
        /// alongside, for the graph's trajectory readers.
        #[arg(long)]
        job: Option<PathBuf>,
        /// Seconds to run [default: the trace's length, or 30 with --pendulums].
        #[arg(long)]
        seconds: Option<f64>,
        /// Load a four-track recording (PATH: one byte per frame; PATH.len:
        /// the sample count) into the node's tape before the run, for a player.
        #[arg(long, value_name = "PATH")]
        load_recording: Option<PathBuf>,
        /// Write the node's tape after the run as PATH (one byte per frame)
        /// and PATH.len (the sample count).
        #[arg(long, value_name = "PATH")]
        save_recording: Option<PathBuf>,
        /// Output folder [default: out/<graph name>].
        #[arg(long)]
        out: Option<PathBuf>,
        #[arg(long, short)]
        quiet: bool,
    },
    /// Measure parsing, planning and simulation speed on a real slicer's G-code.
    Bench {
        #[arg(long, default_value = "examples/printer.toml")]
        machine: PathBuf,
        #[arg(long, default_value = "bench/data/prusaslicer-twisted-vase.gcode.gz")]
        job: PathBuf,
        /// Repetitions of the planning measurement (the best is reported).
        #[arg(long, default_value_t = 3)]
        repeat: usize,
        /// Skip the full simulation.
        #[arg(long)]
        no_sim: bool,
    },
    /// Bytes on the wire per second of motion for a job (batched and plain segments).
    BenchWire(bench_wire::Args),
}

fn main() -> std::process::ExitCode {
    match dispatch(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn dispatch(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Cmd::Run {
            machine,
            job,
            out,
            allow_unknown,
            quiet,
        } => run::run(&machine, &job, out, allow_unknown, quiet),
        Cmd::Check {
            machine,
            job,
            allow_unknown,
        } => run::check(&machine, job.as_deref(), allow_unknown),
        Cmd::Dance {
            machine,
            graph,
            inputs,
            pendulums,
            live,
            stamped,
            job,
            seconds,
            load_recording,
            save_recording,
            out,
            quiet,
        } => dance::dance(dance::DanceArgs {
            machine: &machine,
            graph: &graph,
            inputs: inputs.as_deref(),
            pendulums,
            live: live.as_deref(),
            stamped,
            job: job.as_deref(),
            seconds,
            load_recording: load_recording.as_deref(),
            save_recording: save_recording.as_deref(),
            out,
            quiet,
        }),
        Cmd::Bench {
            machine,
            job,
            repeat,
            no_sim,
        } => bench::bench(&machine, &job, repeat, no_sim),
        Cmd::BenchWire(args) => bench_wire::bench_wire(args),
    }
}
