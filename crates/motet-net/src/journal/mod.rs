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
//! pace COMMAND S                                   the commands from COMMAND on were
//!                                                  planned with moves of at least S
//!                                                  seconds (the host fell behind)
//! hold COMMAND S                                   after command COMMAND (a wait for a
//!                                                  heater) the trajectory held at rest
//!                                                  for S seconds more (one piece of the
//!                                                  wait, planned as a dwell)
//! ```
//!
//! The header carries what the plan depends on beyond the two files: where
//! the machine started, the time the trajectory started at and the shortest
//! move time the run planned with; with them the plan can be made again, bit
//! for bit, and compared. Floats are written in Rust's shortest round-trip
//! form, so they read back bit for bit.

use crate::digest::Digest;
use motet_trajectory::Point;
use motet_wire::frame::Crc32c;

/// The journal format this crate writes and reads.
pub const JOURNAL_FORMAT: u32 = 2;

/// Why a journal could not be read back; what `motet resume` shows.
#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The journal's path.
        path: String,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// A record is malformed, out of order or fails its checksum.
    #[error("{path}:{line}: {error}")]
    Parse {
        /// The journal's path.
        path: String,
        /// The record's 1-based line.
        line: usize,
        /// What is wrong with it.
        error: BadRecord,
    },
}

/// What is wrong with one record of a journal (its file and line are in
/// [`JournalError::Parse`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BadRecord {
    /// The line does not end in ` *` and a checksum.
    #[error("record without a checksum (` *` and 8 hex digits)")]
    NoChecksum,
    /// The checksum is not 8 hex digits (the text given).
    #[error("checksum `{0}` is not 8 hex digits")]
    ChecksumDigits(String),
    /// The checksum does not follow from the record and the one before.
    #[error("checksum {want:08x} does not match the record ({got:08x}): this record or one before it was changed, removed or damaged")]
    Checksum {
        /// The checksum the record's text and its predecessor give.
        want: u32,
        /// The checksum written on the line.
        got: u32,
    },
    /// The first record is not a `motet-journal` header.
    #[error("not a motet journal (it must start with a `motet-journal` header)")]
    NotAJournal,
    /// A header after the first record.
    #[error("a second header")]
    SecondHeader,
    /// A record after the `stop` record, which must be the last.
    #[error("record after the run's stop")]
    AfterStop,
    /// A record kind this format does not have (its first word).
    #[error("unknown record `{0}`")]
    UnknownRecord(String),
    /// More words than the record has.
    #[error("unexpected `{word}` after the {what}")]
    Trailing {
        /// The first extra word.
        word: String,
        /// The record's last field (`stop record`, `end point`).
        what: &'static str,
    },
    /// A format version other than [`JOURNAL_FORMAT`].
    #[error("journal format {0}; this motet reads format {JOURNAL_FORMAT}")]
    Format(u32),
    /// The header lacks a field (its key).
    #[error("header without `{0}=`")]
    NoField(&'static str),
    /// A header word where another field was due.
    #[error("`{word}` where the header has `{key}=`")]
    WrongField {
        /// The word found.
        word: String,
        /// The key due there.
        key: &'static str,
    },
    /// The run number is not 8 hex digits (the text given).
    #[error("run `{0}` is not 8 hex digits")]
    RunDigits(String),
    /// A file digest that is not one (its own message).
    #[error("{0}")]
    Digest(String),
    /// The record ends before a field (its name).
    #[error("missing {0}")]
    Missing(&'static str),
    /// A field that is not a number in the form the journal writes.
    #[error("{what} `{word}` is not a number as motet writes it")]
    Number {
        /// The field.
        what: &'static str,
        /// The text found.
        word: String,
    },
    /// A coordinate or time that is not a finite number (the text given).
    #[error("`{0}` is not a finite number as motet writes it")]
    Finite(String),
    /// A point with fewer than `MAX_AXES` coordinates (which point).
    #[error("{0} with too few coordinates")]
    FewCoordinates(&'static str),
    /// A segment record without `|` between its start and end points.
    #[error("expected `|` between start and end")]
    NoSeparator,
    /// A `stop` record's lost node that is not an index (the text given).
    #[error("lost node `{0}` is not a node index")]
    LostNode(String),
    /// Segments must be recorded in order from 0, none missing.
    #[error("segment {got} where segment {want} was due")]
    SegmentIndex {
        /// The index recorded.
        got: u32,
        /// The index due.
        want: u32,
    },
    /// A segment whose end time is before its start time.
    #[error("segment ends ({t1} µs) before it starts ({t0} µs)")]
    EndsBeforeStart {
        /// Its start, host µs.
        t0: f64,
        /// Its end, host µs.
        t1: f64,
    },
    /// A segment that starts before the one before it ends.
    #[error("segment {index} starts at {t0} µs, before segment {prev} ends")]
    Overlap {
        /// The segment.
        index: u32,
        /// Its start, host µs.
        t0: f64,
        /// The segment before it.
        prev: u32,
    },
    /// A seal commits segments not recorded before it.
    #[error("window end {end} beyond the {segments} segments recorded")]
    EndBeyond {
        /// The seal's window end.
        end: u32,
        /// Segments recorded so far.
        segments: u32,
    },
    /// A seal's tail starts after its window ends.
    #[error("tail start {tail} after window end {end}")]
    TailAfterEnd {
        /// The tail start.
        tail: u32,
        /// The window end.
        end: u32,
    },
    /// A seal says more segments finished than it committed.
    #[error("{done} segments done, but the window ends at {end}")]
    DoneAfterEnd {
        /// Segments finished.
        done: u32,
        /// The window end.
        end: u32,
    },
    /// The `stop` record names a window other than the last seal's.
    #[error("the run stopped on window end {end}, but the last seal ends at {last}")]
    StopEnd {
        /// The stop's window end.
        end: u32,
        /// The last seal's window end.
        last: u32,
    },
    /// A seal whose window ends before the previous seal's.
    #[error("window end {end} does not follow {last}")]
    EndBack {
        /// This seal's window end.
        end: u32,
        /// The previous seal's.
        last: u32,
    },
    /// A `pace` record for an earlier command than the one before it.
    #[error("pace from command {command}, before the last pace's command {last}")]
    PaceBack {
        /// This record's first command.
        command: usize,
        /// The previous pace record's.
        last: usize,
    },
    /// A `hold` record for an earlier command than the one before it, or a
    /// hold that is not a positive number of seconds.
    #[error(
        "hold after command {command} for {seconds} s: holds go forward and last more than 0 s"
    )]
    BadHold {
        /// Its command.
        command: usize,
        /// Its seconds.
        seconds: f64,
    },
    /// A seal with fewer segments done, or an earlier host time, than the
    /// seal before it.
    #[error("segments done or host time going back")]
    GoingBack,
}

