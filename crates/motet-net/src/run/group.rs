//! Seals and stops for every node in one frame, on a shared medium.
//!
//! A group seal is one broadcast datagram listing every node's sequence
//! end: every node that hears it commits the same window at the same
//! instant. Each confirms with its heartbeat (its committed end); a
//! node that has not confirmed in time gets the seal again through its link
//! (it may have missed the frame). One that still has not confirmed when
//! half the lead has passed stops the run, and the window is taken back
//! (on the host and, by the group stop, on every node that took it) while
//! the tail of the window before has not started: every node then brakes
//! on that tail, the one that missed the seal included. The next seal
//! waits until every node confirmed the last.
//!
//! The host also sends a heartbeat to every node when it has sent nothing
//! else for a while; each node sends its own likewise, and one at once to
//! confirm a group seal. A node that no longer hears the host or another
//! member brakes on its committed tail by itself
//! ([`motet_wire::group::SILENCE_US`]).

use super::{NetRun, Phase};
use motet_wire::group::{GroupMessage, Member, HEARTBEAT_US, MAX_GROUP};
use motet_wire::{HostMessage, NodeMessage};

/// The host's side of the group: the windows sealed, what each node
/// confirmed, and the seal not yet confirmed by all.
#[derive(Debug, Default)]
pub(super) struct Group {
    /// Group seals sent in this run.
    window: u32,
    /// Each node's end as of the last seal every node confirmed.
    confirmed: Vec<(usize, Member)>,
    unconfirmed: Option<Unconfirmed>,
    next_beat: u64,
    /// Frames the host had put on the medium at the last round.
    frames_sent: u64,
    /// The end and tail of the last seal journaled: a stop is journaled on it.
    pub(super) journaled: (u32, u32),
    /// Windows taken back by a group stop.
    pub(super) taken_back: u32,
    /// The ends of the group stop, sent again while nodes have not
    /// reported themselves at rest (one may have missed the frame).
    stop_ends: Vec<Member>,
}

/// A group seal not yet confirmed by every node, and what the host had
/// before it, to take it back.
#[derive(Debug)]
struct Unconfirmed {
    members: Vec<(usize, Member)>,
    /// The seal, sent once every link delivered the window's segments.
    msg: GroupMessage,
    prepared_at: u64,
    sent_at: Option<u64>,
    repaired: bool,
    /// Segments the seal added to the committed window.
    added: usize,
    committed_end: f64,
    /// Tail start of the window before, host µs.
    deadline: f64,
    tail_start: u32,
}

/// What the committed window was before a seal.
pub(super) struct Before {
    pub(super) added: usize,
    pub(super) committed_end: f64,
    pub(super) deadline: f64,
    pub(super) tail_start: u32,
}

impl NetRun {
    /// The nodes share one medium (a bus): seals and stops go to every node
    /// in one frame, and the members watch one another's heartbeats.
    /// Before the first poll. More nodes than one frame lists
    /// ([`MAX_GROUP`]) keep their seals through their own links: returns
    /// whether the group is on.
    pub fn on_shared_medium(&mut self) -> bool {
        if self.peers.len() > MAX_GROUP {
            return false;
        }
        self.group = Some(Group::default());
        true
    }

    /// Whether seals go to every node in one frame.
    pub fn shared_medium(&self) -> bool {
        self.group.is_some()
    }

    /// Windows the run took back because a node did not confirm them.
    pub fn windows_taken_back(&self) -> u32 {
        self.group.as_ref().map_or(0, |g| g.taken_back)
    }

    /// A group seal waits for every node's confirmation.
    pub(super) fn group_busy(&self) -> bool {
        self.group.as_ref().is_some_and(|g| g.unconfirmed.is_some())
    }

    /// Sends the seal of the window just committed to every node at once.
    pub(super) fn seal_group(&mut self, now: u64, before: Before) {
        let members: Vec<(usize, Member)> = (0..self.peers.len())
            .filter_map(|k| {
                let next_seq = self.dist.next_seq(k)?;
                let address = self.peers[k].address;
                Some((k, Member { address, next_seq }))
            })
            .collect();
        let Some(g) = self.group.as_mut() else {
            return;
        };
        g.window += 1;
        let msg = GroupMessage::Seal {
            run: self.identity.run,
            window: g.window,
            members: members.iter().map(|m| m.1).collect(),
        };
        g.unconfirmed = Some(Unconfirmed {
            members,
            msg,
            prepared_at: now,
            sent_at: None,
            repaired: false,
            added: before.added,
            committed_end: before.committed_end,
            deadline: before.deadline,
            tail_start: before.tail_start,
        });
        self.send_seal(now);
    }

