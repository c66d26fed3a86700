//! A node's watch over the other members of its group on a shared medium:
//! when each was last heard, when its own heartbeat is due, and which one
//! fell silent.
//!
//! The group is learnt from the host's group seals (every node listed, and
//! the host); any frame a member sends counts as a sign of life, since on a
//! bus every node hears every frame.

use heapless::Vec;
use motet_wire::group::{Member, HEARTBEAT_US, MAX_GROUP, SILENCE_US};
use motet_wire::service::HOST_ADDRESS;

/// The members a node watches and when it last heard each.
#[derive(Clone, Debug, Default)]
pub struct GroupWatch {
    /// The run the group belongs to (0: none).
    run: u32,
    /// (address, local time last heard, µs): the host and the other nodes.
    members: Vec<(u16, u64), { MAX_GROUP + 1 }>,
    /// Local time the next heartbeat is due if nothing else is sent, µs.
    next_beat: u64,
    /// A heartbeat is due at once: it confirms a group seal.
    confirm: bool,
}

impl GroupWatch {
    /// Takes the group of a seal for `run` (this node is `me`): members new
    /// to the watch are taken as heard now, so a node joining late is not
    /// thought silent.
    pub fn join(&mut self, run: u32, me: u16, members: &[Member], now: u64) {
        if run != self.run {
            self.run = run;
            self.members.clear();
            self.next_beat = now;
        }
        let others = members.iter().map(|m| m.address).filter(|&a| a != me);
        for a in core::iter::once(HOST_ADDRESS).chain(others) {
            if !self.members.iter().any(|m| m.0 == a) {
                // Full only past MAX_GROUP members, which a seal cannot list.
                let _ = self.members.push((a, now));
            }
        }
    }

    /// The run the group belongs to (0: none).
    pub fn run(&self) -> u32 {
        self.run
    }

    /// A frame from `src` arrived at `now`.
    pub fn heard(&mut self, src: u16, now: u64) {
        if let Some(m) = self.members.iter_mut().find(|m| m.0 == src) {
            m.1 = m.1.max(now);
        }
    }

    /// The first member not heard for longer than [`SILENCE_US`].
    pub fn silent(&self, now: u64) -> Option<u16> {
        self.members
            .iter()
            .find(|m| now.saturating_sub(m.1) > SILENCE_US)
            .map(|m| m.0)
    }

    /// When the first member would be silent for too long, local µs.
    pub fn silence_deadline(&self) -> Option<u64> {
        self.members.iter().map(|m| m.1 + SILENCE_US + 1).min()
    }

    /// Whether a heartbeat is due at `now`: one confirming a seal, or the
    /// node has sent nothing for [`HEARTBEAT_US`]. Whatever goes out next
    /// is reported with [`GroupWatch::sent`].
    pub fn beat_due(&self, now: u64) -> bool {
        self.run != 0 && (self.confirm || now >= self.next_beat)
    }

    /// A heartbeat goes out at once, whatever was sent lately: the
    /// confirmation of a group seal.
    pub fn confirm(&mut self) {
        self.confirm = true;
    }

    /// A confirmation is waiting to go out.
    pub fn confirming(&self) -> bool {
        self.run != 0 && self.confirm
    }

    /// The node sent a frame at `now` (every member hears it); `beat`: it
    /// was the heartbeat.
    pub fn sent(&mut self, now: u64, beat: bool) {
        self.next_beat = now + HEARTBEAT_US;
        self.confirm &= !beat;
    }

    /// When the next heartbeat is due, local µs (none without a group).
    pub fn next_beat(&self) -> Option<u64> {
        (self.run != 0).then_some(self.next_beat)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_member_unheard_for_too_long_is_named() {
        let mut w = GroupWatch::default();
        let members = [
            Member {
                address: 2,
                next_seq: 5,
            },
            Member {
                address: 3,
                next_seq: 5,
            },
            Member {
                address: 4,
                next_seq: 5,
            },
        ];
        w.join(9, 3, &members, 1_000);
        assert_eq!(w.silent(1_000 + SILENCE_US), None);
        w.heard(HOST_ADDRESS, 200_000);
        w.heard(2, 200_000);
        // Node 4 said nothing since it joined.
        assert_eq!(w.silent(1_001 + SILENCE_US), Some(4));
        // Its own frames do not count for others.
        w.heard(3, 400_000);
        assert_eq!(w.silent(1_001 + SILENCE_US), Some(4));
        w.heard(4, 300_000);
        assert_eq!(w.silent(200_000 + SILENCE_US), None);
        assert_eq!(w.silent(200_001 + SILENCE_US), Some(HOST_ADDRESS));
        // A new run starts a new group.
        w.join(10, 3, &members[..1], 900_000);
        assert_eq!(w.silent(900_000 + SILENCE_US), None);
        assert!(w.beat_due(900_000));
        // Any frame sent puts the next heartbeat off; a confirmation goes
        // at once.
        w.sent(900_000, false);
        assert!(!w.beat_due(900_000 + HEARTBEAT_US - 1));
        assert!(w.beat_due(900_000 + HEARTBEAT_US));
        w.confirm();
        assert!(w.beat_due(900_001));
        w.sent(900_001, false);
        assert!(w.beat_due(900_002), "only the heartbeat confirms");
        w.sent(900_002, true);
        assert!(!w.beat_due(900_003));
    }
}
