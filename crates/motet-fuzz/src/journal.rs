//! Journals: read back as `motet resume` does; every record that parsed can
//! be found again.

use crate::text;
use motet_net::journal::{Journal, JournalError};

/// Runs journal bytes through the parser and its lookups.
pub fn journal(data: &[u8]) {
    let Some(text) = text(data) else { return };
    match Journal::parse(text, "fuzz/journal") {
        Ok(j) => {
            for s in &j.segments {
                assert!(
                    j.segment(s.index).is_some(),
                    "segment {} not found",
                    s.index
                );
            }
            for s in &j.seals {
                assert!(j.seal_ending(s.end).is_some(), "seal {} not found", s.end);
            }
        }
        Err(JournalError::Parse { line, .. }) => {
            assert!(
                (1..=text.lines().count()).contains(&line),
                "error at line {line}"
            )
        }
        Err(e) => panic!("parsing text gave an I/O error: {e}"),
    }
}
