//! The stop protocol: when sealing stops (a request, a lost node, a
//! refusal), every node runs its contingency tail from the same boundary;
//! the host asks each where it came to rest, and journals the stop.

use super::{NetError, NetRun, Phase};
use crate::journal::{JournalSeal, JournalStop};
use crate::source::Sourced;
use motet_planner::Planned;
use motet_trajectory::Point;
use motet_wire::link::State;
use motet_wire::HostMessage;

/// Stopping nodes are asked where they are µs apart.
const WHERE_INTERVAL_US: u64 = 100_000;

/// A coordinated stop.
#[derive(Clone, Debug, PartialEq)]
pub struct StopInfo {
    /// Why the run stopped, for the person (a lost node, Ctrl-C).
    pub reason: String,
    /// Segments before this index were committed; every node that kept
    /// running rests at the end of the one before it.
    pub window_end: u32,
    /// First segment the contingency tail slowed down.
    pub tail_start: u32,
    /// Segments every node had reported finished.
    pub done: u32,
    /// The job command the first segment past the committed window came
    /// from (the job's length when no motion was left): where a job held
    /// on its path continues, from `point`.
    pub next_command: usize,
    /// Host time the tail takes over, µs: when the machine starts braking
    /// (or the stop's own time, when the window already ends at rest).
    pub braking_at: f64,
    /// Where the nodes that kept running come to rest.
    pub point: Point,
    /// Host time at which the machine is at rest, µs.
    pub rest_time: f64,
    /// Machine nodes (indices) that stopped answering: where they are is
    /// not known, only that they got no further than the committed window.
    pub lost: Vec<LostNode>,
    /// Machine nodes that reported themselves at rest, each with the end
    /// of its committed window (`window_end`, unless it missed the last
    /// seal), in node order.
    pub confirmed: Vec<(usize, u32)>,
}

/// A node the host lost during a run.
#[derive(Clone, Debug, PartialEq)]
pub struct LostNode {
    /// Its index among the machine's nodes.
    pub node: usize,
    /// Its name in the machine file.
    pub name: String,
    /// What the host noticed (silent for too long, its link failed).
    pub why: String,
}

impl StopInfo {
    /// Whether every node is known to rest at `point`.
    pub fn all_at_rest(&self) -> bool {
        self.lost.is_empty() && self.confirmed.iter().all(|&(_, e)| e == self.window_end)
    }

    /// Node `k` reported itself at rest at the end of `committed`: kept in
    /// node order, whichever answered first, once.
    pub(super) fn at_rest(&mut self, k: usize, committed: u32) {
        if !self.confirmed.iter().any(|c| c.0 == k) {
            let at = self.confirmed.partition_point(|c| c.0 < k);
            self.confirmed.insert(at, (k, committed));
        }
    }
}

impl NetRun {
    /// Stops sealing: the nodes run their tails. Safe to call at any time.
    pub fn stop(&mut self, reason: &str, now: u64) {
        if matches!(
            self.phase,
            Phase::Stopping(_) | Phase::Stopped(_) | Phase::Done
        ) {
            return;
        }
        for p in self.peers.iter_mut() {
            p.drop_unsealed();
        }
        // A group seal not every node confirmed is taken back first.
        let ends = self.take_back_unconfirmed(now);
        // An open feed's planner holds commands for lookahead: closing it
        // plans them, so the first command not sealed is found among them.
        self.close_feed();
        let next_command = self.first_unsealed_command();
        self.pending.clear();
        self.pending_events = 0;
        let point = self
            .committed
            .back()
            .map(|c| c.seg.end)
            .unwrap_or(self.start_point);
        // From here the nodes run the tail: so does the record.
        let n = self.committed.len().min(self.history.len());
        let from = self.history.len() - n;
        let mut braking_at = now as f64;
        if let Ok(c) = motet_trajectory::contingency::Contingency::of(self.history.range(from..)) {
            braking_at = braking_at.max(c.start_time);
            let mut walk = c.walk();
            for s in self.history.range_mut(from + c.start..) {
                *s = walk.next(s);
            }
        }
        let rest_time = crate::tail::rest_time(self.committed.iter().map(|c| &c.seg), now as f64)
            .max(self.committed_end.min(now as f64));
        self.update_done();
        self.phase = Phase::Stopping(StopInfo {
            reason: reason.to_string(),
            window_end: self.next_index_committed(),
            tail_start: self.tail_start,
            done: self.done,
            next_command,
            braking_at,
            point,
            rest_time,
            lost: self.lost.clone(),
            confirmed: Vec::new(),
        });
        self.next_where = now;
        self.broadcast_stop(ends, now);
    }

    /// The command of the first segment not sealed: the first pending one,
    /// or the next the planner gives (the feed is dropped with the stop).
    fn first_unsealed_command(&mut self) -> usize {
        if let Some(c) = self.pending.first() {
            return c.command;
        }
        if self.feed.is_none() {
            return 0;
        }
        loop {
            match self.next_item() {
                Ok(Some(Sourced {
                    item: Planned::Segment(_),
                    command,
                })) => return command,
                Ok(Some(_)) => {}
                Ok(None) => return self.progress().1,
                Err(_) => return self.progress().0,
            }
        }
    }

