//! `motet node --sim`: a simulated node in its own process, on a UDP socket
//! or a pseudo-terminal, running the node firmware's endpoint on the wall
//! clock (optionally faster, and with a crystal error).

use anyhow::{bail, Context, Result};
use motet_link::Transport;
use motet_net::clock::{Clock, WallClock};
use motet_net::sim_node::{sim_config, FileStore, SimNode};
use motet_net::spawn::announce_line;
use motet_node::storage::RamStore;
use motet_node::storage::Store;
use serialport::SerialPort;
use std::path::PathBuf;
use std::sync::mpsc;
use std::time::Duration;

pub struct NodeArgs {
    pub kind: String,
    pub listen: String,
    pub announce: bool,
    pub state: Option<PathBuf>,
    pub uid: Option<String>,
    pub ppm: f64,
    pub time_scale: f64,
    pub auto_press: bool,
    pub idle_exit: Option<f64>,
    pub quiet: bool,
    /// The machine file and node whose closed loops this node runs on the
    /// simulated plant.
    pub plant: Option<(PathBuf, String)>,
    /// A description file: the module this node is.
    pub describe: Option<PathBuf>,
}

/// Opens what the node listens on; returns the transport and the spec a host
/// reaches it with.
fn listen(spec: &str) -> Result<(Box<dyn Transport + Send>, String)> {
    if spec == "pty" {
        let (master, slave) =
            serialport::TTYPort::pair().context("cannot open a pseudo-terminal")?;
        let name = slave.name().context("the pseudo-terminal has no name")?;
        // The far end stays open here too, so the master never reads EOF
        // between host sessions.
        std::mem::forget(slave);
        let t = motet_link::SerialTransport::from_port(format!("serial:{name}"), Box::new(master));
        return Ok((Box::new(t), format!("serial:{name}")));
    }
    if spec.starts_with("udp-group:") {
        // A member of a multicast group: it hears the host and every other
        // node, as on a bus, and is reached at the group's own spec.
        let t = motet_link::open(spec).with_context(|| format!("--listen {spec:?}"))?;
        return Ok((t, spec.to_string()));
    }
    let Some(addr) = spec.strip_prefix("udp:") else {
        bail!(
            "--listen {spec:?}: expected `udp:HOST:PORT`, `udp-group:GROUP:PORT[@IFACE]` or `pty`"
        );
    };
    let t = motet_link::UdpTransport::listen(addr)
        .with_context(|| format!("cannot listen on udp:{addr}"))?;
    let local = t.local_addr()?;
    Ok((Box::new(t), format!("udp:{local}")))
}

fn random_uid() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u32(std::process::id());
    h.write_u128(
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0),
    );
    h.finish()
}

pub fn node(args: NodeArgs) -> Result<()> {
    if !(args.time_scale.is_finite() && args.time_scale > 0.0) {
        bail!("--time-scale must be a positive number");
    }
    if !(args.ppm.is_finite() && args.ppm.abs() < 10_000.0) {
        bail!("--ppm must be within ±10000");
    }
    let uid = match &args.uid {
        Some(s) => u64::from_str_radix(s.trim_start_matches("0x"), 16)
            .with_context(|| format!("--uid {s:?} is not a hex number"))?,
        None => random_uid(),
    };
    let cfg = sim_config(&args.kind, uid)
        .with_context(|| format!("--type {:?}: at most 16 bytes", args.kind))?;
    // A bad description is refused before the node listens.
    let description = match &args.describe {
        Some(p) => Some(motet_host::module::load_description(p)?),
        None => None,
    };
    let (transport, link) = listen(&args.listen)?;
    match &args.state {
        Some(path) => {
            let store = FileStore { path: path.clone() };
            run(args_with(&args, description)?, cfg, store, transport, &link)
        }
        None => run(
            args_with(&args, description)?,
            cfg,
            RamStore::default(),
            transport,
            &link,
        ),
    }
}

struct Opts {
    plant: Option<Box<dyn motet_node::Board + Send>>,
    announce: bool,
    ppm: f64,
    time_scale: f64,
    auto_press: bool,
    idle_exit: Option<f64>,
    quiet: bool,
    description: Option<motet_wire::describe::Description>,
}

fn args_with(a: &NodeArgs, description: Option<motet_wire::describe::Description>) -> Result<Opts> {
    let plant = match &a.plant {
        None => None,
        Some((file, name)) => {
            let m = motet_host::Machine::load(file)?;
            let k = m
                .nodes
                .iter()
                .position(|n| n.name == *name)
                .with_context(|| {
                    format!("--plant-node {name}: {} has no such node", file.display())
                })?;
            let plants = motet_sim::node_plant::NodePlant::of_node(&m, k);
            Some(Box::new(plants) as Box<dyn motet_node::Board + Send>)
        }
    };
    Ok(Opts {
        plant,
        announce: a.announce,
        ppm: a.ppm,
        time_scale: a.time_scale,
        auto_press: a.auto_press,
        idle_exit: a.idle_exit,
        quiet: a.quiet,
        description,
    })
}

