//! Writing the journal: each record in its text form, signed with the
//! checksum chained to the record before it.

use super::text::*;
use super::*;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Appends records; each seal and stop is on disk before it returns.
pub struct JournalWriter {
    out: BufWriter<std::fs::File>,
    path: String,
    /// The last record's checksum.
    chain: u32,
}

impl JournalWriter {
    /// Creates (or truncates) the journal at `path`.
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

    /// Writes the header; it is on disk when this returns.
    pub fn header(&mut self, h: &JournalHeader) -> Result<(), JournalError> {
        self.record(&header_text(h))?;
        self.sync()
    }

    /// Appends a segment record (buffered: on disk with the next seal, before
    /// the seal is sent).
    pub fn segment(&mut self, s: &JournalSegment) -> Result<(), JournalError> {
        self.record(&segment_text(s))
    }

    /// Appends a seal record; it and every segment before it are on disk when
    /// this returns, so the seal may be sent.
    pub fn seal(&mut self, s: JournalSeal) -> Result<(), JournalError> {
        self.record(&seal_text("seal", &s))?;
        self.sync()
    }

    /// Appends a pace record (buffered: on disk with the next seal, before
    /// any segment planned with it is sent).
    pub fn pace(&mut self, p: &JournalPace) -> Result<(), JournalError> {
        self.record(&pace_text(p))
    }

    /// Appends a hold record (buffered: on disk with the next seal, before
    /// the hold's segment is sent).
    pub fn hold(&mut self, h: &JournalHold) -> Result<(), JournalError> {
        self.record(&hold_text(h))
    }

    /// Appends the stop record, the last; on disk when this returns.
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