    /// Node `k` stopped answering or its link failed: the run stops, and
    /// where that node is, nobody knows.
    pub(super) fn lose(&mut self, k: usize, why: String, now: u64) {
        if self.lost.iter().any(|l| l.node == k) {
            return;
        }
        let name = self.peers[k].name.clone();
        self.lost.push(LostNode {
            node: k,
            name: name.clone(),
            why: why.clone(),
        });
        self.stop(&format!("node {name}: {why}"), now);
        if let Phase::Stopping(info) = &mut self.phase {
            info.lost = self.lost.clone();
            info.confirmed.retain(|&(c, _)| c != k);
        }
    }

    /// Node loss: silence longer than the timeout, or a failed link.
    pub(super) fn watch(&mut self, now: u64) {
        let mut lost = None;
        for (k, p) in self.peers.iter().enumerate() {
            if self.lost.iter().any(|l| l.node == k) {
                continue;
            }
            if let State::Failed(e) = p.link_state() {
                lost = Some((k, format!("link failed ({e:?})")));
                break;
            }
            // Silence while the host itself had no turn is not the node's.
            let heard = p.last_heard.unwrap_or(now).max(self.pace.listening_since);
            let silent = now.saturating_sub(heard);
            if silent > self.cfg.node_timeout_us {
                lost = Some((
                    k,
                    format!("stopped answering ({} ms without a frame)", silent / 1000),
                ));
                break;
            }
        }
        if let Some((k, why)) = lost {
            self.lose(k, why, now);
        }
    }

    /// While the nodes run their tails: ask each where it is until it says
    /// it is at rest on this run; one that does not say so in time is lost.
    pub(super) fn settle(&mut self, now: u64) -> Result<(), NetError> {
        self.watch(now);
        let Phase::Stopping(info) = self.phase.clone() else {
            return Ok(());
        };
        let open: Vec<usize> = (0..self.peers.len())
            .filter(|k| {
                !info.confirmed.iter().any(|c| c.0 == *k) && !info.lost.iter().any(|l| l.node == *k)
            })
            .collect();
        if open.is_empty() {
            return self.stopped(info, now);
        }
        // Counted from the stop at the earliest: a host that stalled past
        // the rest time gives the nodes a timeout to answer once it is back.
        let rest = info.rest_time.max(info.braking_at);
        if now as f64 > rest + self.cfg.node_timeout_us as f64 {
            for k in open {
                self.lose(k, "did not report itself at rest".into(), now);
            }
            let Phase::Stopping(info) = self.phase.clone() else {
                return Ok(());
            };
            return self.stopped(info, now);
        }
        // Asked from the start: the answers also show the node is alive.
        if now >= self.next_where {
            self.stop_again(now);
            for k in open {
                if matches!(self.peers[k].link_state(), State::Established { .. }) {
                    self.peers[k].send_motion(&HostMessage::Where);
                }
            }
            self.next_where = now + WHERE_INTERVAL_US;
        }
        Ok(())
    }

    pub(super) fn stopped(&mut self, info: StopInfo, now: u64) -> Result<(), NetError> {
        // A window taken back was journaled: the stop record names the
        // last seal journaled, the nodes their own ends.
        let (end, tail) = match &self.group {
            Some(g) if g.journaled.0 > info.window_end => g.journaled,
            _ => (info.window_end, info.tail_start),
        };
        if let Some(j) = self.journal.as_mut() {
            j.stop(&JournalStop {
                seal: JournalSeal {
                    end,
                    tail,
                    done: info.done,
                    time: now,
                },
                lost: info.lost.iter().map(|l| l.node).collect(),
            })?;
        }
        self.phase = Phase::Stopped(info);
        Ok(())
    }

    /// Segments every node that takes segments has finished, as far as
    /// their last statuses tell, or their last frames: a node that answers
    /// runs its queue in order, so what ended on its clock before it last
    /// spoke is done (never less than before).
    pub(super) fn update_done(&mut self) {
        let reported = (0..self.peers.len())
            .filter(|&k| self.dist.next_seq(k).is_some())
            .map(|k| {
                let by_status = self.finished_by(k).unwrap_or(0);
                let p = &self.peers[k];
                let by_frame = p.last_heard.map_or(0, |t| {
                    let rtt = p.link().stats().srtt_us as f64;
                    self.ended_by(t as f64 - rtt - super::window::RETIRE_SLACK_US)
                });
                by_status.max(by_frame)
            })
            .min()
            .unwrap_or(0);
        self.done = self.done.max(reported.min(self.next_index_committed()));
    }

    /// Segments the committed trajectory surely ended by host time `t`: the
    /// committed ones before the first that ends later (none the tail may
    /// have slowed), 0 for a time before what the host keeps.
    fn ended_by(&self, t: f64) -> u32 {
        if t < self.forgotten_until {
            return 0;
        }
        let first = self
            .committed
            .iter()
            .find(|c| c.seg.t1() > t)
            .map_or(self.next_index_committed(), |c| c.index);
        first.min(self.tail_start)
    }
}
