//! Datagrams' arrival read at the socket: Linux stamps each datagram as
//! it is queued for the socket (`SO_TIMESTAMPNS`), so a process that gets
//! to read it late (a loaded computer, a scheduler's turn) still knows
//! when it came. A clock exchange stamped on reading instead carries that
//! wait in one direction only, an asymmetry no two-way exchange can see.
//!
//! The kernel's stamp is on the system's real-time clock; what a transport
//! reports is on the process's own clock (scaled and skewed,
//! [`WallClock`]): the stamp's age, read on the real-time clock just
//! before the process's clock is, taken back from the process's clock at
//! its rate. Elsewhere than Linux there are no stamps.

use crate::clock::{Clock, WallClock};
use std::io;
use std::net::{SocketAddr, UdpSocket};

/// The arrival stamps of one socket, on `clock`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SocketStamps {
    clock: WallClock,
}

/// A datagram read with its stamp.
pub(crate) struct Stamped {
    /// Its length in the buffer.
    pub len: usize,
    /// Who sent it.
    pub from: SocketAddr,
    /// Its arrival, µs of the stamps' clock (`None`: the kernel gave none).
    pub at_us: Option<u64>,
}

/// How close the real-time readings either side of the process's clock
/// must lie for the pair to count as one instant.
#[cfg(target_os = "linux")]
const PAIRED_READ: std::time::Duration = std::time::Duration::from_micros(5);

/// Tries at reading both clocks at one instant.
#[cfg(target_os = "linux")]
const PAIRED_TRIES: usize = 8;

#[cfg(target_os = "linux")]
impl SocketStamps {
    /// Asks the kernel to stamp every datagram `sock` receives.
    pub(crate) fn enable(sock: &UdpSocket, clock: WallClock) -> io::Result<SocketStamps> {
        use nix::sys::socket::{setsockopt, sockopt::ReceiveTimestampns};
        use std::os::fd::AsRawFd;
        setsockopt(sock.as_raw_fd(), ReceiveTimestampns, &true).map_err(io::Error::from)?;
        Ok(SocketStamps { clock })
    }

    /// Reads one datagram (as `recv_from` does: blocking or not, with the
    /// socket's read timeout), with its arrival.
    pub(crate) fn recv_from(&self, sock: &UdpSocket, buf: &mut [u8]) -> io::Result<Stamped> {
        use nix::sys::socket::{recvmsg, ControlMessageOwned, MsgFlags, SockaddrStorage};
        use std::io::IoSliceMut;
        use std::os::fd::AsRawFd;
        let mut iov = [IoSliceMut::new(buf)];
        let mut space = nix::cmsg_space!(nix::sys::time::TimeSpec);
        let msg = recvmsg::<SockaddrStorage>(
            sock.as_raw_fd(),
            &mut iov,
            Some(&mut space),
            MsgFlags::empty(),
        )
        .map_err(io::Error::from)?;
        let mut kernel = None;
        for c in msg.cmsgs() {
            if let ControlMessageOwned::ScmTimestampns(ts) = c {
                kernel = Some(std::time::Duration::new(
                    ts.tv_sec().max(0) as u64,
                    ts.tv_nsec().clamp(0, 999_999_999) as u32,
                ));
            }
        }
        let from = msg
            .address
            .and_then(|a| {
                if let Some(v4) = a.as_sockaddr_in() {
                    Some(SocketAddr::V4((*v4).into()))
                } else {
                    a.as_sockaddr_in6().map(|v6| SocketAddr::V6((*v6).into()))
                }
            })
            .ok_or_else(|| io::Error::other("a datagram without its sender's address"))?;
        let at_us = kernel.map(|k| self.age_to_local(k));
        Ok(Stamped {
            len: msg.bytes,
            from,
            at_us,
        })
    }

    /// The stamps' clock now.
    pub(crate) fn now_us(&self) -> u64 {
        self.clock.now_us()
    }

    /// The process's clock when the kernel stamped `kernel` (real time
    /// since the epoch).
    fn age_to_local(&self, kernel: std::time::Duration) -> u64 {
        let (real, now) = self.both_clocks();
        // A stamp from the future (the real-time clock stepped back) is
        // taken as now.
        let age_us = real.saturating_sub(kernel).as_secs_f64() * 1e6 * self.clock.rate();
        now.saturating_sub(age_us as u64)
    }

    /// The real-time clock and the process's clock read at one instant: a
    /// process preempted between the two readings would date the stamp
    /// late by its wait, so they are read again until the real-time
    /// readings either side lie within [`PAIRED_READ`] (or the tries run
    /// out), and the middle of those is taken.
    fn both_clocks(&self) -> (std::time::Duration, u64) {
        let real = || {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .unwrap_or_default()
        };
        let mut best = None;
        for _ in 0..PAIRED_TRIES {
            let before = real();
            let now = self.clock.now_us();
            let after = real();
            let spread = after.saturating_sub(before);
            let mid = before + spread / 2;
            if best.is_none_or(|(s, _, _)| spread < s) {
                best = Some((spread, mid, now));
            }
            if spread <= PAIRED_READ {
                break;
            }
        }
        let (_, mid, now) = best.expect("at least one try");
        (mid, now)
    }
}

#[cfg(not(target_os = "linux"))]
impl SocketStamps {
    /// No stamps here.
    pub(crate) fn enable(_sock: &UdpSocket, _clock: WallClock) -> io::Result<SocketStamps> {
        Err(io::Error::new(
            io::ErrorKind::Unsupported,
            "datagram arrival stamps need Linux",
        ))
    }

    /// Never called: [`SocketStamps::enable`] fails.
    pub(crate) fn now_us(&self) -> u64 {
        self.clock.now_us()
    }

    /// Never called: [`SocketStamps::enable`] fails.
    pub(crate) fn recv_from(&self, sock: &UdpSocket, buf: &mut [u8]) -> io::Result<Stamped> {
        let (len, from) = sock.recv_from(buf)?;
        Ok(Stamped {
            len,
            from,
            at_us: None,
        })
    }
}
