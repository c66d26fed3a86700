//! The journal of a networked run: what identifies the run, every sealed
//! segment and window, written before the seal is sent, and how the run
//! stopped, so that after any stop (even of the host process itself)
//! `motet resume` can prove what it resumes.
//!
//! A text file, one record per line, each ending in ` *` and a checksum (8
//! hex digits): the CRC-32C of the previous record's checksum (4 bytes, little
//! endian; 0 before the first) and of this record's text. An edited or
//! damaged record is caught, and so is one removed, moved or re-signed on its
//! own, since the records after it no longer follow:
//!
//! ```text
//! motet-journal 2 run=RUN machine=SHA256 job=SHA256 t0=T min_move_s=S start=x0 … x5
//! seg INDEX COMMAND T0 T1 x0 … x5 | x0 … x5      one sealed segment: host times
//!                                                  (µs), start | end point
//! seal END TAIL DONE TIME                          segments < END committed; the
//!                                                  contingency tail starts at TAIL;
//!                                                  every node had finished the
//!                                                  segments < DONE at host time TIME
//! stop END TAIL DONE TIME LOST                     the run stopped there; LOST: the
//!                                                  machine nodes (indices, `,`) that
//!                                                  stopped answering, or `-`
//! ```
//!
//! The header carries what the plan depends on beyond the two files: where
//! the machine started, the time the trajectory started at and the shortest
//! move time the run planned with; with them the plan can be made again, bit
//! for bit, and compared. Floats are written in Rust's shortest round-trip
//! form, so they read back bit for bit.

use crate::digest::Digest;
use motet_trajectory::{Point, MAX_AXES};
use motet_wire::frame::Crc32c;
use std::io::{BufWriter, Write};
use std::path::Path;

/// The journal format this crate writes and reads.
pub const JOURNAL_FORMAT: u32 = 2;

#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}:{line}: {message}")]
    Parse {
        path: String,
        line: usize,
        message: String,
    },
}

/// What identifies a run and what its plan depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JournalHeader {
    pub run: u32,
    pub machine: Digest,
    pub job: Digest,
    /// Host time the trajectory starts at, µs.
    pub t0: f64,
    /// Shortest move time the planner kept to, s.
    pub min_move_s: f64,
    /// Where the machine was at rest when the run started.
    pub start: Point,
}

/// One committed segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JournalSegment {
    pub index: u32,
    /// Index of the command (in the run's command list) it came from.
    pub command: usize,
    /// Start and end, host µs.
    pub t0: f64,
    pub t1: f64,
    pub start: Point,
    pub end: Point,
}

/// A sealed window: segments before `end` committed, tail from `tail`; every
/// node had reported the segments before `done` finished at host time `time`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JournalSeal {
    pub end: u32,
    pub tail: u32,
    pub done: u32,
    pub time: u64,
}

/// How a run stopped: the window and tail it stopped on, the segments every
/// node had finished, and the machine nodes that were lost.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct JournalStop {
    pub seal: JournalSeal,
    pub lost: Vec<usize>,
}

/// Appends records; each seal and stop is on disk before it returns.
pub struct JournalWriter {
    out: BufWriter<std::fs::File>,
    path: String,
    /// The last record's checksum.
    chain: u32,
}

/// The checksum of a record whose text is `text` after a record whose
/// checksum was `prev`.
pub fn record_checksum(prev: u32, text: &str) -> u32 {
    let mut c = Crc32c::new();
    c.update(&prev.to_le_bytes());
    c.update(text.as_bytes());
    c.finish()
}

fn fmt_point(p: &Point) -> String {
    p.iter()
        .map(|v| format!("{v:?}"))
        .collect::<Vec<_>>()
        .join(" ")
}

impl JournalWriter {
    pub fn create(path: &Path) -> Result<JournalWriter, JournalError> {
        let io = |source| JournalError::Io {
            path: path.display().to_string(),
            source,
        };
        let file = std::fs::File::create(path).map_err(io)?;
        Ok(JournalWriter {
            out: BufWriter::new(file),
            path: path.display().to_string(),
            chain: 0,
        })
    }

    pub fn header(&mut self, h: &JournalHeader) -> Result<(), JournalError> {
        self.record(&header_text(h))?;
        self.sync()
    }

    pub fn segment(&mut self, s: &JournalSegment) -> Result<(), JournalError> {
        self.record(&segment_text(s))
    }

