//! UDP transport: one datagram per frame.

use crate::udp_stamp::SocketStamps;
use crate::{LinkStats, Stamp, Transport, WallClock};
use std::io;
use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::time::Duration;

/// Largest datagram accepted; anything longer is cut (and then fails to
/// decode).
const MAX_DATAGRAM: usize = 2048;

/// A UDP socket sending every frame to one peer. Datagrams from other
/// addresses are ignored, except by a listening socket ([`UdpTransport::listen`]),
/// which answers whoever sent the latest datagram.
#[derive(Debug)]
pub struct UdpTransport {
    name: String,
    sock: UdpSocket,
    /// `None` until a listening socket hears from someone.
    peer: Option<SocketAddr>,
    listening: bool,
    stats: LinkStats,
    /// Datagrams from other addresses, dropped.
    foreign: u64,
    /// The socket's arrival stamps, once asked for
    /// ([`Transport::stamp_arrivals`]).
    stamps: Option<SocketStamps>,
    /// The last datagram's arrival.
    last_stamp: Option<Stamp>,
}

impl UdpTransport {
    /// Binds `local` and sends to `peer`.
    pub fn bind(local: impl ToSocketAddrs, peer: SocketAddr) -> io::Result<UdpTransport> {
        let sock = UdpSocket::bind(local)?;
        Self::from_socket(sock, peer)
    }

    /// Uses an already bound socket.
    pub fn from_socket(sock: UdpSocket, peer: SocketAddr) -> io::Result<UdpTransport> {
        let name = format!("udp:{}->{}", sock.local_addr()?, peer);
        Ok(UdpTransport {
            name,
            sock,
            peer: Some(peer),
            listening: false,
            stats: LinkStats::default(),
            foreign: 0,
            stamps: None,
            last_stamp: None,
        })
    }

    /// Sends to `peer` from an ephemeral port of the matching address family
    /// (a host reaching a node).
    pub fn connect(peer: SocketAddr) -> io::Result<UdpTransport> {
        let any: SocketAddr = if peer.is_ipv4() {
            (std::net::Ipv4Addr::UNSPECIFIED, 0).into()
        } else {
            (std::net::Ipv6Addr::UNSPECIFIED, 0).into()
        };
        Self::bind(any, peer)
    }

    /// Binds `local` and answers the sender of the latest datagram received
    /// (a node waiting for its host, which may come back from a new port).
    /// Sending before anything arrived fails with `NotConnected`.
    pub fn listen(local: impl ToSocketAddrs) -> io::Result<UdpTransport> {
        let sock = UdpSocket::bind(local)?;
        Ok(UdpTransport {
            name: format!("udp-listen:{}", sock.local_addr()?),
            sock,
            peer: None,
            listening: true,
            stats: LinkStats::default(),
            foreign: 0,
            stamps: None,
            last_stamp: None,
        })
    }

    /// Where frames go, if known.
    pub fn peer(&self) -> Option<SocketAddr> {
        self.peer
    }

    /// Two sockets on 127.0.0.1 (ephemeral ports) aimed at each other.
    pub fn loopback_pair() -> io::Result<(UdpTransport, UdpTransport)> {
        let a = UdpSocket::bind("127.0.0.1:0")?;
        let b = UdpSocket::bind("127.0.0.1:0")?;
        let (aa, ba) = (a.local_addr()?, b.local_addr()?);
        Ok((Self::from_socket(a, ba)?, Self::from_socket(b, aa)?))
    }

    /// Datagrams from other addresses dropped so far.
    pub fn foreign(&self) -> u64 {
        self.foreign
    }

    /// The local address the socket is bound to (the port the OS chose when
    /// bound to port 0).
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.sock.local_addr()
    }
}

