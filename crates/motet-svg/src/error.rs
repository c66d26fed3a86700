//! Located errors for what cannot be read: bytes that are not SVG text,
//! malformed XML, documents usvg refuses.

use motet_planner::{SourceError, SourceLoc};
use usvg::roxmltree;

pub(crate) fn invalid(loc: SourceLoc, what: impl std::fmt::Display) -> SourceError {
    SourceError {
        loc,
        message: format!("invalid SVG: {what}"),
    }
}

/// Bytes to text, with a located error for non-UTF-8 input.
pub(crate) fn decode(data: &[u8]) -> Result<&str, SourceError> {
    if data.starts_with(&[0x1f, 0x8b]) {
        return Err(invalid(
            SourceLoc::default(),
            "compressed SVG (svgz) is not supported; decompress it first",
        ));
    }
    let text = match std::str::from_utf8(data) {
        Ok(t) => t,
        Err(e) => {
            // The prefix up to the bad byte is valid UTF-8 by definition.
            let good = std::str::from_utf8(&data[..e.valid_up_to()]).unwrap_or("");
            let (line, column) = line_col(good, 1, 1);
            return Err(invalid(
                SourceLoc { line, column },
                "not UTF-8 text (or a binary file)",
            ));
        }
    };
    Ok(text.strip_prefix('\u{feff}').unwrap_or(text))
}

/// Line and column (1-based, columns in chars) after reading `s` starting
/// at `line:col`.
pub(crate) fn line_col(s: &str, mut line: u32, mut col: u32) -> (u32, u32) {
    for c in s.chars() {
        if c == '\n' {
            line = line.saturating_add(1);
            col = 1;
        } else {
            col = col.saturating_add(1);
        }
    }
    (line, col)
}

pub(crate) fn xml_error(e: roxmltree::Error) -> SourceError {
    let pos = e.pos();
    let msg = e.to_string();
    let suffix = format!(" at {pos}");
    let msg = msg.strip_suffix(&suffix).unwrap_or(&msg);
    invalid(
        SourceLoc {
            line: pos.row,
            column: pos.col,
        },
        msg,
    )
}

pub(crate) fn usvg_error(e: usvg::Error, root: SourceLoc) -> SourceError {
    match e {
        usvg::Error::ParsingFailed(e) => xml_error(e),
        usvg::Error::InvalidSize => invalid(
            root,
            "the document size is invalid (width/height must be positive)",
        ),
        e => invalid(SourceLoc::default(), e),
    }
}
