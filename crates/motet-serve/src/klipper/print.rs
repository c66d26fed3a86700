//! The virtual SD card: a file in the printer host's G-code folder printed
//! as a job of the server's own (read, checked and planned like an upload),
//! and the print's state as Klipper's `print_stats` tells it, shared by
//! every connection.

use super::CLIENT;
use crate::jobs::{read_upload, ReadOptions, StoredJob};
use crate::server::Shared;
use crate::session::{Session, State};

use std::path::{Component, Path, PathBuf};
use std::sync::mpsc;
use std::sync::Arc;

/// The print started from the virtual SD card, if any.
#[derive(Clone, Debug)]
pub(crate) struct Print {
    /// The file name as given (relative to the G-code folder).
    pub filename: String,
    /// Where it is.
    pub path: PathBuf,
    /// Its size, bytes.
    pub size: u64,
    /// Its job on the server.
    pub job: u64,
    /// When it started, µs (server time).
    pub started_us: u64,
    /// Time spent paused so far, µs.
    pub paused_us: u64,
    /// Paused since, µs.
    pub paused_since: Option<u64>,
    /// Fraction of the file done, as last seen.
    pub progress: f64,
    /// How it ended (`complete`, `cancelled`, `error`), when, and why.
    pub ended: Option<(&'static str, u64, String)>,
}

impl Print {
    /// Klipper's print state: `printing`, `paused`, `complete`,
    /// `cancelled` or `error`.
    pub fn state(&self) -> &'static str {
        match (&self.ended, self.paused_since) {
            (Some((s, _, _)), _) => s,
            (None, Some(_)) => "paused",
            (None, None) => "printing",
        }
    }

    /// Seconds since it started (to its end, once ended).
    pub fn total_s(&self, now: u64) -> f64 {
        let end = self.ended.as_ref().map_or(now, |e| e.1);
        end.saturating_sub(self.started_us) as f64 * 1e-6
    }

    /// Seconds spent printing (not paused).
    pub fn print_s(&self, now: u64) -> f64 {
        let end = self.ended.as_ref().map_or(now, |e| e.1);
        let paused = self.paused_us + self.paused_since.map_or(0, |p| end.saturating_sub(p));
        (end.saturating_sub(self.started_us).saturating_sub(paused)) as f64 * 1e-6
    }

    /// Follows the session: progress, pauses, and the end.
    pub fn follow(&mut self, s: &Session) {
        if self.ended.is_some() {
            return;
        }
        let now = s.status().t_us;
        if s.job_id() == Some(self.job) {
            if let Some(j) = s.status().job {
                self.progress = j.progress;
            }
            match (s.state() == State::Paused, self.paused_since) {
                (true, None) => self.paused_since = Some(now),
                (false, Some(p)) => {
                    self.paused_us += now.saturating_sub(p);
                    self.paused_since = None;
                }
                _ => {}
            }
            return;
        }
        let Some(out) = s.history().filter(|h| h.id == self.job).last() else {
            return;
        };
        if let Some(p) = self.paused_since.take() {
            self.paused_us += out.ended_us.saturating_sub(p);
        }
        let state = match out.outcome.as_str() {
            "finished" => {
                self.progress = 1.0;
                "complete"
            }
            "cancelled" => "cancelled",
            _ => "error",
        };
        self.ended = Some((state, out.ended_us, out.outcome.clone()));
    }
}

/// A file being read into a job, off the session's lock.
pub(crate) struct Loading {
    filename: String,
    path: PathBuf,
    size: u64,
    done: mpsc::Receiver<Result<StoredJob, String>>,
}

/// The file `name` in `gcodes`: relative, inside it, and there.
pub(crate) fn resolve(gcodes: &Path, name: &str) -> Result<PathBuf, String> {
    let rel = Path::new(name.trim_start_matches('/'));
    let inside = rel
        .components()
        .all(|c| matches!(c, Component::Normal(_) | Component::CurDir));
    if name.trim().is_empty() || !inside {
        return Err(format!(
            "Unable to open file {name:?}: not in the G-code folder"
        ));
    }
    let path = gcodes.join(rel);
    if !path.is_file() {
        return Err(format!("Unable to open file {name:?}"));
    }
    Ok(path)
}

/// Starts reading `name` from `gcodes` on a thread of its own.
pub(crate) fn load(shared: &Arc<Shared>, gcodes: &Path, name: &str) -> Result<Loading, String> {
    let path = resolve(gcodes, name)?;
    let size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    let (id, dir) = shared.jobs().reserve();
    let machine = shared.machine.clone();
    let (tx, done) = mpsc::channel();
    let (p, n) = (path.clone(), name.to_string());
    std::thread::Builder::new()
        .name("motet-klipper-load".into())
        .spawn(move || {
            let read = std::fs::read(&p).map_err(|e| format!("Unable to open file {n:?}: {e}"));
            // Slicers' files carry commands motet does not run (fan,
            // temperature reports, macros): skipped with a warning, as a
            // printer host's own skips what it has no module for.
            let opts = ReadOptions {
                allow_unknown: true,
                ..ReadOptions::default()
            };
            let job = read.and_then(|b| {
                read_upload(&machine, &dir, id, &n, &b, &opts).map_err(|e| e.to_string())
            });
            let _ = tx.send(job);
        })
        .map_err(|e| e.to_string())?;
    Ok(Loading {
        filename: name.to_string(),
        path,
        size,
        done,
    })
}

/// What became of a file being read.
pub(crate) enum Loaded {
    /// Still reading.
    Wait,
    /// Started on the machine.
    Started(Print),
    /// Refused: why.
    Failed(String),
}

impl Loading {
    /// Starts the job once read.
    pub fn poll(&self, shared: &Shared, s: &mut Session) -> Loaded {
        let job = match self.done.try_recv() {
            Err(mpsc::TryRecvError::Empty) => return Loaded::Wait,
            Err(mpsc::TryRecvError::Disconnected) => {
                return Loaded::Failed("reading the file failed".into())
            }
            Ok(Err(e)) => return Loaded::Failed(e),
            Ok(Ok(job)) => job,
        };
        let (running, queued) = (s.job_id(), s.queued_ids());
        let job = shared
            .jobs()
            .insert(job, |id| running == Some(id) || queued.contains(&id));
        // Kept across restarts: the clock thread writes it out.
        s.mark_changed();
        let id = job.id;
        if let Err(e) = s.start(job, CLIENT) {
            return Loaded::Failed(e.to_string());
        }
        Loaded::Started(Print {
            filename: self.filename.clone(),
            path: self.path.clone(),
            size: self.size,
            job: id,
            started_us: s.status().t_us,
            paused_us: 0,
            paused_since: None,
            progress: 0.0,
            ended: None,
        })
    }
}
