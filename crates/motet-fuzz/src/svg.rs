//! SVG: read and checked on the pen plotter as `motet run` does, then
//! planned (a bounded prefix) and, when short, run on simulated nodes.

use crate::{bounded, example, plan};
use motet_api::job::parse_job;
use motet_api::{JobError, JobKind, JobOptions};
use std::path::Path;

/// Runs SVG bytes through the job reader, the planner and the nodes.
pub fn svg(data: &[u8]) {
    let data = bounded(data);
    let machine = example::plotter();
    match parse_job(
        machine,
        Path::new("fuzz.svg"),
        JobKind::Svg,
        data,
        &JobOptions::default(),
    ) {
        Ok(job) => plan::plan_and_run(machine, &job.commands),
        Err(JobError::Source { error, .. }) => {
            assert!(
                !error.message.is_empty(),
                "an empty SVG error at {}",
                error.loc
            );
            let lines = data.split(|b| *b == b'\n').count();
            assert!(
                (error.loc.line as usize) <= lines + 1,
                "error placed at line {} of {lines}: {error}",
                error.loc.line
            );
        }
        Err(e) => panic!("SVG bytes gave a file error: {e}"),
    }
}
