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
    /// Every segment record, in index order.
    pub segments: Vec<JournalSegment>,
    /// Every `seal` record, in order (the stop's own seal is in `stop`).
    pub seals: Vec<JournalSeal>,
    /// How the run stopped; `None` if the host died before writing it.
    pub stop: Option<JournalStop>,
    /// Every `pace` record, in order.
    pub paces: Vec<JournalPace>,
    /// How many segment and seal records came before each `pace` record.
    pub pace_after: Vec<(usize, usize)>,
    /// Every `hold` record, in order.
    pub holds: Vec<JournalHold>,
    /// How many segment and seal records came before each `hold` record.
    pub hold_after: Vec<(usize, usize)>,
    /// The order `pace` (false) and `hold` (true) records came in.
    extras: Vec<bool>,
    /// Line of each segment record, for errors that name it.
    pub segment_lines: Vec<usize>,
    /// The file ended in a line cut short (the host died writing it). Only
    /// records after the last seal can be cut short, and those were never
    /// sent, so the journal is still whole.
    pub torn_tail: bool,
}

impl Journal {
    /// Reads and checks the journal at `path`: every record's checksum, order
    /// and consistency with the records before it.
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
        let err = |line: usize, error: BadRecord| JournalError::Parse {
            path: path.to_string(),
            line,
            error,
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
            paces: Vec::new(),
            pace_after: Vec::new(),
            holds: Vec::new(),
            hold_after: Vec::new(),
            extras: Vec::new(),
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
                    return Err(err(n, BadRecord::NotAJournal));
                }
                j.header = Some(parse_header(&mut words).map_err(|m| err(n, m))?);
                continue;
            }
            if j.stop.is_some() {
                return Err(err(n, BadRecord::AfterStop));
            }
            match first {
                "seg" => {
                    let s = parse_segment(&mut words).map_err(|m| err(n, m))?;
                    let want = j.segments.len() as u32;
                    if s.index != want {
                        return Err(err(n, BadRecord::SegmentIndex { got: s.index, want }));
                    }
                    if let Some(prev) = j.segments.last() {
                        if s.t0 < prev.t1 {
                            return Err(err(
                                n,
                                BadRecord::Overlap {
                                    index: s.index,
                                    t0: s.t0,
                                    prev: prev.index,
                                },
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
                            return Err(err(n, trailing(w, "seal")));
                        }
                        j.seals.push(seal);
                    } else {
                        let lost = parse_lost(words.next()).map_err(|m| err(n, m))?;
                        if let Some(w) = words.next() {
                            return Err(err(n, trailing(w, "stop")));
                        }
                        j.stop = Some(JournalStop { seal, lost });
                    }
                }
                "pace" => {
                    let p = parse_pace(&mut words, j.paces.last()).map_err(|m| err(n, m))?;
                    j.paces.push(p);
                    j.pace_after.push((j.segments.len(), j.seals.len()));
                    j.extras.push(false);
                }
                "hold" => {
                    let h = parse_hold(&mut words, j.holds.last()).map_err(|m| err(n, m))?;
                    j.holds.push(h);
                    j.hold_after.push((j.segments.len(), j.seals.len()));
                    j.extras.push(true);
                }
                "motet-journal" => return Err(err(n, BadRecord::SecondHeader)),
                w => return Err(err(n, BadRecord::UnknownRecord(w.into()))),
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
        let mut paces = self.paces.iter().zip(&self.pace_after);
        let mut holds = self.holds.iter().zip(&self.hold_after);
        // The pace and hold records, in the order they came, each with
        // the segments and seals before it.
        let mut extras = self
            .extras
            .iter()
            .filter_map(|&hold| {
                if hold {
                    holds.next().map(|(h, at)| (hold_text(h), *at))
                } else {
                    paces.next().map(|(p, at)| (pace_text(p), *at))
                }
            })
            .peekable();
        // Those written with `next` segments and `seals` seals before them.
        let mut pace = |out: &mut String, chain: &mut u32, next: usize, seals: usize| {
            while let Some((text, _)) = extras.next_if(|(_, at)| *at <= (next, seals)) {
                *out += &signed(chain, &text);
            }
        };
        for (k, seal) in self.seals.iter().enumerate() {
            while next < seal.end as usize {
                pace(&mut out, &mut chain, next, k);
                out += &signed(&mut chain, &segment_text(&self.segments[next]));
                next += 1;
            }
            pace(&mut out, &mut chain, next, k);
            out += &signed(&mut chain, &seal_text("seal", seal));
        }
        let seals = self.seals.len();
        while next < self.segments.len() {
            pace(&mut out, &mut chain, next, seals);
            out += &signed(&mut chain, &segment_text(&self.segments[next]));
            next += 1;
        }
        pace(&mut out, &mut chain, usize::MAX, seals);
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
fn checked<'a>(line: &'a str, chain: &mut u32) -> Result<&'a str, BadRecord> {
    let Some((text, crc)) = line.rsplit_once(" *") else {
        return Err(BadRecord::NoChecksum);
    };
    let want = hex32(crc).ok_or_else(|| BadRecord::ChecksumDigits(crc.into()))?;
    let got = record_checksum(*chain, text);
    if got != want {
        return Err(BadRecord::Checksum { want, got });
    }
    *chain = got;
    Ok(text)
}

fn parse_header<'a>(words: &mut impl Iterator<Item = &'a str>) -> Result<JournalHeader, BadRecord> {
    let format: u32 = num(words.next(), "journal format")?;
    if format != JOURNAL_FORMAT {
        return Err(BadRecord::Format(format));
    }
    let mut field = |key: &'static str| -> Result<&'a str, BadRecord> {
        let w = words.next().ok_or(BadRecord::NoField(key))?;
        w.strip_prefix(key)
            .and_then(|r| r.strip_prefix('='))
            .ok_or_else(|| BadRecord::WrongField {
                word: w.into(),
                key,
            })
    };
    let run = field("run")?;
    let run = hex32(run).ok_or_else(|| BadRecord::RunDigits(run.into()))?;
    let machine = field("machine")?
        .parse::<Digest>()
        .map_err(BadRecord::Digest)?;
    let job = field("job")?.parse::<Digest>().map_err(BadRecord::Digest)?;
    let t0 = finite(field("t0")?)?;
    let min_move_s = finite(field("min_move_s")?)?;
    let first = field("start")?;
    let mut start = [0.0; MAX_AXES];
    start[0] = finite(first)?;
    for v in start.iter_mut().skip(1) {
        *v = finite(
            words
                .next()
                .ok_or(BadRecord::FewCoordinates("start point"))?,
        )?;
    }
    if let Some(w) = words.next() {
        return Err(trailing(w, "header"));
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

fn parse_segment<'a>(
    words: &mut impl Iterator<Item = &'a str>,
) -> Result<JournalSegment, BadRecord> {
    let index = num(words.next(), "segment index")?;
    let command = num(words.next(), "command index")?;
    let t0 = finite(words.next().ok_or(BadRecord::Missing("start time"))?)?;
    let t1 = finite(words.next().ok_or(BadRecord::Missing("end time"))?)?;
    if t1 < t0 {
        return Err(BadRecord::EndsBeforeStart { t0, t1 });
    }
    let start = point(words)?;
    if words.next() != Some("|") {
        return Err(BadRecord::NoSeparator);
    }
    let end = point(words)?;
    if let Some(w) = words.next() {
        return Err(trailing(w, "end point"));
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

fn parse_pace<'a>(
    words: &mut impl Iterator<Item = &'a str>,
    last: Option<&JournalPace>,
) -> Result<JournalPace, BadRecord> {
    let command = num(words.next(), "command index")?;
    let min_move_s = finite(
        words
            .next()
            .ok_or(BadRecord::Missing("shortest move time"))?,
    )?;
    if let Some(w) = words.next() {
        return Err(trailing(w, "pace"));
    }
    let last = last.map_or(0, |p| p.command);
    if command < last {
        return Err(BadRecord::PaceBack { command, last });
    }
    Ok(JournalPace {
        command,
        min_move_s,
    })
}

fn parse_hold<'a>(
    words: &mut impl Iterator<Item = &'a str>,
    last: Option<&JournalHold>,
) -> Result<JournalHold, BadRecord> {
    let command = num(words.next(), "command index")?;
    let seconds = finite(words.next().ok_or(BadRecord::Missing("hold time"))?)?;
    if let Some(w) = words.next() {
        return Err(trailing(w, "hold"));
    }
    if command < last.map_or(0, |h| h.command) || seconds <= 0.0 {
        return Err(BadRecord::BadHold { command, seconds });
    }
    Ok(JournalHold { command, seconds })
}

fn parse_seal<'a>(words: &mut impl Iterator<Item = &'a str>) -> Result<JournalSeal, BadRecord> {
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
) -> Result<(), BadRecord> {
    if s.end > segments {
        return Err(BadRecord::EndBeyond {
            end: s.end,
            segments,
        });
    }
    if s.tail > s.end {
        return Err(BadRecord::TailAfterEnd {
            tail: s.tail,
            end: s.end,
        });
    }
    if s.done > s.end {
        return Err(BadRecord::DoneAfterEnd {
            done: s.done,
            end: s.end,
        });
    }
    let (end, done, time) = prev.map_or((0, 0, 0), |p| (p.end, p.done, p.time));
    // A window may add only events: the same end again.
    let ok = if stop { s.end == end } else { s.end >= end };
    if !ok {
        return Err(if stop {
            BadRecord::StopEnd {
                end: s.end,
                last: end,
            }
        } else {
            BadRecord::EndBack {
                end: s.end,
                last: end,
            }
        });
    }
    if s.done < done || s.time < time {
        return Err(BadRecord::GoingBack);
    }
    Ok(())
}

