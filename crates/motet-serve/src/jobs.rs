//! Uploaded jobs: each stored under the server's own folder with a name the
//! server makes (nothing the client sends reaches a path), read and checked
//! against the machine once, and kept with its preview until newer uploads
//! push it out.

use crate::preview::Preview;
use motet_api::{load_job, JobKind, JobOptions};
use motet_host::Machine;
use motet_planner::{Command, Located};
use serde::Serialize;
use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Largest upload, bytes.
pub const MAX_UPLOAD: usize = 32 << 20;
/// Jobs kept; the oldest (not running) go with their files.
pub const KEPT_JOBS: usize = 16;
/// Longest file name kept for display, characters.
const MAX_NAME: usize = 200;

/// Why an upload was refused. Nothing was kept.
#[derive(Debug, thiserror::Error)]
pub enum UploadError {
    /// No usable file name.
    #[error("the file name {0:?} is empty or not printable")]
    Name(String),
    /// A file of a kind motet does not read.
    #[error(
        "{name}: motet reads G-code (.gcode, .nc, .g …), SVG and photos (.png, .jpg), not .{ext}"
    )]
    Kind {
        /// The file name.
        name: String,
        /// Its extension.
        ext: String,
    },
    /// Over [`MAX_UPLOAD`].
    #[error("the upload is {size} bytes; at most {max} are taken")]
    TooLarge {
        /// Its size.
        size: usize,
        /// The limit.
        max: usize,
    },
    /// Nothing was sent.
    #[error("the upload is empty")]
    Empty,
    /// The server could not store it.
    #[error("storing the upload: {0}")]
    Io(#[from] std::io::Error),
    /// The job does not read, plan or fit the machine: the message says
    /// where (`name:line:column: …`).
    #[error("{0}")]
    Job(String),
}

/// A job read and checked against the machine.
#[derive(Debug, Serialize)]
pub struct StoredJob {
    /// Its id on this server.
    pub id: u64,
    /// The file name it was uploaded as (display only).
    pub name: String,
    /// `gcode`, `svg` or `image`.
    pub kind: &'static str,
    /// Bytes uploaded.
    pub bytes: usize,
    /// How long it takes as planned, seconds.
    pub planned_s: f64,
    /// Things read but not acted on, with their places.
    pub warnings: Vec<String>,
    /// Number of commands.
    pub command_count: usize,
    /// Where a placed drawing landed (`--fit`, `--scale`, `--rotate`,
    /// `--origin`), if it was placed.
    pub placed: Option<PlacedInfo>,
    /// Its commands, in machine space.
    #[serde(skip)]
    pub commands: Vec<Located<Command>>,
    /// What it draws.
    #[serde(skip)]
    pub preview: Preview,
    #[serde(skip)]
    file: PathBuf,
}

/// Where a placed drawing landed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PlacedInfo {
    /// Its scale.
    pub scale: f64,
    /// Its turn, degrees counter-clockwise.
    pub rotate_deg: f64,
    /// Lower-left corner of what it draws, machine units.
    pub min: [f64; 2],
    /// Upper-right corner.
    pub max: [f64; 2],
    /// Moves put onto the travel's edge (within the placement tolerance).
    pub clamped_moves: usize,
}

/// The uploaded jobs.
pub struct JobStore {
    dir: PathBuf,
    next: u64,
    jobs: VecDeque<Arc<StoredJob>>,
}

impl JobStore {
    /// Jobs stored under `dir/jobs` (made if missing).
    pub fn new(dir: &Path) -> std::io::Result<JobStore> {
        let dir = dir.join("jobs");
        std::fs::create_dir_all(&dir)?;
        Ok(JobStore {
            dir,
            next: 1,
            jobs: VecDeque::new(),
        })
    }

    /// A new job id, and the folder its file goes in.
    pub fn reserve(&mut self) -> (u64, PathBuf) {
        let id = self.next;
        self.next += 1;
        (id, self.dir.clone())
    }

