//! In-process transport: two ends joined by channels, one message per frame.

use crate::{LinkStats, Transport};
use std::io;
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::time::Duration;

/// One end of an in-process pair made by [`pair`].
#[derive(Debug)]
pub struct MemTransport {
    name: String,
    tx: Sender<Vec<u8>>,
    rx: Receiver<Vec<u8>>,
    stats: LinkStats,
}

/// Two connected ends: what one sends, the other receives, in order.
pub fn pair(a: &str, b: &str) -> (MemTransport, MemTransport) {
    let (tx_ab, rx_ab) = channel();
    let (tx_ba, rx_ba) = channel();
    (
        MemTransport {
            name: format!("mem:{a}"),
            tx: tx_ab,
            rx: rx_ba,
            stats: LinkStats::default(),
        },
        MemTransport {
            name: format!("mem:{b}"),
            tx: tx_ba,
            rx: rx_ab,
            stats: LinkStats::default(),
        },
    )
}

fn closed() -> io::Error {
    io::Error::new(io::ErrorKind::BrokenPipe, "peer end dropped")
}

impl Transport for MemTransport {
    fn name(&self) -> &str {
        &self.name
    }

    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        self.tx.send(frame.to_vec()).map_err(|_| closed())?;
        self.stats.sent(frame.len());
        Ok(())
    }

    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>> {
        let r = match timeout {
            None => self.rx.try_recv().map_err(|e| match e {
                TryRecvError::Empty => None,
                TryRecvError::Disconnected => Some(closed()),
            }),
            Some(d) => self.rx.recv_timeout(d).map_err(|e| match e {
                RecvTimeoutError::Timeout => None,
                RecvTimeoutError::Disconnected => Some(closed()),
            }),
        };
        match r {
            Ok(f) => {
                self.stats.received(f.len());
                Ok(Some(f))
            }
            Err(None) => Ok(None),
            Err(Some(e)) => Err(e),
        }
    }

    fn stats(&self) -> &LinkStats {
        &self.stats
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::link_exchange;
    use motet_wire::frame::{encode, Flags, Header, MAX_FRAME};

    #[test]
    fn frames_both_ways_in_order() {
        let (mut a, mut b) = pair("host", "node");
        assert_eq!(a.name(), "mem:host");
        assert_eq!(a.recv(None).unwrap(), None);
        let frames: Vec<Vec<u8>> = (0..5u8).map(|i| vec![i + 1; i as usize + 1]).collect();
        for f in &frames {
            a.send(f).unwrap();
        }
        for f in &frames {
            assert_eq!(
                b.recv(Some(Duration::from_secs(5))).unwrap().as_ref(),
                Some(f)
            );
        }
        assert_eq!(b.recv(None).unwrap(), None);
        b.send(&[9, 0]).unwrap();
        assert_eq!(a.recv(None).unwrap(), Some(vec![9, 0]));
        assert_eq!(a.stats().frames_out, 5);
        assert_eq!(a.stats().bytes_out, 15);
        assert_eq!(b.stats().frames_in, 5);
        assert_eq!(b.stats().bytes_in, 15);
        assert_eq!(a.stats().frames_in, 1);
    }

    #[test]
    fn real_frame_decodes() {
        let (mut a, mut b) = pair("a", "b");
        let h = Header {
            dst: 2,
            src: 1,
            port: 10,
            flags: Flags::DATA,
            seq: 3,
            ack: 0,
        };
        let mut out = [0u8; MAX_FRAME];
        let n = encode(&h, b"hello", &mut out).unwrap();
        a.send(&out[..n]).unwrap();
        let got = b.recv(None).unwrap().unwrap();
        let mut raw = [0u8; MAX_FRAME];
        let f = motet_wire::frame::decode(&got, &mut raw).unwrap();
        assert_eq!(f.header, h);
        assert_eq!(f.payload, b"hello");
    }

    #[test]
    fn dropped_peer_is_an_error() {
        let (mut a, b) = pair("a", "b");
        drop(b);
        assert!(a.send(&[1, 0]).is_err());
        assert!(a.recv(None).is_err());
    }

    #[test]
    fn link_over_mem_delivers_in_order() {
        let (mut a, mut b) = pair("host", "node");
        let x = link_exchange(&mut a, &mut b, 1000, None);
        assert_eq!(x.got, (0..1000).collect::<Vec<u32>>());
        assert_eq!(x.host.retransmits, 0);
        assert!(b.stats().frames_in >= 1000);
    }
}
