//! Whatever the text, `Machine::parse` returns (a machine or a located error)
//! and never panics: arbitrary strings, TOML-ish noise, and example machine
//! files with random deletions, insertions and replacements.

use motet_host::Machine;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

fn examples() -> Vec<String> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
        .iter()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect()
}

/// Parses and checks the invariants of the outcome.
fn parse_ok_or_located(text: &str) -> Result<(), TestCaseError> {
    match Machine::parse(text, Path::new("fuzz.toml")) {
        Ok(m) => {
            prop_assert!(!m.axes.is_empty() && !m.nodes.is_empty());
            prop_assert!(m
                .actuators
                .iter()
                .all(|a| a.steps_per_unit.is_finite() && a.steps_per_unit != 0.0));
        }
        Err(e) => {
            let lines = text.split('\n').count();
            prop_assert!(
                e.line >= 1 && e.line <= lines,
                "line {} of {lines}: {e}",
                e.line
            );
            prop_assert!(e.column >= 1, "column {}: {e}", e.column);
            prop_assert!(!e.message.is_empty());
            prop_assert_eq!(&e.file, "fuzz.toml");
        }
    }
    Ok(())
}

#[derive(Clone, Debug)]
enum Edit {
    /// Remove `len` bytes at a position (fraction of the text).
    Delete(f64, usize),
    /// Insert a snippet at a position.
    Insert(f64, String),
    /// Replace one byte.
    Replace(f64, u8),
}

/// Snippets likely to upset the parser or the validator, including multi-byte
/// characters (error places must land on character boundaries).
const SNIPPETS: &[&str] = &[
    "-1",
    "0",
    "0.0",
    "1e400",
    "nan",
    "inf",
    "-inf",
    "\"x\"",
    "\"\"",
    "[",
    "]",
    "{",
    "}",
    ",",
    "=",
    "\n",
    "\"invert\"",
    "{ microstep = 0 }",
    "{ pulley = {} }",
    "[nodes.q]\n",
    "[axes.w]\n",
    "[tools.t]\nkind = \"pen\"\n",
    "actuators = [\"nope\"]\n",
    "é",
    "θ",
    "—",
    "🦀",
    "\u{0}",
    "\t",
    "#",
    "'''",
    "\"\"\"",
    "\r\n",
    "start = { x = 1e9 }\n",
    "kinematics = \"polar\"\n",
    "profile = \"scurve\"\n",
    "[motion]\n",
    "joint = \"theta\"\n",
    "travel = [1, 0]\n",
];

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (0.0..1.0f64, 1..40usize).prop_map(|(at, n)| Edit::Delete(at, n)),
        (0.0..1.0f64, prop::sample::select(SNIPPETS))
            .prop_map(|(at, s)| Edit::Insert(at, s.to_string())),
        (0.0..1.0f64, "\\PC{1,8}").prop_map(|(at, s)| Edit::Insert(at, s)),
        (0.0..1.0f64, any::<u8>()).prop_map(|(at, b)| Edit::Replace(at, b)),
    ]
}

/// Applies edits to the bytes of `text`; the result is read back lossily, so
/// broken UTF-8 turns into replacement characters.
fn mutate(text: &str, edits: &[Edit]) -> String {
    let mut bytes = text.as_bytes().to_vec();
    for e in edits {
        let at = |f: f64, len: usize| ((f * len as f64) as usize).min(len);
        match e {
            Edit::Delete(f, n) => {
                let i = at(*f, bytes.len());
                let j = (i + n).min(bytes.len());
                bytes.drain(i..j);
            }
            Edit::Insert(f, s) => {
                let i = at(*f, bytes.len());
                bytes.splice(i..i, s.bytes());
            }
            Edit::Replace(f, b) => {
                if !bytes.is_empty() {
                    let i = at(*f, bytes.len() - 1);
                    bytes[i] = *b;
                }
            }
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_strings_never_panic(text in any::<String>()) {
        parse_ok_or_located(&text)?;
    }

    #[test]
    fn toml_like_noise_never_panics(text in "([a-z_]{1,8} = [-0-9.e\"a-z{}\\[\\], ]{0,20}\n|\\[[a-z.]{1,12}\\]\n|é|θ){0,30}") {
        parse_ok_or_located(&text)?;
    }

    #[test]
    fn mutated_examples_never_panic(which in 0usize..64, edits in prop::collection::vec(edit(), 1..6)) {
        let files = examples();
        let text = mutate(&files[which % files.len()], &edits);
        parse_ok_or_located(&text)?;
    }
}

#[test]
fn unmutated_examples_parse() {
    for text in examples() {
        Machine::parse(&text, Path::new("fuzz.toml")).unwrap();
    }
}

/// Non-ASCII text before an error: the column counts characters, not bytes.
#[test]
fn columns_count_characters() {
    let text = "name = \"θ-plotter\"\n[axes.x]\ntravel = [0, 100]\nmax_velocity = 100\nmax_acceleration = 1000\n[actuators.m]\njoint = \"x\"\nchain = []\n# é\n";
    let e = Machine::parse(text, Path::new("fuzz.toml")).unwrap_err();
    assert_eq!((e.line, e.column), (8, 9), "{e}");
    let text = "name = \"m\" # ünïcödé\ndescription = 5";
    let e = Machine::parse(text, Path::new("fuzz.toml")).unwrap_err();
    assert_eq!((e.line, e.column), (2, 15), "{e}");
    let text = "name = \"ü\"; oops";
    let e = Machine::parse(text, Path::new("fuzz.toml")).unwrap_err();
    assert_eq!(e.line, 1, "{e}");
    assert!(e.column >= 11 && e.column <= 12, "{e}");
}
