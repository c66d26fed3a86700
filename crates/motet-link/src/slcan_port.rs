//! motet frames over a USB-CAN adapter speaking slcan (a CANable, or any
//! Lawicel-style adapter with CAN-FD lines) on a serial port.
//!
//! Opening sends `C` (close, in case the channel was left open), `Sn` (the
//! nominal bit rate) and `O` (open). Frames go out as CAN-FD `b` lines under
//! this end's identifier, fragmented as [`crate::can`] does: the stuffed
//! frame in 64-byte pieces, the 0x00 delimiter ending the motet frame.
//! Received CAN-FD frames are reassembled per sender identifier; classic and
//! remote frames, frames under this end's own identifier and, when a peer is
//! set, frames from other identifiers are ignored. Adapter replies (`\r`,
//! BEL, `z`/`Z` transmit acknowledgements) are consumed and counted.

use crate::can::fragment;
use crate::serial::open_raw;
use crate::serial::read_port;
use crate::slcan::{self, CanFrame, Command, LineSplitter, BITRATES, MAX_EXT_ID, MAX_STD_ID};
use crate::{Inbox, LinkStats, StreamSplitter, Transport};
use serialport::SerialPort;
use std::collections::BTreeMap;
use std::io::{self, Write};
use std::time::Duration;

/// Settings of an slcan transport.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlcanConfig {
    /// Nominal CAN bit rate, one of [`BITRATES`].
    pub bitrate: u32,
    /// Identifier this end sends under.
    pub id: u32,
    /// `id` is a 29-bit extended identifier (an 11-bit standard one if
    /// `false`).
    pub extended: bool,
    /// Only frames from this identifier are taken (all senders if `None`).
    pub peer: Option<u32>,
    /// Serial baud rate (USB CDC adapters ignore it).
    pub baud: u32,
}

impl Default for SlcanConfig {
    /// 500 kbit/s, standard id 0x010, all senders, 115200 baud.
    fn default() -> Self {
        SlcanConfig {
            bitrate: 500_000,
            id: 0x010,
            extended: false,
            peer: None,
            baud: 115_200,
        }
    }
}

/// The `Sn` code of a bit rate.
pub fn bitrate_code(bitrate: u32) -> Option<u8> {
    BITRATES.iter().position(|&b| b == bitrate).map(|i| i as u8)
}

/// What the adapter said besides frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AdapterCounts {
    /// `\r` and `z`/`Z` acknowledgements.
    pub acks: u64,
    /// BEL replies.
    pub errors: u64,
    /// Lines that do not decode.
    pub bad_lines: u64,
    /// Frames skipped (classic, remote, own id, other sender).
    pub skipped: u64,
}

/// A serial slcan adapter carrying motet frames as CAN-FD frames.
pub struct SlcanTransport {
    name: String,
    port: Box<dyn SerialPort>,
    cfg: SlcanConfig,
    rx: Lines,
    inbox: Inbox,
    stats: LinkStats,
}

/// What is read from the adapter: its lines, the frames' fragments per
/// sender, and the counts of everything else it said.
#[derive(Default)]
struct Lines {
    lines: LineSplitter,
    splitters: BTreeMap<u32, StreamSplitter>,
    counts: AdapterCounts,
}

impl std::fmt::Debug for SlcanTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SlcanTransport")
            .field("name", &self.name)
            .field("cfg", &self.cfg)
            .field("ready", &self.inbox.len())
            .field("counts", &self.rx.counts)
            .field("stats", &self.stats)
            .finish()
    }
}

fn invalid(msg: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, msg)
}

impl SlcanTransport {
    /// Opens the adapter at `path` and opens its CAN channel.
    pub fn open(path: &str, cfg: SlcanConfig) -> io::Result<SlcanTransport> {
        Self::check(&cfg)?;
        let port = open_raw(path, cfg.baud)?;
        Self::from_port(format!("slcan:{path}"), port, cfg)
    }

