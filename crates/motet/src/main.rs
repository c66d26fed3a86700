//! The `motet` command line. Thin: it reads files, calls the libraries, and
//! prints; all behaviour lives in the crates.

mod bench;
mod bench_instructions;
mod bench_memory;
mod bench_net;
mod bench_net_traffic;
mod bench_wire;
mod bus_arg;
mod cable;
mod dance;
mod elf;
mod error_text;
mod flags;
mod heaters;
mod machine_cmd;
mod modules;
mod net_report;
mod netrun;
mod node;
mod nodes;
mod peak;
mod run;
mod s3g;
mod serve;
mod tune;

use clap::{Parser, Subcommand};
use motet_api::{JobOptions, Placement};
use motet_planner::ranges;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "motet",
    version,
    about = "Describe a machine, drive it from G-code, SVG and photos, on simulated or networked nodes"
)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand)]
enum NodesCmd {
    /// List the nodes that answer on links.
    Scan {
        /// Link to scan (repeatable): udp:HOST:PORT, serial:PATH[@BAUD], slcan:PATH[@BITRATE].
        #[arg(long = "link", required = true)]
        links: Vec<String>,
        /// Seconds to wait for answers.
        #[arg(long, default_value_t = 1.0, value_parser = flags::number(ranges::WAIT_S))]
        wait: f64,
    },
    /// Give each node of a machine an address and write the pairing file beside it.
    Pair {
        machine: PathBuf,
        /// NODE=LINK for each node of the machine (repeatable).
        #[arg(long = "link", required = true)]
        links: Vec<String>,
        /// Ask for a button press even for a node alone on its link.
        #[arg(long)]
        button: bool,
        /// Seconds to wait for a button press.
        #[arg(long, default_value_t = 60.0, value_parser = flags::number(ranges::WAIT_S))]
        wait: f64,
    },
    /// State of each paired node of a machine.
    Status { machine: PathBuf },
    /// Make a paired node blink.
    Identify {
        machine: PathBuf,
        node: String,
        #[arg(long, default_value_t = 5.0, value_parser = flags::number(ranges::WAIT_S))]
        seconds: f64,
    },
    /// Upload a firmware image to a paired node (write, read back, verify, start).
    Flash {
        machine: PathBuf,
        node: String,
        image: PathBuf,
    },
    /// Build a firmware image file from a payload.
    Image {
        #[arg(long)]
        kind: String,
        /// The board the payload is built for (`mps2-an500`, …): a board
        /// refuses images for another board or for none.
        #[arg(long)]
        board: Option<String>,
        #[arg(long)]
        version: String,
        /// The payload: a flat binary, or the firmware's ELF file (its
        /// loadable segments are laid out at their load addresses).
        payload: PathBuf,
        #[arg(long, short)]
        out: PathBuf,
    },
}

/// `motet run`'s arguments.
#[derive(clap::Args)]
struct RunArgs {
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
    /// Which nodes run the job: `sim` (simulated in this process: render
    /// and report), `spawn` (node processes started for the run),
    /// `paired` (the paired nodes), or `s3g:PORT[@BAUD]` (the whole
    /// machine is a MakerBot-style S3G bot on a serial port; docs/compat.md).
    #[arg(long, default_value = "sim", value_parser = s3g::nodes_arg)]
    nodes: s3g::NodesArg,
    /// With --nodes spawn|paired: run time this many times faster than
    /// real time (nodes started by hand need the same --time-scale).
    #[arg(long, default_value_t = 1.0, value_parser = flags::number(ranges::TIME_SCALE))]
    time_scale: f64,
    /// With --nodes spawn|paired: least time the committed trajectory
    /// reaches ahead, ms of the run's time (at least 2×RTT, and 50 ms of
    /// wall time, are used anyway).
    #[arg(long, default_value_t = 100.0, value_parser = flags::number(ranges::LEAD_MS))]
    lead_ms: f64,
    /// With --nodes spawn|paired: longest time between clock exchanges
    /// with each node, ms. They are as rare as each clock's error bound
    /// allows and no rarer than this (about 70 bytes per exchange); a node
    /// with nothing else to say is asked after 1 s anyway.
    #[arg(long, default_value_t = 10_000.0, value_parser = flags::number(ranges::SYNC_MS))]
    sync_ms: f64,
    /// With --nodes spawn: every node on one shared medium, a UDP
    /// multicast group, as on a CAN bus: `udp` (a new group on this
    /// computer's loopback) or `udp-group:GROUP:PORT[@IFACE]`. Seals and
    /// stops reach every node in one frame, one sync frame aligns every
    /// clock, and the nodes hear one another's heartbeats.
    #[arg(long, value_name = "udp|udp-group:…")]
    bus: Option<String>,
    /// With --nodes spawn|paired, on a computer too busy for the clock
    /// target: past the connect timeout, start once every node's clock is
    /// known within what the machine's path allows (100 × the target, at
    /// least 1 ms), naming each clock that fell short. Without it nothing
    /// moves on a clock above its target, but for a machine's only node
    /// that moves or drives a tool (its clock sets no two nodes apart).
    /// Implied by --nodes spawn (its simulated nodes share this computer's
    /// cores). A resume keeps the choice.
    #[arg(long)]
    start_late_clocks: bool,
    #[command(flatten)]
    place: flags::PlacementFlags,
    /// With --nodes sim: inject a fault into a heater a node drives, at a
    /// time of the job (s): disconnected, sensor-lost or thermistor-off,
    /// e.g. hotend=disconnected@60 (repeatable).
    #[arg(long, value_name = "NAME=KIND@S", value_parser = heaters::parse_fault)]
    heater_fault: Vec<(String, motet_host::heater_loop::HeaterFault)>,
}