/// What identifies a run and what its plan depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JournalHeader {
    /// The run number the nodes hold (never 0).
    pub run: u32,
    /// SHA-256 of the machine file the run was made from.
    pub machine: Digest,
    /// SHA-256 of the job file.
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
    /// Its sequence number in the run, from 0.
    pub index: u32,
    /// Index of the command (in the run's command list) it came from.
    pub command: usize,
    /// Start, host µs.
    pub t0: f64,
    /// End, host µs.
    pub t1: f64,
    /// Where it starts, machine units.
    pub start: Point,
    /// Where it ends.
    pub end: Point,
}

/// A sealed window: segments before `end` committed, tail from `tail`; every
/// node had reported the segments before `done` finished at host time `time`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JournalSeal {
    /// Segments committed (those with an index below `end`).
    pub end: u32,
    /// First segment of the contingency tail, at most `end`.
    pub tail: u32,
    /// Segments every node had reported finished, at most `end`.
    pub done: u32,
    /// Host time of that report, µs.
    pub time: u64,
}

/// The run slowed what it had not planned yet: the commands from `command`
/// on were planned with moves of at least `min_move_s` seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JournalPace {
    /// The first command planned with it.
    pub command: usize,
    /// Shortest move time, s.
    pub min_move_s: f64,
}

/// The run held the trajectory at rest after command `command` (a wait for
/// a heater a node drives) for `seconds` more: one piece of the wait,
/// planned as a dwell, journaled before the seal that commits it so that a
/// resume plans the same dwells at the same place.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JournalHold {
    /// The waiting command.
    pub command: usize,
    /// The piece's length, s.
    pub seconds: f64,
}

/// How a run stopped: the window and tail it stopped on, the segments every
/// node had finished, and the machine nodes that were lost.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct JournalStop {
    /// The window it stopped on and what had finished.
    pub seal: JournalSeal,
    /// Machine node indices that stopped answering; empty if none.
    pub lost: Vec<usize>,
}

/// The checksum of a record whose text is `text` after a record whose
/// checksum was `prev`.
pub fn record_checksum(prev: u32, text: &str) -> u32 {
    let mut c = Crc32c::new();
    c.update(&prev.to_le_bytes());
    c.update(text.as_bytes());
    c.finish()
}

mod flusher;
mod read;
mod text;
mod write;

