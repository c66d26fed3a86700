//! Feeding a planned job to the dance's node: its segments go through the
//! machine's [`Distributor`] as the node's queue makes room.

use super::node::{send, DanceNode};
use super::{DanceError, PlannedJob};
use motet_host::{Distributor, Machine};
use motet_planner::Planned;
use motet_trajectory::MAX_AXES;

/// The job's segments still to send, and the route they take.
pub(super) struct JobFeed {
    dist: Distributor,
    /// The job's segments in plan order (empty without a job).
    segments: Vec<Planned>,
    /// How many of `segments` were handed to the distributor.
    pub sent: usize,
}

impl JobFeed {
    /// The feed for `job` on `machine`: the first node's subscription is
    /// widened to every machine axis so a `trajectory_reader` can follow
    /// any. A machine without nodes cannot take a job.
    pub fn new(machine: &Machine, job: Option<&PlannedJob>) -> Result<JobFeed, DanceError> {
        let mut dist = Distributor::new(machine);
        if job.is_some() {
            let Some(sub) = dist.subscriptions.first_mut() else {
                return Err(DanceError::Setup(format!(
                    "{} has no node to send the job to",
                    machine.name
                )));
            };
            sub.axes = ((1u16 << machine.axes.len().min(MAX_AXES)) - 1) as u8;
        }
        let segments = job
            .map(|j| {
                j.items
                    .iter()
                    .filter(|i| matches!(i, Planned::Segment(_)))
                    .cloned()
                    .collect()
            })
            .unwrap_or_default();
        Ok(JobFeed {
            dist,
            segments,
            sent: 0,
        })
    }

    /// Sends the node segments while its queue has room.
    pub fn fill(&mut self, node: &mut DanceNode) -> Result<(), DanceError> {
        while self.sent < self.segments.len() && node.status().segment_space > 0 {
            if let Some(m) = self.dist.route(0, &self.segments[self.sent]) {
                send(node, &m)?;
            }
            self.sent += 1;
        }
        Ok(())
    }
}
