//! The code stays within what a reader can hold: no function over
//! [`MAX_FN_LINES`] lines and no file over [`MAX_FILE_LINES`] lines, tests
//! aside, across the workspace's crates and the firmware. A function counts
//! from its `fn` to its closing brace; a file counts its lines less its
//! `#[cfg(test)]` modules. Files named `tests.rs` and `tests/` folders are
//! tests.

use proc_macro2::Span;
use std::path::{Path, PathBuf};
use syn::spanned::Spanned;
use syn::visit::Visit;

const MAX_FN_LINES: usize = 120;
const MAX_FILE_LINES: usize = 800;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Every `.rs` file under the `src` folders of the crates and firmware.
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let path = e.path();
        let name = e.file_name();
        let name = name.to_string_lossy();
        if path.is_dir() {
            if !matches!(name.as_ref(), "target" | "tests" | "benches" | "examples") {
                sources(&path, out);
            }
        } else if name.ends_with(".rs")
            && name != "tests.rs"
            && path.components().any(|c| c.as_os_str() == "src")
        {
            out.push(path);
        }
    }
}

fn lines(span: Span) -> usize {
    span.end().line + 1 - span.start().line
}

fn is_test(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("test")
            || (a.path().is_ident("cfg")
                && a.parse_args::<syn::Path>()
                    .is_ok_and(|p| p.is_ident("test")))
    })
}

/// Long functions, and the lines test modules take.
#[derive(Default)]
struct Sizes {
    long: Vec<(String, usize, usize)>,
    test_lines: usize,
}

impl Sizes {
    fn function(&mut self, name: &syn::Ident, fn_token: Span, body: &syn::Block) {
        let n = lines(fn_token.join(body.span()).unwrap_or_else(|| body.span()));
        let n = n.max(body.brace_token.span.close().end().line + 1 - fn_token.start().line);
        if n > MAX_FN_LINES {
            self.long.push((name.to_string(), fn_token.start().line, n));
        }
    }
}

impl<'a> Visit<'a> for Sizes {
    fn visit_item_mod(&mut self, m: &'a syn::ItemMod) {
        if is_test(&m.attrs) {
            if m.content.is_some() {
                self.test_lines += lines(m.span());
            }
            return;
        }
        syn::visit::visit_item_mod(self, m);
    }

    fn visit_item_fn(&mut self, f: &'a syn::ItemFn) {
        if is_test(&f.attrs) {
            return;
        }
        self.function(&f.sig.ident, f.sig.fn_token.span, &f.block);
        syn::visit::visit_item_fn(self, f);
    }

    fn visit_impl_item_fn(&mut self, f: &'a syn::ImplItemFn) {
        self.function(&f.sig.ident, f.sig.fn_token.span, &f.block);
        syn::visit::visit_impl_item_fn(self, f);
    }

    fn visit_trait_item_fn(&mut self, f: &'a syn::TraitItemFn) {
        if let Some(body) = &f.default {
            self.function(&f.sig.ident, f.sig.fn_token.span, body);
        }
        syn::visit::visit_trait_item_fn(self, f);
    }
}

#[test]
fn no_function_or_file_is_too_long() {
    let root = root();
    let mut files = Vec::new();
    for top in ["crates", "firmware"] {
        sources(&root.join(top), &mut files);
    }
    files.sort();
    assert!(files.len() > 100, "found only {} source files", files.len());
    let mut faults = Vec::new();
    for path in &files {
        let text = std::fs::read_to_string(path).unwrap();
        let shown = path.strip_prefix(&root).unwrap_or(path).display();
        let file = match syn::parse_file(&text) {
            Ok(f) => f,
            Err(e) => {
                faults.push(format!("{shown}: does not parse: {e}"));
                continue;
            }
        };
        let mut sizes = Sizes::default();
        sizes.visit_file(&file);
        let code_lines = text.lines().count().saturating_sub(sizes.test_lines);
        if code_lines > MAX_FILE_LINES {
            faults.push(format!(
                "{shown}: {code_lines} lines outside tests (at most {MAX_FILE_LINES}): split it along its concepts"
            ));
        }
        for (name, line, n) in sizes.long {
            faults.push(format!(
                "{shown}:{line}: fn {name} is {n} lines (at most {MAX_FN_LINES}): split it into named steps"
            ));
        }
    }
    assert!(faults.is_empty(), "{}", faults.join("\n"));
}