    /// Sends the group seal once every node's link delivered what it seals
    /// (a datagram overtakes the link's frames): until then a node would
    /// refuse it as out of order.
    fn send_seal(&mut self, now: u64) {
        let delivered = self
            .peers
            .iter()
            .enumerate()
            .all(|(k, p)| p.backlog() == 0 || self.lost.iter().any(|l| l.node == k));
        let Some(u) = self.group.as_mut().and_then(|g| g.unconfirmed.as_mut()) else {
            return;
        };
        if u.sent_at.is_some() || !delivered {
            return;
        }
        u.sent_at = Some(now);
        let msg = u.msg.clone();
        self.broadcast(&msg, now);
    }

    /// Sends `msg` to every node through the first live peer's transport;
    /// a transport that fails loses its node.
    fn broadcast(&mut self, msg: &GroupMessage, now: u64) {
        let Some(k) = (0..self.peers.len()).find(|k| !self.lost.iter().any(|l| l.node == *k))
        else {
            return;
        };
        if let Err(e) = self.peers[k].broadcast(msg) {
            self.lose(k, format!("link error: {e}"), now);
        }
    }

    /// One clock exchange for every node in one frame. On a medium where
    /// the host hears its own frame at the instant every node did, each
    /// answer is an exact sample of that node's clock (reference
    /// broadcast); elsewhere still one frame instead of one per node. Each
    /// node's next exchange is planned from it.
    pub(super) fn sync_all(&mut self, now: u64) {
        let Some(k) = (0..self.peers.len()).find(|k| !self.lost.iter().any(|l| l.node == *k))
        else {
            return;
        };
        // A lost datagram is only a missing sample.
        let _ = self.peers[k].send_time_to_all(now);
        let starting = matches!(self.phase, Phase::Starting);
        for p in self.peers.iter_mut() {
            let target = super::clocks::clock_target(&self.cfg, p);
            // A start hurries exchanges under jitter; reference samples
            // are exact, and each sync frame costs every node an answer.
            let hurry = starting && p.references == 0;
            p.sync
                .exchanged(now, target, self.cfg.sync_interval_us, hurry);
            p.asked(now);
        }
    }

    /// Every round on a shared medium: the host's heartbeat, and the
    /// confirmations of the last group seal (repaired through the links,
    /// or the run stopped when a node does not confirm in time).
    pub(super) fn keep_group(&mut self, now: u64) {
        let Some(g) = self.group.as_mut() else {
            return;
        };
        let active = matches!(
            self.phase,
            Phase::Streaming | Phase::Draining | Phase::Stopping(_)
        );
        // Every frame the host puts on the medium tells the nodes it is
        // there: the heartbeat only fills a silence.
        let sent: u64 = self
            .peers
            .iter()
            .map(|p| p.transport().stats().frames_out)
            .sum();
        if sent != g.frames_sent {
            g.frames_sent = sent;
            g.next_beat = now + HEARTBEAT_US;
        }
        if active && now >= g.next_beat {
            let msg = GroupMessage::Heartbeat {
                run: self.identity.run,
                committed: g.window,
            };
            self.broadcast(&msg, now);
        }
        self.send_seal(now);
        let Some(u) = self.group.as_ref().and_then(|g| g.unconfirmed.as_ref()) else {
            return;
        };
        let open: Vec<(usize, Member)> = u
            .members
            .iter()
            .copied()
            .filter(|&(k, m)| !self.confirms(k, m.next_seq))
            .collect();
        let (sent_at, repaired) = (u.sent_at.unwrap_or(u.prepared_at), u.repaired);
        let sent = u.sent_at.is_some();
        if open.is_empty() {
            if let Some(g) = self.group.as_mut() {
                g.confirmed = g.unconfirmed.take().map(|u| u.members).unwrap_or_default();
            }
            return;
        }
        let lead = self.lead_us();
        let rtt = self.slowest_srtt_us();
        if sent && !repaired && now >= sent_at + (2 * rtt).max(lead / 8) {
            // It may have missed the frame: the seal again, through its link.
            for &(k, m) in &open {
                self.peers[k].send_motion(&HostMessage::Seal {
                    next_seq: m.next_seq,
                });
            }
            if let Some(u) = self.group.as_mut().and_then(|g| g.unconfirmed.as_mut()) {
                u.repaired = true;
            }
        } else if now >= sent_at + lead / 2 && !matches!(self.phase, Phase::Stopping(_)) {
            let window = self.group.as_ref().map_or(0, |g| g.window);
            let reason = if sent {
                let names: Vec<&str> = open
                    .iter()
                    .map(|&(k, _)| self.peers[k].name.as_str())
                    .collect();
                format!("node {} did not confirm window {window}", names.join(", "))
            } else {
                let names: Vec<&str> = (0..self.peers.len())
                    .filter(|&k| self.peers[k].backlog() > 0)
                    .map(|k| self.peers[k].name.as_str())
                    .collect();
                format!(
                    "window {window} was not sealed: node {} did not take its segments",
                    names.join(", ")
                )
            };
            self.stop(&reason, now);
        }
    }