fn parse_lost(w: Option<&str>) -> Result<Vec<usize>, BadRecord> {
    match w.ok_or(BadRecord::Missing("lost nodes (`-` for none)"))? {
        "-" => Ok(Vec::new()),
        list => list
            .split(',')
            .map(|k| k.parse().map_err(|_| BadRecord::LostNode(k.into())))
            .collect(),
    }
}

fn trailing(word: &str, what: &'static str) -> BadRecord {
    BadRecord::Trailing {
        word: word.into(),
        what,
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

fn num<T: std::str::FromStr + std::fmt::Display>(
    w: Option<&str>,
    what: &'static str,
) -> Result<T, BadRecord> {
    let w = w.ok_or(BadRecord::Missing(what))?;
    w.parse::<T>()
        .ok()
        .filter(|v| v.to_string() == w)
        .ok_or_else(|| BadRecord::Number {
            what,
            word: w.into(),
        })
}

fn finite(w: &str) -> Result<f64, BadRecord> {
    w.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && format!("{v:?}") == w)
        .ok_or_else(|| BadRecord::Finite(w.into()))
}

fn point<'a>(words: &mut impl Iterator<Item = &'a str>) -> Result<Point, BadRecord> {
    let mut p = [0.0; MAX_AXES];
    for v in p.iter_mut() {
        *v = finite(words.next().ok_or(BadRecord::FewCoordinates("point"))?)?;
    }
    Ok(p)
}
