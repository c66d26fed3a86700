//! UDP multicast as a shared medium: every member (the host and each node)
//! joins one group and sends each frame as one datagram to it, so every
//! member hears every frame, as on a bus: a group seal, stop or sync frame
//! sent once reaches every node.
//!
//! A member receives on the group's port (shared by every member on one
//! computer) and sends from a port of its own, whose address names its
//! frames: its own frames heard back are dropped, or, when it asks
//! ([`UdpGroup::hearing_own`]), handed out stamped `own`.
//!
//! Stamps: given a clock ([`UdpGroup::stamping`]), a frame is stamped when
//! it is taken from the socket, in the receiver's clock. On one computer's
//! loopback the datagram reaches every member's socket at once, so when
//! every member takes it in the same moment (a simulation that waits for
//! delivery, [`GroupTally::settle`]) the stamps are one instant on every
//! clock, as a bus controller's are. A process reading its socket when its
//! main loop gets there stamps late by that loop's delay, which no two
//! members share: there such stamps are no reference. The kernel's own
//! stamps ([`Transport::stamp_arrivals`], on Linux) are: each member's
//! socket is stamped as the kernel delivers the datagram to all of them,
//! so node processes and a host on one computer (or on one switch, to
//! within its forwarding) share each frame's instant. A member claims
//! its own frames heard back only with stamps of either kind.

use crate::clock::{Clock, Crystal, WallClock};
use crate::udp_stamp::SocketStamps;
use crate::{LinkStats, Stamp, Transport};
use std::collections::VecDeque;
use std::io;
use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4, UdpSocket};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// Largest datagram accepted; anything longer is cut (and then fails to
/// decode).
const MAX_DATAGRAM: usize = 2048;

/// A frame taken from the socket, with its stamp.
type Taken = (Vec<u8>, Option<Stamp>);

/// One member's receiving side, shared with a [`GroupTally`] that may take
/// its frames for it.
struct Member {
    rx: UdpSocket,
    /// This member's sending address: frames from it are its own.
    me: SocketAddr,
    hear_own: bool,
    stamping: Option<(Arc<dyn Clock + Send + Sync>, Crystal)>,
    /// The kernel's arrival stamps, on the process's clock
    /// ([`Transport::stamp_arrivals`]): taken before `stamping`.
    kernel: Option<SocketStamps>,
    inbox: VecDeque<Taken>,
    /// Datagrams taken from the socket, own ones included.
    taken: u64,
}

