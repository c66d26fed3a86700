//! Job files: G-code, SVG and photographs, turned into checked commands for a
//! machine. Used by the command line and by scripts alike.

use crate::placement::{Placed, Placement, PlacementError};
use crate::reader::JobReader;
use flate2::read::GzDecoder;
use motet_host::{Clamps, Machine};
use motet_planner::{Command, Located, Planner, SourceError};
use std::io::Read;
use std::path::{Path, PathBuf};

/// The kinds of job file motet reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JobKind {
    /// G-code (`.gcode`, `.nc`, `.g`, optionally gzipped), read a line at a
    /// time.
    Gcode,
    /// An SVG drawing (`.svg`): its paths become pen strokes.
    Svg,
    /// A photograph (`.png`, `.jpg`): its edges are traced into strokes.
    Image,
}

/// A job file that could not be read or does not fit the machine; the message
/// names `file:line:column` where it applies.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error("{file}: unknown job type `.{ext}`; expected G-code (.gcode, .nc, .g), SVG (.svg) or a photo (.png, .jpg)")]
    /// The file's extension names no job type motet reads.
    UnknownKind {
        /// The job file's path.
        file: String,
        /// Its extension, without the dot.
        ext: String,
    },
    #[error("cannot read job {file}: {error}")]
    /// The file could not be opened or read.
    Read {
        /// The job file's path.
        file: String,
        /// What the operating system said.
        error: std::io::Error,
    },
    #[error("{file}: not a valid gzip file: {error}")]
    /// A `.gz` job whose compressed data is damaged or not gzip.
    Gzip {
        /// The job file's path.
        file: String,
        /// What the decompressor said.
        error: std::io::Error,
    },
    #[error("{file}:{line}: G-code is not valid UTF-8 text")]
    /// A G-code line that is not UTF-8: most likely not a G-code file.
    NotText {
        /// The job file's path.
        file: String,
        /// The 1-based line.
        line: usize,
    },
    #[error(
        "{file}:{line}: line longer than {} bytes; is this a G-code file?",
        crate::reader::MAX_LINE
    )]
    /// A G-code line longer than [`crate::reader::MAX_LINE`] bytes: refused
    /// rather than held in memory.
    LineTooLong {
        /// The job file's path.
        file: String,
        /// The 1-based line.
        line: usize,
    },
    #[error("{}", located(.file, .error))]
    /// The job's content is wrong for this machine (a code, a coordinate
    /// beyond travel, a move the planner refuses); shown as
    /// `file:line:column: message`.
    Source {
        /// The job file's path.
        file: String,
        /// What is wrong, and where in the file.
        error: SourceError,
    },
    #[error("{file}: {error}")]
    /// A placement that is invalid, or that does not fit the drawing on the
    /// machine.
    Placement {
        /// The job file's path.
        file: String,
        /// What is wrong.
        error: PlacementError,
    },
}

/// `file:line:column: message`; `file: message` for errors about the whole
/// file (line 0, as for an image that cannot be decoded).
fn located(file: &str, error: &SourceError) -> String {
    match error.loc.line {
        0 => format!("{file}: {}", error.message),
        _ => format!("{file}:{error}"),
    }
}

/// Options for reading jobs. The default reads every job as it is.
#[derive(Clone, Debug, Default)]
pub struct JobOptions {
    /// Skip unsupported G-codes with a warning instead of refusing the job.
    pub allow_unknown: bool,
    /// Where an SVG or photo goes on the machine (default: where it is);
    /// anything else on a G-code job is [`JobError::Placement`].
    pub placement: Placement,
}

/// A job read and checked against a machine.
#[derive(Clone, Debug)]
pub struct Job {
    /// The job file it was read from.
    pub path: PathBuf,
    /// What kind of file it was read as (from its extension).
    pub kind: JobKind,
    /// The job's commands in machine space, each with its place in the file.
    pub commands: Vec<Located<Command>>,
    /// `file:line:column: message` for things accepted but not acted on.
    pub warnings: Vec<String>,
    /// Coordinates beyond travel by less than half a step, clamped onto it.
    pub clamps: Clamps,
    /// How long the job takes as planned, seconds; set by [`load_job`]
    /// (see [`plan_check`]).
    pub planned_s: Option<f64>,
    /// Where the drawing was placed, with a [`JobOptions::placement`] other
    /// than the default.
    pub placed: Option<Placed>,
}