    pub fn seal(&mut self, s: JournalSeal) -> Result<(), JournalError> {
        self.record(&seal_text("seal", &s))?;
        self.sync()
    }

    pub fn stop(&mut self, s: &JournalStop) -> Result<(), JournalError> {
        self.record(&stop_text(s))?;
        self.sync()
    }

    fn record(&mut self, text: &str) -> Result<(), JournalError> {
        let line = signed(&mut self.chain, text);
        self.out
            .write_all(line.as_bytes())
            .map_err(|source| JournalError::Io {
                path: self.path.clone(),
                source,
            })
    }

    fn sync(&mut self) -> Result<(), JournalError> {
        self.out
            .flush()
            .and_then(|_| self.out.get_ref().sync_data())
            .map_err(|source| JournalError::Io {
                path: self.path.clone(),
                source,
            })
    }
}

fn header_text(h: &JournalHeader) -> String {
    format!(
        "motet-journal {JOURNAL_FORMAT} run={:08x} machine={} job={} t0={:?} min_move_s={:?} start={}",
        h.run,
        h.machine,
        h.job,
        h.t0,
        h.min_move_s,
        fmt_point(&h.start)
    )
}

fn segment_text(s: &JournalSegment) -> String {
    format!(
        "seg {} {} {:?} {:?} {} | {}",
        s.index,
        s.command,
        s.t0,
        s.t1,
        fmt_point(&s.start),
        fmt_point(&s.end)
    )
}

fn seal_text(kind: &str, s: &JournalSeal) -> String {
    format!("{kind} {} {} {} {}", s.end, s.tail, s.done, s.time)
}

fn stop_text(s: &JournalStop) -> String {
    let lost = if s.lost.is_empty() {
        "-".to_string()
    } else {
        s.lost
            .iter()
            .map(|k| k.to_string())
            .collect::<Vec<_>>()
            .join(",")
    };
    format!("{} {lost}", seal_text("stop", &s.seal))
}

/// The record's line (newline included), its checksum chained after `chain`
/// (then moved on to it).
fn signed(chain: &mut u32, text: &str) -> String {
    *chain = record_checksum(*chain, text);
    format!("{text} *{:08x}\n", *chain)
}

/// A journal read back and checked: every record's checksum, segment indices
/// consecutive from 0, windows that grow, a tail inside its window.
#[derive(Clone, Debug, PartialEq)]
pub struct Journal {
    /// None for an empty journal: the run stopped before its trajectory
    /// started (nothing was sent to move).
    pub header: Option<JournalHeader>,
    pub segments: Vec<JournalSegment>,
    pub seals: Vec<JournalSeal>,
    pub stop: Option<JournalStop>,
    /// Line of each segment record, for errors that name it.
    pub segment_lines: Vec<usize>,
    /// The file ended in a line cut short (the host died writing it). Only
    /// records after the last seal can be cut short, and those were never
    /// sent, so the journal is still whole.
    pub torn_tail: bool,
}

