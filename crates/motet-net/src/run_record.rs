//! `resume.toml`: what a networked run was started with, written when it
//! starts, so that `motet resume` finds the files, the nodes and the options
//! again and can check that nothing changed.

use crate::digest::Digest;
use motet_planner::{ranges, Command, Located};
use motet_trajectory::{Point, MAX_AXES};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The `resume.toml` format this crate writes and reads.
pub const RECORD_FORMAT: u32 = 2;

/// Why `resume.toml` could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The file could not be read: most often the folder is not a run's.
    #[error("cannot read {path}: {source} (is {dir} the output folder of a networked run?)")]
    Read {
        /// The `resume.toml` path.
        path: String,
        /// The folder it was looked for in.
        dir: String,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The file is not a valid record: TOML, format, run number, ranges.
    #[error("{path}: {message}")]
    Parse {
        /// The `resume.toml` path.
        path: String,
        /// What is wrong, with the key where TOML says it.
        message: String,
    },
    /// The file could not be written into the run's output folder.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The `resume.toml` path.
        path: String,
        /// What the operating system said.
        source: std::io::Error,
    },
}

/// A networked run as `resume.toml` records it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunRecord {
    /// [`RECORD_FORMAT`] when written; another is refused.
    pub format: u32,
    /// The run's number (hex), as the journal and the nodes know it.
    pub run: String,
    /// Absolute paths, so that resuming works from any folder.
    pub machine: PathBuf,
    /// SHA-256 of the machine file when the run started.
    pub machine_sha256: Digest,
    /// The job file's absolute path.
    pub job: PathBuf,
    /// SHA-256 of the job file when the run started.
    pub job_sha256: Digest,
    /// G-code codes not supported were skipped with a warning
    /// (`--allow-unknown`); the job must be read the same way again.
    pub allow_unknown: bool,
    /// `--time-scale`: how many times faster than real time the simulated
    /// nodes' clocks ran.
    pub time_scale: f64,
    /// `--lead-ms`: least time the committed window reached ahead, ms.
    pub lead_ms: f64,
    /// `--sync-ms`: clock exchanges with each node, ms apart.
    pub sync_ms: f64,
    /// `--start-late-clocks`: past the connect timeout, a start went ahead
    /// with clocks short of their target, within the machine's path.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub start_late_clocks: bool,
    /// For a run that resumed another: how its commands follow from the job's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub continues: Option<Continuation>,
    /// The machine's nodes, in the machine file's order.
    pub nodes: Vec<RunNode>,
}

/// A resumed run's commands: travel from `from` to `to` and the tools
/// restored (`prelude` commands), then the job from command `command` on.
/// It began with the nodes at rest at `from` on the run `after_run`, at the
/// end of its window `after_window`: a node that still says so has not
/// moved since.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Continuation {
    /// The job command the job continues at.
    pub command: usize,
    /// Commands before it in the resumed run: the travel and the tools.
    pub prelude: usize,
    /// Where the machine rested, `MAX_AXES` coordinates.
    pub from: Vec<f64>,
    /// Where the job continues, `MAX_AXES` coordinates.
    pub to: Vec<f64>,
    /// The stopped run's number (hex).
    pub after_run: String,
    /// The stopped run's committed window end (segments).
    pub after_window: u32,
}

/// A node of the run: where it was reached, and which device it was.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunNode {
    /// Its name in the machine file.
    pub name: String,
    /// The link spec it was reached on.
    pub link: String,
    /// Its address on that link.
    pub address: u16,
    /// Unique id (16 hex digits) and firmware version the node reported.
    pub uid: String,
    /// See `uid`.
    pub firmware: String,
    /// The process simulating it, when the run started one
    /// (`--nodes spawn`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pid: Option<u32>,
}

