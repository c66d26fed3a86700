//! Journals: read back as `motet resume` does. Every error names a line of
//! the text; a journal that reads is written again exactly as it was (its
//! records, their order and their chained checksums: nothing is accepted
//! that motet would not have written).

use crate::text;
use motet_net::journal::{Journal, JournalError};

/// Runs journal bytes through the parser and, when they read, the writer.
pub fn journal(data: &[u8]) {
    let Some(text) = text(data) else { return };
    match Journal::parse(text, "fuzz/journal") {
        Ok(j) => {
            let whole = if j.torn_tail {
                &text[..text.rfind('\n').map_or(0, |i| i + 1)]
            } else {
                text
            };
            assert_eq!(
                j.to_text(),
                whole,
                "a journal that reads is not what motet writes"
            );
            for (i, s) in j.segments.iter().enumerate() {
                assert_eq!(s.index as usize, i, "segment indices not consecutive");
            }
            for s in &j.seals {
                assert!(s.tail <= s.end && s.end as usize <= j.segments.len());
            }
        }
        Err(JournalError::Parse { line, .. }) => {
            assert!(
                (1..=text.split('\n').count()).contains(&line),
                "error at line {line}"
            )
        }
        Err(e) => panic!("parsing text gave an I/O error: {e}"),
    }
}
