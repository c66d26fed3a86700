//! G-code: read and checked as `motet run` does, on every example machine,
//! then planned (a bounded prefix) and, when short, run on simulated nodes.

use crate::{bounded, example, plan};
use motet_api::job::parse_job;
use motet_api::{JobError, JobKind, JobOptions};
use std::path::Path;

/// Runs G-code bytes through the job reader, the planner and the nodes.
pub fn gcode(data: &[u8]) {
    let data = bounded(data);
    let lines = data.split(|b| *b == b'\n').count();
    for (i, machine) in example::gcode_machines().iter().enumerate() {
        // Unknown codes refused on one machine (the default), skipped with a
        // warning on the others (`--allow-unknown`), to reach past them.
        let opts = JobOptions {
            allow_unknown: i > 0,
            ..Default::default()
        };
        match parse_job(
            machine,
            Path::new("fuzz.gcode"),
            JobKind::Gcode,
            data,
            &opts,
        ) {
            Ok(job) => {
                for c in &job.commands {
                    let line = c.loc.line as usize;
                    assert!(
                        (1..=lines).contains(&line),
                        "command {:?} placed at line {line} of {lines}",
                        c.item
                    );
                }
                plan::plan_and_run(machine, &job.commands);
            }
            Err(JobError::NotText { line, .. }) => assert!((1..=lines).contains(&line)),
            Err(JobError::Source { error, .. }) => {
                let line = error.loc.line as usize;
                assert!(
                    (1..=lines + 1).contains(&line),
                    "error placed at line {line} of {lines}: {error}"
                );
            }
            Err(e) => panic!("G-code bytes gave a file error: {e}"),
        }
    }
}
