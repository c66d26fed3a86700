//! Making the journal durable behind the run: a thread of its own calls
//! `fdatasync` on the journal's file whenever a seal asks, so a disk that
//! takes a tenth of a second to flush (an ext4 commit, a busy virtual
//! disk) never holds up the run's loop, and with it every node's clock
//! exchanges, acknowledgements and seals.
//!
//! A seal is written to the operating system before it is sent: a host
//! process that dies (killed, crashed) leaves every seal it sent in the
//! file. Only the host computer losing power within one flush can leave a
//! node a window ahead of the journal on disk, which `motet resume` names
//! (`NodeAhead`) instead of guessing.

use std::fs::File;
use std::io;
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Instant;

/// What the flushing thread reports.
#[derive(Default)]
struct Flushed {
    /// Requests made durable so far.
    done: u64,
    /// The first error, as the system said it; every later request fails.
    error: Option<(io::ErrorKind, String)>,
    /// The longest flush, µs of wall time.
    worst_us: u64,
}

/// The journal's flushing thread.
pub(super) struct Flusher {
    tx: Option<Sender<u64>>,
    flushed: Arc<Mutex<Flushed>>,
    requested: u64,
    thread: Option<JoinHandle<()>>,
}

fn lock(m: &Mutex<Flushed>) -> MutexGuard<'_, Flushed> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Flusher {
    /// A thread flushing `file` (a handle on the journal's open file).
    pub(super) fn start(file: File) -> io::Result<Flusher> {
        let (tx, rx) = mpsc::channel();
        let flushed = Arc::new(Mutex::new(Flushed::default()));
        let f = flushed.clone();
        let thread = std::thread::Builder::new()
            .name("journal-flush".into())
            .spawn(move || flush_loop(&file, &rx, &f))?;
        Ok(Flusher {
            tx: Some(tx),
            flushed,
            requested: 0,
            thread: Some(thread),
        })
    }

    /// Asks for everything written so far to reach the disk; returns at
    /// once. An earlier flush that failed is returned here.
    pub(super) fn request(&mut self) -> io::Result<()> {
        self.failed()?;
        self.requested += 1;
        if let Some(tx) = &self.tx {
            // A thread gone is a flush that failed: said by `failed` next.
            let _ = tx.send(self.requested);
        }
        Ok(())
    }

    /// The first flush that failed, if any.
    fn failed(&self) -> io::Result<()> {
        match &lock(&self.flushed).error {
            Some((kind, msg)) => Err(io::Error::new(*kind, msg.clone())),
            None => Ok(()),
        }
    }

    /// Whether every request so far has reached the disk.
    #[cfg(test)]
    pub(super) fn caught_up(&self) -> bool {
        lock(&self.flushed).done >= self.requested
    }

    /// The longest flush so far, µs of wall time.
    pub(super) fn worst_us(&self) -> u64 {
        lock(&self.flushed).worst_us
    }
}

impl Drop for Flusher {
    /// The last requests are flushed before the journal closes.
    fn drop(&mut self) {
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn flush_loop(file: &File, rx: &Receiver<u64>, flushed: &Mutex<Flushed>) {
    while let Ok(mut upto) = rx.recv() {
        // Requests that came during the last flush are one flush now.
        while let Ok(later) = rx.try_recv() {
            upto = later;
        }
        let t0 = Instant::now();
        let r = file.sync_data();
        let took = t0.elapsed().as_micros() as u64;
        let mut f = lock(flushed);
        f.worst_us = f.worst_us.max(took);
        match r {
            Ok(()) => f.done = upto,
            Err(e) => {
                f.error.get_or_insert((e.kind(), e.to_string()));
                return;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn requests_reach_the_disk_behind_the_writer_and_before_it_closes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("j");
        let mut file = File::create(&path).unwrap();
        let mut f = Flusher::start(file.try_clone().unwrap()).unwrap();
        for k in 0..20 {
            writeln!(file, "record {k}").unwrap();
            f.request().unwrap();
        }
        let t0 = Instant::now();
        while !f.caught_up() {
            assert!(t0.elapsed().as_secs() < 10, "the flushes never caught up");
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        drop(f);
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text.lines().count(), 20);
    }
}
