//! Locations, errors and warnings (repeats folded into the first).

use motet_planner::{Command, Located, SourceError, SourceLoc};

use super::Interp;
use crate::lex::{code10, LexError, Word};
use crate::MAX_WARNINGS;

/// Key for folding repeated warnings.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) struct WarnKey(pub(super) u8, pub(super) u32);

/// 1-based character column of byte offset `at` in `line`.
fn column(line: &str, at: usize) -> u32 {
    let prefix = line.get(..at).unwrap_or(line);
    let n = if prefix.is_ascii() {
        prefix.len()
    } else {
        prefix.chars().count()
    };
    u32::try_from(n.saturating_add(1)).unwrap_or(u32::MAX)
}

impl Interp {
    pub(super) fn loc(&self, at: usize) -> SourceLoc {
        SourceLoc {
            line: self.line_no,
            column: column(&self.line, at),
        }
    }

    pub(super) fn error(&self, at: usize, msg: impl Into<String>) -> SourceError {
        SourceError {
            loc: self.loc(at),
            message: msg.into(),
        }
    }

    pub(super) fn warn(&mut self, key: WarnKey, at: usize, msg: impl FnOnce() -> String) {
        if let Some(e) = self.warn_index.iter_mut().find(|e| e.0 == key) {
            e.2 += 1;
            return;
        }
        if self.warnings.len() >= MAX_WARNINGS {
            // Still said at the end, never stored.
            self.unlisted_warnings += 1;
            return;
        }
        let w = SourceError {
            loc: self.loc(at),
            message: msg(),
        };
        self.warn_index.push((key, self.warnings.len(), 0));
        self.warnings.push(w);
    }

    pub(super) fn emit(&mut self, at: usize, item: Command) {
        let loc = self.loc(at);
        self.out.push(Located { loc, item });
    }

    pub(super) fn lex_err(&self, e: LexError) -> SourceError {
        self.error(e.at, e.msg)
    }

    pub(super) fn axes_list(&self) -> String {
        let names: Vec<&str> = self.target.axes.iter().map(|a| a.name.as_str()).collect();
        names.join(", ")
    }

    /// Unknown code or word: error, or warning when allowed.
    pub(super) fn unknown(&mut self, w: Word<'_>, what: String) -> Result<(), SourceError> {
        if !self.allow_unknown {
            return Err(self.error(w.at, what));
        }
        let key = WarnKey(w.letter, code10(w.text).unwrap_or(u32::MAX));
        self.warn(key, w.at, || format!("{what} skipped"));
        Ok(())
    }

    pub(super) fn same_group(&self, at: usize, this: &str, other: &str) -> SourceError {
        self.error(
            at,
            format!("{this} and {other} on one line: they are in the same modal group"),
        )
    }
}
