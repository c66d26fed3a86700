//! How the jobs ended: a bounded record a screen lists.

use super::{Activity, Session};
use serde::Serialize;

/// Jobs kept in the history.
pub const KEPT_HISTORY: usize = 100;

/// How a job ended.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JobOutcome {
    /// The job's id.
    pub id: u64,
    /// Its file name.
    pub name: String,
    /// When it started, µs (server time).
    pub started_us: u64,
    /// When it ended.
    pub ended_us: u64,
    /// `finished`, `cancelled`, `emergency stop`, or the alarm's reason.
    pub outcome: String,
}

impl Session {
    /// The current run's activity is over; a job's outcome goes into the
    /// history.
    pub(super) fn end_activity(&mut self, outcome: &str) {
        if let Activity::Job(j) = std::mem::replace(&mut self.activity, Activity::None) {
            if self.history.len() == KEPT_HISTORY {
                self.history.pop_front();
            }
            self.history.push_back(JobOutcome {
                id: j.job.id,
                name: j.job.name.clone(),
                started_us: j.started_us,
                ended_us: self.now,
                outcome: outcome.to_string(),
            });
        }
    }

    /// The jobs that ended, oldest first (the newest [`KEPT_HISTORY`]).
    pub fn history(&self) -> impl Iterator<Item = &JobOutcome> {
        self.history.iter()
    }
}