impl Journal {
    pub fn load(path: &Path) -> Result<Journal, JournalError> {
        let bytes = std::fs::read(path).map_err(|source| JournalError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let text = String::from_utf8_lossy(&bytes);
        Journal::parse(&text, &path.display().to_string())
    }

    /// Parses journal text; `path` names it in errors.
    pub fn parse(text: &str, path: &str) -> Result<Journal, JournalError> {
        let err = |line: usize, message: String| JournalError::Parse {
            path: path.to_string(),
            line,
            message,
        };
        let mut lines: Vec<&str> = text.split('\n').collect();
        // The last element is what follows the last newline: empty for a
        // whole file, a record cut short if the writer died mid-line.
        let cut = lines.pop().unwrap_or("");
        let torn_tail = !cut.is_empty();
        let mut j = Journal {
            header: None,
            segments: Vec::new(),
            seals: Vec::new(),
            stop: None,
            segment_lines: Vec::new(),
            torn_tail,
        };
        let mut chain = 0;
        for (i, raw) in lines.iter().enumerate() {
            let n = i + 1;
            let text = checked(raw, &mut chain).map_err(|m| err(n, m))?;
            let mut words = text.split_ascii_whitespace();
            let first = words.next().unwrap_or("");
            if j.header.is_none() {
                if first != "motet-journal" {
                    return Err(err(
                        n,
                        "not a motet journal (it must start with a `motet-journal` header)".into(),
                    ));
                }
                j.header = Some(parse_header(&mut words).map_err(|m| err(n, m))?);
                continue;
            }
            if j.stop.is_some() {
                return Err(err(n, "record after the run's stop".into()));
            }
            match first {
                "seg" => {
                    let s = parse_segment(&mut words).map_err(|m| err(n, m))?;
                    let want = j.segments.len() as u32;
                    if s.index != want {
                        return Err(err(
                            n,
                            format!("segment {} where segment {want} was due", s.index),
                        ));
                    }
                    if let Some(prev) = j.segments.last() {
                        if s.t0 < prev.t1 {
                            return Err(err(
                                n,
                                format!(
                                    "segment {} starts at {} µs, before segment {} ends",
                                    s.index, s.t0, prev.index
                                ),
                            ));
                        }
                    }
                    j.segments.push(s);
                    j.segment_lines.push(n);
                }
                "seal" | "stop" => {
                    let seal = parse_seal(&mut words).map_err(|m| err(n, m))?;
                    let prev = j.seals.last().copied();
                    check_seal(&seal, prev, j.segments.len() as u32, first == "stop")
                        .map_err(|m| err(n, m))?;
                    if first == "seal" {
                        if let Some(w) = words.next() {
                            return Err(err(n, format!("unexpected `{w}` after the seal")));
                        }
                        j.seals.push(seal);
                    } else {
                        let lost = parse_lost(words.next()).map_err(|m| err(n, m))?;
                        if let Some(w) = words.next() {
                            return Err(err(n, format!("unexpected `{w}` after the stop")));
                        }
                        j.stop = Some(JournalStop { seal, lost });
                    }
                }
                "motet-journal" => return Err(err(n, "a second header".into())),
                w => return Err(err(n, format!("unknown record `{w}`"))),
            }
        }
        Ok(j)
    }

    /// The journal as the writer writes it. Seals and the segments they
    /// commit interleave by segment index, as they were written.
    pub fn to_text(&self) -> String {
        let mut chain = 0;
        let mut out = String::new();
        let Some(h) = &self.header else {
            return out;
        };
        out += &signed(&mut chain, &header_text(h));
        let mut next = 0usize;
        for seal in &self.seals {
            while next < seal.end as usize {
                out += &signed(&mut chain, &segment_text(&self.segments[next]));
                next += 1;
            }
            out += &signed(&mut chain, &seal_text("seal", seal));
        }
        while next < self.segments.len() {
            out += &signed(&mut chain, &segment_text(&self.segments[next]));
            next += 1;
        }
        if let Some(stop) = &self.stop {
            out += &signed(&mut chain, &stop_text(stop));
        }
        out
    }

    /// The segment with index `i`.
    pub fn segment(&self, i: u32) -> Option<&JournalSegment> {
        self.segments.get(i as usize)
    }

    /// The line of segment `i`'s record.
    pub fn segment_line(&self, i: u32) -> Option<usize> {
        self.segment_lines.get(i as usize).copied()
    }

    /// The seal whose window ends at `end`.
    pub fn seal_ending(&self, end: u32) -> Option<JournalSeal> {
        self.seals.iter().rev().find(|s| s.end == end).copied()
    }

    /// The last committed window's end (0 before the first seal).
    pub fn committed(&self) -> u32 {
        self.seals.last().map_or(0, |s| s.end)
    }

    /// The most segments every node is known to have finished.
    pub fn done(&self) -> u32 {
        let sealed = self.seals.last().map_or(0, |s| s.done);
        self.stop
            .as_ref()
            .map_or(sealed, |s| s.seal.done.max(sealed))
    }
}

/// The record's text with its checksum checked against the chain (then
/// moved on to this record).
fn checked<'a>(line: &'a str, chain: &mut u32) -> Result<&'a str, String> {
    let Some((text, crc)) = line.rsplit_once(" *") else {
        return Err("record without a checksum (` *` and 8 hex digits)".into());
    };
    let want = hex32(crc).ok_or_else(|| format!("checksum `{crc}` is not 8 hex digits"))?;
    let got = record_checksum(*chain, text);
    if got != want {
        return Err(format!(
            "checksum {want:08x} does not match the record ({got:08x}): this record or one before it was changed, removed or damaged"
        ));
    }
    *chain = got;
    Ok(text)
}

