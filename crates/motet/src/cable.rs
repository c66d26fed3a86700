//! A simulated node's cable, which a person (or a test) can pull: `kill
//! -USR1 PID` pulls it, the next one plugs it back. While it is out the
//! node neither hears nor is heard, and keeps running: it brakes on its
//! committed tail when the host's seals stop coming, as a board whose
//! cable came loose does. What went by while it was out is gone.

use motet_link::{LinkStats, Stamp, Transport, WallClock};
use std::io;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::{Duration, Instant};

/// Out or in; flipped by the signal.
static OUT: AtomicBool = AtomicBool::new(false);
/// Flips the node has seen (to say each one once).
static FLIPS: AtomicU32 = AtomicU32::new(0);

extern "C" fn on_usr1(_: libc::c_int) {
    // Only atomics here: a signal handler may do nothing else.
    OUT.fetch_xor(true, Ordering::SeqCst);
    FLIPS.fetch_add(1, Ordering::SeqCst);
}

/// Installs the signal handler (once a process).
pub fn install() -> io::Result<()> {
    // SAFETY: the handler only touches atomics; `sigaction` with a zeroed
    // struct and an empty mask is the documented way to set one.
    unsafe {
        let mut sa: libc::sigaction = std::mem::zeroed();
        sa.sa_sigaction = on_usr1 as extern "C" fn(libc::c_int) as usize;
        sa.sa_flags = libc::SA_RESTART;
        libc::sigemptyset(&mut sa.sa_mask);
        if libc::sigaction(libc::SIGUSR1, &sa, std::ptr::null_mut()) != 0 {
            return Err(io::Error::last_os_error());
        }
    }
    Ok(())
}

/// Whether the cable is out now.
pub fn out() -> bool {
    OUT.load(Ordering::SeqCst)
}

/// A transport behind the cable: frames either way are dropped while it
/// is out.
pub struct Cable {
    inner: Box<dyn Transport + Send>,
}

impl Cable {
    pub fn new(inner: Box<dyn Transport + Send>) -> Cable {
        Cable { inner }
    }
}

/// What the cable did since it was last asked.
pub struct News {
    seen: u32,
}

impl News {
    pub fn new() -> News {
        News {
            seen: FLIPS.load(Ordering::SeqCst),
        }
    }

    /// "cable pulled …" or "cable plugged back …" when it flipped since
    /// the last call.
    pub fn take(&mut self) -> Option<&'static str> {
        let flips = FLIPS.load(Ordering::SeqCst);
        if flips == self.seen {
            return None;
        }
        self.seen = flips;
        Some(if out() {
            "cable pulled (SIGUSR1): the node neither hears nor is heard"
        } else {
            "cable plugged back (SIGUSR1)"
        })
    }
}

impl Transport for Cable {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        if out() {
            return Ok(());
        }
        self.inner.send(frame)
    }

    fn recv(&mut self, timeout: Option<Duration>) -> io::Result<Option<Vec<u8>>> {
        // What arrives while the cable is out never reached the node: read
        // and dropped until the wait is over.
        let until = timeout.map(|t| Instant::now() + t);
        loop {
            let left = until.map(|u| u.saturating_duration_since(Instant::now()));
            let frame = self.inner.recv(left)?;
            if frame.is_none() || !out() {
                return Ok(frame);
            }
            if left.is_some_and(|l| l.is_zero()) {
                return Ok(None);
            }
        }
    }

    fn stats(&self) -> &LinkStats {
        self.inner.stats()
    }

    fn last_stamp(&self) -> Option<Stamp> {
        self.inner.last_stamp()
    }

    fn stamp_arrivals(&mut self, clock: WallClock) -> bool {
        self.inner.stamp_arrivals(clock)
    }
}
