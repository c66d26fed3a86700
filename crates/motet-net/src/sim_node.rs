//! A simulated node: the node firmware's endpoint with a file for its
//! identity, RAM for its firmware slot, and a board that counts steps. The
//! same [`motet_node::endpoint::Endpoint`] code runs on a real board.

use motet_link::Transport;
use motet_node::endpoint::Endpoint;
use motet_node::service::NodeConfig;
use motet_node::storage::{Persisted, RamFlash, StorageError, Store};
use motet_node::{Board, DEFAULT_QUEUE, MAX_CHANNELS, MAX_TOOLS};
use motet_wire::frame::MAX_FRAME;
use motet_wire::link::PROTOCOL_VERSION;
use motet_wire::service::{Kind, Version};
use std::path::PathBuf;

/// Bytes of a simulated node's firmware slot.
pub const SIM_FLASH: usize = 256 * 1024;

/// The firmware version simulated nodes report until one is flashed.
pub fn sim_firmware() -> Version {
    let mut v = env!("CARGO_PKG_VERSION")
        .split('.')
        .map(|p| p.parse().unwrap_or(0));
    Version {
        major: v.next().unwrap_or(0),
        minor: v.next().unwrap_or(0),
        patch: v.next().unwrap_or(0),
    }
}

/// The configuration of a simulated node of `kind`.
pub fn sim_config(kind: &str, uid: u64) -> Option<NodeConfig> {
    let kind: Kind = Kind::try_from(kind).ok()?;
    Some(NodeConfig {
        kind,
        uid,
        firmware: sim_firmware(),
        protocol_min: PROTOCOL_VERSION,
        protocol_max: PROTOCOL_VERSION,
        queue_capacity: DEFAULT_QUEUE as u16,
        channels: MAX_CHANNELS as u8,
        tools: MAX_TOOLS as u8,
        // Simulated: no board, and no step rate it cannot reach.
        board: None,
        max_step_hz: 0,
    })
}

/// A node's identity in a small text file (`uid`, `address`, `firmware`),
/// written whole and renamed into place so a crash never leaves half a record.
#[derive(Clone, Debug)]
pub struct FileStore {
    /// The file; created on the first save.
    pub path: PathBuf,
}

impl Store for FileStore {
    fn load(&mut self) -> Option<Persisted> {
        let text = std::fs::read_to_string(&self.path).ok()?;
        let mut uid = None;
        let mut address = None;
        let mut firmware = None;
        for line in text.lines() {
            let (k, v) = line.split_once('=')?;
            let v = v.trim();
            match k.trim() {
                "uid" => uid = u64::from_str_radix(v, 16).ok(),
                "address" => address = v.parse().ok(),
                "firmware" => {
                    let mut p = v.split('.').map(|x| x.parse::<u16>());
                    firmware = match (p.next(), p.next(), p.next()) {
                        (Some(Ok(major)), Some(Ok(minor)), Some(Ok(patch))) => Some(Version {
                            major,
                            minor,
                            patch,
                        }),
                        _ => None,
                    }
                }
                _ => {}
            }
        }
        Some(Persisted {
            uid: uid?,
            address: address?,
            firmware: firmware?,
        })
    }

    fn save(&mut self, p: &Persisted) -> Result<(), StorageError> {
        let text = format!(
            "uid = {:016x}\naddress = {}\nfirmware = {}\n",
            p.uid, p.address, p.firmware
        );
        let tmp = self.path.with_extension("tmp");
        std::fs::write(&tmp, text)
            .and_then(|_| std::fs::rename(&tmp, &self.path))
            .map_err(|_| StorageError::Device)
    }
}

/// What a simulated board did: step counts and positions per channel, tool values.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepCounter {
    /// Net steps per channel (forward minus backward, in direction-output terms).
    pub position: [i64; MAX_CHANNELS],
    /// All steps per channel.
    pub steps: [u64; MAX_CHANNELS],
    /// Each tool output's present value.
    pub tools: [f32; MAX_TOOLS],
    /// Every step (host time µs, channel, forward) when tracing.
    pub trace: Option<Vec<(f64, u8, bool)>>,
    /// Every tool change (host time µs, output, value) when tracing.
    pub tool_trace: Option<Vec<(f64, u8, f32)>>,
    /// The heaters the node drives, simulated (none: a board without
    /// temperature sensors).
    pub heat: motet_host::thermal::NodeHeat,
}

