//! `motet bench`'s memory figures: the peak resident memory of `motet run`
//! on the job, and on a job N times longer, each in its own process so that
//! nothing the benchmark itself holds is counted.

use crate::peak::PEAK_LINE;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// A scratch folder removed when dropped.
pub struct Scratch(pub PathBuf);

impl Scratch {
    pub fn new() -> Result<Scratch> {
        let dir = std::env::temp_dir().join(format!("motet-bench-{}", std::process::id()));
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        Ok(Scratch(dir))
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Runs `motet run MACHINE JOB` in a child process; returns the peak
/// resident memory it reports for itself, MiB.
pub fn run_peak_mib(machine: &Path, job: &Path, out: &Path) -> Result<f64> {
    // Output goes to files: a pipe nobody reads while the child runs could fill.
    let out_path = out.with_extension("stdout");
    let err_path = out.with_extension("stderr");
    let create =
        |p: &Path| std::fs::File::create(p).with_context(|| format!("creating {}", p.display()));
    let exe = std::env::current_exe().context("finding the motet binary")?;
    let status = std::process::Command::new(exe)
        .arg("run")
        .arg(machine)
        .arg(job)
        .arg("--out")
        .arg(out)
        .stdout(create(&out_path)?)
        .stderr(create(&err_path)?)
        .status()
        .context("starting motet run")?;
    if !status.success() {
        let err = std::fs::read_to_string(&err_path).unwrap_or_default();
        bail!("motet run {} failed: {}", job.display(), err.trim());
    }
    let text = std::fs::read_to_string(&out_path)?;
    text.lines()
        .find_map(|l| l.trim().strip_prefix(PEAK_LINE))
        .and_then(|rest| rest.split_whitespace().next()?.parse().ok())
        .context("motet run did not report its peak memory (only Linux does)")
}

/// Writes the job's text `times` times over into one G-code file.
pub fn repeated_job(data: &[u8], times: usize, path: &Path) -> Result<()> {
    use std::io::Write;
    let f = std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
    let mut w = std::io::BufWriter::new(f);
    for _ in 0..times {
        w.write_all(data)?;
        if !data.ends_with(b"\n") {
            w.write_all(b"\n")?;
        }
    }
    w.flush()?;
    Ok(())
}