impl RunRecord {
    /// Reads `DIR/resume.toml`.
    pub fn load(dir: &Path) -> Result<RunRecord, RecordError> {
        let path = dir.join("resume.toml");
        let p = path.display().to_string();
        let text = std::fs::read_to_string(&path).map_err(|source| RecordError::Read {
            path: p.clone(),
            dir: dir.display().to_string(),
            source,
        })?;
        let r: RunRecord = toml::from_str(&text).map_err(|e| RecordError::Parse {
            path: p.clone(),
            message: e.to_string().trim_end().to_string(),
        })?;
        if r.format != RECORD_FORMAT {
            return Err(RecordError::Parse {
                path: p,
                message: format!(
                    "format {}: this motet resumes runs of format {RECORD_FORMAT}",
                    r.format
                ),
            });
        }
        r.run_number().map_err(|message| RecordError::Parse {
            path: p.clone(),
            message,
        })?;
        for (key, range, v) in [
            ("time_scale", ranges::TIME_SCALE, r.time_scale),
            ("lead_ms", ranges::LEAD_MS, r.lead_ms),
            ("sync_ms", ranges::SYNC_MS, r.sync_ms),
        ] {
            range.check(key, v).map_err(|e| RecordError::Parse {
                path: p.clone(),
                message: e.to_string(),
            })?;
        }
        if let Some(c) = &r.continues {
            if c.from.len() != MAX_AXES || c.to.len() != MAX_AXES {
                return Err(RecordError::Parse {
                    path: p,
                    message: format!("`continues`: `from` and `to` need {MAX_AXES} coordinates"),
                });
            }
        }
        Ok(r)
    }

    /// Writes `DIR/resume.toml`, replacing one there.
    pub fn save(&self, dir: &Path) -> Result<(), RecordError> {
        let path = dir.join("resume.toml");
        let text = toml::to_string_pretty(self).map_err(|e| RecordError::Parse {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        std::fs::write(&path, text).map_err(|source| RecordError::Write {
            path: path.display().to_string(),
            source,
        })
    }

    /// The run's number.
    pub fn run_number(&self) -> Result<u32, String> {
        u32::from_str_radix(&self.run, 16)
            .ok()
            .filter(|&r| r != 0)
            .ok_or_else(|| format!("run `{}` is not a run number (hex, not 0)", self.run))
    }

    /// The commands the run was given, from the job's.
    pub fn run_commands(&self, job: &[Located<Command>]) -> Vec<Located<Command>> {
        match &self.continues {
            None => job.to_vec(),
            Some(c) => {
                crate::resume::resume_at(job, point(&c.from), point(&c.to), c.command).commands
            }
        }
    }

    /// Where the run started: where a resumed run found the machine, or
    /// the machine file's start.
    pub fn start(&self, machine_start: Point) -> Point {
        self.continues
            .as_ref()
            .map_or(machine_start, |c| point(&c.from))
    }

    /// The job command a command of the run stands for, and, for one in a
    /// resumed run's prelude (the travel back), where the job continues.
    pub fn job_command(&self, run_command: usize) -> (usize, Option<Point>) {
        match &self.continues {
            None => (run_command, None),
            Some(c) if run_command < c.prelude => (c.command, Some(point(&c.to))),
            Some(c) => (c.command + run_command - c.prelude, None),
        }
    }
}

fn point(v: &[f64]) -> Point {
    let mut p = [0.0; MAX_AXES];
    for (d, s) in p.iter_mut().zip(v) {
        *d = *s;
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record() -> RunRecord {
        RunRecord {
            format: RECORD_FORMAT,
            run: "0000abcd".into(),
            machine: "/m.toml".into(),
            machine_sha256: Digest::of(b"m"),
            job: "/j.svg".into(),
            job_sha256: Digest::of(b"j"),
            allow_unknown: false,
            time_scale: 1.0,
            lead_ms: 100.0,
            sync_ms: 400.0,
            start_late_clocks: false,
            continues: None,
            nodes: vec![],
        }
    }

    #[test]
    fn a_record_reads_back_and_bad_ones_say_what() {
        let scratch = tempfile::Builder::new()
            .prefix("motet-record-")
            .tempdir()
            .unwrap();
        let dir = scratch.path();
        record().save(dir).unwrap();
        assert_eq!(RunRecord::load(dir).unwrap(), record());
        let text = std::fs::read_to_string(dir.join("resume.toml")).unwrap();
        let cases = [
            ("lead_ms = 100.0", "lead_ms = 1e12", "lead_ms must be from"),
            (
                "time_scale = 1.0",
                "time_scale = -1.0",
                "time_scale must be from",
            ),
            (
                "format = 2",
                "format = 1",
                "format 1: this motet resumes runs of format 2",
            ),
            (
                "run = \"0000abcd\"",
                "run = \"0\"",
                "run `0` is not a run number",
            ),
            (
                "allow_unknown = false",
                "allow_unknown = false\nextra = 1",
                "unknown field",
            ),
        ];
        for (from, to, want) in cases {
            std::fs::write(dir.join("resume.toml"), text.replace(from, to)).unwrap();
            let e = RunRecord::load(dir).unwrap_err().to_string();
            assert!(e.contains("resume.toml") && e.contains(want), "{to}: {e}");
        }
    }
}
