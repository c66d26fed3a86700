//! Base service routines every node answers, whatever its kind: status,
//! identify, info, addressing, reset, firmware and time.
//!
//! Each request belongs to one [port] ([`ServiceRequest::port`]); the
//! reply goes back on the same port, the same way the request came (as a
//! datagram, a frame without flags, or through the reliable link). Payloads
//! are postcard like every other message (see docs/wire.md for the bytes).
//!
//! Addresses: the host is [`HOST_ADDRESS`]; a node that has none yet is
//! [`UNPAIRED`] and answers only broadcast requests and requests naming its
//! unique id; paired nodes take [`FIRST_NODE_ADDRESS`]..=[`LAST_NODE_ADDRESS`].
//!
//! A broadcast (or group multicast) request gets a reply only when the reply
//! carries information (status, info, paired, time): acks and errors from every
//! node on a bus would bury the replies that matter, so a node stays silent on
//! a broadcast it refuses ([`ServiceReply::answers_broadcast`]). Firmware
//! and clock-model requests are ignored when broadcast
//! ([`ServiceRequest::allowed_by_broadcast`]). Unicast requests to a paired
//! node always get a reply.

use crate::image::ImageError;
use heapless::{String, Vec};
use serde::{Deserialize, Serialize};

/// Service ports (the frame's port byte).
pub mod port {
    /// The link's own frames (SYN, RST, pure ACK).
    pub const LINK: u8 = 0;
    /// Node status ([`super::ServiceRequest::Status`]): state, address, link and clock.
    pub const STATUS: u8 = 1;
    /// Blinking the node's light, to find it on the bench.
    pub const IDENTIFY: u8 = 2;
    /// Info; a broadcast Info is the host's scan for nodes.
    pub const INFO: u8 = 3;
    /// Pairing and address changes.
    pub const ADDRESS: u8 = 4;
    /// Restarting the node's link and application.
    pub const RESET: u8 = 5;
    /// The bootloader: firmware upload, read-back, verify, start.
    pub const FIRMWARE: u8 = 6;
    /// Clock exchanges and the clock model.
    pub const TIME: u8 = 7;
    /// The module's description of itself, a part at a time
    /// ([`crate::describe`]).
    pub const DESCRIBE: u8 = 8;
    /// Motion messages (`HostMessage` / `NodeMessage`).
    pub const MOTION: u8 = 10;
    /// Seals, stops and heartbeats to every node at once
    /// ([`crate::group::GroupMessage`]), as broadcast datagrams.
    pub const GROUP: u8 = 11;
}

/// The host's address.
pub const HOST_ADDRESS: u16 = 1;
/// Address of a node that has not been paired.
pub const UNPAIRED: u16 = 0;
/// Lowest address a node can be given.
pub const FIRST_NODE_ADDRESS: u16 = 2;
/// Highest address a node can be given (0xFFF0.. are multicast).
pub const LAST_NODE_ADDRESS: u16 = 0xFFEF;

/// True for addresses a node may take.
pub const fn is_node_address(addr: u16) -> bool {
    addr >= FIRST_NODE_ADDRESS && addr <= LAST_NODE_ADDRESS
}

/// Longest node kind, bytes.
pub const KIND_LEN: usize = 16;
/// Bytes of firmware per page request or read-back.
pub const PAGE_SIZE: usize = 128;
/// Largest |skew| a clock model may give: far beyond any crystal, small
/// enough that `1 + skew` stays well away from zero.
pub const MAX_SKEW: f64 = 0.01;

/// A node type: what the host looks its driver up by.
pub type Kind = String<KIND_LEN>;

/// Known node kinds. A host keeps a registry from kind to driver; a node of a
/// kind it does not know is listed by a scan but not driven.
pub mod kind {
    /// Step/direction channels following the trajectory (`motet-node`'s `Node`).
    pub const STEPPER: &str = "stepper";
    /// Closed-loop servo channels following the trajectory.
    pub const SERVO: &str = "servo";
    /// A laser (or spindle) power output on an event track.
    pub const LASER: &str = "laser";
    /// A node run by the simulator.
    pub const SIM: &str = "sim";
}

