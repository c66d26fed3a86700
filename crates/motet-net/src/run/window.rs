//! Windows and seals: planned segments routed to the nodes as a pending
//! window, committed by a seal once the window reaches far enough ahead,
//! never more than the nodes' queues hold.

use super::{NetError, NetRun, Phase};
use crate::journal::{JournalSeal, JournalSegment};
use crate::plan_feed::FeedError;
use crate::source::Sourced;
use motet_planner::Planned;
use motet_trajectory::Segment;
use motet_wire::{HostMessage, NodeMessage};

/// How long after a segment's end a node may still hold it, µs.
pub(super) const RETIRE_SLACK_US: f64 = 50_000.0;

/// How long after a segment's end, on the host's clock, the host still
/// keeps it, µs: how far back [`NetRun::position_at`] answers.
pub(super) const KEEP_PAST_US: f64 = 1e6;

/// A sealed segment the host keeps until the machine is past it.
#[derive(Clone, Copy, Debug)]
pub(super) struct Committed {
    pub(super) index: u32,
    pub(super) seg: Segment,
    /// The job command it came from.
    pub(super) command: usize,
}

impl NetRun {
    /// The smoothed round trip of the slowest link, µs.
    pub(super) fn slowest_srtt_us(&self) -> u64 {
        self.peers
            .iter()
            .map(|p| p.link().stats().srtt_us)
            .max()
            .unwrap_or(0)
    }

    /// Asks every node that takes segments for its status, at most once per
    /// round trip.
    pub(super) fn ask_room(&mut self, now: u64) {
        let rtt = self.slowest_srtt_us();
        if self.room_asked_at.is_some_and(|t| now < t + rtt.max(1_000)) {
            return;
        }
        self.room_asked_at = Some(now);
        for k in 0..self.peers.len() {
            if self.dist.next_seq(k).is_some() {
                self.peers[k].send_motion(&HostMessage::Status);
            }
        }
    }

    /// Segments a node holds (committed and not yet run, and pending).
    pub(super) fn queued_on_nodes(&self, now: u64) -> usize {
        // A place frees when the node retires a segment, a little after its
        // end on the host's clock (the node's clock and polling lag). The
        // node's own count (its status, sent with every seal's
        // acknowledgement) is exact but dated; the host's clock is current
        // but a guess. A segment is taken as retired when either says so,
        // the clock only well after the segment's end.
        let t = now as f64 - RETIRE_SLACK_US;
        let sent = self.next_index;
        let by_time = self
            .committed
            .iter()
            .find(|c| c.seg.t1() > t)
            .map_or(sent - self.pending.len() as u32, |c| c.index);
        let by_status = (0..self.peers.len())
            .filter(|&k| self.dist.next_seq(k).is_some())
            .filter_map(|k| self.finished_by(k))
            .min();
        let retired = by_status.map_or(by_time, |s| s.max(by_time)).min(sent);
        (sent - retired) as usize
    }

    /// How many segments node `k` has finished, as its last status tells:
    /// those it was sent less those still in its queue.
    pub(super) fn finished_by(&self, k: usize) -> Option<u32> {
        match self.status[k] {
            Some(NodeMessage::Status {
                segment_space,
                next_seq,
                ..
            }) => {
                let held = (motet_node::DEFAULT_QUEUE as u32).saturating_sub(segment_space as u32);
                Some(next_seq.saturating_sub(held))
            }
            _ => None,
        }
    }

    pub(super) fn capacity(&self) -> usize {
        self.machine
            .nodes
            .iter()
            .map(|n| n.queue)
            .min()
            .unwrap_or(64)
            .saturating_sub(2)
            .max(2)
    }