fn parse_header<'a>(words: &mut impl Iterator<Item = &'a str>) -> Result<JournalHeader, String> {
    let format: u32 = num(words.next(), "journal format")?;
    if format != JOURNAL_FORMAT {
        return Err(format!(
            "journal format {format}; this motet reads format {JOURNAL_FORMAT}"
        ));
    }
    let mut field = |key: &str| -> Result<&'a str, String> {
        let w = words
            .next()
            .ok_or_else(|| format!("header without `{key}=`"))?;
        w.strip_prefix(key)
            .and_then(|r| r.strip_prefix('='))
            .ok_or_else(|| format!("`{w}` where the header has `{key}=`"))
    };
    let run = field("run")?;
    let run = hex32(run).ok_or_else(|| format!("run `{run}` is not 8 hex digits"))?;
    let machine = field("machine")?.parse::<Digest>()?;
    let job = field("job")?.parse::<Digest>()?;
    let t0 = finite(field("t0")?)?;
    let min_move_s = finite(field("min_move_s")?)?;
    let first = field("start")?;
    let mut start = [0.0; MAX_AXES];
    start[0] = finite(first)?;
    for v in start.iter_mut().skip(1) {
        *v = finite(words.next().ok_or("start point with too few coordinates")?)?;
    }
    if let Some(w) = words.next() {
        return Err(format!("unexpected `{w}` after the header"));
    }
    Ok(JournalHeader {
        run,
        machine,
        job,
        t0,
        min_move_s,
        start,
    })
}

fn parse_segment<'a>(words: &mut impl Iterator<Item = &'a str>) -> Result<JournalSegment, String> {
    let index = num(words.next(), "segment index")?;
    let command = num(words.next(), "command index")?;
    let t0 = finite(words.next().ok_or("missing start time")?)?;
    let t1 = finite(words.next().ok_or("missing end time")?)?;
    if t1 < t0 {
        return Err(format!("segment ends ({t1} µs) before it starts ({t0} µs)"));
    }
    let start = point(words)?;
    if words.next() != Some("|") {
        return Err("expected `|` between start and end".into());
    }
    let end = point(words)?;
    if let Some(w) = words.next() {
        return Err(format!("unexpected `{w}` after the end point"));
    }
    Ok(JournalSegment {
        index,
        command,
        t0,
        t1,
        start,
        end,
    })
}

fn parse_seal<'a>(words: &mut impl Iterator<Item = &'a str>) -> Result<JournalSeal, String> {
    Ok(JournalSeal {
        end: num(words.next(), "window end")?,
        tail: num(words.next(), "tail start")?,
        done: num(words.next(), "segments done")?,
        time: num(words.next(), "host time")?,
    })
}

/// A seal (or the stop) against the one before it and the segments so far.
fn check_seal(
    s: &JournalSeal,
    prev: Option<JournalSeal>,
    segments: u32,
    stop: bool,
) -> Result<(), String> {
    if s.end > segments {
        return Err(format!(
            "window end {} beyond the {segments} segments recorded",
            s.end
        ));
    }
    if s.tail > s.end {
        return Err(format!("tail start {} after window end {}", s.tail, s.end));
    }
    if s.done > s.end {
        return Err(format!(
            "{} segments done, but the window ends at {}",
            s.done, s.end
        ));
    }
    let (end, done, time) = prev.map_or((0, 0, 0), |p| (p.end, p.done, p.time));
    // A window may add only events: the same end again.
    let ok = if stop { s.end == end } else { s.end >= end };
    if !ok {
        return Err(if stop {
            format!(
                "the run stopped on window end {}, but the last seal ends at {end}",
                s.end
            )
        } else {
            format!("window end {} does not follow {end}", s.end)
        });
    }
    if s.done < done || s.time < time {
        return Err("segments done or host time going back".into());
    }
    Ok(())
}

fn parse_lost(w: Option<&str>) -> Result<Vec<usize>, String> {
    match w.ok_or("missing lost nodes (`-` for none)")? {
        "-" => Ok(Vec::new()),
        list => list
            .split(',')
            .map(|k| {
                k.parse()
                    .map_err(|_| format!("lost node `{k}` is not a node index"))
            })
            .collect(),
    }
}

// Every field must be written as the writer writes it (lowercase hex,
// integers without signs or leading zeros, floats in their shortest
// round-trip form): a record that reads the same but is written otherwise
// was not written by motet.

/// 8 lowercase hex digits.
fn hex32(w: &str) -> Option<u32> {
    let v = u32::from_str_radix(w, 16).ok()?;
    (format!("{v:08x}") == w).then_some(v)
}