    fn check(cfg: &SlcanConfig) -> io::Result<u8> {
        let max = if cfg.extended { MAX_EXT_ID } else { MAX_STD_ID };
        if cfg.id > max {
            return Err(invalid(format!("CAN id {:#x} out of range", cfg.id)));
        }
        bitrate_code(cfg.bitrate).ok_or_else(|| {
            invalid(format!(
                "CAN bit rate {} not one of {BITRATES:?}",
                cfg.bitrate
            ))
        })
    }

    /// Uses a port opened elsewhere (raw mode) and opens the CAN channel.
    pub fn from_port(
        name: String,
        port: Box<dyn SerialPort>,
        cfg: SlcanConfig,
    ) -> io::Result<SlcanTransport> {
        let code = Self::check(&cfg)?;
        let mut t = SlcanTransport {
            name,
            port,
            cfg,
            rx: Lines::default(),
            inbox: Inbox::new(),
            stats: LinkStats::default(),
        };
        let mut setup = Vec::new();
        for cmd in [Command::Close, Command::Bitrate(code), Command::Open] {
            setup.extend(slcan::encode(&cmd).map_err(|e| invalid(e.to_string()))?);
        }
        t.port.write_all(&setup)?;
        t.port.flush()?;
        Ok(t)
    }

    /// The settings it was opened with.
    pub fn config(&self) -> &SlcanConfig {
        &self.cfg
    }

    /// What the adapter answered so far: acknowledgements, errors, lines that
    /// did not decode, frames skipped.
    pub fn adapter_counts(&self) -> &AdapterCounts {
        &self.rx.counts
    }
}

impl Lines {
    /// Reads once, waiting at most `wait`; returns whether bytes arrived.
    fn fill(
        &mut self,
        port: &mut dyn SerialPort,
        cfg: &SlcanConfig,
        inbox: &mut Inbox,
        wait: Duration,
    ) -> io::Result<bool> {
        let mut buf = [0u8; 1024];
        let n = read_port(port, wait, &mut buf)?;
        let mut lines = Vec::new();
        self.lines.push(&buf[..n], &mut |l| lines.push(l));
        for l in lines {
            self.on_line(cfg, inbox, &l);
        }
        Ok(n > 0)
    }

    fn on_line(&mut self, cfg: &SlcanConfig, inbox: &mut Inbox, line: &[u8]) {
        match line {
            [] | [b'z'] | [b'Z'] => {
                self.counts.acks += 1;
                return;
            }
            [0x07] => {
                self.counts.errors += 1;
                return;
            }
            _ => {}
        }
        let f = match slcan::decode(line) {
            Ok(Command::Frame(f)) => f,
            Ok(_) | Err(_) => {
                self.counts.bad_lines += 1;
                return;
            }
        };
        if !wanted(cfg, &f) {
            self.counts.skipped += 1;
            return;
        }
        inbox.take_from(&mut self.splitters, f.id, &f.data);
    }
}

fn wanted(cfg: &SlcanConfig, f: &CanFrame) -> bool {
    f.fd && !f.rtr
        && f.extended == cfg.extended
        && f.id != cfg.id
        && cfg.peer.is_none_or(|p| p == f.id)
}

impl Drop for SlcanTransport {
    fn drop(&mut self) {
        // Leave the adapter closed; nothing to do if the port is gone.
        let _ = self.port.write_all(b"C\r");
    }
}