    /// Keeps a job; the oldest beyond [`KEPT_JOBS`] go, unless `busy` says
    /// one is on the machine.
    pub fn insert(&mut self, job: StoredJob, busy: impl Fn(u64) -> bool) -> Arc<StoredJob> {
        let job = Arc::new(job);
        self.jobs.push_back(job.clone());
        while self.jobs.len() > KEPT_JOBS {
            let Some(i) = self.jobs.iter().position(|j| !busy(j.id)) else {
                break;
            };
            if let Some(old) = self.jobs.remove(i) {
                let _ = std::fs::remove_file(&old.file);
            }
        }
        job
    }

    /// The job with this id.
    pub fn get(&self, id: u64) -> Option<Arc<StoredJob>> {
        self.jobs.iter().find(|j| j.id == id).cloned()
    }

    /// Every job kept, oldest first.
    pub fn list(&self) -> Vec<Arc<StoredJob>> {
        self.jobs.iter().cloned().collect()
    }
}

/// Stores `bytes` as job `id` in `dir` and reads it for `machine`. `name`
/// is the client's file name: only its extension (checked against the
/// kinds motet reads) and its text for display are used.
pub fn read_upload(
    machine: &Machine,
    dir: &Path,
    id: u64,
    name: &str,
    bytes: &[u8],
    opts: &JobOptions,
) -> Result<StoredJob, UploadError> {
    let name = display_name(name)?;
    if bytes.is_empty() {
        return Err(UploadError::Empty);
    }
    if bytes.len() > MAX_UPLOAD {
        return Err(UploadError::TooLarge {
            size: bytes.len(),
            max: MAX_UPLOAD,
        });
    }
    let lower = name.to_ascii_lowercase();
    let (stem, gz) = match lower.strip_suffix(".gz") {
        Some(s) => (s, ".gz"),
        None => (lower.as_str(), ""),
    };
    let ext = stem.rsplit_once('.').map_or("", |(_, e)| e);
    let kind = JobKind::of(Path::new(&lower)).map_err(|_| UploadError::Kind {
        name: name.clone(),
        ext: ext.to_string(),
    })?;
    // The extension passed the kinds' list: letters only, safe in a path.
    let file = dir.join(format!("{id}.{ext}{gz}"));
    std::fs::write(&file, bytes)?;
    let read = load_job(machine, &file, opts).map_err(|e| {
        let _ = std::fs::remove_file(&file);
        UploadError::Job(e.to_string().replace(&file.display().to_string(), &name))
    });
    let job = read?;
    let preview = Preview::of(machine, &job.commands);
    let warnings = job
        .warnings
        .iter()
        .map(|w| w.replace(&file.display().to_string(), &name))
        .collect();
    Ok(StoredJob {
        id,
        name,
        kind: match kind {
            JobKind::Gcode => "gcode",
            JobKind::Svg => "svg",
            JobKind::Image => "image",
        },
        bytes: bytes.len(),
        planned_s: job.planned_s.unwrap_or(0.0),
        warnings,
        command_count: job.commands.len(),
        placed: job.placed.map(|p| PlacedInfo {
            scale: p.scale,
            rotate_deg: p.rotate_deg,
            min: p.min,
            max: p.max,
            clamped_moves: p.clamps.moves,
        }),
        commands: job.commands,
        preview,
        file,
    })
}

/// The last component of a client's file name, for display.
fn display_name(name: &str) -> Result<String, UploadError> {
    let last = name.rsplit(['/', '\\']).next().unwrap_or("").trim();
    if last.is_empty() || last == "." || last == ".." || last.chars().any(char::is_control) {
        return Err(UploadError::Name(name.to_string()));
    }
    Ok(last.chars().take(MAX_NAME).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_names_keep_only_the_last_component() {
        for (given, want) in [
            ("drawing.svg", Some("drawing.svg")),
            ("../../etc/passwd.svg", Some("passwd.svg")),
            ("C:\\Users\\me\\part.gcode", Some("part.gcode")),
            ("..", None),
            ("", None),
            ("a/", None),
            ("bad\nname.svg", None),
        ] {
            let got = display_name(given).ok();
            assert_eq!(got.as_deref(), want, "{given:?}");
        }
    }
}