pub use read::Journal;
pub use write::JournalWriter;

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
        let dir = tempfile::Builder::new()
            .prefix("motet-journal-")
            .tempdir()
            .unwrap();
        let path = dir.path().join("journal");
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
        std::fs::read_to_string(&path).unwrap()
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

    /// Hold records read back where the run wrote them, in their order
    /// among pace records at the same place, and are written again so; one
    /// for an earlier command, or of no time, is refused.
    #[test]
    fn hold_records_read_back_in_place() {
        let dir = tempfile::Builder::new()
            .prefix("motet-journal-")
            .tempdir()
            .unwrap();
        let path = dir.path().join("journal");
        let mut w = JournalWriter::create(&path).unwrap();
        w.header(&header()).unwrap();
        let hold = |command, seconds| JournalHold { command, seconds };
        let segs = segs();
        w.segment(&segs[0]).unwrap();
        w.hold(&hold(1, 0.5)).unwrap();
        w.pace(&JournalPace {
            command: 2,
            min_move_s: 0.01,
        })
        .unwrap();
        w.hold(&hold(1, 0.25)).unwrap();
        for s in &segs[1..3] {
            w.segment(s).unwrap();
        }
        w.seal(JournalSeal {
            end: 3,
            tail: 1,
            done: 0,
            time: 10,
        })
        .unwrap();
        drop(w);
        let text = std::fs::read_to_string(&path).unwrap();
        let j = Journal::parse(&text, "j").unwrap();
        assert_eq!(j.holds, vec![hold(1, 0.5), hold(1, 0.25)]);
        assert_eq!(j.hold_after, vec![(1, 0), (1, 0)]);
        assert_eq!(j.to_text(), text);
        for (from, to, words) in [
            ("hold 1 0.25", "hold 0 0.25", "hold after command 0"),
            ("hold 1 0.25", "hold 1 0.0", "last more than 0 s"),
        ] {
            // Re-signed, so only the record's own check can refuse it.
            let mut chain = 0;
            let changed: String = text
                .lines()
                .map(|l| l.rsplit_once(" *").unwrap().0.replace(from, to))
                .map(|l| text::signed(&mut chain, &l))
                .collect();
            let e = Journal::parse(&changed, "j").unwrap_err().to_string();
            assert!(e.contains(words), "{e}");
        }
    }

    /// Pace records where the run wrote them (before the first segment,
    /// after a seal, before the stop) read back and are written again in
    /// the same places; one for an earlier command is refused.
    #[test]
    fn pace_records_read_back_in_place() {
        let dir = tempfile::Builder::new()
            .prefix("motet-journal-")
            .tempdir()
            .unwrap();
        let path = dir.path().join("journal");
        let mut w = JournalWriter::create(&path).unwrap();
        w.header(&header()).unwrap();
        let pace = |command, min_move_s| JournalPace {
            command,
            min_move_s,
        };
        w.pace(&pace(0, 0.01)).unwrap();
        let segs = segs();
        for s in &segs[..3] {
            w.segment(s).unwrap();
        }
        let seal = JournalSeal {
            end: 3,
            tail: 1,
            done: 0,
            time: 10,
        };
        w.seal(seal).unwrap();
        w.pace(&pace(4, 0.1 / 3.0)).unwrap();
        for s in &segs[3..] {
            w.segment(s).unwrap();
        }
        w.pace(&pace(7, 0.25)).unwrap();
        w.stop(&JournalStop {
            seal: JournalSeal { end: 3, ..seal },
            lost: vec![],
        })
        .unwrap();
        drop(w);
        let text = std::fs::read_to_string(&path).unwrap();
        let j = Journal::parse(&text, "j").unwrap();
        assert_eq!(
            j.paces,
            vec![pace(0, 0.01), pace(4, 0.1 / 3.0), pace(7, 0.25)]
        );
        assert_eq!(j.pace_after, vec![(0, 0), (3, 1), (5, 1)]);
        assert_eq!(j.to_text(), text);
        let lines: Vec<String> = text
            .lines()
            .map(|l| l.rsplit_once(" *").unwrap().0.replace("pace 7 ", "pace 3 "))
            .collect();
        let err = Journal::parse(&resign(&lines), "j").unwrap_err();
        assert!(
            err.to_string()
                .contains("pace from command 3, before the last pace's command 4"),
            "{err}"
        );
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
        // The reason is a value callers can match, not only text.
        match Journal::parse(&with(4, &sign("seal 3 1 4 10")), "j") {
            Err(JournalError::Parse {
                line: 5,
                error: BadRecord::DoneAfterEnd { done: 4, end: 3 },
                ..
            }) => {}
            other => panic!("{other:?}"),
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