#[derive(Subcommand)]
enum Cmd {
    /// Run a job (G-code, SVG or a photo) on the simulated machine and write a render and a report.
    Run(RunArgs),
    /// Continue a networked job that stopped, from where every node came to
    /// rest, after checking that the files, the journal and the nodes are the run's.
    Resume {
        /// The stopped run's output folder (it holds resume.toml and the journal).
        out: PathBuf,
        /// Where the machine is, for nodes that lost their position (restarted
        /// or reset): AXIS=VALUE,… for the axes they drive, e.g. x=10,y=20.5.
        /// Measure it or home the machine first: the job continues from there.
        #[arg(long, value_name = "AXIS=VALUE,…")]
        assume_position: Option<String>,
        /// The machine file, if it moved since the run (it must be the same file).
        #[arg(long)]
        machine: Option<PathBuf>,
        /// The job file, if it moved since the run (it must be the same file).
        #[arg(long)]
        job: Option<PathBuf>,
        #[arg(long, short)]
        quiet: bool,
    },
    /// Run a simulated node in this process, reachable on UDP or a
    /// pseudo-terminal. `kill -USR1 PID` pulls its cable (it neither hears
    /// nor is heard, and runs on); the next one plugs it back.
    Node {
        /// Simulated node (the only kind this command runs).
        #[arg(long, required = true)]
        sim: bool,
        /// Node type reported to the host.
        #[arg(long = "type", default_value = "stepper")]
        kind: String,
        /// `udp:HOST:PORT` (port 0: any free one), `pty` (a new
        /// pseudo-terminal; its path is printed), or
        /// `udp-group:GROUP:PORT[@IFACE]` (a member of a multicast group
        /// with the host and the other nodes, as on a bus).
        #[arg(long, default_value = "udp:127.0.0.1:0")]
        listen: String,
        /// Print one line `motet-node listening LINK uid UID` first (for scripts).
        #[arg(long)]
        announce: bool,
        /// File keeping the node's uid, address and firmware version across restarts.
        #[arg(long)]
        state: Option<PathBuf>,
        /// Unique id (hex) when the state file has none [default: random].
        #[arg(long)]
        uid: Option<String>,
        /// Crystal error of the node's clock, parts per million.
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = flags::number(ranges::PPM))]
        ppm: f64,
        /// Run the node's clock this many times faster than real time.
        #[arg(long, default_value_t = 1.0, value_parser = flags::number(ranges::TIME_SCALE))]
        time_scale: f64,
        /// Press the pairing button as soon as the node is asked to pair.
        #[arg(long)]
        auto_press: bool,
        /// Exit after this many seconds without a frame from a host.
        #[arg(long, value_parser = flags::number(ranges::WAIT_S))]
        idle_exit: Option<f64>,
        /// With --type s3g: misbehave, e.g. `crc=5,full=3,garbage=7,generic=9,reply-crc=4,ack-crc=20,silent-after=100`
        /// (every N-th packet).
        #[arg(long)]
        faults: Option<String>,
        /// With --type s3g: write each point run as a line `n,clock_us,x,y,z,a,b` (steps).
        #[arg(long)]
        record: Option<PathBuf>,
        /// Run the servo, sensor and heater channels of this machine file's node
        /// (`--plant-node`) on its simulated plant (motors, encoders,
        /// switches, sensors).
        #[arg(long, requires = "plant_node")]
        plant: Option<PathBuf>,
        /// The node of `--plant`'s machine file.
        #[arg(long, requires = "plant")]
        plant_node: Option<String>,
        /// A description file: the module this node is (docs/network.md,
        /// "Machines from modules").
        #[arg(long, value_name = "FILE")]
        describe: Option<PathBuf>,
        #[arg(long, short)]
        quiet: bool,
    },
    /// Find, pair, inspect and update nodes.
    Nodes {
        #[command(subcommand)]
        command: NodesCmd,
    },
    /// Tune a servo actuator: its node runs drive steps (and a relay) on
    /// the simulated plant, the gains follow (Ziegler–Nichols, or from the
    /// identified model), a move checks them, a plot shows it all.
    Tune {
        /// Machine file (TOML).
        machine: PathBuf,
        /// The servo actuator's name.
        actuator: String,
        /// `step` (drive steps: the reaction curve) or `relay`
        /// (Åström–Hägglund: the ultimate gain and period).
        #[arg(long, default_value = "step")]
        method: String,
        /// `model` (from the identified motor) or `zn` (Ziegler–Nichols).
        #[arg(long, default_value = "model")]
        rule: String,
        /// Write the gains into the machine file (its comments kept).
        #[arg(long)]
        write: bool,
        /// Where the plot goes [default: out/tune].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Machines from modules: compose the modules on the bus (or
    /// description files) into a machine file, follow them live.
    Machine {
        #[command(subcommand)]
        command: machine_cmd::MachineCmd,
    },
    /// Check a machine file and a job without running it.
    Check {
        machine: PathBuf,
        job: Option<PathBuf>,
        #[arg(long)]
        allow_unknown: bool,
        /// `paired`: also check that the modules on the bus are those the
        /// machine file records, and that they still make a machine fit
        /// for the job.
        #[arg(long, value_parser = ["paired"])]
        nodes: Option<String>,
        #[command(flatten)]
        place: flags::PlacementFlags,
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
        #[arg(long, value_parser = flags::number(ranges::DANCE_S))]
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
    /// Serve the machine over HTTP: a browser page, a JSON API and a
    /// WebSocket to upload jobs, start, pause, stop and jog.
    Serve(serve::ServeArgs),
    /// Measure parsing, planning and simulation speed on a real slicer's G-code.
    Bench {
        #[arg(long, default_value = "examples/printer.toml")]
        machine: PathBuf,
        #[arg(long, default_value = "bench/data/prusaslicer-twisted-vase.gcode.gz")]
        job: PathBuf,
        /// Repetitions of the planning measurement (the best is reported).
        #[arg(long, default_value_t = 3, value_parser = flags::count::<u32>(ranges::REPEAT))]
        repeat: u32,
        /// Skip the full simulation.
        #[arg(long)]
        no_sim: bool,
        /// Replace every actuator chain's microstep value (as bench-net's).
        #[arg(long, value_parser = flags::count::<u32>(ranges::MICROSTEPS))]
        microsteps: Option<u32>,
        /// Also measure `motet run`'s peak memory on the job written N times
        /// over into one file.
        #[arg(long, value_parser = flags::count::<u32>(ranges::LONG_JOB))]
        long: Option<u32>,
        /// Also count instructions per step under callgrind (valgrind) on
        /// the job's first N lines.
        #[arg(long, value_name = "LINES", value_parser = flags::count::<u32>(ranges::INSTRUCTION_LINES))]
        instructions: Option<u32>,
    },
    /// Bytes on the wire per second of motion for a job (batched and plain segments).
    BenchWire(bench_wire::Args),
    /// Stream a job through the whole network stack on a simulated clock: bytes on the wire per second of motion, clock error, under optional jitter and faults.
    BenchNet(bench_net::Args),
}

fn main() -> std::process::ExitCode {
    // Output piped into a program that stops reading (`motet … | head`)
    // ends motet quietly, as it ends any command-line tool, instead of a
    // panic in the middle of a print.
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to its default before any
    // thread starts; nothing else handles SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    match dispatch(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_text::error_text(&e));
            std::process::ExitCode::FAILURE
        }
    }
}

