//! Writing the journal: each record in its text form, signed with the
//! checksum chained to the record before it.

use super::flusher::Flusher;
use super::text::*;
use super::*;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Appends records. Each seal is in the operating system's hands when it
/// returns and on disk a flush later (by a thread of its own); the header and
/// the stop are on disk when they return.
pub struct JournalWriter {
    out: BufWriter<std::fs::File>,
    path: String,
    /// The last record's checksum.
    chain: u32,
    flusher: Flusher,
}

impl JournalWriter {
    /// Creates (or truncates) the journal at `path`.
    pub fn create(path: &Path) -> Result<JournalWriter, JournalError> {
        let io = |source| JournalError::Io {
            path: path.display().to_string(),
            source,
        };
        let file = std::fs::File::create(path).map_err(io)?;
        let flusher = Flusher::start(file.try_clone().map_err(io)?).map_err(io)?;
        Ok(JournalWriter {
            out: BufWriter::new(file),
            path: path.display().to_string(),
            chain: 0,
            flusher,
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

    /// Appends a seal record; it and every segment before it are in the
    /// file when this returns, so the seal may be sent, and on disk once
    /// the flush it asks for is done.
    pub fn seal(&mut self, s: JournalSeal) -> Result<(), JournalError> {
        self.record(&seal_text("seal", &s))?;
        self.out
            .flush()
            .and_then(|_| self.flusher.request())
            .map_err(|source| JournalError::Io {
                path: self.path.clone(),
                source,
            })
    }

    /// The longest the disk took to flush the journal behind a seal, µs of
    /// wall time.
    pub fn worst_flush_us(&self) -> u64 {
        self.flusher.worst_us()
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
