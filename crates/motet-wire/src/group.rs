//! One frame for every node on a shared medium: seals, stops and
//! heartbeats sent as datagrams to [`BROADCAST`] on [`port::GROUP`].
//!
//! On a bus every node hears every frame, so a seal sent once reaches every
//! node at the same instant: nodes given the same group seals commit the
//! same windows, and a host that dies between two seals cannot leave them a
//! window apart. Each member answers a group seal with its `Status` through
//! its own reliable link (the host's confirmation); heartbeats tell every
//! member that the others (and the host) are alive.
//!
//! [`parse`] checks a group frame before a node acts on it: seals and stops
//! come only from the host, members are node addresses listed once, and a
//! run is never 0. What it refuses changes nothing.

use crate::frame::BROADCAST;
use crate::service::{is_node_address, port, HOST_ADDRESS};
use heapless::Vec;
use serde::{Deserialize, Serialize};

/// Most nodes a group frame lists: 16 members of at most 8 bytes each,
/// 140 bytes in all, fit a message.
pub const MAX_GROUP: usize = 16;

/// A member that has sent nothing else for this long sends a heartbeat,
/// µs of its own clock: every frame on a shared medium is heard by every
/// member, so the heartbeat only fills silences.
pub const HEARTBEAT_US: u64 = 500_000;

/// A member (or the host) not heard for this long is taken as gone: a node
/// with committed motion then takes no more seals and brakes on its
/// committed window's tail, µs. Over two heartbeats: one frame lost is not
/// a death; shorter than the host's node timeout (1.5 s), so the other
/// nodes hear a node fall silent before the host gives it up.
pub const SILENCE_US: u64 = 1_200_000;

/// One node's part of a group seal or stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Member {
    /// The node's address.
    pub address: u16,
    /// The sequence number after the node's last segment of the window:
    /// its `next_seq` once sealed.
    pub next_seq: u32,
}

/// What goes to (or comes from) every node at once.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum GroupMessage {
    /// Host → every node: commit the pending window; each listed node seals
    /// as `HostMessage::Seal { next_seq }` would, and confirms with its
    /// heartbeat (its committed end) at once; a refusal goes through its
    /// link. The list is also the group: the nodes that watch one
    /// another's heartbeats.
    Seal {
        /// The run (`Windowed { run }`); a node on another run ignores it.
        run: u32,
        /// The window's number, counted from 1 in the run.
        window: u32,
        /// Every node that takes segments, with its sequence end.
        members: Vec<Member, MAX_GROUP>,
    },
    /// Host → every node: the run stops at these ends. A node whose last
    /// window goes beyond its end takes that window back if the tail of the
    /// one before has not started yet; every node drops what is pending
    /// and takes no more seals, so all brake on the same committed tail.
    Stop {
        /// The run, as in `Seal`.
        run: u32,
        /// Every node that takes segments, with the end it stops at.
        members: Vec<Member, MAX_GROUP>,
    },
    /// Any member (or the host) → every node: still here.
    Heartbeat {
        /// The sender's run.
        run: u32,
        /// The sender's committed end (the host's: its window count).
        committed: u32,
    },
}

/// Why a group frame was refused; nothing changed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GroupError {
    /// Not a group message, or not to the broadcast address.
    Malformed,
    /// A seal or stop from another address than the host's.
    NotFromHost {
        /// The address it came from.
        src: u16,
    },
    /// A member that is not a node address, or listed twice.
    BadMember {
        /// The address.
        address: u16,
    },
    /// Run 0: no run.
    NoRun,
}

impl core::fmt::Display for GroupError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            GroupError::Malformed => f.write_str("not a group message to every node"),
            GroupError::NotFromHost { src } => write!(
                f,
                "a group seal or stop from address {src}, not the host's ({HOST_ADDRESS})"
            ),
            GroupError::BadMember { address } => {
                write!(
                    f,
                    "member {address} is not a node address or is listed twice"
                )
            }
            GroupError::NoRun => f.write_str("a group message for run 0"),
        }
    }
}

impl GroupMessage {
    /// The run the message is about.
    pub fn run(&self) -> u32 {
        match self {
            GroupMessage::Seal { run, .. }
            | GroupMessage::Stop { run, .. }
            | GroupMessage::Heartbeat { run, .. } => *run,
        }
    }

    /// The members listed (none for a heartbeat).
    pub fn members(&self) -> &[Member] {
        match self {
            GroupMessage::Seal { members, .. } | GroupMessage::Stop { members, .. } => members,
            GroupMessage::Heartbeat { .. } => &[],
        }
    }

    /// The end listed for `address`, if it is a member.
    pub fn next_seq_of(&self, address: u16) -> Option<u32> {
        self.members()
            .iter()
            .find(|m| m.address == address)
            .map(|m| m.next_seq)
    }
}