/// `motet run`: on the simulated machine, or on node processes or boards.
fn run_cmd(a: RunArgs) -> anyhow::Result<()> {
    let placement = a.place.placement()?;
    match a.nodes {
        s3g::NodesArg::Mode(netrun::NodesMode::Sim) => run::run(
            &a.machine,
            &a.job,
            a.out,
            &JobOptions {
                allow_unknown: a.allow_unknown,
                placement,
            },
            a.quiet,
            &a.heater_fault,
        ),
        // A stopped run resumes from the job file as it is: placing it
        // would need the placement kept with the journal.
        _ if placement != Placement::default() => {
            anyhow::bail!("--fit, --scale, --rotate and --origin work with --nodes sim only")
        }
        s3g::NodesArg::S3g(port, baud) => s3g::run(
            &a.machine,
            &a.job,
            a.out,
            a.allow_unknown,
            a.quiet,
            (&port, baud),
        ),
        s3g::NodesArg::Mode(mode) => netrun::run(netrun::NetArgs {
            machine_path: &a.machine,
            job_path: &a.job,
            out: a.out,
            allow_unknown: a.allow_unknown,
            quiet: a.quiet,
            mode,
            time_scale: a.time_scale,
            lead_ms: a.lead_ms,
            sync_ms: a.sync_ms,
            bus: a.bus,
            start_late_clocks: a.start_late_clocks,
        }),
    }
}