impl Member {
    /// Takes every datagram the socket has into the inbox, stamped now.
    fn pull(&mut self) -> io::Result<()> {
        let mut buf = [0u8; MAX_DATAGRAM];
        loop {
            let got = match &self.kernel {
                Some(st) => st
                    .recv_from(&self.rx, &mut buf)
                    .map(|d| (d.len, d.from, Some(d.at_us.unwrap_or_else(|| st.now_us())))),
                None => self.rx.recv_from(&mut buf).map(|(n, f)| (n, f, None)),
            };
            match got {
                Ok((n, from, kernel_at)) => {
                    self.taken += 1;
                    let own = from == self.me;
                    // Its own frame is worth something only stamped: the
                    // instant every member heard it.
                    let stamped = self.kernel.is_some() || self.stamping.is_some();
                    if own && !(self.hear_own && stamped) {
                        continue;
                    }
                    let at = kernel_at.or_else(|| {
                        let (clock, crystal) = self.stamping.as_ref()?;
                        Some(crystal.local(clock.now_us() as f64))
                    });
                    let stamp = at.map(|at_us| Stamp { at_us, own });
                    self.inbox.push_back((buf[..n].to_vec(), stamp));
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(()),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
}

fn lock(m: &Mutex<Member>) -> MutexGuard<'_, Member> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// A member of a UDP multicast group (see the module documentation).
pub struct UdpGroup {
    name: String,
    tx: UdpSocket,
    group: SocketAddrV4,
    member: Arc<Mutex<Member>>,
    tally: Option<Arc<GroupTally>>,
    last_stamp: Option<Stamp>,
    stats: LinkStats,
}

impl UdpGroup {
    /// Joins `group` (a multicast address and port) on the interface
    /// `iface` (its address: 127.0.0.1 for this computer's loopback).
    pub fn join(group: SocketAddrV4, iface: Ipv4Addr) -> io::Result<UdpGroup> {
        if !group.ip().is_multicast() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("{} is not a multicast address (224.0.0.0/4)", group.ip()),
            ));
        }
        let sock = socket2::Socket::new(
            socket2::Domain::IPV4,
            socket2::Type::DGRAM,
            Some(socket2::Protocol::UDP),
        )?;
        // Every member on this computer receives on the group's port.
        sock.set_reuse_address(true)?;
        #[cfg(unix)]
        sock.set_reuse_port(true)?;
        sock.bind(&SocketAddr::V4(group).into())?;
        let rx: UdpSocket = sock.into();
        rx.join_multicast_v4(group.ip(), &iface)?;
        rx.set_nonblocking(true)?;
        let tx = socket2::Socket::new(
            socket2::Domain::IPV4,
            socket2::Type::DGRAM,
            Some(socket2::Protocol::UDP),
        )?;
        tx.set_multicast_if_v4(&iface)?;
        tx.set_multicast_loop_v4(true)?;
        tx.set_multicast_ttl_v4(1)?;
        tx.bind(&SocketAddr::V4(SocketAddrV4::new(iface, 0)).into())?;
        let tx: UdpSocket = tx.into();
        let me = tx.local_addr()?;
        Ok(UdpGroup {
            name: format!("udp-group:{group}@{iface} ({me})"),
            tx,
            group,
            member: Arc::new(Mutex::new(Member {
                rx,
                me,
                hear_own: false,
                stamping: None,
                kernel: None,
                inbox: VecDeque::new(),
                taken: 0,
            })),
            tally: None,
            last_stamp: None,
            stats: LinkStats::default(),
        })
    }

    /// Stamps each frame when it is taken from the socket, `crystal`'s
    /// reading of `clock` (see the module documentation on what such a
    /// stamp is worth).
    pub fn stamping(self, clock: Arc<dyn Clock + Send + Sync>, crystal: Crystal) -> UdpGroup {
        lock(&self.member).stamping = Some((clock, crystal));
        self
    }

    /// Hands this member's own frames back too, stamped `own` (with a
    /// clock): the instant every member heard them, where every member
    /// takes a frame in the same moment.
    pub fn hearing_own(self) -> UdpGroup {
        lock(&self.member).hear_own = true;
        self
    }

    /// Counts this member's frames into `tally`, which waits for them to
    /// reach every member.
    pub fn counted(mut self, tally: &Arc<GroupTally>) -> UdpGroup {
        tally
            .members
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(self.member.clone());
        self.tally = Some(tally.clone());
        self
    }

    /// The address this member's frames come from.
    pub fn address(&self) -> SocketAddr {
        lock(&self.member).me
    }
}

impl Transport for UdpGroup {
    fn name(&self) -> &str {
        &self.name
    }

    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        self.tx.send_to(frame, self.group)?;
        if let Some(t) = &self.tally {
            t.sent.fetch_add(1, Ordering::SeqCst);
        }
        self.stats.sent(frame.len());
        Ok(())
    }

    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>> {
        let until = timeout.map(|t| Instant::now() + t);
        loop {
            let mut m = lock(&self.member);
            if m.inbox.is_empty() {
                m.pull()?;
            }
            if let Some((f, stamp)) = m.inbox.pop_front() {
                if !stamp.is_some_and(|s| s.own) {
                    self.stats.received(f.len());
                }
                self.last_stamp = stamp;
                return Ok(Some(f));
            }
            drop(m);
            match until {
                Some(u) if Instant::now() < u => std::thread::sleep(Duration::from_micros(200)),
                _ => return Ok(None),
            }
        }
    }

    fn stats(&self) -> &LinkStats {
        &self.stats
    }

    fn last_stamp(&self) -> Option<Stamp> {
        self.last_stamp
    }