impl Transport for UdpTransport {
    fn name(&self) -> &str {
        &self.name
    }

    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        let peer = self
            .peer
            .ok_or_else(|| io::Error::new(io::ErrorKind::NotConnected, "no datagram heard yet"))?;
        let n = self.sock.send_to(frame, peer)?;
        self.stats.sent(n);
        Ok(())
    }

    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>> {
        match timeout {
            None => self.sock.set_nonblocking(true)?,
            Some(d) => {
                self.sock.set_nonblocking(false)?;
                // A zero timeout is refused by the OS: wait 1 µs instead.
                self.sock
                    .set_read_timeout(Some(d.max(Duration::from_micros(1))))?;
            }
        }
        let mut buf = [0u8; MAX_DATAGRAM];
        loop {
            let got = match &self.stamps {
                Some(st) => st
                    .recv_from(&self.sock, &mut buf)
                    .map(|d| (d.len, d.from, d.at_us)),
                None => self.sock.recv_from(&mut buf).map(|(n, f)| (n, f, None)),
            };
            match got.map(|(n, from, at)| ((n, from), at)) {
                Ok(((n, from), at)) if self.listening || Some(from) == self.peer => {
                    self.peer = Some(from);
                    self.stats.received(n);
                    // Without the kernel's stamp, the moment it was read:
                    // after it came, and after the caller's own time.
                    let at = at.or_else(|| self.stamps.as_ref().map(|st| st.now_us()));
                    self.last_stamp = at.map(|at_us| Stamp { at_us, own: false });
                    return Ok(Some(buf[..n].to_vec()));
                }
                Ok(_) => {
                    self.foreign += 1;
                    if timeout.is_some() {
                        // Do not restart the full wait for each stray datagram.
                        self.sock.set_nonblocking(true)?;
                    }
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) =>
                {
                    return Ok(None)
                }
                Err(e) => return Err(e),
            }
        }
    }

    fn stats(&self) -> &LinkStats {
        &self.stats
    }

    fn last_stamp(&self) -> Option<Stamp> {
        self.last_stamp
    }

    fn stamp_arrivals(&mut self, clock: WallClock) -> bool {
        match SocketStamps::enable(&self.sock, clock) {
            Ok(s) => {
                self.stamps = Some(s);
                true
            }
            Err(_) => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::link_exchange;
    use crate::Clock;

    const WAIT: Option<Duration> = Some(Duration::from_secs(5));

    #[test]
    fn frames_between_two_sockets() {
        let (mut a, mut b) = UdpTransport::loopback_pair().unwrap();
        assert!(a.name().starts_with("udp:127.0.0.1:"));
        let frames: Vec<Vec<u8>> = (1..=20u8).map(|i| vec![i; i as usize * 10]).collect();
        for f in &frames {
            a.send(f).unwrap();
            // Loopback keeps order; wait for each so nothing is dropped.
            assert_eq!(b.recv(WAIT).unwrap().as_ref(), Some(f));
        }
        b.send(&[7, 7, 0]).unwrap();
        assert_eq!(a.recv(WAIT).unwrap(), Some(vec![7, 7, 0]));
        assert_eq!(a.stats().frames_out, 20);
        assert_eq!(b.stats().frames_in, 20);
        assert_eq!(b.stats().bytes_in, (1..=20).map(|i| i * 10).sum::<u64>());
    }

    /// A datagram read late is stamped when it arrived, on the
    /// receiver's clock (Linux); unasked, nothing is stamped.
    #[test]
    fn arrivals_are_stamped_at_the_socket() {
        let (mut a, mut b) = UdpTransport::loopback_pair().unwrap();
        a.send(&[1, 0]).unwrap();
        assert_eq!(b.recv(WAIT).unwrap(), Some(vec![1, 0]));
        assert_eq!(b.last_stamp(), None);
        // A clock five times as fast as real time.
        let clock = WallClock::with(5.0, 0.0, 1_000_000);
        let stamping = b.stamp_arrivals(clock);
        assert_eq!(
            stamping,
            cfg!(target_os = "linux"),
            "Linux stamps datagrams"
        );
        if !stamping {
            return;
        }
        // The kernel starts stamping a moment after it is first asked to.
        std::thread::sleep(Duration::from_millis(50));
        let sent = clock.now_us();
        a.send(&[2, 0]).unwrap();
        std::thread::sleep(Duration::from_millis(60));
        assert_eq!(b.recv(WAIT).unwrap(), Some(vec![2, 0]));
        let read = clock.now_us();
        let at = b.last_stamp().expect("a stamp").at_us;
        // Read at least 300 ms of this clock after it came; it came after
        // it was sent (a µs of rounding either way).
        assert!(at + 1 >= sent, "stamped {at}, sent {sent}");
        assert!(read >= at + 250_000, "stamped {at}, read {read}");
    }

    #[test]
    fn nothing_waiting_and_foreign_ignored() {
        let (mut a, mut b) = UdpTransport::loopback_pair().unwrap();
        assert_eq!(b.recv(None).unwrap(), None);
        let stranger = UdpSocket::bind("127.0.0.1:0").unwrap();
        stranger
            .send_to(&[1, 2, 0], b.local_addr().unwrap())
            .unwrap();
        a.send(&[3, 0]).unwrap();
        assert_eq!(b.recv(WAIT).unwrap(), Some(vec![3, 0]));
        assert_eq!(b.foreign(), 1);
    }

    #[test]
    fn listener_answers_latest_sender() {
        let mut node = UdpTransport::listen("127.0.0.1:0").unwrap();
        let addr = node.local_addr().unwrap();
        assert!(node.name().starts_with("udp-listen:127.0.0.1:"));
        assert_eq!(
            node.send(&[1, 0]).unwrap_err().kind(),
            io::ErrorKind::NotConnected
        );
        let mut host = UdpTransport::connect(addr).unwrap();
        host.send(&[2, 0]).unwrap();
        assert_eq!(node.recv(WAIT).unwrap(), Some(vec![2, 0]));
        assert_eq!(
            node.peer(),
            Some(host.local_addr().unwrap().port())
                .map(|p| (std::net::Ipv4Addr::LOCALHOST, p).into())
        );
        node.send(&[3, 0]).unwrap();
        assert_eq!(host.recv(WAIT).unwrap(), Some(vec![3, 0]));
        // A restarted host on a new port is answered there.
        let mut host2 = UdpTransport::connect(addr).unwrap();
        host2.send(&[4, 0]).unwrap();
        assert_eq!(node.recv(WAIT).unwrap(), Some(vec![4, 0]));
        node.send(&[5, 0]).unwrap();
        assert_eq!(host2.recv(WAIT).unwrap(), Some(vec![5, 0]));
        assert_eq!(host.recv(None).unwrap(), None);
    }

    #[test]
    fn link_over_udp_delivers_1000_in_order() {
        let (mut a, mut b) = UdpTransport::loopback_pair().unwrap();
        let got = link_exchange(&mut a, &mut b, 1000, Some(Duration::from_millis(20))).got;
        assert_eq!(got, (0..1000).collect::<Vec<u32>>());
    }
}
