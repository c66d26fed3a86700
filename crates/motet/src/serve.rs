//! `motet serve`: one machine, its nodes and its jobs, driven over HTTP, a
//! WebSocket and the browser page (crates/motet-serve).

use anyhow::{bail, Context};
use motet_net::pairing_file::pairing_path;
use motet_net::session::Session;
use motet_serve::{serve_config, LinkedNodes, Nodes, Server, ServerConfig, SimNodes};
use std::io::Write;
use std::net::SocketAddr;
use std::path::PathBuf;

/// Where a server's nodes are.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum NodesAt {
    /// Simulated in this process, on the server's clock.
    Sim,
    /// Simulated node processes this server starts, on UDP.
    Spawn,
    /// The machine's paired nodes (`motet nodes pair`).
    Paired,
}

/// `motet serve` arguments.
#[derive(clap::Args)]
pub struct ServeArgs {
    /// Machine file (TOML).
    machine: PathBuf,
    /// Where the machine's nodes are.
    #[arg(long, value_enum, default_value = "sim")]
    nodes: NodesAt,
    /// Address and port to listen on (port 0: any free port). An address
    /// other than loopback needs the server's token on every request.
    #[arg(long, default_value = "127.0.0.1:8080")]
    listen: SocketAddr,
    /// The server's folder: uploaded jobs and the token [default:
    /// out/serve].
    #[arg(long)]
    dir: Option<PathBuf>,
    /// Require the token on loopback too.
    #[arg(long)]
    token: bool,
    /// Also be a grbl 1.1 device for G-code senders: `pty` (a
    /// pseudo-terminal; its path is printed) or `tcp:ADDRESS:PORT`
    /// (docs/compat.md). Same machine, same state as the web page.
    #[arg(long, value_name = "pty|tcp:ADDR:PORT")]
    grbl: Option<motet_serve::device::port::Port>,
    /// Drive the machine by hand through this motion-stream graph (as
    /// `motet dance`): it runs on a simulated node, paced to the wall
    /// clock, its `[inputs]` set live from the page's sliders or
    /// `/api/graph/inputs`. The machine then takes no jobs.
    #[arg(long, value_name = "GRAPH.toml", conflicts_with_all = ["grbl", "klipper_api", "ebb", "marlin"])]
    graph: Option<PathBuf>,
    /// Also be Klipper's API server for a printer host (Moonraker, and
    /// through it Mainsail or Fluidd): its Unix socket, Moonraker's
    /// `klippy_uds_address` (docs/compat.md).
    #[arg(long, value_name = "PATH")]
    klipper_api: Option<PathBuf>,
    /// The folder the printer host keeps G-code files in (Klipper's
    /// `[virtual_sdcard] path`) [default: ~/printer_data/gcodes].
    #[arg(long, value_name = "DIR", requires = "klipper_api")]
    klipper_gcodes: Option<PathBuf>,
    /// Also be an EiBotBoard for the AxiDraw software and plotink: `pty`
    /// or `tcp:ADDRESS:PORT` (docs/compat.md). May be given with --grbl.
    #[arg(long, value_name = "pty|tcp:ADDR:PORT")]
    ebb: Option<motet_serve::device::port::Port>,
    /// Also be a Marlin-style printer for print hosts (OctoPrint): `pty`
    /// or `tcp:ADDRESS:PORT` (docs/compat.md).
    #[arg(long, value_name = "pty|tcp:ADDR:PORT")]
    marlin: Option<motet_serve::device::port::Port>,
}