    /// The kernel stamps every datagram as it reaches this member's
    /// socket: on one computer a frame reaches every member's socket in
    /// one pass of the kernel, so the stamps are one instant on every
    /// member's clock however late each process reads it, and a member
    /// hearing its own frames ([`UdpGroup::hearing_own`]) has reference
    /// samples, as on a bus.
    fn stamp_arrivals(&mut self, clock: WallClock) -> bool {
        let mut m = lock(&self.member);
        match SocketStamps::enable(&m.rx, clock) {
            Ok(st) => {
                m.kernel = Some(st);
                true
            }
            Err(_) => false,
        }
    }
}

/// The members of one group in one process, and the frames they sent: a
/// simulation waits for every frame to reach every member before it goes
/// on ([`GroupTally::settle`]), as a bus delivers a frame to every node at
/// its end.
#[derive(Default)]
pub struct GroupTally {
    sent: AtomicU64,
    members: Mutex<Vec<Arc<Mutex<Member>>>>,
}

impl GroupTally {
    /// A tally with no members yet.
    pub fn new() -> Arc<GroupTally> {
        Arc::new(GroupTally::default())
    }

    /// Waits, at most `timeout` of real time, until every frame the members
    /// sent has been taken from every member's socket (stamped now, each in
    /// its member's clock). Returns whether all arrived.
    pub fn settle(&self, timeout: Duration) -> io::Result<bool> {
        let until = Instant::now() + timeout;
        let members = self.members.lock().unwrap_or_else(|e| e.into_inner());
        loop {
            let sent = self.sent.load(Ordering::SeqCst);
            let mut all = true;
            for m in members.iter() {
                let mut m = lock(m);
                m.pull()?;
                all &= m.taken >= sent;
            }
            if all {
                return Ok(true);
            }
            if Instant::now() >= until {
                return Ok(false);
            }
            std::thread::yield_now();
        }
    }
}

/// A free port for a new group on this computer's loopback: one the system
/// hands out for UDP now.
pub fn free_port() -> io::Result<u16> {
    Ok(UdpSocket::bind((Ipv4Addr::LOCALHOST, 0))?
        .local_addr()?
        .port())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_member_hears_every_frame_and_its_own_when_it_asks() {
        let group = SocketAddrV4::new(Ipv4Addr::new(239, 255, 77, 1), free_port().unwrap());
        let tally = GroupTally::new();
        let join = || UdpGroup::join(group, Ipv4Addr::LOCALHOST).unwrap();
        let clock: Arc<dyn Clock + Send + Sync> = Arc::new(crate::SimClock::new());
        let mut host = join()
            .stamping(clock, Crystal::default())
            .hearing_own()
            .counted(&tally);
        // Its own frames are worth nothing unstamped: not handed back.
        let mut unstamped = join().hearing_own().counted(&tally);
        let mut a = join().counted(&tally);
        let mut b = join().counted(&tally);
        host.send(b"seal\0").unwrap();
        a.send(b"beat\0").unwrap();
        assert!(tally.settle(Duration::from_secs(5)).unwrap());
        assert_eq!(a.recv(None).unwrap().as_deref(), Some(&b"seal\0"[..]));
        assert_eq!(a.recv(None).unwrap(), None, "its own frame is dropped");
        assert_eq!(b.recv(None).unwrap().as_deref(), Some(&b"seal\0"[..]));
        assert_eq!(b.recv(None).unwrap().as_deref(), Some(&b"beat\0"[..]));
        let mut got = Vec::new();
        while let Some(f) = host.recv(None).unwrap() {
            got.push(f);
        }
        assert!(got.contains(&b"seal\0".to_vec()) && got.contains(&b"beat\0".to_vec()));
        unstamped.send(b"mine\0").unwrap();
        assert!(tally.settle(Duration::from_secs(5)).unwrap());
        let mut heard = Vec::new();
        while let Some(f) = unstamped.recv(None).unwrap() {
            heard.push(f);
        }
        assert!(!heard.contains(&b"mine\0".to_vec()), "{heard:?}");
        assert!(heard.contains(&b"seal\0".to_vec()));
        assert_eq!((a.stats().frames_out, b.stats().frames_in), (1, 2));
        assert!(UdpGroup::join(
            SocketAddrV4::new(Ipv4Addr::LOCALHOST, 4000),
            Ipv4Addr::LOCALHOST
        )
        .is_err());
    }
}
