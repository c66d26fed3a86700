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

/// Waits until the networked run `host` writing to `out` has sealed
/// `seals` windows (at most a minute); fails if it ended first.
pub fn wait_for_seals(out: &std::path::Path, host: &mut std::process::Child, seals: usize) {
    let started = std::time::Instant::now();
    while journal_seals(out) < seals {
        assert!(
            started.elapsed() < std::time::Duration::from_secs(60),
            "the run never got going"
        );
        assert!(
            host.try_wait().unwrap().is_none(),
            "the run ended before it was under way"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
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

/// `motet serve ARGS --dir DIR`, started in the repository root: the
/// process (killed when dropped), its address (`HOST:PORT`), and the lines
/// it printed up to the address (the token's among them).
pub struct Served {
    pub child: std::process::Child,
    pub addr: String,
    pub banner: Vec<String>,
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

pub fn serve(args: &[&str], dir: &std::path::Path) -> Served {
    use std::io::BufRead;
    let mut child = Command::new(env!("CARGO_BIN_EXE_motet"))
        .arg("serve")
        .args(args)
        .arg("--dir")
        .arg(dir)
        .current_dir(root())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
    let mut banner = Vec::new();
    let addr = loop {
        let line = lines
            .next()
            .expect("motet serve printed no address")
            .unwrap();
        banner.push(line.clone());
        if let Some(w) = line.split_whitespace().find(|w| w.starts_with("http://")) {
            break w
                .trim_start_matches("http://")
                .trim_end_matches('/')
                .to_string();
        }
    };
    // Keep reading its output so it never blocks on a full pipe.
    std::thread::spawn(move || for _ in lines {});
    Served {
        child,
        addr,
        banner,
    }
}
