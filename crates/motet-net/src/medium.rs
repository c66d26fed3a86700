//! One transport shared by every node on a medium (a CAN bus): the host
//! reaches all nodes through it, and frames coming in are handed to the
//! peer of the address they come from. Each peer keeps its own reliable
//! link over its [`MediumPort`]; a frame sent through any port reaches
//! every node, which is what a group seal needs.
//!
//! A transport that hears the host's own frames back, stamped at the
//! instant every node heard them, hands its own clock exchanges to every
//! port: each peer then knows when the nodes received the sync frame
//! (reference broadcast).

use motet_link::{LinkStats, Stamp, Transport};
use motet_wire::frame::{self, MAX_RAW};
use motet_wire::service::{port, HOST_ADDRESS};
use std::collections::{BTreeMap, VecDeque};
use std::io;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

/// What the shared transport took in that no peer could be given.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MediumStats {
    /// Frames from an address that is no node of the run.
    pub strangers: u64,
    /// The last such address.
    pub last_stranger: Option<u16>,
    /// Frames that did not decode (their sender is unknown).
    pub bad_frames: u64,
}

/// Service datagrams from unknown addresses kept.
const STRANGERS: usize = 64;

/// A frame as it arrived, with its stamp.
type Arrived = (Vec<u8>, Option<Stamp>);

struct Demux {
    transport: Box<dyn Transport + Send>,
    /// Frames waiting for each node's peer, by source address, with their
    /// stamps.
    queues: BTreeMap<u16, VecDeque<Arrived>>,
    stats: MediumStats,
    /// Service datagrams to the host from addresses no port has (a module
    /// plugged in, an unpaired node), the newest few, with their source.
    strangers: VecDeque<(u16, motet_wire::ServiceReply)>,
}

impl Demux {
    /// Takes every frame the transport has and files it by source.
    fn pump(&mut self) -> io::Result<()> {
        let mut raw = [0u8; MAX_RAW];
        while let Some(bytes) = self.transport.recv(None)? {
            let stamp = self.transport.last_stamp();
            let Ok(f) = frame::decode(&bytes, &mut raw) else {
                self.stats.bad_frames += 1;
                continue;
            };
            let own = stamp.is_some_and(|s| s.own) && f.header.src == HOST_ADDRESS;
            if own {
                // Only the host's own sync frames to every node matter to
                // its peers.
                if f.header.port == port::TIME && f.header.dst == frame::BROADCAST {
                    for q in self.queues.values_mut() {
                        q.push_back((bytes.clone(), stamp));
                    }
                }
                continue;
            }
            match self.queues.get_mut(&f.header.src) {
                Some(q) => q.push_back((bytes, stamp)),
                None => {
                    self.stats.strangers += 1;
                    self.stats.last_stranger = Some(f.header.src);
                    let to_host = f.header.dst == HOST_ADDRESS
                        && f.header.flags == motet_wire::frame::Flags::NONE;
                    if let (true, Ok(r)) = (to_host, motet_wire::decode(f.payload)) {
                        if self.strangers.len() == STRANGERS {
                            self.strangers.pop_front();
                        }
                        self.strangers.push_back((f.header.src, r));
                    }
                }
            }
        }
        Ok(())
    }
}

/// The host's end of a shared medium.
#[derive(Clone)]
pub struct Medium {
    inner: Arc<Mutex<Demux>>,
}

