//! What a run reports: each node's figures, what its outputs did, and
//! where the machine was on the committed trajectory.

use super::{NetRun, Phase};
use motet_trajectory::{Point, Segment};
use motet_wire::{HostMessage, NodeMessage};

/// What a node's outputs did in a run (`NodeMessage::Tally`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tally {
    /// Steps made on each channel (both directions), by channel index.
    pub steps: [u32; 8],
    /// Tool output changes.
    pub tool_changes: u32,
    /// Hash over every output with its exact time: equal on two nodes that
    /// ran the same trajectory the same way.
    pub hash: u64,
}

impl From<&motet_node::StepTally> for Tally {
    fn from(t: &motet_node::StepTally) -> Tally {
        Tally {
            steps: t.steps,
            tool_changes: t.tool_changes,
            hash: t.hash,
        }
    }
}

/// Per-node figures for the report.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PeerFigures {
    /// The machine node's name.
    pub name: String,
    /// The link's smoothed round-trip time, µs.
    pub rtt_us: u64,
    /// Frames the link sent again for want of an acknowledgement.
    pub retransmits: u64,
    /// Frames received that failed their CRC (or did not decode).
    pub crc_errors: u64,
    /// Bytes the transport sent.
    pub bytes_out: u64,
    /// Bytes the transport received.
    pub bytes_in: u64,
    /// Frames the transport sent.
    pub frames_out: u64,
    /// Frames the transport received.
    pub frames_in: u64,
    /// Estimated standard deviation of the node's clock model at the time
    /// asked, µs.
    pub sync_error_us: f64,
    /// The node's crystal error as measured, parts per million.
    pub skew_ppm: f64,
    /// Times the node ran out of segments while moving, as it last reported.
    pub underruns: u32,
}

impl NetRun {
    /// What each node's outputs did in the run, if it said (after `Done`).
    pub fn tallies(&self) -> Vec<Option<Tally>> {
        self.tallies.iter().map(|t| t.flatten()).collect()
    }

    /// At the end: what each node's outputs did, for the report; done once
    /// every node answered (or after the node timeout: a report without it).
    pub(super) fn collect_tallies(&mut self, now: u64) {
        let asked = *self.tally_asked.get_or_insert_with(|| {
            for p in self.peers.iter_mut() {
                p.send_motion(&HostMessage::TallyGet);
            }
            now
        });
        if self.tallies.iter().all(Option::is_some) || now > asked + self.cfg.node_timeout_us {
            self.phase = Phase::Done;
        }
    }

    /// Figures for the report.
    pub fn figures(&self, now: u64) -> Vec<PeerFigures> {
        self.peers
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let t = p.transport().stats();
                let l = p.link().stats();
                let underruns = match self.status[k] {
                    Some(NodeMessage::Status { underruns, .. }) => underruns,
                    _ => 0,
                };
                PeerFigures {
                    name: p.name.clone(),
                    rtt_us: l.srtt_us,
                    retransmits: l.retransmits,
                    crc_errors: l.crc_errors,
                    bytes_out: t.bytes_out,
                    bytes_in: t.bytes_in,
                    frames_out: t.frames_out,
                    frames_in: t.frames_in,
                    sync_error_us: p.sync.error_bound(now as f64),
                    skew_ppm: p.sync.model().skew * 1e6,
                    underruns,
                }
            })
            .collect()
    }

    /// Where the machine was (or will be, within the committed window) at
    /// host time `t`, µs: on the committed trajectory, with the tail after a
    /// stop, at rest between segments and after the last. `None` for a time
    /// the host no longer keeps: more than a second before now, while the
    /// run streams (the journal keeps the whole run).
    pub fn position_at(&self, t: f64) -> Option<Point> {
        if t < self.forgotten_until {
            return None;
        }
        let i = self.history.partition_point(|s| s.t0 <= t);
        Some(match i.checked_sub(1).map(|i| &self.history[i]) {
            None => self.before,
            Some(s) if t < s.t1() => s.position_at(t),
            Some(s) => s.end,
        })
    }

    /// How many segments the host keeps for [`NetRun::position_at`] and a
    /// stop's tail: bounded whatever the job's length (see [`NetRun`]).
    pub fn history_len(&self) -> usize {
        self.history.len()
    }

    /// The committed segments the host still keeps, with their indices.
    pub fn committed(&self) -> impl Iterator<Item = (u32, &Segment)> {
        self.committed.iter().map(|c| (c.index, &c.seg))
    }

    /// The job command whose motion runs at host time `t`, µs, among the
    /// committed segments the host keeps (the last one's after the window).
    pub fn command_at(&self, t: f64) -> Option<usize> {
        let i = self.committed.partition_point(|c| c.seg.t0 <= t);
        self.committed.get(i.checked_sub(1)?).map(|c| c.command)
    }

    /// The last status each node sent.
    pub fn node_status(&self, k: usize) -> Option<&NodeMessage> {
        self.status[k].as_ref()
    }
}