    /// Node `k` committed up to `next_seq`: its heartbeat says so (a node
    /// sends one as soon as it takes a group seal), or its link
    /// acknowledged the seal sent through it, or its last status says so.
    fn confirms(&self, k: usize, next_seq: u32) -> bool {
        let reached = |committed: u32| committed.wrapping_sub(next_seq) < 1 << 31;
        let p = &self.peers[k];
        let beat = p
            .beat
            .is_some_and(|(run, c)| run == self.identity.run && reached(c));
        let status = matches!(
            self.status[k],
            Some(NodeMessage::Status { committed, run, .. })
                if run == self.identity.run && reached(committed)
        );
        beat || status || p.sealed == Some(next_seq)
    }

    /// When the run stops with a group seal not confirmed by every node:
    /// the window is taken back while the tail before it has not started
    /// (its segments go back to pending, so the job continues at its
    /// first). Returns the ends every node is to stop at.
    pub(super) fn take_back_unconfirmed(&mut self, now: u64) -> Vec<Member> {
        let all = self
            .group
            .as_ref()
            .and_then(|g| g.unconfirmed.as_ref())
            .is_some_and(|u| u.members.iter().all(|&(k, m)| self.confirms(k, m.next_seq)));
        let committed = self.committed.len();
        let Some(g) = self.group.as_mut() else {
            return Vec::new();
        };
        let Some(u) = g.unconfirmed.take() else {
            return g.confirmed.iter().map(|m| m.1).collect();
        };
        // Too late, or nothing before it to brake on: the nodes that took
        // it run it; the others stop a window short, and say so when asked
        // where they are.
        if all || (now as f64) >= u.deadline || u.added >= committed || g.confirmed.is_empty() {
            g.confirmed = u.members;
            return g.confirmed.iter().map(|m| m.1).collect();
        }
        g.taken_back += 1;
        let ends: Vec<Member> = g.confirmed.iter().map(|m| m.1).collect();
        let mut back = Vec::new();
        for _ in 0..u.added {
            if let Some(c) = self.committed.pop_back() {
                back.push(c);
            }
            self.history.pop_back();
        }
        back.reverse();
        back.append(&mut self.pending);
        self.pending = back;
        self.committed_end = u.committed_end;
        self.deadline = u.deadline;
        self.tail_start = u.tail_start;
        ends
    }

    /// Tells every node the run stops at `ends`, in one frame.
    pub(super) fn broadcast_stop(&mut self, ends: Vec<Member>, now: u64) {
        let Some(g) = self.group.as_mut() else {
            return;
        };
        g.stop_ends = ends;
        self.stop_again(now);
    }

    /// The group stop again (for a node that may have missed it).
    pub(super) fn stop_again(&mut self, now: u64) {
        let Some(g) = self.group.as_ref() else {
            return;
        };
        if g.stop_ends.is_empty() {
            return;
        }
        let msg = GroupMessage::Stop {
            run: self.identity.run,
            members: g.stop_ends.iter().copied().collect(),
        };
        self.broadcast(&msg, now);
    }
}
