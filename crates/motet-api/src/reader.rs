//! A job file read as a stream of checked commands: what a run holds of a
//! G-code job is the line being read and the commands it made, never the
//! file, so a job of any length runs in the same memory.
//!
//! SVG drawings and photos are read whole (their parsers need the whole
//! document, and ordering strokes needs all of them); their commands are then
//! handed out one by one like a G-code job's. Their size is bounded by the
//! input file, not by how long the job runs.

use crate::job::{JobError, JobKind, JobOptions};
use crate::place::{self, Area};
use crate::placement::{Placed, PlacementError};
use flate2::read::GzDecoder;
use motet_gcode::{line_number, GcodeOptions, Interpreter};
use motet_host::{Clamps, JobCheck, Machine};
use motet_planner::ranges::COORDINATE;
use motet_planner::{Command, JobTarget, Located, Planner, SourceError};
use std::cell::Cell;
use std::collections::VecDeque;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::rc::Rc;

/// Longest G-code line read, bytes: far beyond any real line (slicers write
/// under 100 bytes, thumbnails 78 per line), short enough that a file with no
/// line ends cannot take the memory a job is promised not to take.
pub const MAX_LINE: usize = 1 << 20;

/// Counts the bytes read from the file (before decompression), for progress.
struct Counting<R> {
    inner: R,
    count: Rc<Cell<u64>>,
}

impl<R: Read> Read for Counting<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.count.set(self.count.get() + n as u64);
        Ok(n)
    }
}

enum Source<'a> {
    Gcode {
        text: Box<dyn BufRead + 'a>,
        gzip: bool,
        /// Boxed: it is large, and `None` once the text has ended.
        interp: Option<Box<Interpreter>>,
        line: Vec<u8>,
        /// Lines read so far.
        lines: usize,
    },
    Loaded(std::vec::IntoIter<Located<Command>>),
}

/// The checked commands of a job file, in order (see the module docs). An
/// error ends the stream; warnings and clamps are complete once the stream
/// has ended.
pub struct JobReader<'a> {
    file: String,
    machine: &'a Machine,
    source: Source<'a>,
    check: JobCheck,
    pending: VecDeque<Located<Command>>,
    warnings: Vec<String>,
    read: Rc<Cell<u64>>,
    size: u64,
    commands: usize,
    finished: bool,
    placed: Option<Placed>,
}

