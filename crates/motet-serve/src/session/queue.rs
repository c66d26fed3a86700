//! The job queue: jobs waiting their turn on the machine. Started by the
//! person, it runs them one after another; each job that finishes starts
//! the next. A job that ends any other way (a cancel, an emergency stop, an
//! alarm) halts the queue with its jobs still in it, since the machine may
//! need the person before the next one (a print to take off, a pen to
//! change).

use super::{ActionError, Client, Session};
use crate::events::Level;
use crate::jobs::StoredJob;
use serde::Serialize;
use std::sync::Arc;

/// Jobs the queue holds at most.
pub const MAX_QUEUED: usize = 64;

/// The queue as a screen shows it.
#[derive(Clone, Debug, Serialize)]
pub struct QueueView {
    /// Whether it runs: each job that finishes starts the next.
    pub running: bool,
    /// The waiting jobs' ids and names, next first.
    pub jobs: Vec<QueuedJob>,
}

/// A waiting job.
#[derive(Clone, Debug, Serialize)]
pub struct QueuedJob {
    /// The job's id.
    pub id: u64,
    /// Its file name.
    pub name: String,
}

/// The queue's state inside the session.
#[derive(Default)]
pub(super) struct Queue {
    pub(super) jobs: std::collections::VecDeque<Arc<StoredJob>>,
    pub(super) running: bool,
    /// Who started it: the jobs it starts are theirs.
    pub(super) owner: Option<String>,
}

impl Session {
    /// The queue now.
    pub fn queue(&self) -> QueueView {
        QueueView {
            running: self.queue.running,
            jobs: self
                .queue
                .jobs
                .iter()
                .map(|j| QueuedJob {
                    id: j.id,
                    name: j.name.clone(),
                })
                .collect(),
        }
    }

    /// Ids of the jobs waiting, next first.
    pub fn queued_ids(&self) -> Vec<u64> {
        self.queue.jobs.iter().map(|j| j.id).collect()
    }

    /// Appends a job to the queue.
    pub fn enqueue(&mut self, job: Arc<StoredJob>, client: Client) -> Result<(), ActionError> {
        self.may_drive(client)?;
        if self.queue.jobs.len() >= MAX_QUEUED {
            return Err(ActionError::QueueFull(MAX_QUEUED));
        }
        self.events.push(
            self.now,
            Level::Info,
            format!("job {} ({}) queued", job.id, job.name),
        );
        self.queue.jobs.push_back(job);
        self.changed();
        Ok(())
    }

    /// Takes the job at `index` (0: next) out of the queue.
    pub fn dequeue(&mut self, index: usize, client: Client) -> Result<(), ActionError> {
        self.may_drive(client)?;
        let len = self.queue.jobs.len();
        let job = self
            .queue
            .jobs
            .remove(index)
            .ok_or(ActionError::NoSuchEntry { index, len })?;
        self.events.push(
            self.now,
            Level::Info,
            format!("job {} ({}) taken out of the queue", job.id, job.name),
        );
        self.changed();
        Ok(())
    }

    /// Starts the queue: its next job now, the others as each finishes.
    pub fn start_queue(&mut self, client: Client) -> Result<(), ActionError> {
        self.ready("start the queue")?;
        let Some(next) = self.queue.jobs.front().cloned() else {
            return Err(ActionError::QueueEmpty);
        };
        self.start(next, client)?;
        self.queue.jobs.pop_front();
        self.queue.running = true;
        self.queue.owner = client.map(str::to_string);
        self.changed();
        Ok(())
    }

    /// A job finished: the next one starts if the queue runs. A next job
    /// that cannot start (its first move out of reach from here) halts the
    /// queue and says why.
    pub(super) fn queue_advance(&mut self) {
        if !self.queue.running {
            return;
        }
        let Some(next) = self.queue.jobs.front().cloned() else {
            self.queue.running = false;
            self.events
                .push(self.now, Level::Info, "the queue is done".into());
            self.changed();
            return;
        };
        let owner = self.queue.owner.clone();
        match self.start(next, owner.as_deref()) {
            Ok(()) => {
                self.queue.jobs.pop_front();
            }
            Err(e) => {
                self.queue.running = false;
                self.events.push(
                    self.now,
                    Level::Warn,
                    format!("the queue halts: the next job cannot start: {e}"),
                );
            }
        }
        self.changed();
    }

    /// A job ended other than by finishing: the queue waits for the person.
    pub(super) fn queue_halt(&mut self) {
        if self.queue.running {
            self.queue.running = false;
            self.events.push(
                self.now,
                Level::Info,
                format!(
                    "the queue halts with {} jobs waiting",
                    self.queue.jobs.len()
                ),
            );
        }
    }

    /// Puts back a queue kept from before the server restarted (halted:
    /// the person starts it again).
    pub fn restore_queue(&mut self, jobs: Vec<Arc<StoredJob>>) {
        self.queue.jobs = jobs.into_iter().take(MAX_QUEUED).collect();
        self.queue.running = false;
    }
}