impl Board for StepCounter {
    fn step(&mut self, channel: u8, forward: bool, at_us: f64) {
        if let Some(c) = self.position.get_mut(channel as usize) {
            *c += if forward { 1 } else { -1 };
            self.steps[channel as usize] += 1;
        }
        if let Some(t) = self.trace.as_mut() {
            t.push((at_us, channel, forward));
        }
    }
    fn set_tool(&mut self, output: u8, value: f32, at_us: f64) {
        if let Some(t) = self.tools.get_mut(output as usize) {
            *t = value;
        }
        if let Some(t) = self.tool_trace.as_mut() {
            t.push((at_us, output, value));
        }
    }
    fn temperature(&mut self, index: u8, at_us: f64) -> Option<f32> {
        self.heat.read(index, at_us)
    }
    fn drive(&mut self, channel: u8, duty: f32, at_us: f64) {
        self.heat.drive(channel, duty, at_us);
    }
}

/// A board of steps counted and closed loops on a plant: what a
/// simulated node with servo channels drives.
struct WithPlant<'a> {
    steps: &'a mut StepCounter,
    plant: &'a mut (dyn Board + Send),
}

impl Board for WithPlant<'_> {
    fn step(&mut self, channel: u8, forward: bool, at_us: f64) {
        self.steps.step(channel, forward, at_us);
    }
    fn set_tool(&mut self, output: u8, value: f32, at_us: f64) {
        self.steps.set_tool(output, value, at_us);
    }
    fn encoder(&mut self, channel: u8, at_us: f64) -> Option<i64> {
        self.plant.encoder(channel, at_us)
    }
    fn drive(&mut self, channel: u8, duty: f32, at_us: f64) {
        self.plant.drive(channel, duty, at_us);
    }
    fn limit(&mut self, channel: u8, at_us: f64) -> bool {
        self.plant.limit(channel, at_us)
    }
    fn temperature(&mut self, index: u8, at_us: f64) -> Option<f32> {
        self.plant.temperature(index, at_us)
    }
    fn sensor(&mut self, index: u8, at_us: f64) -> Option<f32> {
        self.plant.sensor(index, at_us)
    }
}

/// The endpoint type of simulated nodes.
pub type SimEndpoint<S> = Endpoint<S, RamFlash<SIM_FLASH>, DEFAULT_QUEUE>;

/// A simulated node bound to a transport.
pub struct SimNode<S: Store> {
    /// The node firmware's endpoint: link, services and motion.
    pub endpoint: Box<SimEndpoint<S>>,
    /// What carries its frames to the host.
    pub transport: Box<dyn Transport + Send>,
    /// The simulated board its outputs drive.
    pub board: StepCounter,
    /// The plant its closed loops drive (servo motors, sensors), if any:
    /// it answers the node's encoder reads and drives as it polls.
    pub plant: Option<Box<dyn Board + Send>>,
    /// Transport errors seen (the link is down).
    pub link_errors: u64,
}

impl<S: Store> SimNode<S> {
    /// A node with configuration `cfg`, persisting its identity in `store`,
    /// reached over `transport`, started at local time `now` (µs).
    pub fn new(cfg: NodeConfig, store: S, transport: Box<dyn Transport + Send>, now: u64) -> Self {
        SimNode {
            endpoint: Box::new(Endpoint::new(cfg, store, RamFlash::new(), now)),
            transport,
            board: StepCounter::default(),
            plant: None,
            link_errors: 0,
        }
    }

    /// One round at local time `now`: take frames, run the motion, transmit.
    /// A link that fails does not stop the node: it runs on to the end of its
    /// committed window, as a board whose cable was pulled would.
    pub fn step(&mut self, now: u64) {
        loop {
            match self.transport.recv(None) {
                Ok(Some(f)) => {
                    let stamp = self.transport.last_stamp().map(|s| s.at_us);
                    self.endpoint.on_frame_stamped(&f, now, stamp);
                }
                Ok(None) => break,
                Err(_) => {
                    self.link_errors += 1;
                    break;
                }
            }
        }
        match self.plant.as_mut() {
            Some(plant) => self.endpoint.poll(
                now,
                &mut WithPlant {
                    steps: &mut self.board,
                    plant: plant.as_mut(),
                },
            ),
            None => self.endpoint.poll(now, &mut self.board),
        }
        let mut out = [0u8; MAX_FRAME];
        while let Some(f) = self.endpoint.transmit(now, &mut out) {
            if self.transport.send(f).is_err() {
                self.link_errors += 1;
            }
        }
    }
}
