//! The journal of a networked run: every sealed segment and window, written
//! before the seal is sent, so that after any stop (even of the host process
//! itself) `motet resume` knows which command each committed segment came from
//! and where the machine came to rest.
//!
//! A text file, one record per line:
//!
//! ```text
//! seg INDEX COMMAND x0 y0 … | x1 y1 …     one sealed segment (start | end point)
//! seal END TAIL                            segments < END are committed; the
//!                                          contingency tail starts at TAIL
//! ```
//!
//! Floats are written in Rust's shortest round-trip form, so points read
//! back bit for bit.

use motet_trajectory::{Point, MAX_AXES};
use std::io::{BufRead, BufWriter, Write};
use std::path::Path;

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

/// One committed segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JournalSegment {
    pub index: u32,
    pub command: usize,
    pub start: Point,
    pub end: Point,
}

/// A sealed window: segments before `end` committed, tail from `tail`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JournalSeal {
    pub end: u32,
    pub tail: u32,
}

/// Appends records; each seal is flushed to the file before it returns.
pub struct JournalWriter {
    out: BufWriter<std::fs::File>,
    path: String,
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
        })
    }

    pub fn segment(&mut self, s: &JournalSegment) -> Result<(), JournalError> {
        let mut line = format!("seg {} {}", s.index, s.command);
        for v in s.start {
            line.push_str(&format!(" {v:?}"));
        }
        line.push_str(" |");
        for v in s.end {
            line.push_str(&format!(" {v:?}"));
        }
        line.push('\n');
        self.write(&line)
    }

    pub fn seal(&mut self, seal: JournalSeal) -> Result<(), JournalError> {
        self.write(&format!("seal {} {}\n", seal.end, seal.tail))?;
        self.out
            .flush()
            .and_then(|_| self.out.get_ref().sync_data())
            .map_err(|source| JournalError::Io {
                path: self.path.clone(),
                source,
            })
    }

    fn write(&mut self, s: &str) -> Result<(), JournalError> {
        self.out
            .write_all(s.as_bytes())
            .map_err(|source| JournalError::Io {
                path: self.path.clone(),
                source,
            })
    }
}

/// A journal read back.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Journal {
    pub segments: Vec<JournalSegment>,
    pub seals: Vec<JournalSeal>,
}

impl Journal {
    pub fn load(path: &Path) -> Result<Journal, JournalError> {
        let p = path.display().to_string();
        let file = std::fs::File::open(path).map_err(|source| JournalError::Io {
            path: p.clone(),
            source,
        })?;
        let mut j = Journal::default();
        for (i, line) in std::io::BufReader::new(file).lines().enumerate() {
            let line = line.map_err(|source| JournalError::Io {
                path: p.clone(),
                source,
            })?;
            j.parse_line(&line).map_err(|message| JournalError::Parse {
                path: p.clone(),
                line: i + 1,
                message,
            })?;
        }
        Ok(j)
    }

    /// Parses journal text (for tests and tools).
    pub fn parse(text: &str, path: &str) -> Result<Journal, JournalError> {
        let mut j = Journal::default();
        for (i, line) in text.lines().enumerate() {
            j.parse_line(line).map_err(|message| JournalError::Parse {
                path: path.to_string(),
                line: i + 1,
                message,
            })?;
        }
        Ok(j)
    }

    fn parse_line(&mut self, line: &str) -> Result<(), String> {
        let mut words = line.split_ascii_whitespace();
        match words.next() {
            None => Ok(()),
            Some("seg") => {
                let index = num(words.next(), "segment index")?;
                let command = num(words.next(), "command index")?;
                let start = point(&mut words)?;
                if words.next() != Some("|") {
                    return Err("expected `|` between start and end".into());
                }
                let end = point(&mut words)?;
                if let Some(w) = words.next() {
                    return Err(format!("unexpected `{w}` after the end point"));
                }
                self.segments.push(JournalSegment {
                    index,
                    command,
                    start,
                    end,
                });
                Ok(())
            }
            Some("seal") => {
                let end = num(words.next(), "window end")?;
                let tail = num(words.next(), "tail start")?;
                if tail > end {
                    return Err(format!("tail start {tail} after window end {end}"));
                }
                self.seals.push(JournalSeal { end, tail });
                Ok(())
            }
            Some(w) => Err(format!("unknown record `{w}`")),
        }
    }

    /// The segment with index `i`.
    pub fn segment(&self, i: u32) -> Option<&JournalSegment> {
        // Indices are written in order from the first: usually a direct hit.
        match self.segments.get(i as usize) {
            Some(s) if s.index == i => Some(s),
            _ => self.segments.iter().find(|s| s.index == i),
        }
    }

    /// The seal whose window ends at `end`.
    pub fn seal_ending(&self, end: u32) -> Option<JournalSeal> {
        self.seals.iter().rev().find(|s| s.end == end).copied()
    }
}

fn num<T: std::str::FromStr>(w: Option<&str>, what: &str) -> Result<T, String> {
    let w = w.ok_or_else(|| format!("missing {what}"))?;
    w.parse()
        .map_err(|_| format!("{what} `{w}` is not a number"))
}

fn point<'a>(words: &mut impl Iterator<Item = &'a str>) -> Result<Point, String> {
    let mut p = [0.0; MAX_AXES];
    for v in p.iter_mut() {
        let w = words.next().ok_or("point with too few coordinates")?;
        *v = w
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("coordinate `{w}` is not a finite number"))?;
    }
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_journal_reads_back_bit_for_bit() {
        let dir = std::env::temp_dir().join(format!("motet-journal-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("journal");
        let mut w = JournalWriter::create(&path).unwrap();
        let segs: Vec<JournalSegment> = (0..5)
            .map(|i| JournalSegment {
                index: i,
                command: 3 * i as usize,
                start: [0.1 * i as f64, 1.0 / 3.0, -2.5e-7, 0.0, 1e300, 7.0],
                end: [0.1 * (i + 1) as f64, 2.0 / 3.0, 0.0, -0.0, 5.0, 7.25],
            })
            .collect();
        for s in &segs[..3] {
            w.segment(s).unwrap();
        }
        w.seal(JournalSeal { end: 3, tail: 1 }).unwrap();
        for s in &segs[3..] {
            w.segment(s).unwrap();
        }
        w.seal(JournalSeal { end: 5, tail: 5 }).unwrap();
        drop(w);
        let j = Journal::load(&path).unwrap();
        assert_eq!(j.segments, segs);
        assert_eq!(j.seal_ending(3), Some(JournalSeal { end: 3, tail: 1 }));
        assert_eq!(j.segment(4), Some(&segs[4]));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_lines_say_where() {
        let cases = [
            ("seal 3 1\nseal x 1\n", "j:2: window end `x`"),
            ("seg 0 0 1 2 3 4 5 6 | 1 2 3\n", "j:1: point with too few"),
            (
                "seg 0 0 1 2 3 4 5 NaN | 1 2 3 4 5 6\n",
                "`NaN` is not a finite",
            ),
            ("seal 1 2\n", "tail start 2 after window end 1"),
            ("hello\n", "unknown record `hello`"),
        ];
        for (text, want) in cases {
            let e = Journal::parse(text, "j").unwrap_err().to_string();
            assert!(e.contains(want), "{text:?} gave {e}");
        }
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_text_never_panics(s in "(seg|seal|[0-9 .|-]|x){0,80}") {
            let _ = Journal::parse(&s, "j");
        }
    }
}