fn num<T: std::str::FromStr + std::fmt::Display>(w: Option<&str>, what: &str) -> Result<T, String> {
    let w = w.ok_or_else(|| format!("missing {what}"))?;
    w.parse::<T>()
        .ok()
        .filter(|v| v.to_string() == w)
        .ok_or_else(|| format!("{what} `{w}` is not a number as motet writes it"))
}

fn finite(w: &str) -> Result<f64, String> {
    w.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && format!("{v:?}") == w)
        .ok_or_else(|| format!("`{w}` is not a finite number as motet writes it"))
}

fn point<'a>(words: &mut impl Iterator<Item = &'a str>) -> Result<Point, String> {
    let mut p = [0.0; MAX_AXES];
    for v in p.iter_mut() {
        *v = finite(words.next().ok_or("point with too few coordinates")?)?;
    }
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> JournalHeader {
        JournalHeader {
            run: 0xabcd_0123,
            machine: Digest::of(b"machine"),
            job: Digest::of(b"job"),
            t0: 200_000.5,
            min_move_s: 1.0 / 3.0,
            start: [0.0, 1.5, -0.0, 0.0, 2.0, 0.0],
        }
    }

    fn segs() -> Vec<JournalSegment> {
        (0..5)
            .map(|i| JournalSegment {
                index: i,
                command: 3 * i as usize,
                t0: 1000.0 * i as f64,
                t1: 1000.0 * i as f64 + 999.75,
                start: [0.1 * i as f64, 1.0 / 3.0, -2.5e-7, 0.0, 1e300, 7.0],
                end: [0.1 * (i + 1) as f64, 2.0 / 3.0, 0.0, -0.0, 5.0, 7.25],
            })
            .collect()
    }

    /// A journal with two windows and a stop, as text.
    fn written() -> String {
        static TEXT: std::sync::OnceLock<String> = std::sync::OnceLock::new();
        TEXT.get_or_init(write_one).clone()
    }

    fn write_one() -> String {
        static N: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("motet-journal-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("journal");
        let mut w = JournalWriter::create(&path).unwrap();
        w.header(&header()).unwrap();
        let segs = segs();
        for s in &segs[..3] {
            w.segment(s).unwrap();
        }
        w.seal(JournalSeal {
            end: 3,
            tail: 1,
            done: 0,
            time: 10,
        })
        .unwrap();
        for s in &segs[3..] {
            w.segment(s).unwrap();
        }
        w.seal(JournalSeal {
            end: 5,
            tail: 5,
            done: 2,
            time: 20,
        })
        .unwrap();
        w.stop(&JournalStop {
            seal: JournalSeal {
                end: 5,
                tail: 5,
                done: 4,
                time: 30,
            },
            lost: vec![0, 2],
        })
        .unwrap();
        drop(w);
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        text
    }

    #[test]
    fn written_journal_reads_back_bit_for_bit() {
        let j = Journal::parse(&written(), "j").unwrap();
        assert_eq!(j.header, Some(header()));
        assert_eq!(j.segments, segs());
        assert_eq!(j.seal_ending(3).map(|s| s.tail), Some(1));
        assert_eq!(j.segment(4), Some(&segs()[4]));
        assert_eq!(j.segment_line(4), Some(7));
        assert_eq!(j.committed(), 5);
        assert_eq!(j.done(), 4);
        assert_eq!(j.stop.as_ref().map(|s| s.lost.clone()), Some(vec![0, 2]));
        assert!(!j.torn_tail);
    }

    #[test]
    fn a_line_cut_short_at_the_end_is_ignored() {
        let text = written();
        let cut = text.len() - 20;
        let j = Journal::parse(&text[..cut], "j").unwrap();
        assert!(j.torn_tail);
        assert_eq!(j.stop, None);
    }

    /// Signs every record again after an edit: a deliberate forgery, which
    /// the checksums cannot tell from the real thing (resume re-plans).
    fn resign(lines: &[String]) -> String {
        let mut chain = 0;
        let mut out = String::new();
        for l in lines {
            let text = l.rsplit_once(" *").map_or(l.as_str(), |(t, _)| t);
            chain = record_checksum(chain, text);
            out += &format!("{text} *{chain:08x}\n");
        }
        out
    }

    fn sign(text: &str) -> String {
        format!("{text} *00000000")
    }

    #[test]
    fn bad_records_say_where() {
        let text = written();
        let lines: Vec<&str> = text.lines().collect();
        let owned = || lines.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let with = |i: usize, line: &str| {
            let mut l = owned();
            l[i] = line.to_string();
            resign(&l)
        };
        let unsigned = |i: usize, line: &str| {
            let mut l = owned();
            l[i] = line.to_string();
            l.join("\n") + "\n"
        };
        let removed = |i: usize| {
            let mut l = owned();
            l.remove(i);
            l.join("\n") + "\n"
        };
        let cases = [
            // One changed digit, checksum kept: damage or an edit.
            (
                unsigned(2, &lines[2].replacen("seg 1 3", "seg 1 4", 1)),
                "j:3: checksum",
            ),
            // A record taken out (or re-signed on its own): the next one no
            // longer follows.
            (removed(4), "j:5: checksum"),
            (
                unsigned(2, &sign(lines[2].rsplit_once(" *").unwrap().0)),
                "j:3: checksum",
            ),
            (unsigned(2, "seg 1 3 0 1"), "j:3: record without a checksum"),
            // Read the same, written otherwise: not motet's.
            (
                unsigned(2, &{
                    let (t, c) = lines[2].rsplit_once(" *").unwrap();
                    format!("{t} *{}", c.to_uppercase())
                }),
                "j:3: checksum",
            ),
            (
                with(2, &lines[2].replacen(" 1000.0 ", " 1e3 ", 1)),
                "`1e3` is not a finite number as motet writes it",
            ),
            (
                with(2, &lines[2].replacen("seg 1 ", "seg 01 ", 1)),
                "segment index `01`",
            ),
            (
                with(0, &sign("motet-journal 1 run=1")),
                "j:1: journal format 1",
            ),
            (with(0, &sign("hello")), "j:1: not a motet journal"),
            (
                with(
                    2,
                    &sign("seg 7 3 0.0 1.0 0.0 0.0 0.0 0.0 0.0 0.0 | 0.0 0.0 0.0 0.0 0.0 0.0"),
                ),
                "j:3: segment 7 where segment 1 was due",
            ),
            (
                with(
                    2,
                    &sign(
                        "seg 1 3 2000.0 1000.0 0.0 0.0 0.0 0.0 0.0 0.0 | 0.0 0.0 0.0 0.0 0.0 0.0",
                    ),
                ),
                "ends (1000 µs) before it starts",
            ),
            (
                with(
                    2,
                    &sign("seg 1 3 0.0 1.0 0.0 0.0 0.0 0.0 0.0 NaN | 0.0 0.0 0.0 0.0 0.0 0.0"),
                ),
                "`NaN` is not a finite",
            ),
            (
                with(4, &sign("seal 3 4 0 10")),
                "tail start 4 after window end 3",
            ),
            (with(4, &sign("seal 9 1 0 10")), "window end 9 beyond the 3"),
            (with(4, &sign("seal 3 1 4 10")), "j:5: 4 segments done, but"),
            (
                with(8, &sign("stop 4 4 0 30 -")),
                "stopped on window end 4, but the last seal ends at 5",
            ),
            (with(8, &sign("stop 5 5 4 30 x")), "lost node `x`"),
            (with(3, &sign("hello")), "j:4: unknown record `hello`"),
        ];
        for (text, want) in cases {
            let e = Journal::parse(&text, "j").unwrap_err().to_string();
            assert!(e.contains(want), "want {want:?}, got {e}");
        }
        assert_eq!(Journal::parse("", "j").unwrap().header, None);
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_text_never_panics(s in "(seg|seal|stop|motet-journal|[0-9 .|*-]|x|\n){0,120}") {
            let _ = Journal::parse(&s, "j");
        }

        /// Any byte flipped in a journal is refused (or, in the last line's
        /// newline, leaves a line cut short that is ignored and flagged).
        #[test]
        fn a_flipped_byte_is_caught(at in proptest::prelude::any::<proptest::sample::Index>(), bit in 0u8..8) {
            let text = written();
            let mut bytes = text.into_bytes();
            let i = at.index(bytes.len());
            bytes[i] ^= 1 << bit;
            let t = String::from_utf8_lossy(&bytes);
            match Journal::parse(&t, "j") {
                Err(_) => {}
                Ok(j) => proptest::prop_assert!(
                    j.torn_tail && j.stop.is_none(),
                    "flip at {} accepted", i
                ),
            }
        }
    }
}