impl JobKind {
    /// The kind from the file name (`.gz` is looked through).
    pub fn of(path: &Path) -> Result<JobKind, JobError> {
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default()
            .to_ascii_lowercase();
        let name = name.strip_suffix(".gz").unwrap_or(&name);
        let ext = name.rsplit_once('.').map_or("", |(_, e)| e);
        Ok(match ext {
            "gcode" | "gco" | "g" | "nc" | "ngc" | "tap" => JobKind::Gcode,
            "svg" => JobKind::Svg,
            "png" | "jpg" | "jpeg" => JobKind::Image,
            _ => {
                return Err(JobError::UnknownKind {
                    file: path.display().to_string(),
                    ext: ext.to_string(),
                })
            }
        })
    }
}

/// The job's name for output folders: the file name without its extensions.
pub fn job_name(path: &Path) -> String {
    let n = path.file_name().and_then(|n| n.to_str()).unwrap_or("job");
    let n = n.strip_suffix(".gz").unwrap_or(n);
    n.rsplit_once('.').map_or(n, |(a, _)| a).to_string()
}

/// The file's bytes, decompressed if it ends in `.gz`.
pub fn read_bytes(path: &Path) -> Result<Vec<u8>, JobError> {
    let file = path.display().to_string();
    let raw = std::fs::read(path).map_err(|error| JobError::Read {
        file: file.clone(),
        error,
    })?;
    if path.extension().is_some_and(|e| e == "gz") {
        let mut out = Vec::new();
        GzDecoder::new(&raw[..])
            .read_to_end(&mut out)
            .map_err(|error| JobError::Gzip { file, error })?;
        return Ok(out);
    }
    Ok(raw)
}

/// Reads, parses, checks and plans a job file for `machine` (the plan is
/// only checked, and its duration kept), keeping every command. Nothing moves
/// on error. A run that need not hold the job reads it with a
/// [`JobReader`] instead.
pub fn load_job(machine: &Machine, path: &Path, opts: &JobOptions) -> Result<Job, JobError> {
    let kind = JobKind::of(path)?;
    let reader = JobReader::open(machine, path, opts)?;
    let mut job = collect(path, kind, reader)?;
    job.planned_s = Some(plan_check(machine, &job)?);
    Ok(job)
}

/// Plans the whole job without running it: every command the planner
/// refuses (a job longer than [`motet_planner::ranges::JOB_S`], a polar move
/// through the centre) is an error at its place before anything moves.
/// Returns the planned duration, seconds. Planning is deterministic, so the
/// run plans the same.
pub fn plan_check(machine: &Machine, job: &Job) -> Result<f64, JobError> {
    let mut planner = Planner::new(machine.limits(), machine.start, 0.0);
    for c in &job.commands {
        planner.push(&c.item).map_err(|e| JobError::Source {
            file: job.path.display().to_string(),
            error: SourceError {
                loc: c.loc,
                message: e.to_string(),
            },
        })?;
        while planner.pop().is_some() {}
    }
    planner.finish();
    Ok(planner.clock() * 1e-6)
}

/// Parses and checks job bytes of a known kind; `path` names it in errors.
pub fn parse_job(
    machine: &Machine,
    path: &Path,
    kind: JobKind,
    data: &[u8],
    opts: &JobOptions,
) -> Result<Job, JobError> {
    let reader = JobReader::from_bytes(machine, path, kind, data, opts)?;
    collect(path, kind, reader)
}

fn collect(path: &Path, kind: JobKind, mut reader: JobReader<'_>) -> Result<Job, JobError> {
    let commands = reader.by_ref().collect::<Result<Vec<_>, _>>()?;
    Ok(Job {
        path: path.to_path_buf(),
        kind,
        commands,
        warnings: reader.warnings().to_vec(),
        clamps: reader.clamps(),
        planned_s: None,
        placed: reader.placed(),
    })
}