/// Firmware version.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct Version {
    /// Incompatible changes.
    pub major: u16,
    /// Added features, compatible.
    pub minor: u16,
    /// Fixes only.
    pub patch: u16,
}

impl core::fmt::Display for Version {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{}.{}.{}", self.major, self.minor, self.patch)
    }
}

/// Host → node, on the ports listed for each variant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ServiceRequest {
    /// Port 1. Answered by [`ServiceReply::Status`].
    Status,
    /// Port 2. Blink for `ms` milliseconds (0 stops); [`ServiceReply::Ack`].
    Identify {
        /// How long to blink, ms; 0 stops.
        ms: u32,
    },
    /// Port 3. Answered by [`ServiceReply::Info`]; broadcast, it is a scan.
    Info,
    /// Port 4, broadcast. Every unpaired node blinks and waits for its
    /// button; the one pressed takes `address` and sends
    /// [`ServiceReply::Paired`]. Paired nodes ignore it.
    Pair {
        /// The address the node pressed takes, [`FIRST_NODE_ADDRESS`]..=[`LAST_NODE_ADDRESS`].
        address: u16,
    },
    /// Port 4. Stop waiting for the button and stop blinking.
    PairCancel,
    /// Port 4. The node whose unique id is `uid` takes `address` at once
    /// (a node alone on its link, or one the host already knows) and answers
    /// [`ServiceReply::Paired`]; other nodes ignore a broadcast one.
    SetAddress {
        /// The node's unique id ([`Info::uid`]); a node with another ignores (or refuses) the
        /// request.
        uid: u64,
        /// The address it takes, [`FIRST_NODE_ADDRESS`]..=[`LAST_NODE_ADDRESS`].
        address: u16,
    },
    /// Port 5. [`ServiceReply::Ack`], then the node restarts its link and its
    /// motion state (and leaves the bootloader, discarding an upload).
    Reset,
    /// Port 6. Start an upload of a whole image file (header included) of
    /// `size` bytes whose CRC-32C is `crc32c`; the node enters the bootloader.
    FirmwareBegin {
        /// The image's length, bytes.
        size: u32,
        /// CRC-32C (Castagnoli) of the whole image, checked at `FirmwareVerify`.
        crc32c: u32,
        /// The node kind the image is for; a node of another kind refuses it.
        kind: Kind,
        /// The version the image carries, checked at `FirmwareVerify`.
        version: Version,
    },
    /// Port 6. Write image bytes at `offset`; pages come in order (a page may
    /// be sent again). Answered by [`ServiceReply::FirmwareWritten`].
    FirmwarePage {
        /// Where the page goes in the image, bytes from its start; pages are sent in order.
        offset: u32,
        /// The page's bytes, at most [`PAGE_SIZE`].
        data: Vec<u8, PAGE_SIZE>,
    },
    /// Port 6. Read back `len` ≤ 128 bytes at `offset`:
    /// [`ServiceReply::FirmwareData`].
    FirmwareRead {
        /// Where to read, bytes from the image's start.
        offset: u32,
        /// How many bytes, at most [`PAGE_SIZE`].
        len: u8,
    },
    /// Port 6. Check size, CRC and image header of what was written:
    /// [`ServiceReply::FirmwareVerified`] or an error.
    FirmwareVerify,
    /// Port 6. Install the verified image and run it; refused before a
    /// successful verify.
    FirmwareStart,
    /// Port 7, a datagram. `t1` is the host clock when it was sent, µs.
    /// Answered by [`ServiceReply::Time`].
    TimeGet {
        /// The host clock when the request was sent, µs.
        t1: u64,
    },
    /// Port 7. The node's clock model `local = offset + (1 + skew) · host`
    /// (µs), as `motet_wire::sync` estimates it; [`ServiceReply::Ack`].
    TimeSet {
        /// Node clock at host time 0, µs.
        offset: f64,
        /// How much faster the node's clock runs than the host's (`local` gains `skew` µs per host
        /// µs); within ±[`MAX_SKEW`].
        skew: f64,
    },
    /// Port 8. Part `part` of the node's description
    /// ([`crate::describe`]): [`ServiceReply::Description`]. With `uid`,
    /// only that node answers (an unpaired one too, as for `SetAddress`);
    /// without, any node asked.
    Describe {
        /// The node meant, or any.
        uid: Option<u64>,
        /// Which part: 0 is the head, which says how many there are.
        part: u8,
    },
}