impl<'a> JobReader<'a> {
    /// Opens a job file for `machine`; G-code (plain or `.gz`) is read as it
    /// is consumed.
    pub fn open(
        machine: &'a Machine,
        path: &Path,
        opts: &JobOptions,
    ) -> Result<JobReader<'a>, JobError> {
        let kind = JobKind::of(path)?;
        let file = path.display().to_string();
        if kind != JobKind::Gcode {
            let data = crate::job::read_bytes(path)?;
            return JobReader::drawing(machine, file, kind, &data, opts);
        }
        let read_err = |error| JobError::Read {
            file: file.clone(),
            error,
        };
        let f = std::fs::File::open(path).map_err(read_err)?;
        let size = f.metadata().map_err(read_err)?.len();
        let read = Rc::new(Cell::new(0));
        let counted = Counting {
            inner: f,
            count: read.clone(),
        };
        let gzip = path.extension().is_some_and(|e| e == "gz");
        let text: Box<dyn BufRead> = if gzip {
            Box::new(BufReader::with_capacity(
                1 << 16,
                GzDecoder::new(BufReader::new(counted)),
            ))
        } else {
            Box::new(BufReader::with_capacity(1 << 16, counted))
        };
        JobReader::gcode(machine, file, text, gzip, read, size, opts)
    }

    /// A job already in memory (`path` names it in errors).
    pub fn from_bytes(
        machine: &'a Machine,
        path: &Path,
        kind: JobKind,
        data: &'a [u8],
        opts: &JobOptions,
    ) -> Result<JobReader<'a>, JobError> {
        let file = path.display().to_string();
        let size = data.len() as u64;
        if kind != JobKind::Gcode {
            return JobReader::drawing(machine, file, kind, data, opts);
        }
        let read = Rc::new(Cell::new(0));
        let text = Counting {
            inner: data,
            count: read.clone(),
        };
        JobReader::gcode(
            machine,
            file,
            Box::new(BufReader::new(text)),
            false,
            read,
            size,
            opts,
        )
    }

    /// An SVG drawing or a photo: parsed whole, placed, handed out a command
    /// at a time.
    fn drawing(
        machine: &'a Machine,
        file: String,
        kind: JobKind,
        data: &[u8],
        opts: &JobOptions,
    ) -> Result<JobReader<'a>, JobError> {
        let target = machine.job_target();
        let located = |error: SourceError| JobError::Source {
            file: file.clone(),
            error,
        };
        let parse = |target: &JobTarget| match kind {
            JobKind::Svg => {
                motet_svg::parse(data, target, &motet_svg::SvgOptions::default()).map_err(located)
            }
            _ => motet_image::parse(data, target, &motet_image::ImageOptions::default())
                .map_err(located),
        };
        let placing = |error: PlacementError| JobError::Placement {
            file: file.clone(),
            error,
        };
        opts.placement.check().map_err(placing)?;
        let mut commands = parse(&target)?;
        let mut placed = None;
        if !opts.placement.is_identity() {
            let area = Area::of(machine).map_err(placing)?;
            let mut plan = place::plan(&opts.placement, &commands, &area).map_err(placing)?;
            if let (Some(t), JobKind::Svg) = (plan, kind) {
                // Read the drawing again as it will be placed: curves
                // flattened to the tolerance at the placed size, strokes
                // ordered from where the machine starts.
                let mut fine = target.clone();
                fine.tolerance = target.tolerance / t.scale.max(1.0);
                let [xi, yi] = area.axes;
                [fine.start[xi], fine.start[yi]] = t.inverse([target.start[xi], target.start[yi]]);
                // A start mapped far beyond any drawing (the drawing moved
                // a long way) orders nothing better than none.
                if fine.start.iter().all(|v| COORDINATE.contains(*v)) {
                    commands = parse(&fine)?;
                    plan = place::plan(&opts.placement, &commands, &area).map_err(placing)?;
                }
            }
            if let Some(t) = plan {
                placed =
                    Some(place::apply(&opts.placement, &t, &mut commands, &area).map_err(placing)?);
            }
        }
        let size = data.len() as u64;
        let mut r = JobReader::new(machine, file, Source::Loaded(commands.into_iter()), size);
        r.read.set(size);
        r.placed = placed;
        Ok(r)
    }

    fn gcode(
        machine: &'a Machine,
        file: String,
        text: Box<dyn BufRead + 'a>,
        gzip: bool,
        read: Rc<Cell<u64>>,
        size: u64,
        opts: &JobOptions,
    ) -> Result<JobReader<'a>, JobError> {
        if !opts.placement.is_identity() {
            return Err(JobError::Placement {
                file,
                error: PlacementError::NotADrawing,
            });
        }
        let gopts = GcodeOptions {
            allow_unknown: opts.allow_unknown,
            ..Default::default()
        };
        let interp =
            Interpreter::new(&machine.job_target(), &gopts).map_err(|error| JobError::Source {
                file: file.clone(),
                error,
            })?;
        let source = Source::Gcode {
            text,
            gzip,
            interp: Some(Box::new(interp)),
            line: Vec::new(),
            lines: 0,
        };
        let mut r = JobReader::new(machine, file, source, size);
        r.read = read;
        Ok(r)
    }

    fn new(machine: &'a Machine, file: String, source: Source<'a>, size: u64) -> JobReader<'a> {
        JobReader {
            file,
            machine,
            source,
            check: JobCheck::new(machine),
            pending: VecDeque::new(),
            warnings: Vec::new(),
            read: Rc::new(Cell::new(0)),
            size,
            commands: 0,
            finished: false,
            placed: None,
        }
    }

    /// Bytes of the file read so far and the file's size (compressed bytes
    /// for a `.gz`): progress through the job.
    pub fn progress(&self) -> (u64, u64) {
        (self.read.get(), self.size)
    }

    /// Commands handed out so far.
    pub fn commands(&self) -> usize {
        self.commands
    }

    /// `file:line:column: message` for things accepted but not acted on;
    /// complete once the stream has ended.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// Where the drawing was placed, for a job read with a
    /// [`crate::Placement`] other than the default.
    pub fn placed(&self) -> Option<Placed> {
        self.placed
    }

    /// Coordinates clamped onto travel so far.
    pub fn clamps(&self) -> Clamps {
        self.check.clamps
    }

    /// How many commands wait between the file and the caller: at most one
    /// line's (an arc's chords); what [`JobReader`] holds of the job.
    pub fn held(&self) -> usize {
        self.pending.len()
    }

    fn source_error(&self, error: SourceError) -> JobError {
        JobError::Source {
            file: self.file.clone(),
            error,
        }
    }

    /// Reads lines until one makes commands or the file ends.
    fn fill(&mut self) -> Result<(), JobError> {
        let Source::Gcode {
            text,
            gzip,
            interp,
            line,
            lines,
        } = &mut self.source
        else {
            return Ok(());
        };
        while self.pending.is_empty() {
            let Some(it) = interp.as_mut() else {
                return Ok(());
            };
            let n = *lines;
            let line_no = line_number(n);
            let ended_by_newline = read_line(text.as_mut(), line).map_err(|e| match e {
                LineError::Io(error) if *gzip => JobError::Gzip {
                    file: self.file.clone(),
                    error,
                },
                LineError::Io(error) => JobError::Read {
                    file: self.file.clone(),
                    error,
                },
                LineError::TooLong => JobError::LineTooLong {
                    file: self.file.clone(),
                    line: n + 1,
                },
            })?;
            *lines += 1;
            let s = std::str::from_utf8(line).map_err(|_| JobError::NotText {
                file: self.file.clone(),
                line: n + 1,
            })?;
            it.line(s, line_no).map_err(|error| JobError::Source {
                file: self.file.clone(),
                error,
            })?;
            self.pending.extend(it.drain());
            if !ended_by_newline {
                // That was the last line: the interpreter's warnings are complete.
                line.clear();
                if let Some(it) = interp.take() {
                    self.warnings = it
                        .finish()
                        .iter()
                        .map(|w| format!("{}:{w}", self.file))
                        .collect();
                }
            }
        }
        Ok(())
    }

    fn next_command(&mut self) -> Result<Option<Located<Command>>, JobError> {
        let mut c = match &mut self.source {
            Source::Loaded(it) => match it.next() {
                Some(c) => c,
                None => return Ok(None),
            },
            Source::Gcode { .. } => {
                self.fill()?;
                match self.pending.pop_front() {
                    Some(c) => c,
                    None => return Ok(None),
                }
            }
        };
        self.check
            .check(self.machine, &mut c)
            .map_err(|e| self.source_error(e))?;
        self.commands += 1;
        Ok(Some(c))
    }
}