    /// Seals windows until the committed trajectory reaches far enough ahead.
    pub(super) fn fill(&mut self, now: u64) -> Result<(), NetError> {
        let lead = self.lead_us() as f64;
        let t = now as f64;
        // Forget what the machine is well past; the record of where it was
        // goes with it (the segments the nodes still hold stay, and the
        // last one, for where the machine rests).
        while self.committed.len() > 1 && self.committed[0].seg.t1() < t - KEEP_PAST_US {
            self.committed.pop_front();
            if let Some(s) = self.history.pop_front() {
                self.forgotten_until = s.t1();
                self.before = s.end;
            }
        }
        // A window is sealed when the committed one runs short, or early
        // when a node has been quiet long enough to be asked (the seal
        // asks, see `quiet_node`).
        while self.deadline < t + lead || self.quiet_node(now) {
            // One seal in flight at a time: a node that missed a seal can then
            // differ from the others by at most that one window.
            if self.peers.iter().any(|p| p.seal_in_flight()) || self.group_busy() {
                break;
            }
            let window = self.cfg.window_us as f64;
            let grew = self.grow(t + lead + 0.5 * window, t + lead + window, now)?;
            if self.pending.is_empty() && self.pending_events == 0 && self.starving(t + lead) {
                // An open feed with nothing to plan while the window needs
                // more: plan what the planner holds to rest now, while the
                // seal still arrives before the tail would start.
                self.close_feed();
                continue;
            }
            if self.pending.is_empty() && self.pending_events == 0 {
                if !grew && self.feed.as_ref().is_some_and(|f| f.exhausted()) {
                    self.phase = Phase::Draining;
                }
                break;
            }
            let base = self.base_lead_us();
            self.pace.sealing(now, self.deadline - t, base);
            self.seal(now)?;
            let lead = self.lead_us();
            self.pace.sealed(now, self.deadline, lead);
        }
        let short = self.deadline < t + lead && self.queued_on_nodes(now) >= self.capacity();
        if short && matches!(self.phase, Phase::Streaming) {
            self.slow_feed(lead as u64)?;
        }
        Ok(())
    }

    /// An open feed has nothing left to plan and the committed window (or,
    /// before anything is committed, the feed's start) reaches no further
    /// than `needed`.
    fn starving(&self, needed: f64) -> bool {
        let reach = if self.committed.is_empty() {
            self.feed_t0
        } else {
            self.deadline
        };
        self.feed_open && self.feed.as_ref().is_some_and(|f| f.starved()) && reach < needed
    }

    /// Routes planned items into the pending window until its tail would start
    /// at or after `target`, the queue is full, or the job is planned out;
    /// or, once it reaches `enough`, where every node's segment batch is
    /// nearly full, so that the window goes out in full frames.
    pub(super) fn grow(&mut self, enough: f64, target: f64, now: u64) -> Result<bool, NetError> {
        let mut grew = false;
        loop {
            if self.queued_on_nodes(now) >= self.capacity() {
                // Full as far as the host knows: ask the nodes how full.
                self.ask_room(now);
                break;
            }
            // A wait for a heater: one more piece of the hold, unless the
            // heater is ready.
            self.hold()?;
            let item = match self.next_item() {
                Ok(Some(item)) => item,
                Ok(None) => break,
                // The job could not be read further (its file changed or
                // went): the machine stops on the path, as for a node's
                // trouble, and what was sealed is the record to resume from.
                Err(NetError::Source(message)) => {
                    self.stop(&format!("reading the job: {message}"), now);
                    break;
                }
                Err(e) => return Err(e),
            };
            grew = true;
            match item.item {
                Planned::Segment(seg) => {
                    let c = Committed {
                        index: self.next_index,
                        seg,
                        command: item.command,
                    };
                    self.next_index += 1;
                    self.route(&item.item)?;
                    self.pending.push(c);
                    self.segments_sent += 1;
                    let (start, _) = crate::tail::deadline(
                        self.committed
                            .iter()
                            .map(|c| &c.seg)
                            .chain(self.pending.iter().map(|c| &c.seg)),
                    );
                    let full = start >= enough && self.dist.batches_nearly_full();
                    if (start >= target || full) && self.pending.len() >= 2 {
                        break;
                    }
                }
                Planned::Event(_) => {
                    self.route(&item.item)?;
                    // Held on the nodes like segments until the seal.
                    self.pending_events += 1;
                }
                Planned::Pause { .. } => {
                    self.route(&item.item)?;
                    self.pauses += 1;
                }
                Planned::Aux(a) => {
                    self.route(&item.item)?;
                    // A temperature for a heater a node drives is an event
                    // there, held like the others until the seal.
                    if (0..self.peers.len()).any(|k| self.dist.takes_event(k, &item.item)) {
                        self.pending_events += 1;
                    }
                    self.start_wait(&a);
                }
            }
        }
        Ok(grew)
    }

