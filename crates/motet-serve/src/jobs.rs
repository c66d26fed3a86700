//! Uploaded jobs: each stored under the server's own folder with a name the
//! server makes (nothing the client sends reaches a path), read and checked
//! against the machine once, and kept with its preview until newer uploads
//! push it out.

use crate::preview::Preview;
use motet_api::{load_job, JobKind, JobOptions};
use motet_host::Machine;
use motet_planner::{Command, Located};
use serde::{Deserialize, Serialize};
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
    /// How it was read (kept so a restarted server reads it the same way).
    #[serde(skip)]
    pub options: ReadOptions,
    /// What it draws.
    #[serde(skip)]
    pub preview: Preview,
    #[serde(skip)]
    file: PathBuf,
}

/// How an upload is read: [`JobOptions`] in a form kept on disk.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ReadOptions {
    /// Unsupported G-codes skipped with a warning.
    #[serde(default)]
    pub allow_unknown: bool,
    /// Fit margin, mm.
    pub fit: Option<f64>,
    /// Scale factor.
    pub scale: Option<f64>,
    /// Turn, degrees counter-clockwise.
    #[serde(default)]
    pub rotate_deg: f64,
    /// Lower-left corner, machine x, y.
    pub origin: Option<[f64; 2]>,
}

impl ReadOptions {
    /// The options as the job reader takes them.
    pub fn job_options(&self) -> JobOptions {
        JobOptions {
            allow_unknown: self.allow_unknown,
            placement: motet_api::Placement {
                fit_margin_mm: self.fit,
                scale: self.scale,
                rotate_deg: self.rotate_deg,
                origin: self.origin,
            },
        }
    }
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

    /// The next id a job will get.
    pub fn next_id(&self) -> u64 {
        self.next
    }

    /// Reads again the jobs a server kept before it restarted, from their
    /// files under this store's folder. A job whose file is gone or no
    /// longer reads (the machine file changed) is left out; the reasons
    /// come back, one per job.
    pub fn restore(&mut self, machine: &Machine, saved: &[SavedJob], next: u64) -> Vec<String> {
        let mut problems = Vec::new();
        for j in saved.iter().rev().take(KEPT_JOBS).rev() {
            let read = match self.saved_file(j) {
                Ok(file) => read_file(machine, &file, j.id, &j.name, &j.options),
                Err(e) => Err(e),
            };
            match read {
                Ok(job) => self.jobs.push_back(Arc::new(job)),
                Err(e) => problems.push(format!("job {} ({}): {e}", j.id, j.name)),
            }
        }
        let highest = saved.iter().map(|j| j.id + 1).max().unwrap_or(1);
        self.next = next.max(highest).max(self.next);
        problems
    }

    /// The file of a kept job: a name this server made, checked again
    /// since the index is a file on disk.
    fn saved_file(&self, j: &SavedJob) -> Result<PathBuf, UploadError> {
        let made = j.file.split_once('.').is_some_and(|(id, ext)| {
            id == j.id.to_string()
                && !ext.is_empty()
                && ext.chars().all(|c| c.is_ascii_alphanumeric() || c == '.')
        });
        if !made || j.file.contains("..") {
            return Err(UploadError::Name(j.file.clone()));
        }
        Ok(self.dir.join(&j.file))
    }

    /// What to keep of each job across restarts.
    pub fn saved(&self) -> Vec<SavedJob> {
        self.jobs
            .iter()
            .map(|j| SavedJob {
                id: j.id,
                name: j.name.clone(),
                file: j
                    .file
                    .file_name()
                    .map(|f| f.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                bytes: j.bytes,
                options: j.options,
            })
            .collect()
    }
}

/// A job as a server keeps it across restarts: its file and how to read it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SavedJob {
    /// Its id.
    pub id: u64,
    /// The name it was uploaded as.
    pub name: String,
    /// Its file's name in the jobs folder (`ID.EXT`).
    pub file: String,
    /// Bytes uploaded.
    pub bytes: usize,
    /// How it is read.
    pub options: ReadOptions,
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
    opts: &ReadOptions,
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
    JobKind::of(Path::new(&lower)).map_err(|_| UploadError::Kind {
        name: name.clone(),
        ext: ext.to_string(),
    })?;
    // The extension passed the kinds' list: letters only, safe in a path.
    let file = dir.join(format!("{id}.{ext}{gz}"));
    std::fs::write(&file, bytes)?;
    read_file(machine, &file, id, &name, opts).inspect_err(|_| {
        let _ = std::fs::remove_file(&file);
    })
}

/// Reads job `id`'s stored `file` for `machine`; `name` is how the person
/// knows it, used in messages instead of the server's path.
fn read_file(
    machine: &Machine,
    file: &Path,
    id: u64,
    name: &str,
    opts: &ReadOptions,
) -> Result<StoredJob, UploadError> {
    let lower = name.to_ascii_lowercase();
    let kind = JobKind::of(Path::new(&lower)).map_err(|_| UploadError::Kind {
        name: name.to_string(),
        ext: lower.rsplit_once('.').map_or("", |(_, e)| e).to_string(),
    })?;
    let bytes = std::fs::metadata(file)?.len() as usize;
    let job = load_job(machine, file, &opts.job_options())
        .map_err(|e| UploadError::Job(e.to_string().replace(&file.display().to_string(), name)))?;
    let preview = Preview::of(machine, &job.commands);
    let warnings = job
        .warnings
        .iter()
        .map(|w| w.replace(&file.display().to_string(), name))
        .collect();
    Ok(StoredJob {
        id,
        name: name.to_string(),
        kind: match kind {
            JobKind::Gcode => "gcode",
            JobKind::Svg => "svg",
            JobKind::Image => "image",
        },
        bytes,
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
        options: *opts,
        preview,
        file: file.to_path_buf(),
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
