//! How the jobs ended: a bounded record a screen lists.

use super::{Activity, Session};
use serde::{Deserialize, Serialize};
use std::time::{SystemTime, UNIX_EPOCH};

/// Jobs kept in the history.
pub const KEPT_HISTORY: usize = 100;

/// How a job ended.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JobOutcome {
    /// The job's id.
    pub id: u64,
    /// Its file name.
    pub name: String,
    /// When it started, µs (server time).
    pub started_us: u64,
    /// When it ended.
    pub ended_us: u64,
    /// When it ended, calendar time (ms since 1970): server times start
    /// again when a server restarts, this does not.
    #[serde(default)]
    pub ended_wall_ms: u64,
    /// `finished`, `cancelled`, `emergency stop`, or the alarm's reason.
    pub outcome: String,
}

impl Session {
    /// The current run's activity is over; a job's outcome goes into the
    /// history. A job that did not finish halts the queue.
    pub(super) fn end_activity(&mut self, outcome: &str) {
        if let Activity::Job(j) = std::mem::replace(&mut self.activity, Activity::None) {
            if outcome != "finished" {
                self.queue_halt();
            }
            if self.history.len() == KEPT_HISTORY {
                self.history.pop_front();
            }
            self.history.push_back(JobOutcome {
                id: j.job.id,
                name: j.job.name.clone(),
                started_us: j.started_us,
                ended_us: self.now,
                ended_wall_ms: SystemTime::now()
                    .duration_since(UNIX_EPOCH)
                    .map_or(0, |d| d.as_millis() as u64),
                outcome: outcome.to_string(),
            });
            self.changed();
        }
    }

    /// Puts back a history kept from before the server restarted.
    pub fn restore_history(&mut self, kept: Vec<JobOutcome>) {
        let skip = kept.len().saturating_sub(KEPT_HISTORY);
        self.history = kept.into_iter().skip(skip).collect();
    }

    /// The jobs that ended, oldest first (the newest [`KEPT_HISTORY`]).
    pub fn history(&self) -> impl Iterator<Item = &JobOutcome> {
        self.history.iter()
    }
}