impl Transport for SlcanTransport {
    fn name(&self) -> &str {
        &self.name
    }

    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        let parts = fragment(frame);
        let mut out = Vec::with_capacity(parts.len() * (2 * 64 + 12));
        let mut n = 0;
        for p in parts {
            n += p.len();
            let cmd = Command::Frame(CanFrame::fd(self.cfg.id, self.cfg.extended, &p));
            out.extend(slcan::encode(&cmd).map_err(|e| invalid(e.to_string()))?);
        }
        self.port.write_all(&out)?;
        self.stats.sent(n);
        Ok(())
    }

    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>> {
        let (port, cfg, rx) = (&mut self.port, &self.cfg, &mut self.rx);
        self.inbox.recv(timeout, &mut self.stats, |inbox, wait| {
            rx.fill(port.as_mut(), cfg, inbox, wait)
        })
    }

    fn stats(&self) -> &LinkStats {
        &self.stats
    }
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use crate::can::{CanBus, CanTransport};
    use crate::serial::pty;
    use crate::testutil::link_exchange;
    use std::io::Read;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    use std::thread;

    const HOST_ID: u32 = 0x010;
    const NODE_ID: u32 = 0x123;

    /// What the simulated adapter saw.
    #[derive(Debug, Default)]
    struct AdapterLog {
        /// Commands other than frames, in order.
        commands: Vec<Command>,
        frames_from_host: u64,
        frames_to_host: u64,
        bad_lines: Vec<Vec<u8>>,
    }

    /// A USB-CAN adapter on the far end of a pty: slcan lines from the host
    /// become frames on `bus` under the host's id; frames on the bus from
    /// others become slcan lines to the host. Commands are answered with
    /// `\r`, frames sent while the channel is closed with BEL.
    fn adapter(
        mut master: serialport::TTYPort,
        bus: CanBus,
        stop: Arc<AtomicBool>,
    ) -> thread::JoinHandle<AdapterLog> {
        let port = bus.attach(HOST_ID, false).unwrap();
        thread::spawn(move || {
            let mut log = AdapterLog::default();
            let mut lines = LineSplitter::default();
            let mut open = false;
            let mut buf = [0u8; 4096];
            master.set_timeout(Duration::from_millis(1)).unwrap();
            while !stop.load(Ordering::Relaxed) {
                let mut got = Vec::new();
                match master.read(&mut buf) {
                    Ok(n) => lines.push(&buf[..n], &mut |l| got.push(l)),
                    Err(e) if e.kind() == io::ErrorKind::TimedOut => {}
                    Err(_) => break,
                }
                let mut reply = Vec::new();
                for l in got {
                    match slcan::decode(&l) {
                        Ok(Command::Frame(f)) if open => {
                            port.transmit_frame(f).unwrap();
                            log.frames_from_host += 1;
                        }
                        Ok(Command::Frame(_)) => reply.push(0x07),
                        Ok(cmd) => {
                            open = match cmd {
                                Command::Open => true,
                                Command::Close => false,
                                _ => open,
                            };
                            log.commands.push(cmd);
                            reply.push(b'\r');
                        }
                        Err(_) => {
                            log.bad_lines.push(l);
                            reply.push(0x07);
                        }
                    }
                }
                bus.run(1 << 16);
                while let Some(f) = port.receive() {
                    if open {
                        reply.extend(slcan::encode(&Command::Frame(f)).unwrap());
                        log.frames_to_host += 1;
                    }
                }
                if !reply.is_empty() && master.write_all(&reply).is_err() {
                    break;
                }
            }
            log
        })
    }

    fn host_cfg() -> SlcanConfig {
        SlcanConfig {
            id: HOST_ID,
            peer: Some(NODE_ID),
            ..SlcanConfig::default()
        }
    }

    #[test]
    fn link_over_slcan_pty_delivers_1000_in_order() {
        let (master, host) = pty::open_with(|path| SlcanTransport::open(path, host_cfg()).unwrap());
        let mut host = host;
        let bus = CanBus::new();
        let mut node = CanTransport::new(bus.attach(NODE_ID, false).unwrap(), Some(HOST_ID));
        // Another node on the bus whose frames the host must ignore.
        let stranger = bus.attach(0x050, false).unwrap();
        stranger.transmit(&[1, 2, 3, 0]).unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let sim = adapter(master, bus, stop.clone());
        let got = link_exchange(&mut host, &mut node, 1000, Some(Duration::from_millis(20))).got;
        stop.store(true, Ordering::Relaxed);
        let log = sim.join().unwrap();
        assert_eq!(got, (0..1000).collect::<Vec<u32>>());
        // Opened at 500 kbit/s before any frame, and every line understood.
        assert_eq!(
            log.commands,
            vec![Command::Close, Command::Bitrate(6), Command::Open]
        );
        assert!(log.bad_lines.is_empty(), "{:?}", log.bad_lines);
        assert!(log.frames_from_host >= 1000);
        assert!(log.frames_to_host > 0);
        assert_eq!(host.adapter_counts().acks, 3);
        assert_eq!(host.adapter_counts().errors, 0);
        assert_eq!(host.adapter_counts().skipped, 1);
    }

    #[test]
    fn replies_and_foreign_lines() {
        let (mut master, host) =
            pty::open_with(|path| SlcanTransport::open(path, host_cfg()).unwrap());
        let mut host = host;
        let mut setup = [0u8; 64];
        let mut n = 0;
        master.set_timeout(Duration::from_secs(5)).unwrap();
        while n < 7 {
            n += master.read(&mut setup[n..]).unwrap();
        }
        assert_eq!(&setup[..n], b"C\rS6\rO\r");
        // One motet frame in two fragments from the node, interleaved with
        // an ack, an error, a classic frame, a frame from another sender, a
        // remote frame and a garbage line.
        let frame: Vec<u8> = (1..=100u8).chain([0]).collect();
        let parts = fragment(&frame);
        let line =
            |id, p: &[u8]| slcan::encode(&Command::Frame(CanFrame::fd(id, false, p))).unwrap();
        let mut blob = Vec::new();
        blob.extend(line(NODE_ID, &parts[0]));
        blob.extend(b"\r\x07z\r");
        blob.extend(slcan::encode(&Command::Frame(CanFrame::standard(NODE_ID, &[1]))).unwrap());
        blob.extend(line(0x300, &[9; 8]));
        blob.extend(b"r1230\rxyz\r");
        blob.extend(line(NODE_ID, &parts[1]));
        master.write_all(&blob).unwrap();
        let got = host.recv(Some(Duration::from_secs(5))).unwrap().unwrap();
        assert_eq!(got, frame);
        let c = *host.adapter_counts();
        assert_eq!(
            c,
            AdapterCounts {
                acks: 2,
                errors: 1,
                bad_lines: 1,
                skipped: 3
            }
        );
        // Sending: b lines under the host's id.
        host.send(&frame).unwrap();
        let mut out = Vec::new();
        while !out.ends_with(b"\r") || out.iter().filter(|&&b| b == b'\r').count() < 2 {
            let mut b = [0u8; 512];
            let k = master.read(&mut b).unwrap();
            out.extend_from_slice(&b[..k]);
        }
        let mut lines = Vec::new();
        LineSplitter::default().push(&out, &mut |l| lines.push(l));
        let cmds: Vec<Command> = lines.iter().map(|l| slcan::decode(l).unwrap()).collect();
        let want: Vec<Command> = parts
            .iter()
            .map(|p| Command::Frame(CanFrame::fd(HOST_ID, false, p)))
            .collect();
        assert_eq!(cmds, want);
    }

    #[test]
    fn bad_settings_are_refused() {
        for cfg in [
            SlcanConfig {
                bitrate: 123_456,
                ..SlcanConfig::default()
            },
            SlcanConfig {
                id: 0x800,
                ..SlcanConfig::default()
            },
        ] {
            let e = SlcanTransport::open("/dev/null-does-not-exist", cfg).unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::InvalidInput, "{cfg:?}");
        }
        assert_eq!(bitrate_code(1_000_000), Some(8));
        assert_eq!(bitrate_code(10_000), Some(0));
    }
}