    /// Sends `item` (quantized) to every node that reads it; segments go out
    /// in batches.
    pub(super) fn route(&mut self, item: &Planned) -> Result<(), NetError> {
        for k in 0..self.peers.len() {
            let out = self
                .dist
                .route_batched(k, item)
                .map_err(|e| NetError::Node {
                    node: self.peers[k].name.clone(),
                    message: format!("segment stream: {e:?}"),
                })?;
            for o in out {
                self.peers[k].send_motion(&o.message);
            }
        }
        Ok(())
    }

    /// The next planned item, planning more commands as needed.
    pub(super) fn next_item(&mut self) -> Result<Option<Sourced>, NetError> {
        let Some(feed) = self.feed.as_mut() else {
            return Ok(None);
        };
        feed.next(&mut self.dist).map_err(|e| match e {
            FeedError::Plan(loc, error) => NetError::Plan { loc, error },
            FeedError::Source(message) => NetError::Source(message),
        })
    }

    /// Commits the pending window on every node.
    pub(super) fn seal(&mut self, now: u64) -> Result<(), NetError> {
        let pending = std::mem::take(&mut self.pending);
        self.pending_events = 0;
        let before = super::group::Before {
            added: pending.len(),
            committed_end: self.committed_end,
            deadline: self.deadline,
            tail_start: self.tail_start,
        };
        if let Some(j) = self.journal.as_mut() {
            for c in &pending {
                j.segment(&JournalSegment {
                    index: c.index,
                    command: c.command,
                    t0: c.seg.t0,
                    t1: c.seg.t1(),
                    start: c.seg.start,
                    end: c.seg.end,
                })?;
            }
        }
        for c in &pending {
            self.sensor_plan.segment(&c.seg);
            self.committed.push_back(*c);
            self.history.push_back(c.seg);
            self.committed_end = c.seg.t1();
        }
        let segs: Vec<&Segment> = self.committed.iter().map(|c| &c.seg).collect();
        let (deadline, tail_pos) = crate::tail::deadline(segs.iter().copied());
        self.deadline = deadline;
        self.tail_start = self.committed.front().map_or(0, |c| c.index) + tail_pos as u32;
        let end = self.next_index_committed();
        self.update_done();
        if let Some(j) = self.journal.as_mut() {
            j.seal(JournalSeal {
                end,
                tail: self.tail_start,
                done: self.done,
                time: now,
            })?;
        }
        if let Some(g) = self.group.as_mut() {
            g.journaled = (end, self.tail_start);
        }
        for k in 0..self.peers.len() {
            if let Some(o) = self.dist.flush(k) {
                self.peers[k].send_motion(&o.message);
            }
            if let (Some(next_seq), None) = (self.dist.next_seq(k), &self.group) {
                // In the window's last batch when it can: its
                // acknowledgement is the node's confirmation.
                self.peers[k].send_seal(next_seq);
                self.peers[k].last_asked = Some(now);
            }
        }
        if self.group.is_some() {
            // On a shared medium one frame seals every node, sent once every
            // link has delivered the window's segments.
            self.seal_group(now, before);
        }
        self.windows += 1;
        Ok(())
    }

    pub(super) fn next_index_committed(&self) -> u32 {
        self.committed.back().map_or(0, |c| c.index + 1)
    }
}
