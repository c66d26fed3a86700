//! What a server keeps across restarts, in `DIR/state.json`: the uploaded
//! jobs (their files stay in `DIR/jobs/`, read again at start), the queue
//! and the history. Written whole to a temporary file and renamed over the
//! old one, so a server killed mid-write leaves the previous state, never
//! half of one.

use crate::jobs::SavedJob;
use crate::session::JobOutcome;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The file's format version.
const VERSION: u32 = 1;

/// What is kept.
#[derive(Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Saved {
    /// Format version (1).
    pub version: u32,
    /// The id the next upload gets (ids are never reused).
    pub next_job: u64,
    /// The jobs kept, oldest first.
    pub jobs: Vec<SavedJob>,
    /// Ids of the queued jobs, next first.
    pub queue: Vec<u64>,
    /// How jobs ended, oldest first.
    pub history: Vec<JobOutcome>,
}

/// Why the kept state could not be read. The server starts empty and keeps
/// the unreadable file aside (`state.json.bad`), so nothing is lost.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// Reading the file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What failed.
        source: std::io::Error,
    },
    /// It is not a state this server writes.
    #[error("{path}: line {line}, column {column}: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// Where.
        line: usize,
        /// Where on the line.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// Written by a newer motet.
    #[error("{path}: format version {found}; this motet reads version {VERSION}")]
    Version {
        /// The file.
        path: PathBuf,
        /// The version found.
        found: u32,
    },
}

/// The state file in the server's folder.
pub fn path(dir: &Path) -> PathBuf {
    dir.join("state.json")
}

/// Reads the kept state (`None` if there is none yet).
pub fn load(dir: &Path) -> Result<Option<Saved>, LoadError> {
    let path = path(dir);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(LoadError::Io { path, source }),
    };
    let saved: Saved = serde_json::from_str(&text).map_err(|e| LoadError::Format {
        path: path.clone(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })?;
    if saved.version != VERSION {
        return Err(LoadError::Version {
            path,
            found: saved.version,
        });
    }
    Ok(Some(saved))
}

/// Puts an unreadable state file aside, keeping it for the person.
pub fn set_aside(dir: &Path) -> std::io::Result<PathBuf> {
    let bad = dir.join("state.json.bad");
    std::fs::rename(path(dir), &bad)?;
    Ok(bad)
}

/// Writes `saved` in place of the kept state.
pub fn store(dir: &Path, saved: &Saved) -> std::io::Result<()> {
    let tmp = dir.join("state.json.tmp");
    let text = serde_json::to_string_pretty(saved).map_err(std::io::Error::other)?;
    std::fs::write(&tmp, text)?;
    std::fs::rename(&tmp, path(dir))
}

impl Saved {
    /// A state to write: `version` set.
    pub fn new(
        next_job: u64,
        jobs: Vec<SavedJob>,
        queue: Vec<u64>,
        history: Vec<JobOutcome>,
    ) -> Saved {
        Saved {
            version: VERSION,
            next_job,
            jobs,
            queue,
            history,
        }
    }
}
