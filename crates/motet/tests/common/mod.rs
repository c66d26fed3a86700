//! What the command-line tests share: the repository root and running `motet`.
#![allow(dead_code)] // each test file uses its own part

use std::path::PathBuf;
use std::process::Command;
use tempfile::TempDir;

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Runs `motet ARGS` in the repository root: (success, stdout, stderr).
pub fn motet(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_motet"))
        .args(args)
        .current_dir(root())
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// An empty scratch folder for one test, `motet-KIND-NAME-…` under the
/// system's temporary folder. It is removed when the guard is dropped, also
/// when the test fails: hold it until the test no longer needs the folder
/// (after any process writing into it has ended).
pub fn scratch(kind: &str, name: &str) -> TempDir {
    tempfile::Builder::new()
        .prefix(&format!("motet-{kind}-{name}-"))
        .tempdir()
        .unwrap()
}

/// Seals the journal of a networked run in `out` holds so far.
pub fn journal_seals(out: &std::path::Path) -> usize {
    std::fs::read_to_string(out.join("journal"))
        .map(|t| t.lines().filter(|l| l.starts_with("seal")).count())
        .unwrap_or(0)
}

/// `motet resume OUT` succeeds and finishes the job: its stdout.
pub fn resume_to_done(out: &std::path::Path, extra: &[&str]) -> String {
    let mut args = vec!["resume", out.to_str().unwrap()];
    args.extend(extra);
    let (ok, stdout, stderr) = motet(&args);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("resuming") && stdout.contains("done"),
        "{stdout}"
    );
    let report = std::fs::read_to_string(out.join("net.json")).unwrap();
    assert!(report.contains("\"outcome\": \"done\""), "{report}");
    stdout
}