fn dispatch(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Cmd::Run(a) => run_cmd(a),
        Cmd::Resume {
            out,
            assume_position,
            machine,
            job,
            quiet,
        } => netrun::resume_cmd(netrun::ResumeArgs {
            out: &out,
            quiet,
            assume_position: assume_position.as_deref(),
            machine: machine.as_deref(),
            job: job.as_deref(),
        }),
        cmd @ Cmd::Node { .. } => node_cmd(cmd),
        Cmd::Nodes { command } => nodes_cmd(command),
        Cmd::Tune {
            machine,
            actuator,
            method,
            rule,
            write,
            out,
        } => tune::tune_cmd(tune::TuneArgs {
            machine,
            actuator,
            method,
            rule,
            write,
            out,
        }),
        Cmd::Check {
            machine,
            job,
            allow_unknown,
            nodes,
            place,
        } => run::check(
            &machine,
            job.as_deref(),
            &JobOptions {
                allow_unknown,
                placement: place.placement()?,
            },
            nodes.is_some(),
        ),
        Cmd::Machine { command } => machine_cmd::machine_cmd(command),
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
            microsteps,
            long,
            instructions,
        } => bench::bench(
            &machine,
            &job,
            repeat as usize,
            no_sim,
            microsteps,
            long.map_or(0, |n| n as usize),
            instructions.map(|n| n as usize),
        ),
        Cmd::Serve(args) => serve::serve(args),
        Cmd::BenchWire(args) => bench_wire::bench_wire(args),
        Cmd::BenchNet(args) => bench_net::bench_net(args),
    }
}

/// `motet node`: a simulated motet node, or with `--type s3g` a simulated
/// S3G bot.
fn node_cmd(cmd: Cmd) -> anyhow::Result<()> {
    let Cmd::Node {
        sim: _,
        kind,
        listen,
        announce,
        state,
        uid,
        ppm,
        time_scale,
        auto_press,
        idle_exit,
        faults,
        record,
        plant,
        plant_node,
        describe,
        quiet,
    } = cmd
    else {
        unreachable!("dispatch passes `node` only")
    };
    if kind == "s3g" && describe.is_some() {
        anyhow::bail!("--describe is for motet nodes (a simulated S3G bot is one whole machine)");
    }
    if kind == "s3g" {
        return s3g::bot(s3g::BotArgs {
            listen,
            announce,
            time_scale,
            idle_exit,
            faults,
            record,
            quiet,
        });
    }
    if faults.is_some() || record.is_some() {
        anyhow::bail!("--faults and --record are for simulated S3G bots (--type s3g)");
    }
    node::node(node::NodeArgs {
        kind,
        listen,
        announce,
        state,
        uid,
        ppm,
        time_scale,
        auto_press,
        idle_exit,
        quiet,
        plant: plant.zip(plant_node),
        describe,
    })
}

/// `motet nodes ...`: the node management commands.
fn nodes_cmd(command: NodesCmd) -> anyhow::Result<()> {
    match command {
        NodesCmd::Scan { links, wait } => nodes::scan(&links, wait),
        NodesCmd::Pair {
            machine,
            links,
            button,
            wait,
        } => nodes::pair(&machine, &links, button, wait),
        NodesCmd::Status { machine } => nodes::status(&machine),
        NodesCmd::Identify {
            machine,
            node,
            seconds,
        } => nodes::identify(&machine, &node, seconds),
        NodesCmd::Flash {
            machine,
            node,
            image,
        } => nodes::flash(&machine, &node, &image),
        NodesCmd::Image {
            kind,
            board,
            version,
            payload,
            out,
        } => nodes::image(&kind, board.as_deref(), &version, &payload, &out),
    }
}