/// Checks a group frame (`dst`, `src`, `port` of its header, and its
/// payload) before a node acts on it.
pub fn parse(
    dst: u16,
    src: u16,
    frame_port: u8,
    payload: &[u8],
) -> Result<GroupMessage, GroupError> {
    if dst != BROADCAST || frame_port != port::GROUP {
        return Err(GroupError::Malformed);
    }
    let msg: GroupMessage = crate::decode(payload).map_err(|_| GroupError::Malformed)?;
    let from_host = src == HOST_ADDRESS;
    match &msg {
        GroupMessage::Seal { .. } | GroupMessage::Stop { .. } if !from_host => {
            return Err(GroupError::NotFromHost { src });
        }
        GroupMessage::Heartbeat { .. } if !from_host && !is_node_address(src) => {
            return Err(GroupError::NotFromHost { src });
        }
        _ => {}
    }
    if msg.run() == 0 {
        return Err(GroupError::NoRun);
    }
    let members = msg.members();
    for (i, m) in members.iter().enumerate() {
        if !is_node_address(m.address) || members[..i].iter().any(|o| o.address == m.address) {
            return Err(GroupError::BadMember { address: m.address });
        }
    }
    Ok(msg)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::{encode, MAX_MESSAGE};
    use proptest::prelude::*;

    fn members(list: &[(u16, u32)]) -> Vec<Member, MAX_GROUP> {
        list.iter()
            .map(|&(address, next_seq)| Member { address, next_seq })
            .collect()
    }

    fn bytes(m: &GroupMessage) -> heapless::Vec<u8, MAX_MESSAGE> {
        let mut buf = [0u8; MAX_MESSAGE];
        heapless::Vec::from_slice(encode(m, &mut buf).unwrap()).unwrap()
    }

    #[test]
    fn checks() {
        let seal = GroupMessage::Seal {
            run: 7,
            window: 3,
            members: members(&[(2, 10), (3, 12), (4, 0)]),
        };
        let beat = GroupMessage::Heartbeat {
            run: 7,
            committed: 12,
        };
        let g = port::GROUP;
        type Case = (u16, u16, u8, GroupMessage, Result<GroupMessage, GroupError>);
        // (dst, src, port, message, expected)
        let cases: [Case; 8] = [
            (BROADCAST, 1, g, seal.clone(), Ok(seal.clone())),
            (
                BROADCAST,
                3,
                g,
                seal.clone(),
                Err(GroupError::NotFromHost { src: 3 }),
            ),
            (BROADCAST, 3, g, beat.clone(), Ok(beat.clone())),
            (
                BROADCAST,
                0,
                g,
                beat.clone(),
                Err(GroupError::NotFromHost { src: 0 }),
            ),
            (2, 1, g, seal.clone(), Err(GroupError::Malformed)),
            (
                BROADCAST,
                1,
                port::MOTION,
                seal.clone(),
                Err(GroupError::Malformed),
            ),
            (
                BROADCAST,
                1,
                g,
                GroupMessage::Stop {
                    run: 7,
                    members: members(&[(2, 1), (2, 1)]),
                },
                Err(GroupError::BadMember { address: 2 }),
            ),
            (
                BROADCAST,
                1,
                g,
                GroupMessage::Stop {
                    run: 0,
                    members: members(&[(2, 1)]),
                },
                Err(GroupError::NoRun),
            ),
        ];
        for (dst, src, p, m, want) in cases {
            assert_eq!(parse(dst, src, p, &bytes(&m)), want, "{m:?} from {src}");
        }
        assert_eq!(seal.next_seq_of(3), Some(12));
        assert_eq!(seal.next_seq_of(5), None);
    }

    #[test]
    fn a_full_group_fits_a_message() {
        let m = GroupMessage::Seal {
            run: u32::MAX,
            window: u32::MAX,
            members: (0..MAX_GROUP as u16)
                .map(|i| Member {
                    address: 0xFFEF - i,
                    next_seq: u32::MAX,
                })
                .collect(),
        };
        let mut buf = [0u8; MAX_MESSAGE];
        assert!(encode(&m, &mut buf).is_ok());
    }

    proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(src in any::<u16>(), payload in proptest::collection::vec(any::<u8>(), 0..200)) {
            if let Ok(m) = parse(BROADCAST, src, port::GROUP, &payload) {
                prop_assert!(m.run() != 0);
            }
        }

        #[test]
        fn round_trip(run in 1u32.., window in any::<u32>(), list in proptest::collection::vec((2u16..0xFFF0, any::<u32>()), 0..MAX_GROUP)) {
            let mut seen = std::collections::BTreeSet::new();
            let list: std::vec::Vec<(u16, u32)> = list.into_iter().filter(|(a, _)| seen.insert(*a)).collect();
            let m = GroupMessage::Seal { run, window, members: members(&list) };
            prop_assert_eq!(parse(BROADCAST, HOST_ADDRESS, port::GROUP, &bytes(&m)), Ok(m));
        }
    }
}