fn run<S: Store>(
    o: Opts,
    cfg: motet_node::service::NodeConfig,
    store: S,
    transport: Box<dyn Transport + Send>,
    link: &str,
) -> Result<()> {
    // A node's clock starts wherever its crystal happens to be.
    let clock = WallClock::with(
        o.time_scale,
        o.ppm,
        (random_uid() % 1_000_000_000) + 1_000_000,
    );
    // Frames stamped as they arrive, so that a clock exchange's time here
    // is when the host's request came, however late the process runs.
    // Behind a cable a signal pulls (`cable`).
    crate::cable::install().context("cannot install the SIGUSR1 handler")?;
    let mut transport: Box<dyn Transport + Send> = Box::new(crate::cable::Cable::new(transport));
    transport.stamp_arrivals(clock);
    let mut node = SimNode::new(cfg, store, transport, clock.now_us());
    node.plant = o.plant;
    let module = o
        .description
        .as_ref()
        .map(|d| format!(", module {} ({})", d.identity.name, d.kind.name()));
    if let Some(d) = o.description {
        node.endpoint.set_description(d);
    }
    // It says it is here as it starts (a host on its link hears it at
    // once; on UDP, once a host has spoken, at the host's next probe).
    node.endpoint.announce();
    let uid = node.endpoint.services().uid();
    if o.announce {
        println!("{}", announce_line(link, uid));
    } else {
        println!(
            "motet node: {} uid {uid:016x}, firmware {}{}, listening on {link}",
            node.endpoint.services().info().kind,
            node.endpoint.services().firmware(),
            module.unwrap_or_default()
        );
    }
    use std::io::Write;
    std::io::stdout().flush()?;
    let press_rx = button_presses(o.auto_press);
    let mut blinking = false;
    let mut last_report = 0u64;
    let started = clock.now_us();
    let mut cable = crate::cable::News::new();
    loop {
        let now = clock.now_us();
        if let Some(news) = cable.take() {
            eprintln!("{news}");
        }
        node.step(now);
        let blink = node.endpoint.services().blinking(now);
        let pairing = node.endpoint.services().pairing();
        if blink != blinking && !o.quiet {
            eprintln!(
                "{}",
                if !blink {
                    "identify: off".to_string()
                } else if pairing {
                    "identify: blinking — press Enter here to pair this node".to_string()
                } else {
                    "identify: blinking".to_string()
                }
            );
        }
        blinking = blink;
        if pairing && (o.auto_press || press_rx.try_recv().is_ok()) {
            node.endpoint.press_button(now);
            if !o.quiet {
                eprintln!(
                    "button pressed: address {}",
                    node.endpoint.services().address()
                );
            }
        }
        if !o.quiet && now > last_report + 5_000_000 * o.time_scale as u64 {
            last_report = now;
            let n = node.endpoint.node();
            eprintln!(
                "node: address {} state {:?} queued {} steps {:?}",
                node.endpoint.services().address(),
                node.endpoint.services().state(),
                n.queued(),
                &node.board.position[..n.channels().len()]
            );
        }
        if let Some(idle) = o.idle_exit {
            let last = node.endpoint.last_host_frame().unwrap_or(started);
            if now.saturating_sub(last) as f64 > idle * 1e6 * o.time_scale {
                if !o.quiet {
                    eprintln!("no host for {idle} s: exiting");
                }
                return Ok(());
            }
        }
        let next = node.endpoint.next_wakeup(now).unwrap_or(now + 2_000);
        let wait = next.saturating_sub(now).clamp(50, 2_000);
        let real = clock.real(wait);
        // Wait for a frame or the next deadline, whichever comes first.
        if let Some(f) = node
            .transport
            .recv(Some(real.max(Duration::from_micros(20))))?
        {
            let stamp = node.transport.last_stamp().map(|s| s.at_us);
            node.endpoint.on_frame_stamped(&f, clock.now_us(), stamp);
        }
    }
}

/// The button: Enter on this terminal (none when it presses itself).
fn button_presses(auto_press: bool) -> mpsc::Receiver<()> {
    let (press_tx, press_rx) = mpsc::channel();
    if !auto_press {
        std::thread::spawn(move || {
            let mut line = String::new();
            while std::io::stdin().read_line(&mut line).is_ok_and(|n| n > 0) {
                if press_tx.send(()).is_err() {
                    break;
                }
                line.clear();
            }
        });
    }
    press_rx
}
