//! `motet bench --instructions N`: instructions per step, counted by
//! callgrind on `motet run` over the job's first N lines.
//!
//! Wall time on a shared machine moves with its neighbours; instruction
//! counts do not, and they are what a node's firmware budget is written in
//! (docs/firmware.md). Callgrind runs the program about fifty times slower,
//! so it sees a prefix of the job. Where valgrind is not installed, the
//! benchmark says so and goes on.

use crate::bench_memory::Scratch;
use anyhow::{bail, Context, Result};
use std::path::Path;
use std::process::{Command, Stdio};

/// What each part of a run costs per step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PerStep {
    pub steps: u64,
    /// The nodes (`Node::poll`, inclusive): solving every step and handing
    /// it out in time order.
    pub node: f64,
    /// Of the nodes' share, the step solve (`Channel::solve_ahead`,
    /// inclusive): each step's time from the segment's profile and joint
    /// path, the arithmetic firmware runs per step.
    pub solve: f64,
    /// The observer (`Plant::apply`, inclusive): checking every step and
    /// recording the executed path.
    pub observer: f64,
    /// Everything the process did, reading and planning the job and
    /// drawing and writing its renders included.
    pub whole: f64,
}

/// The function names (as callgrind_annotate prints them) of the parts.
const NODE: &str = "motet_node::node::Node<_,_>::poll";
const SOLVE: &str = "motet_node::channel::Channel::solve_ahead";
const OBSERVER: &str = "motet_sim::plant::Plant::apply";
const TOTAL: &str = "PROGRAM TOTALS";

/// Measures `motet run MACHINE` on the first `lines` lines of `data` (the
/// job's text); `None` when valgrind is not installed.
pub fn measure(
    machine: &Path,
    data: &[u8],
    lines: usize,
    scratch: &Scratch,
) -> Result<Option<PerStep>> {
    let found = Command::new("valgrind")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !found {
        return Ok(None);
    }
    let job = scratch.0.join("first.gcode");
    std::fs::write(&job, first_lines(data, lines))
        .with_context(|| format!("writing {}", job.display()))?;
    let out = scratch.0.join("instructions");
    let profile = scratch.0.join("callgrind.out");
    let exe = std::env::current_exe().context("finding the motet binary")?;
    let run = Command::new("valgrind")
        .arg("--tool=callgrind")
        .arg(format!("--callgrind-out-file={}", profile.display()))
        .arg(exe)
        .arg("run")
        .arg(machine)
        .arg(&job)
        .arg("-q")
        .arg("--out")
        .arg(&out)
        .output()
        .context("starting valgrind")?;
    if !run.status.success() {
        bail!(
            "motet run under callgrind failed: {}",
            String::from_utf8_lossy(&run.stderr).trim()
        );
    }
    let annotated = Command::new("callgrind_annotate")
        .arg("--inclusive=yes")
        .arg(&profile)
        .output()
        .context("starting callgrind_annotate (it comes with valgrind)")?;
    let text = String::from_utf8_lossy(&annotated.stdout);
    let report = std::fs::read_to_string(out.join("report.json"))
        .with_context(|| format!("reading {}", out.join("report.json").display()))?;
    let steps = steps_of(&report)?;
    per_step(&text, steps).map(Some)
}

/// The first `lines` lines of `data`.
fn first_lines(data: &[u8], lines: usize) -> &[u8] {
    let end = data
        .iter()
        .enumerate()
        .filter(|(_, b)| **b == b'\n')
        .nth(lines.saturating_sub(1))
        .map_or(data.len(), |(i, _)| i + 1);
    &data[..end]
}

/// Steps of every actuator in a run's report.
fn steps_of(report: &str) -> Result<u64> {
    let v: serde_json::Value = serde_json::from_str(report).context("reading the run's report")?;
    let actuators = v["actuators"]
        .as_array()
        .context("the run's report lists no actuators")?;
    Ok(actuators.iter().filter_map(|a| a["steps"].as_u64()).sum())
}