impl ServiceRequest {
    /// The port this request belongs to.
    pub const fn port(&self) -> u8 {
        match self {
            ServiceRequest::Status => port::STATUS,
            ServiceRequest::Identify { .. } => port::IDENTIFY,
            ServiceRequest::Info => port::INFO,
            ServiceRequest::Pair { .. }
            | ServiceRequest::PairCancel
            | ServiceRequest::SetAddress { .. } => port::ADDRESS,
            ServiceRequest::Reset => port::RESET,
            ServiceRequest::FirmwareBegin { .. }
            | ServiceRequest::FirmwarePage { .. }
            | ServiceRequest::FirmwareRead { .. }
            | ServiceRequest::FirmwareVerify
            | ServiceRequest::FirmwareStart => port::FIRMWARE,
            ServiceRequest::TimeGet { .. } | ServiceRequest::TimeSet { .. } => port::TIME,
            ServiceRequest::Describe { .. } => port::DESCRIBE,
        }
    }

    /// False for requests a node ignores when broadcast: firmware (one node
    /// at a time) and a clock model (each node has its own).
    pub const fn allowed_by_broadcast(&self) -> bool {
        !matches!(
            self,
            ServiceRequest::FirmwareBegin { .. }
                | ServiceRequest::FirmwarePage { .. }
                | ServiceRequest::FirmwareRead { .. }
                | ServiceRequest::FirmwareVerify
                | ServiceRequest::FirmwareStart
                | ServiceRequest::TimeSet { .. }
        )
    }
}

/// What a node is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum NodeState {
    /// Application running, nothing queued.
    Idle,
    /// Application running and moving.
    Running,
    /// Application halted (an error or a stop); it needs a reset.
    Stopped,
    /// In the bootloader: no application runs.
    Bootloader,
}

/// Answer to [`ServiceRequest::Status`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Status {
    /// What the node is doing.
    pub state: NodeState,
    /// The node's address ([`UNPAIRED`] until paired).
    pub address: u16,
    /// The node has an address it keeps across restarts.
    pub paired: bool,
    /// The reliable link to the host is established.
    pub link_up: bool,
    /// The node has a clock model ([`ServiceRequest::TimeSet`]).
    pub synced: bool,
    /// Local clock since the node started or was reset, µs.
    pub uptime_us: u64,
    /// The node's own estimate of its clock's drift against the host's,
    /// from the clock exchanges it answered; none before they span a
    /// second.
    pub drift: Option<Drift>,
}

/// How fast a node's clock runs against the host's, as the node measures
/// it from the host's send times (`motet_node::drift`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Drift {
    /// Node µs gained per host second, in thousandths (parts per billion).
    pub ppb: i32,
    /// Host seconds the estimate spans.
    pub span_s: u32,
}

/// Answer to [`ServiceRequest::Info`].
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Info {
    /// Node type (see [`kind`]).
    pub kind: Kind,
    /// Installed firmware.
    pub firmware: Version,
    /// Unique id (from the chip, or made once and persisted).
    pub uid: u64,
    /// The node's address ([`UNPAIRED`] until paired).
    pub address: u16,
    /// Link protocol versions the node speaks.
    pub protocol_min: u16,
    /// The newest link protocol version it speaks.
    pub protocol_max: u16,
    /// Places in the segment queue.
    pub queue_capacity: u16,
    /// Step channels.
    pub channels: u8,
    /// Tool outputs.
    pub tools: u8,
    /// The board the firmware runs on (what a firmware image must name);
    /// empty on a simulated node.
    pub board: Kind,
    /// The fastest step rate a channel reaches, steps/s; 0: no limit (a
    /// simulated node).
    pub max_step_hz: u32,
}

