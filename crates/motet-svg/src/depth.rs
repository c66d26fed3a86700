//! How deep a document's elements nest, refused past
//! [`motet_planner::ranges::SVG_DEPTH`] before anything else reads it.
//!
//! XML parsers and usvg walk up the tree for each element (inherited styles,
//! layers), so time grows with depth times elements: 200,000 nested groups
//! took minutes before usvg gave up at its own limit of 1024. The scan here
//! is one pass over the bytes and stops at the first element too deep, so a
//! hostile document costs time linear in its length. It follows only what
//! changes depth (tags, comments, CDATA, processing instructions, the DOCTYPE
//! with its internal subset, quoted attribute values); malformed XML is left
//! to the parser, which reports it with its place. Elements made by entities
//! are counted on the parsed tree by [`check_tree`].

use motet_planner::ranges::SVG_DEPTH;
use motet_planner::{SourceError, SourceLoc};
use usvg::roxmltree;

/// The deepest nesting allowed, in elements from the root (the root is 1).
fn max_depth() -> usize {
    SVG_DEPTH.max as usize
}

fn too_deep(loc: SourceLoc) -> SourceError {
    SourceError {
        loc,
        message: format!(
            "invalid SVG: elements nest more than {} deep here (SVG documents may nest at most {} levels)",
            max_depth(),
            max_depth()
        ),
    }
}

/// Refuses text whose elements nest deeper than the limit, at the first
/// element too deep.
pub(crate) fn check_text(text: &str) -> Result<(), SourceError> {
    let b = text.as_bytes();
    let mut depth = 0usize;
    let mut i = 0;
    while let Some(off) = memchr(b'<', &b[i..]) {
        let at = i + off;
        let rest = &b[at..];
        i = if rest.starts_with(b"<!--") {
            skip_past(b, at + 4, b"-->")
        } else if rest.starts_with(b"<![CDATA[") {
            skip_past(b, at + 9, b"]]>")
        } else if rest.starts_with(b"<?") {
            skip_past(b, at + 2, b"?>")
        } else if rest.starts_with(b"<!") {
            skip_declaration(b, at + 2)
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            skip_tag(b, at + 2).0
        } else {
            let (end, self_closing) = skip_tag(b, at + 1);
            if !self_closing {
                depth += 1;
                if depth > max_depth() {
                    return Err(too_deep(loc_at(text, at)));
                }
            }
            end
        };
    }
    Ok(())
}

/// Refuses a parsed tree whose elements nest deeper than the limit (entities
/// can make elements the text scan does not see). Linear in the tree.
pub(crate) fn check_tree(doc: &roxmltree::Document) -> Result<(), SourceError> {
    // Depth of each node from its parent's, in document order (parents first).
    let mut depth: Vec<usize> = Vec::new();
    for n in doc.descendants() {
        let d = n
            .parent()
            .and_then(|p| depth.get(p.id().get_usize()).copied())
            .unwrap_or(0)
            + usize::from(n.is_element());
        let i = n.id().get_usize();
        if depth.len() <= i {
            depth.resize(i + 1, 0);
        }
        depth[i] = d;
        if d > max_depth() {
            let p = doc.text_pos_at(n.range().start);
            return Err(too_deep(SourceLoc {
                line: p.row,
                column: p.col,
            }));
        }
    }
    Ok(())
}

fn memchr(needle: u8, hay: &[u8]) -> Option<usize> {
    hay.iter().position(|&c| c == needle)
}

/// The index just past the first `end` at or after `from` (or the end).
fn skip_past(b: &[u8], from: usize, end: &[u8]) -> usize {
    b.get(from..)
        .and_then(|r| r.windows(end.len()).position(|w| w == end))
        .map_or(b.len(), |p| from + p + end.len())
}

/// Past the `>` closing a tag that starts at `from`, skipping quoted values;
/// and whether the tag closes itself (`/>`).
fn skip_tag(b: &[u8], from: usize) -> (usize, bool) {
    let mut quote = None;
    let mut prev = 0u8;
    for (k, &c) in b.iter().enumerate().skip(from) {
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None if c == b'"' || c == b'\'' => quote = Some(c),
            None if c == b'>' => return (k + 1, prev == b'/'),
            None => {}
        }
        prev = c;
    }
    (b.len(), false)
}

/// Past a `<!…>` declaration (DOCTYPE, with an internal subset in `[ ]`
/// whose declarations and comments may hold `>`).
fn skip_declaration(b: &[u8], from: usize) -> usize {
    let mut quote = None;
    let mut brackets = 0usize;
    let mut k = from;
    while k < b.len() {
        let c = b[k];
        match quote {
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None => match c {
                b'"' | b'\'' => quote = Some(c),
                b'[' => brackets += 1,
                b']' => brackets = brackets.saturating_sub(1),
                b'<' if b[k..].starts_with(b"<!--") => {
                    k = skip_past(b, k + 4, b"-->");
                    continue;
                }
                b'>' if brackets == 0 => return k + 1,
                _ => {}
            },
        }
        k += 1;
    }
    b.len()
}

/// Line and column (1-based, columns in characters) of byte `at`.
fn loc_at(text: &str, at: usize) -> SourceLoc {
    let before = &text.as_bytes()[..at];
    let line = before.iter().filter(|&&c| c == b'\n').count() + 1;
    let start = before
        .iter()
        .rposition(|&c| c == b'\n')
        .map_or(0, |p| p + 1);
    let column = text[start..at].chars().count() + 1;
    SourceLoc {
        line: u32::try_from(line).unwrap_or(u32::MAX),
        column: u32::try_from(column).unwrap_or(u32::MAX),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nested(n: usize, inner: &str) -> String {
        format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\">{}{inner}{}</svg>",
            "<g>".repeat(n),
            "</g>".repeat(n)
        )
    }

    #[test]
    fn depth_counts_only_what_nests() {
        let limit = max_depth();
        // The root counts: limit - 1 groups inside it fit, one more does not.
        for (text, ok) in [
            (nested(limit - 1, ""), true),
            (nested(limit, ""), false),
            (nested(limit - 1, "<path d='M0 0'/>"), true),
            (nested(limit - 1, "<path d='M0 0'></path>"), false),
            // Markup-like text in comments, CDATA, attribute values and the
            // DOCTYPE's internal subset does not nest.
            (nested(limit - 1, "<!-- <g><g> -->"), true),
            (nested(limit - 1, "<![CDATA[<g><g>]]>"), true),
            (nested(limit - 1, "<?pi <g> ?>"), true),
            (nested(limit - 1, "<x a='<g>' b=\"/>\" />"), true),
            (
                format!(
                    "<!DOCTYPE svg [<!ENTITY e \"<g><g>\"> <!-- > --> ]>{}",
                    nested(limit - 1, "")
                ),
                true,
            ),
        ] {
            assert_eq!(
                check_text(&text).is_ok(),
                ok,
                "{}",
                &text[..80.min(text.len())]
            );
        }
    }

    #[test]
    fn the_first_element_too_deep_is_named() {
        let text = format!("<svg>\n{}\n  <g>", "<g>".repeat(max_depth() - 1));
        let e = check_text(&text).unwrap_err();
        assert_eq!((e.loc.line, e.loc.column), (3, 3));
        assert!(e.message.contains("more than 256 deep"), "{}", e.message);
    }
}