/// The figures from callgrind_annotate's inclusive listing for a run of
/// `steps` steps.
fn per_step(annotated: &str, steps: u64) -> Result<PerStep> {
    if steps == 0 {
        bail!("the job's first lines take no step: give more lines");
    }
    let get = |name: &str| {
        inclusive(annotated, name)
            .with_context(|| format!("callgrind_annotate's listing has no {name}"))
    };
    let per = |n: u64| n as f64 / steps as f64;
    Ok(PerStep {
        steps,
        node: per(get(NODE)?),
        solve: per(get(SOLVE)?),
        observer: per(get(OBSERVER)?),
        whole: per(get(TOTAL)?),
    })
}

/// A function's inclusive count: the largest on the lines naming it (a
/// function is listed once for itself and once per file it was inlined
/// from), or the program's total.
fn inclusive(annotated: &str, name: &str) -> Option<u64> {
    annotated
        .lines()
        .filter(|l| {
            if name == TOTAL {
                return l.contains(TOTAL);
            }
            // callgrind_annotate prints the object (`[/path/motet]`) only
            // where it differs from the line above, so a line may end with
            // the function's name or with the object after it.
            let l = l.trim_end();
            let l = match l.rfind(" [") {
                Some(i) if l.ends_with(']') => &l[..i],
                _ => l,
            };
            l.ends_with(&format!(":{name}"))
        })
        .filter_map(|l| l.split_whitespace().next()?.replace(',', "").parse().ok())
        .max()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A listing as callgrind_annotate prints it, trimmed.
    const LISTING: &str = "\
--------------------------------------------------------------------------------
Ir
--------------------------------------------------------------------------------
4,213,790,249 (100.0%)  PROGRAM TOTALS

--------------------------------------------------------------------------------
Ir                     file:function
--------------------------------------------------------------------------------
1,011,390,312 (24.00%)  crates/motet-node/src/node.rs:motet_node::node::Node<_,_>::poll [/x/motet]
1,011,000,000 (23.99%)  /x/crates/motet-node/src/node.rs:motet_node::node::Node<_,_>::poll
  300,000,000 ( 7.12%)  crates/motet-node/src/channel.rs:motet_node::channel::Channel::solve_ahead [/x/motet]
  742,233,171 (17.61%)  crates/motet-sim/src/plant.rs:motet_sim::plant::Plant::apply [/x/motet]
  100,000,000 ( 2.37%)  crates/motet-sim/src/plant.rs:motet_sim::plant::Plant::apply_more [/x/motet]
";

    #[test]
    fn reads_the_parts_per_step() {
        // The object after a function's largest line, or none (printed only
        // where it changes from the line above).
        for listing in [
            LISTING.to_string(),
            LISTING.replace("Node<_,_>::poll [/x/motet]", "Node<_,_>::poll"),
        ] {
            let p = per_step(&listing, 1_000_000).unwrap();
            assert_eq!(p.node, 1011.390312, "{listing}");
            assert_eq!(p.solve, 300.0);
            assert_eq!(p.observer, 742.233171);
            assert_eq!(p.whole, 4213.790249);
        }
    }

    #[test]
    fn a_missing_part_is_named() {
        let listing = LISTING.replace("Plant::apply [", "Plant::other [");
        let e = per_step(&listing, 10).unwrap_err().to_string();
        assert!(e.contains("Plant::apply"), "{e}");
        assert!(per_step(LISTING, 0).is_err());
    }

    #[test]
    fn first_lines_cuts_at_a_line_end() {
        for (data, n, want) in [
            ("a\nb\nc\n", 2, "a\nb\n"),
            ("a\nb\nc", 5, "a\nb\nc"),
            ("a\nb\n", 1, "a\n"),
            ("", 3, ""),
        ] {
            assert_eq!(
                first_lines(data.as_bytes(), n),
                want.as_bytes(),
                "{data:?} {n}"
            );
        }
    }

    #[test]
    fn steps_are_summed_over_actuators() {
        let r = r#"{"actuators": [{"steps": 3}, {"steps": 4}]}"#;
        assert_eq!(steps_of(r).unwrap(), 7);
        assert!(steps_of("{}").is_err());
        assert!(steps_of("not json").is_err());
    }
}
