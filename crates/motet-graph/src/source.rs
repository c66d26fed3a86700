//! Places in a graph file and errors located at them.

use crate::file::{FileError, Loc};
use std::ops::Range;

/// `file:line:column`, or the file alone when the error has no line.
pub(crate) fn place(file: &str, line: usize, column: usize) -> String {
    match line {
        0 => file.to_string(),
        _ => format!("{file}:{line}:{column}"),
    }
}

/// The text of a graph file and its name, to locate errors.
pub(crate) struct Source<'a> {
    pub file: String,
    pub text: &'a str,
}

impl Source<'_> {
    pub fn loc(&self, span: Range<usize>) -> Loc {
        let at = span.start.min(self.text.len());
        let before = &self.text[..at];
        Loc {
            line: before.matches('\n').count() + 1,
            column: before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1,
        }
    }

    pub fn err_at(
        &self,
        loc: Loc,
        key: impl Into<String>,
        message: impl Into<String>,
    ) -> FileError {
        let key = key.into();
        let message = message.into();
        FileError {
            file: self.file.clone(),
            line: loc.line,
            column: loc.column,
            message: if key.is_empty() {
                message
            } else {
                format!("`{key}`: {message}")
            },
            key,
        }
    }

    pub fn err(
        &self,
        span: Range<usize>,
        key: impl Into<String>,
        message: impl Into<String>,
    ) -> FileError {
        self.err_at(self.loc(span), key, message)
    }
}