/// Node → host, on the port of the request it answers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ServiceReply {
    /// Done (Identify, PairCancel, Reset, FirmwareBegin, TimeSet).
    Ack,
    /// Refused; nothing changed.
    Error(ServiceError),
    /// No service routine on this port.
    UnknownPort {
        /// The port the request came on.
        port: u8,
    },
    /// Answer to [`ServiceRequest::Status`].
    Status(Status),
    /// Answer to [`ServiceRequest::Info`].
    Info(Info),
    /// The node now has `address`. The host checks that `uid` is the one it
    /// named (SetAddress) and `address` the one it asked for; a node answering
    /// otherwise is not the one the host meant.
    Paired {
        /// The node's unique id.
        uid: u64,
        /// The address it now has.
        address: u16,
    },
    /// A page was written: its `offset` and length echoed for the host to check.
    FirmwareWritten {
        /// The page's offset, as sent.
        offset: u32,
        /// How many bytes were written.
        len: u8,
    },
    /// Answer to [`ServiceRequest::FirmwareRead`]: the bytes at `offset`.
    FirmwareData {
        /// Where the bytes were read, as asked.
        offset: u32,
        /// The bytes (fewer than asked at the image's end).
        data: Vec<u8, PAGE_SIZE>,
    },
    /// The uploaded image checks out; it carries this version.
    FirmwareVerified {
        /// The version in the image's header.
        version: Version,
    },
    /// `t1` echoed; `t2` the node clock when the request arrived, `t3` when
    /// the reply left, µs. With the host's arrival time `t4` this is a
    /// `motet_wire::sync::Exchange`.
    Time {
        /// The host's send time, echoed, µs on the host clock.
        t1: u64,
        /// When the request arrived, µs on the node clock.
        t2: u64,
        /// When the reply left, µs on the node clock.
        t3: u64,
    },
    /// Answer to [`ServiceRequest::Describe`]: part `part` of the node's
    /// description. A node also sends its head (part 0) unasked when it
    /// starts (its announcement).
    Description {
        /// Which part this is, as asked.
        part: u8,
        /// The part.
        data: crate::describe::DescribePart,
    },
}

impl ServiceReply {
    /// Whether this reply is sent when the request was a broadcast: only
    /// replies that carry information; acks and errors from
    /// every node on a bus would bury them.
    pub const fn answers_broadcast(&self) -> bool {
        matches!(
            self,
            ServiceReply::Status(_)
                | ServiceReply::Info(_)
                | ServiceReply::Paired { .. }
                | ServiceReply::Time { .. }
                | ServiceReply::Description { .. }
        )
    }

    /// Sets `t3` of a [`ServiceReply::Time`] to the moment it is sent, for an
    /// endpoint that can stamp closer to the wire than the service handler.
    pub fn stamp_t3(&mut self, now_local_us: u64) {
        if let ServiceReply::Time { t2, t3, .. } = self {
            // Never before the request came: a loop that read its clock
            // before reading the frame (stamped at its arrival, later)
            // sends no sooner than the stamp, and an early t3 only widens
            // what the exchange tells.
            *t3 = now_local_us.max(*t2);
        }
    }
}

