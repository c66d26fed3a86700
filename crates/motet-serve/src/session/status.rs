//! The machine as a screen shows it: where the tool is, how fast, and how
//! far the job has come.

use super::{Activity, Session, State};
use motet_trajectory::Point;
use serde::Serialize;

/// The job on the machine, for the person.
#[derive(Clone, Debug, Serialize)]
pub struct JobProgress {
    /// The job's id.
    pub id: u64,
    /// Its file name, as uploaded.
    pub name: String,
    /// Fraction of its commands done, 0..=1.
    pub progress: f64,
    /// Planned time left, seconds.
    pub left_s: f64,
}

/// Everything a screen shows of the machine, at one moment.
#[derive(Clone, Debug, Serialize)]
pub struct Status {
    /// Server time, µs since it started: the trajectory's clock.
    pub t_us: u64,
    /// What the machine is doing.
    pub state: State,
    /// The nodes' links are being set up and their clocks measured (a few
    /// seconds after the server starts): motion asked for waits.
    pub connecting: bool,
    /// Where the tool is, axis by axis, in the machine's axis order.
    pub position: Vec<f64>,
    /// Path speed, units/s.
    pub speed: f64,
    /// The job on the machine, if any.
    pub job: Option<JobProgress>,
    /// Why the machine stopped or is in alarm.
    pub reason: Option<String>,
    /// The client in control, if any.
    pub controller: Option<String>,
    /// Sequence number of the newest event.
    pub event_seq: u64,
    /// Jobs waiting in the queue.
    pub queued: usize,
    /// The machine's heaters (none on a machine without an extruder).
    pub heaters: Vec<super::HeaterState>,
}

impl Session {
    /// Where the tool is now.
    pub fn position(&self) -> Point {
        self.position_at(self.now as f64)
    }

    pub(super) fn position_at(&self, t: f64) -> Point {
        match self.state {
            State::Running | State::Holding | State::Stopping => {
                self.nodes.run().position_at(t).unwrap_or(self.rest)
            }
            _ => self.rest,
        }
    }

    /// The machine as a screen shows it now.
    pub fn status(&self) -> Status {
        let n = self.machine.axes.len();
        let now = self.now as f64;
        let p = self.position_at(now);
        let dt = 10_000.0;
        let before = self.position_at(now - dt);
        let speed = self
            .machine
            .axes
            .iter()
            .enumerate()
            .filter(|(_, a)| a.path)
            .map(|(i, _)| (p[i] - before[i]).powi(2))
            .sum::<f64>()
            .sqrt()
            / (dt * 1e-6);
        Status {
            t_us: self.now,
            state: self.state,
            connecting: self.status_connecting(),
            position: p[..n].to_vec(),
            speed,
            job: self.job_progress(),
            reason: self.reason.clone(),
            controller: self.controller.clone(),
            event_seq: self.events.last_seq(),
            queued: self.queue.jobs.len(),
            heaters: self.heaters().to_vec(),
        }
    }

    pub(super) fn job_progress(&self) -> Option<JobProgress> {
        let Activity::Job(j) = &self.activity else {
            return None;
        };
        let total = j.job.commands.len().max(1);
        let done = match (self.state, j.held_at) {
            (_, Some(at)) => at,
            (State::Running | State::Holding | State::Stopping, None) => {
                let run = self.nodes.run();
                match run.command_at(self.now as f64) {
                    Some(c) => j.base + c.saturating_sub(j.prelude),
                    None => j.base,
                }
            }
            _ => j.base,
        };
        let progress = (done as f64 / total as f64).clamp(0.0, 1.0);
        Some(JobProgress {
            id: j.job.id,
            name: j.job.name.clone(),
            progress,
            left_s: j.job.planned_s * (1.0 - progress),
        })
    }
}