/// Runs the server until Ctrl-C or SIGTERM; then stops the machine on its
/// path.
pub fn serve(args: ServeArgs) -> anyhow::Result<()> {
    let machine = motet_host::Machine::load(&args.machine)?;
    let dir = args.dir.unwrap_or_else(|| PathBuf::from("out/serve"));
    std::fs::create_dir_all(&dir).with_context(|| format!("{}", dir.display()))?;
    let needs_token = args.token || !args.listen.ip().is_loopback();
    let token = if needs_token {
        let (t, made) = motet_serve::auth::load_or_make_token(&dir)
            .with_context(|| format!("{}/token", dir.display()))?;
        if made {
            println!("token (shown once; kept in {}/token): {t}", dir.display());
        } else {
            println!("token: in {}/token", dir.display());
        }
        Some(t)
    } else {
        None
    };
    let graph = match &args.graph {
        Some(p) => Some(motet_graph::GraphFile::load(p)?),
        None => None,
    };
    let nodes = nodes(&machine, &args.machine, args.nodes)?;
    let name = machine.name.clone();
    let where_ = match args.nodes {
        NodesAt::Sim => "simulated",
        NodesAt::Spawn => "spawned",
        NodesAt::Paired => "paired",
    };
    let grbl = args.grbl;
    let klipper = args.klipper_api.map(|sock| {
        let gcodes = args.klipper_gcodes.unwrap_or_else(|| {
            let home = std::env::var_os("HOME").map_or_else(|| PathBuf::from("."), PathBuf::from);
            home.join("printer_data/gcodes")
        });
        (sock, gcodes)
    });
    let ebb = args.ebb;
    let marlin = args.marlin;
    let cfg = ServerConfig {
        listen: args.listen,
        dir,
        token,
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    rt.block_on(async move {
        let listener = match tokio::net::TcpListener::bind(cfg.listen).await {
            Ok(l) => l,
            Err(e) => bail!("--listen {}: {e}", cfg.listen),
        };
        let addr = listener.local_addr()?;
        let server = Server::start(machine, nodes, &cfg)?;
        if let Some(g) = graph {
            let file = g.file.clone();
            server
                .drive_by_graph(g)
                .with_context(|| format!("--graph {file}"))?;
            println!("graph: {file}, inputs set from the page or /api/graph/inputs");
        }
        println!("motet serve: machine {name} on {where_} nodes at http://{addr}/");
        if let Some(port) = &grbl {
            let at = server
                .grbl(port)
                .with_context(|| format!("--grbl {port}"))?;
            println!("grbl: {at}");
        }
        if let Some((sock, gcodes)) = &klipper {
            let at = server
                .klipper(sock, gcodes)
                .with_context(|| format!("--klipper-api {}", sock.display()))?;
            println!("klipper api: {at} (G-code folder {})", gcodes.display());
        }
        if let Some(port) = &ebb {
            let at = server.ebb(port).with_context(|| format!("--ebb {port}"))?;
            println!("ebb: {at}");
        }
        if let Some(port) = &marlin {
            let at = server
                .marlin(port)
                .with_context(|| format!("--marlin {port}"))?;
            println!("marlin: {at}");
        }
        std::io::stdout().flush()?;
        server.serve(listener, shutdown()).await?;
        println!("motet serve: stopped");
        Ok(())
    })
}

/// The machine's nodes where the person said they are, reached and
/// checked against the machine file.
fn nodes(
    machine: &motet_host::Machine,
    machine_path: &std::path::Path,
    at: NodesAt,
) -> anyhow::Result<Box<dyn Nodes>> {
    let clock = motet_net::clock::wall();
    let session = match at {
        NodesAt::Sim => {
            return Ok(Box::new(SimNodes::new(
                machine,
                machine.start,
                serve_config(),
            )))
        }
        NodesAt::Spawn => {
            let exe = std::env::current_exe().context("cannot find the motet executable")?;
            // The nodes outlive a server killed without its clean-up by
            // ten seconds of silence at most.
            let extra = ["--idle-exit", "10", "--quiet"].map(String::from);
            Session::spawn(machine, &exe, &extra, &clock)?
        }
        NodesAt::Paired => Session::paired(
            machine,
            &crate::nodes::paired(machine_path)?,
            &pairing_path(machine_path),
            &clock,
        )?,
    };
    let kind = if at == NodesAt::Spawn {
        "spawn"
    } else {
        "paired"
    };
    Ok(Box::new(
        LinkedNodes::new(
            machine,
            session,
            machine.start,
            // Other processes and boards: a lead that outlasts a busy host's
            // scheduling delays (and twice the round trip whatever this says).
            motet_serve::linked_config(),
            kind,
        )
        // The page's Pair writes the pairing file where `motet nodes pair`
        // does.
        .pairing_file(pairing_path(machine_path)),
    ))
}

/// Resolves on Ctrl-C or SIGTERM.
async fn shutdown() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {},
        _ = term => {},
    }
}
