//! Every file of the fuzz corpora through its harness, then a short
//! deterministic mutation run per target, so a regression found by fuzzing
//! fails the ordinary test suite on stable Rust.

use motet_fuzz::mutate::{mutate, Rng};
use motet_fuzz::{Harness, MAX_INPUT, TARGETS};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

/// Mutated inputs per target in the smoke run.
const SMOKE_INPUTS: usize = 1000;

fn corpus(target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/corpus")
        .join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            (p, bytes)
        })
        .collect()
}

/// Runs `harness` on `input`; the failure message names the input.
fn check(target: &str, harness: Harness, what: &str, input: &[u8]) -> Result<(), String> {
    catch_unwind(AssertUnwindSafe(|| harness(input))).map_err(|e| {
        let msg = e
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default();
        format!(
            "{target}: {what}: {msg}\ninput ({} bytes): {:?}",
            input.len(),
            String::from_utf8_lossy(&input[..input.len().min(2000)])
        )
    })
}

fn run_target(target: &str, harness: Harness) {
    let files = corpus(target);
    assert!(!files.is_empty(), "fuzz/corpus/{target} is empty");
    let mut failures = Vec::new();
    for (path, bytes) in &files {
        assert!(
            bytes.len() <= MAX_INPUT,
            "{}: larger than the harness reads",
            path.display()
        );
        if let Err(e) = check(target, harness, &path.display().to_string(), bytes) {
            failures.push(e);
        }
    }
    // The smoke run: seeded, so every run tries the same inputs.
    let mut rng = Rng::new(0x6d6f_7465_7466_757a ^ target.len() as u64);
    for i in 0..SMOKE_INPUTS {
        let (_, a) = &files[rng.below(files.len())];
        let (_, b) = &files[rng.below(files.len())];
        let input = mutate(a, b, &mut rng, MAX_INPUT);
        if let Err(e) = check(target, harness, &format!("smoke input {i}"), &input) {
            failures.push(e);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

fn harness(name: &str) -> Harness {
    motet_fuzz::target(name).unwrap_or_else(|| panic!("no target {name}"))
}

#[test]
fn every_target_has_a_corpus_and_a_fuzz_target() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz");
    for (name, _) in TARGETS {
        assert!(
            root.join("corpus").join(name).is_dir(),
            "no corpus for {name}"
        );
        assert!(
            root.join("fuzz_targets")
                .join(format!("{name}.rs"))
                .is_file(),
            "no fuzz target for {name}"
        );
    }
}

macro_rules! corpus_tests {
    ($($name:ident),* $(,)?) => {$(
        #[test]
        fn $name() {
            run_target(stringify!($name), harness(stringify!($name)));
        }
    )*};
}

corpus_tests!(
    gcode,
    svg,
    machine_file,
    graph_file,
    pairing_file,
    journal,
    firmware_image,
    wire_frame,
    module_description,
    describe_wire,
);
