//! Reading the journal back: every record's checksum and canonical form,
//! then the run's consistency (indices, windows, tails).

use super::text::*;
use super::*;
use motet_trajectory::MAX_AXES;
use std::path::Path;

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