/// Why a request was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ServiceError {
    /// The payload is not a request.
    Malformed,
    /// The request belongs to another port (given).
    WrongPort {
        /// The port the request is for.
        port: u8,
    },
    /// An address outside 2..=0xFFEF.
    BadAddress {
        /// The address asked for.
        address: u16,
    },
    /// Pair sent to a node that already has an address (use SetAddress).
    AlreadyPaired,
    /// SetAddress named another node; this node's uid is given.
    WrongUid {
        /// This node's uid.
        uid: u64,
    },
    /// A firmware request without an upload begun.
    NoUpload,
    /// The image does not fit the node's firmware storage.
    TooLarge {
        /// Bytes of firmware storage the node has.
        capacity: u32,
    },
    /// Firmware for another kind of node.
    WrongKind,
    /// A page or read outside the image (or the storage).
    OutOfRange {
        /// The request's offset, bytes.
        offset: u32,
        /// The request's length, bytes.
        len: u32,
    },
    /// A page beyond the bytes written so far: the next one expected is at `expected`.
    OutOfOrder {
        /// The offset of the next page expected, bytes.
        expected: u32,
    },
    /// Verify: fewer bytes written than announced.
    SizeMismatch {
        /// The size `FirmwareBegin` announced, bytes.
        expected: u32,
        /// The bytes written.
        written: u32,
    },
    /// Verify: the written bytes' CRC-32C is not the announced one.
    CrcMismatch {
        /// The CRC-32C `FirmwareBegin` announced.
        expected: u32,
        /// The CRC-32C of what was written.
        actual: u32,
    },
    /// Verify: the image header or payload is bad.
    BadImage(ImageError),
    /// Verify: the image's version is not the one announced.
    VersionMismatch {
        /// The version the image's header carries.
        image: Version,
    },
    /// FirmwareStart before a successful FirmwareVerify.
    NotVerified,
    /// Persistent storage or flash failed.
    Storage,
    /// A clock model that is not finite or whose |skew| ≥ [`MAX_SKEW`].
    BadClock,
    /// Refused while the node has committed motion (segments queued): a
    /// reset, a firmware upload or an address change would lose its
    /// position mid-job. Wait for the job to finish or stop.
    Busy,
    /// The image names another board than the node's, or (format 1) none.
    WrongBoard,
    /// Describe: the description has only `parts` parts.
    NoPart {
        /// Parts the description has.
        parts: u8,
    },
}

