//! One transport shared by every node on a medium (a CAN bus): the host
//! reaches all nodes through it, and frames coming in are handed to the
//! peer of the address they come from. Each peer keeps its own reliable
//! link over its [`MediumPort`]; a frame sent through any port reaches
//! every node, which is what a group seal needs.

use motet_link::{LinkStats, Transport};
use motet_wire::frame::{self, MAX_RAW};
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

struct Demux {
    transport: Box<dyn Transport + Send>,
    /// Frames waiting for each node's peer, by source address.
    queues: BTreeMap<u16, VecDeque<Vec<u8>>>,
    stats: MediumStats,
}

impl Demux {
    /// Takes every frame the transport has and files it by source.
    fn pump(&mut self) -> io::Result<()> {
        let mut raw = [0u8; MAX_RAW];
        while let Some(bytes) = self.transport.recv(None)? {
            let Ok(f) = frame::decode(&bytes, &mut raw) else {
                self.stats.bad_frames += 1;
                continue;
            };
            match self.queues.get_mut(&f.header.src) {
                Some(q) => q.push_back(bytes),
                None => {
                    self.stats.strangers += 1;
                    self.stats.last_stranger = Some(f.header.src);
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
        }
    }

    /// What came in that no port took.
    pub fn stats(&self) -> MediumStats {
        lock(&self.inner).stats
    }
}

/// One node's share of a [`Medium`], a transport for its peer.
pub struct MediumPort {
    inner: Arc<Mutex<Demux>>,
    address: u16,
    name: String,
    stats: LinkStats,
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

    /// Takes what the medium has, then hands out this node's next frame;
    /// never waits.
    fn recv(&mut self, _timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>> {
        let mut d = lock(&self.inner);
        d.pump()?;
        let f = d.queues.get_mut(&self.address).and_then(|q| q.pop_front());
        if let Some(f) = &f {
            self.stats.received(f.len());
        }
        Ok(f)
    }

    fn stats(&self) -> &LinkStats {
        &self.stats
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