impl Iterator for JobReader<'_> {
    type Item = Result<Located<Command>, JobError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.finished {
            return None;
        }
        match self.next_command() {
            Ok(Some(c)) => Some(Ok(c)),
            Ok(None) => {
                self.finished = true;
                None
            }
            Err(e) => {
                self.finished = true;
                Some(Err(e))
            }
        }
    }
}

enum LineError {
    Io(std::io::Error),
    TooLong,
}

/// Reads one line into `line` without its `\n`; `true` if a `\n` ended it,
/// `false` for the last line. As with `str::split('\n')`, the text after
/// the last `\n` is a line even when empty, so line numbers match a
/// whole-text parse.
fn read_line(text: &mut dyn BufRead, line: &mut Vec<u8>) -> Result<bool, LineError> {
    line.clear();
    loop {
        let buf = match text.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(LineError::Io(e)),
        };
        if buf.is_empty() {
            return Ok(false);
        }
        let (take, done) = match buf.iter().position(|b| *b == b'\n') {
            Some(i) => (i, true),
            None => (buf.len(), false),
        };
        if line.len() + take > MAX_LINE {
            return Err(LineError::TooLong);
        }
        line.extend_from_slice(&buf[..take]);
        text.consume(take + usize::from(done));
        if done {
            return Ok(true);
        }
    }
}

/// What reading a job through to its end found: enough to report on it and
/// to run it again, without holding it.
#[derive(Clone, Debug, PartialEq)]
pub struct JobScan {
    /// Commands in the job.
    pub commands: usize,
    /// `file:line:column: message` for things accepted but not acted on.
    pub warnings: Vec<String>,
    /// Coordinates beyond travel by less than half a step, clamped onto it.
    pub clamps: Clamps,
    /// How long the job takes as planned, seconds.
    pub planned_s: f64,
    /// Where the drawing was placed (see [`JobReader::placed`]).
    pub placed: Option<Placed>,
    /// The axes, tools and heaters it uses, each with where it first does
    /// (what a machine composed from modules must offer it).
    pub needs: motet_host::module::JobNeeds,
}

/// Reads a job through, checking every command and planning it (see
/// [`crate::plan_check`]) without keeping any of it: every error is found, at
/// its place, before anything moves. `progress` gets (bytes read, file size).
pub fn scan_job(
    mut reader: JobReader<'_>,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<JobScan, JobError> {
    let m = reader.machine;
    let mut planner = Planner::new(m.limits(), m.start, 0.0);
    let mut n = 0usize;
    let mut needs = motet_host::module::JobNeeds::default();
    while let Some(c) = reader.next() {
        let c = c?;
        needs.take(m, &c);
        planner.push(&c.item).map_err(|e| {
            reader.source_error(SourceError {
                loc: c.loc,
                message: e.to_string(),
            })
        })?;
        while planner.pop().is_some() {}
        n += 1;
        if n.is_multiple_of(4096) {
            let (a, b) = reader.progress();
            progress(a, b);
        }
    }
    planner.finish();
    let (a, b) = reader.progress();
    progress(a, b);
    Ok(JobScan {
        commands: reader.commands(),
        warnings: reader.warnings().to_vec(),
        clamps: reader.clamps(),
        planned_s: planner.clock() * 1e-6,
        placed: reader.placed(),
        needs,
    })
}