fn lock(m: &Mutex<Demux>) -> MutexGuard<'_, Demux> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Medium {
    /// The medium reached through `transport`, which takes frames from
    /// every sender.
    pub fn new(transport: Box<dyn Transport + Send>) -> Medium {
        Medium {
            inner: Arc::new(Mutex::new(Demux {
                transport,
                queues: BTreeMap::new(),
                stats: MediumStats::default(),
                strangers: VecDeque::new(),
            })),
        }
    }

    /// The port of the node at `address`: frames from it come in there.
    pub fn port(&self, address: u16) -> MediumPort {
        lock(&self.inner).queues.entry(address).or_default();
        MediumPort {
            inner: self.inner.clone(),
            address,
            name: format!("bus node {address}"),
            stats: LinkStats::default(),
            last_stamp: None,
        }
    }

    /// What came in that no port took.
    pub fn stats(&self) -> MediumStats {
        lock(&self.inner).stats
    }

    /// Service datagrams to the host from addresses no port has, with
    /// their source, oldest first (a module watch's answers from modules
    /// the run does not know). Takes what the transport has first.
    pub fn take_strangers(&self) -> Vec<(u16, motet_wire::ServiceReply)> {
        let mut d = lock(&self.inner);
        let _ = d.pump();
        d.strangers.drain(..).collect()
    }
}

/// One node's share of a [`Medium`], a transport for its peer.
pub struct MediumPort {
    inner: Arc<Mutex<Demux>>,
    address: u16,
    name: String,
    stats: LinkStats,
    last_stamp: Option<Stamp>,
}

impl Transport for MediumPort {
    fn name(&self) -> &str {
        &self.name
    }

    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        lock(&self.inner).transport.send(frame)?;
        self.stats.sent(frame.len());
        Ok(())
    }

    /// Takes what the medium has, then hands out this node's next frame,
    /// waiting up to `timeout` for one (a request's answer; the run's
    /// polls never wait).
    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>> {
        let until = timeout.map(|t| std::time::Instant::now() + t);
        let (f, stamp) = loop {
            let mut d = lock(&self.inner);
            d.pump()?;
            if let Some(got) = d.queues.get_mut(&self.address).and_then(|q| q.pop_front()) {
                break got;
            }
            drop(d);
            match until {
                Some(u) if std::time::Instant::now() < u => {
                    std::thread::sleep(Duration::from_micros(200))
                }
                _ => return Ok(None),
            }
        };
        // The host's own frame heard back is no traffic.
        if !stamp.is_some_and(|s| s.own) {
            self.stats.received(f.len());
        }
        self.last_stamp = stamp;
        Ok(Some(f))
    }

    fn stats(&self) -> &LinkStats {
        &self.stats
    }

    fn last_stamp(&self) -> Option<Stamp> {
        self.last_stamp
    }

    /// The shared transport stamps arrivals (once for every port).
    fn stamp_arrivals(&mut self, clock: motet_link::WallClock) -> bool {
        lock(&self.inner).transport.stamp_arrivals(clock)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motet_link::pair;
    use motet_wire::frame::{encode, Flags, Header, MAX_FRAME};

    fn from(src: u16) -> Vec<u8> {
        let h = Header {
            dst: 1,
            src,
            port: 3,
            flags: Flags::NONE,
            seq: 0,
            ack: 0,
        };
        let mut out = [0u8; MAX_FRAME];
        let n = encode(&h, &[src as u8], &mut out).unwrap();
        out[..n].to_vec()
    }

    #[test]
    fn frames_go_to_the_port_of_their_sender() {
        let (host, mut bus) = pair("host", "bus");
        let m = Medium::new(Box::new(host));
        let mut a = m.port(2);
        let mut b = m.port(3);
        for src in [3, 2, 9, 3] {
            bus.send(&from(src)).unwrap();
        }
        bus.send(&[7, 7, 0]).unwrap();
        assert_eq!(a.recv(None).unwrap(), Some(from(2)));
        assert_eq!(a.recv(None).unwrap(), None);
        assert_eq!(b.recv(None).unwrap(), Some(from(3)));
        assert_eq!(b.recv(None).unwrap(), Some(from(3)));
        assert_eq!(b.recv(None).unwrap(), None);
        let s = m.stats();
        assert_eq!(
            (s.strangers, s.last_stranger, s.bad_frames),
            (1, Some(9), 1)
        );
        a.send(&from(1)).unwrap();
        assert_eq!(bus.recv(None).unwrap(), Some(from(1)));
    }
}