impl core::fmt::Display for ServiceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ServiceError::Malformed => f.write_str("malformed service request"),
            ServiceError::WrongPort { port } => write!(f, "request belongs to port {port}"),
            ServiceError::BadAddress { address } => {
                write!(f, "address {address:#06x} is not a node address")
            }
            ServiceError::AlreadyPaired => f.write_str("node already paired"),
            ServiceError::WrongUid { uid } => write!(f, "node uid is {uid:#018x}"),
            ServiceError::NoUpload => f.write_str("no firmware upload begun"),
            ServiceError::TooLarge { capacity } => {
                write!(f, "firmware larger than the node's {capacity} bytes")
            }
            ServiceError::WrongKind => f.write_str("firmware for another kind of node"),
            ServiceError::OutOfRange { offset, len } => {
                write!(f, "{len} bytes at {offset} out of range")
            }
            ServiceError::OutOfOrder { expected } => {
                write!(f, "page out of order, next expected at {expected}")
            }
            ServiceError::SizeMismatch { expected, written } => {
                write!(f, "{written} firmware bytes written, {expected} announced")
            }
            ServiceError::CrcMismatch { expected, actual } => write!(
                f,
                "firmware CRC-32C {actual:#010x}, announced {expected:#010x}"
            ),
            ServiceError::BadImage(e) => write!(f, "{e}"),
            ServiceError::VersionMismatch { image } => {
                write!(f, "image is version {image}, another was announced")
            }
            ServiceError::NotVerified => f.write_str("firmware not verified"),
            ServiceError::Storage => f.write_str("storage failed"),
            ServiceError::BadClock => f.write_str("bad clock model"),
            ServiceError::Busy => f.write_str(
                "the node is moving (it has committed motion); wait for its job to finish or stop",
            ),
            ServiceError::WrongBoard => {
                f.write_str("firmware image built for another board (or naming none)")
            }
            ServiceError::NoPart { parts } => {
                write!(f, "the description has {parts} parts")
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{decode, encode, MAX_MESSAGE};

    fn kind(s: &str) -> Kind {
        let mut k = Kind::new();
        k.push_str(s).unwrap();
        k
    }

    pub(crate) fn requests() -> [ServiceRequest; 15] {
        [
            ServiceRequest::Status,
            ServiceRequest::Identify { ms: u32::MAX },
            ServiceRequest::Info,
            ServiceRequest::Pair { address: 0xFFEF },
            ServiceRequest::PairCancel,
            ServiceRequest::SetAddress {
                uid: u64::MAX,
                address: 7,
            },
            ServiceRequest::Reset,
            ServiceRequest::FirmwareBegin {
                size: u32::MAX,
                crc32c: u32::MAX,
                kind: kind("0123456789abcdef"),
                version: Version {
                    major: u16::MAX,
                    minor: u16::MAX,
                    patch: u16::MAX,
                },
            },
            ServiceRequest::FirmwarePage {
                offset: u32::MAX,
                data: Vec::from_slice(&[0xAB; PAGE_SIZE]).unwrap(),
            },
            ServiceRequest::FirmwareRead {
                offset: 128,
                len: 128,
            },
            ServiceRequest::FirmwareVerify,
            ServiceRequest::FirmwareStart,
            ServiceRequest::TimeGet { t1: u64::MAX },
            ServiceRequest::TimeSet {
                offset: -1e12,
                skew: 1e-4,
            },
            ServiceRequest::Describe {
                uid: Some(u64::MAX),
                part: u8::MAX,
            },
        ]
    }

    fn replies() -> [ServiceReply; 11] {
        [
            ServiceReply::Ack,
            ServiceReply::Error(ServiceError::CrcMismatch {
                expected: u32::MAX,
                actual: u32::MAX,
            }),
            ServiceReply::Error(ServiceError::BadImage(ImageError::UnknownFormat {
                format: 9,
            })),
            ServiceReply::UnknownPort { port: 255 },
            ServiceReply::Status(Status {
                state: NodeState::Bootloader,
                address: 0xFFEF,
                paired: true,
                link_up: true,
                synced: false,
                uptime_us: u64::MAX,
                drift: Some(Drift {
                    ppb: i32::MIN,
                    span_s: u32::MAX,
                }),
            }),
            ServiceReply::Info(Info {
                kind: kind("0123456789abcdef"),
                firmware: Version {
                    major: u16::MAX,
                    minor: u16::MAX,
                    patch: u16::MAX,
                },
                uid: u64::MAX,
                address: u16::MAX,
                protocol_min: u16::MAX,
                protocol_max: u16::MAX,
                queue_capacity: u16::MAX,
                channels: 255,
                tools: 255,
                board: kind("0123456789abcdef"),
                max_step_hz: u32::MAX,
            }),
            ServiceReply::Paired {
                uid: u64::MAX,
                address: 0xFFEF,
            },
            ServiceReply::FirmwareWritten {
                offset: u32::MAX,
                len: 128,
            },
            ServiceReply::FirmwareData {
                offset: u32::MAX,
                data: Vec::from_slice(&[0xCD; PAGE_SIZE]).unwrap(),
            },
            ServiceReply::FirmwareVerified {
                version: Version::default(),
            },
            ServiceReply::Time {
                t1: u64::MAX,
                t2: u64::MAX,
                t3: u64::MAX,
            },
        ]
    }

    #[test]
    fn round_trip_and_fit() {
        let mut buf = [0u8; MAX_MESSAGE];
        for m in requests() {
            let bytes = encode(&m, &mut buf).unwrap();
            assert_eq!(decode::<ServiceRequest>(bytes).unwrap(), m);
        }
        for m in replies() {
            let bytes = encode(&m, &mut buf).unwrap();
            assert_eq!(decode::<ServiceReply>(bytes).unwrap(), m);
        }
    }

    #[test]
    fn every_request_has_a_service_port() {
        let ports: [u8; 15] = requests().map(|r| r.port());
        assert_eq!(ports, [1, 2, 3, 4, 4, 4, 5, 6, 6, 6, 6, 6, 7, 7, 8]);
    }

    #[test]
    fn node_addresses() {
        for (a, ok) in [
            (0, false),
            (1, false),
            (2, true),
            (0xFFEF, true),
            (0xFFF0, false),
            (0xFFFF, false),
        ] {
            assert_eq!(is_node_address(a), ok, "{a:#x}");
        }
    }

    #[test]
    fn stamp_t3_only_touches_time() {
        let mut t = ServiceReply::Time {
            t1: 1,
            t2: 2,
            t3: 2,
        };
        t.stamp_t3(9);
        assert_eq!(
            t,
            ServiceReply::Time {
                t1: 1,
                t2: 2,
                t3: 9
            }
        );
        let mut a = ServiceReply::Ack;
        a.stamp_t3(9);
        assert_eq!(a, ServiceReply::Ack);
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..300)) {
            let _ = decode::<ServiceRequest>(&bytes);
            let _ = decode::<ServiceReply>(&bytes);
        }
    }
}
