//! The base service routines: each request against each node state, pairing
//! on a shared medium, firmware upload, the clock exchange, and arbitrary
//! payloads.

use motet_node::{Action, Handled, NodeConfig, Persisted, RamFlash, RamStore, Services};
use motet_wire::frame::{crc32c, BROADCAST};
use motet_wire::image::{self, ImageError, MIN_HEADER_LEN};
use motet_wire::service::{
    port, Info, Kind, NodeState, ServiceError, ServiceReply, ServiceRequest, Status, Version,
    PAGE_SIZE,
};
use motet_wire::sync::{ClockSync, Exchange, SyncConfig};
use motet_wire::{encode, MAX_MESSAGE};
use proptest::prelude::*;

const UID: u64 = 0x1234_5678_9abc_def0;
const OTHER_UID: u64 = 0x0bad_cafe;
const ADDR: u16 = 5;
const START_US: u64 = 1_000;
const NOW: u64 = 2_000_000;
const FLASH: usize = 4096;
const V1: Version = Version {
    major: 1,
    minor: 0,
    patch: 0,
};
const V2: Version = Version {
    major: 1,
    minor: 1,
    patch: 3,
};

type Svc = Services<RamStore, RamFlash<FLASH>>;

fn kind(s: &str) -> Kind {
    let mut k = Kind::new();
    k.push_str(s).unwrap();
    k
}

fn cfg(uid: u64) -> NodeConfig {
    NodeConfig {
        kind: kind("stepper"),
        uid,
        firmware: V1,
        protocol_min: 1,
        protocol_max: 1,
        queue_capacity: 64,
        channels: 4,
        tools: 2,
        board: None,
        max_step_hz: 0,
    }
}

fn unpaired(uid: u64) -> Svc {
    Services::new(cfg(uid), RamStore::default(), RamFlash::new(), START_US)
}

fn paired(uid: u64, address: u16) -> Svc {
    let store = RamStore {
        record: Some(Persisted {
            uid,
            address,
            firmware: V1,
        }),
        saves: 0,
    };
    Services::new(cfg(uid), store, RamFlash::new(), START_US)
}

fn bytes<T: serde::Serialize>(m: &T) -> Vec<u8> {
    let mut buf = [0u8; 256];
    encode(m, &mut buf).unwrap().to_vec()
}

fn request(s: &mut Svc, r: &ServiceRequest, broadcast: bool) -> Handled {
    s.handle(r.port(), &bytes(r), broadcast, NOW)
}

fn firmware_image(kind: &str, version: Version, payload_len: usize) -> Vec<u8> {
    board_image(kind, None, version, payload_len)
}

fn board_image(kind: &str, board: Option<&str>, version: Version, payload_len: usize) -> Vec<u8> {
    let payload: Vec<u8> = (0..payload_len).map(|i| (i * 7 + 3) as u8).collect();
    let mut out = vec![0u8; image::MAX_HEADER_LEN + payload_len];
    let n = image::build(kind, board, version, &payload, &mut out).unwrap();
    out.truncate(n);
    out
}

fn begin(img: &[u8], version: Version) -> ServiceRequest {
    ServiceRequest::FirmwareBegin {
        size: img.len() as u32,
        crc32c: crc32c(img),
        kind: kind("stepper"),
        version,
    }
}

fn page(offset: usize, data: &[u8]) -> ServiceRequest {
    ServiceRequest::FirmwarePage {
        offset: offset as u32,
        data: heapless::Vec::from_slice(data).unwrap(),
    }
}

/// Sends every page of `img` in order and checks each echo.
fn upload(s: &mut Svc, img: &[u8]) {
    for (i, chunk) in img.chunks(PAGE_SIZE).enumerate() {
        let h = request(s, &page(i * PAGE_SIZE, chunk), false);
        assert_eq!(
            h.reply,
            Some(ServiceReply::FirmwareWritten {
                offset: (i * PAGE_SIZE) as u32,
                len: chunk.len() as u8
            })
        );
    }
}

/// Everything observable about a node's services.
#[derive(Clone, Debug, PartialEq)]
struct Snap {
    status: Status,
    info: Info,
    pairing: bool,
    blinking: bool,
    clock: Option<(u64, u64)>,
    record: Option<Persisted>,
    flash_crc: u32,
}

fn snap(s: &Svc) -> Snap {
    Snap {
        status: s.status(NOW),
        info: s.info(),
        pairing: s.pairing(),
        blinking: s.blinking(NOW),
        clock: s
            .clock_model()
            .map(|m| (m.offset.to_bits(), m.skew.to_bits())),
        record: s.store().record,
        flash_crc: crc32c(s.flash().bytes()),
    }
}

#[derive(Clone, Copy, Debug)]
enum Start {
    Unpaired,
    Paired,
    /// Paired, an upload of a 300-byte-payload image begun.
    Uploading,
    /// Paired, a V2 image uploaded and verified.
    Verified,
    /// Paired, the motion node has committed segments.
    Moving,
}

fn start(st: Start) -> Svc {
    match st {
        Start::Unpaired => unpaired(UID),
        Start::Paired => paired(UID, ADDR),
        Start::Moving => {
            let mut s = paired(UID, ADDR);
            s.set_state(NodeState::Running);
            s
        }
        Start::Uploading | Start::Verified => {
            let mut s = paired(UID, ADDR);
            let img = firmware_image("stepper", V2, 300);
            assert_eq!(
                request(&mut s, &begin(&img, V2), false).reply,
                Some(ServiceReply::Ack)
            );
            if let Start::Verified = st {
                upload(&mut s, &img);
                assert_eq!(
                    request(&mut s, &ServiceRequest::FirmwareVerify, false).reply,
                    Some(ServiceReply::FirmwareVerified { version: V2 })
                );
            }
            s
        }
    }
}

fn err(e: ServiceError) -> Option<ServiceReply> {
    Some(ServiceReply::Error(e))
}

struct Row {
    start: Start,
    port: u8,
    payload: Vec<u8>,
    broadcast: bool,
    reply: Option<ServiceReply>,
    action: Action,
    /// Applied to the snapshot before the request to give the one after.
    change: fn(&mut Snap),
}

fn same(_: &mut Snap) {}

fn row(
    start: Start,
    r: ServiceRequest,
    broadcast: bool,
    reply: Option<ServiceReply>,
    action: Action,
    change: fn(&mut Snap),
) -> Row {
    Row {
        start,
        port: r.port(),
        payload: bytes(&r),
        broadcast,
        reply,
        action,
        change,
    }
}

fn raw(
    start: Start,
    port: u8,
    payload: &[u8],
    broadcast: bool,
    reply: Option<ServiceReply>,
) -> Row {
    Row {
        start,
        port,
        payload: payload.to_vec(),
        broadcast,
        reply,
        action: Action::None,
        change: same,
    }
}

#[test]
fn requests_against_states() {
    use Action as A;
    use ServiceRequest as R;
    use Start::*;
    let uni = false;
    let bc = true;
    let status = |state, address, paired| {
        Some(ServiceReply::Status(Status {
            state,
            address,
            paired,
            link_up: false,
            synced: false,
            uptime_us: NOW - START_US,
            drift: None,
        }))
    };
    let info = |address| {
        Some(ServiceReply::Info(Info {
            kind: kind("stepper"),
            firmware: V1,
            uid: UID,
            address,
            protocol_min: 1,
            protocol_max: 1,
            queue_capacity: 64,
            channels: 4,
            tools: 2,
            board: Kind::new(),
            max_step_hz: 0,
        }))
    };
    let img = firmware_image("stepper", V2, 300);
    let rows = vec![
        // status
        row(
            Paired,
            R::Status,
            uni,
            status(NodeState::Idle, ADDR, true),
            A::None,
            same,
        ),
        row(
            Unpaired,
            R::Status,
            bc,
            status(NodeState::Idle, 0, false),
            A::None,
            same,
        ),
        row(Unpaired, R::Status, uni, None, A::None, same),
        row(
            Uploading,
            R::Status,
            uni,
            status(NodeState::Bootloader, ADDR, true),
            A::None,
            same,
        ),
        // identify
        row(
            Paired,
            R::Identify { ms: 500 },
            uni,
            Some(ServiceReply::Ack),
            A::None,
            |s| s.blinking = true,
        ),
        row(Unpaired, R::Identify { ms: 500 }, bc, None, A::None, |s| {
            s.blinking = true
        }),
        row(
            Paired,
            R::Identify { ms: 0 },
            uni,
            Some(ServiceReply::Ack),
            A::None,
            same,
        ),
        // info
        row(Paired, R::Info, uni, info(ADDR), A::None, same),
        row(Unpaired, R::Info, bc, info(0), A::None, same),
        // pairing
        row(Unpaired, R::Pair { address: 7 }, bc, None, A::None, |s| {
            s.pairing = true;
            s.blinking = true;
        }),
        row(Paired, R::Pair { address: 7 }, bc, None, A::None, same),
        row(
            Paired,
            R::Pair { address: 7 },
            uni,
            err(ServiceError::AlreadyPaired),
            A::None,
            same,
        ),
        row(Unpaired, R::Pair { address: 1 }, bc, None, A::None, same),
        row(
            Unpaired,
            R::Pair { address: 0xFFF0 },
            bc,
            None,
            A::None,
            same,
        ),
        row(
            Paired,
            R::PairCancel,
            uni,
            Some(ServiceReply::Ack),
            A::None,
            same,
        ),
        row(
            Paired,
            R::SetAddress {
                uid: UID,
                address: 9,
            },
            uni,
            Some(ServiceReply::Paired {
                uid: UID,
                address: 9,
            }),
            A::AddressChanged(9),
            |s| {
                s.status.address = 9;
                s.info.address = 9;
                s.record.as_mut().unwrap().address = 9;
            },
        ),
        row(
            Unpaired,
            R::SetAddress {
                uid: UID,
                address: 9,
            },
            uni,
            Some(ServiceReply::Paired {
                uid: UID,
                address: 9,
            }),
            A::AddressChanged(9),
            |s| {
                s.status.address = 9;
                s.status.paired = true;
                s.info.address = 9;
                s.record.as_mut().unwrap().address = 9;
            },
        ),
        row(
            Paired,
            R::SetAddress {
                uid: UID,
                address: ADDR,
            },
            uni,
            Some(ServiceReply::Paired {
                uid: UID,
                address: ADDR,
            }),
            A::None,
            same,
        ),
        row(
            Unpaired,
            R::SetAddress {
                uid: OTHER_UID,
                address: 9,
            },
            bc,
            None,
            A::None,
            same,
        ),
        row(
            Unpaired,
            R::SetAddress {
                uid: OTHER_UID,
                address: 9,
            },
            uni,
            None,
            A::None,
            same,
        ),
        row(
            Paired,
            R::SetAddress {
                uid: OTHER_UID,
                address: 9,
            },
            uni,
            err(ServiceError::WrongUid { uid: UID }),
            A::None,
            same,
        ),
        row(
            Paired,
            R::SetAddress {
                uid: UID,
                address: 0,
            },
            uni,
            err(ServiceError::BadAddress { address: 0 }),
            A::None,
            same,
        ),
        row(
            Paired,
            R::SetAddress {
                uid: UID,
                address: 1,
            },
            uni,
            err(ServiceError::BadAddress { address: 1 }),
            A::None,
            same,
        ),
        row(
            Paired,
            R::SetAddress {
                uid: UID,
                address: 0xFFF0,
            },
            uni,
            err(ServiceError::BadAddress { address: 0xFFF0 }),
            A::None,
            same,
        ),
        row(
            Unpaired,
            R::SetAddress {
                uid: UID,
                address: BROADCAST,
            },
            bc,
            None,
            A::None,
            same,
        ),
        // reset
        row(
            Paired,
            R::Reset,
            uni,
            Some(ServiceReply::Ack),
            A::Reset,
            |s| s.status.uptime_us = 0,
        ),
        row(
            Uploading,
            R::Reset,
            uni,
            Some(ServiceReply::Ack),
            A::Reset,
            |s| {
                s.status.uptime_us = 0;
                s.status.state = NodeState::Idle;
            },
        ),
        row(Paired, R::Reset, bc, None, A::Reset, |s| {
            s.status.uptime_us = 0
        }),
        // firmware
        row(
            Paired,
            begin(&img, V2),
            uni,
            Some(ServiceReply::Ack),
            A::EnterBootloader,
            |s| s.status.state = NodeState::Bootloader,
        ),
        row(
            Uploading,
            begin(&img, V2),
            uni,
            Some(ServiceReply::Ack),
            A::None,
            same,
        ),
        row(Paired, begin(&img, V2), bc, None, A::None, same),
        row(
            Paired,
            R::FirmwareBegin {
                size: 100,
                crc32c: 0,
                kind: kind("laser"),
                version: V2,
            },
            uni,
            err(ServiceError::WrongKind),
            A::None,
            same,
        ),
        row(
            Paired,
            R::FirmwareBegin {
                size: FLASH as u32 + 1,
                crc32c: 0,
                kind: kind("stepper"),
                version: V2,
            },
            uni,
            err(ServiceError::TooLarge {
                capacity: FLASH as u32,
            }),
            A::None,
            same,
        ),
        row(
            Paired,
            R::FirmwareBegin {
                size: 10,
                crc32c: 0,
                kind: kind("stepper"),
                version: V2,
            },
            uni,
            err(ServiceError::BadImage(ImageError::Truncated)),
            A::None,
            same,
        ),
        row(
            Paired,
            page(0, &[1, 2, 3]),
            uni,
            err(ServiceError::NoUpload),
            A::None,
            same,
        ),
        row(
            Uploading,
            page(128, &[1; 128]),
            uni,
            err(ServiceError::OutOfOrder { expected: 0 }),
            A::None,
            same,
        ),
        row(
            Uploading,
            page(0, &[0; 3]),
            uni,
            Some(ServiceReply::FirmwareWritten { offset: 0, len: 3 }),
            A::None,
            |s| {
                let mut f = [0xFFu8; FLASH];
                f[..3].fill(0);
                s.flash_crc = crc32c(&f);
            },
        ),
        row(
            Verified,
            page(256, &[0; 128]),
            uni,
            err(ServiceError::OutOfRange {
                offset: 256,
                len: 128,
            }),
            A::None,
            same,
        ),
        row(
            Paired,
            R::FirmwareVerify,
            uni,
            err(ServiceError::NoUpload),
            A::None,
            same,
        ),
        row(
            Uploading,
            R::FirmwareVerify,
            uni,
            err(ServiceError::SizeMismatch {
                expected: img.len() as u32,
                written: 0,
            }),
            A::None,
            same,
        ),
        row(
            Paired,
            R::FirmwareStart,
            uni,
            err(ServiceError::NoUpload),
            A::None,
            same,
        ),
        row(
            Uploading,
            R::FirmwareStart,
            uni,
            err(ServiceError::NotVerified),
            A::None,
            same,
        ),
        row(Verified, R::FirmwareStart, bc, None, A::None, same),
        row(
            Verified,
            R::FirmwareStart,
            uni,
            Some(ServiceReply::Ack),
            A::StartApplication,
            |s| {
                s.status.state = NodeState::Idle;
                s.info.firmware = V2;
                s.record.as_mut().unwrap().firmware = V2;
            },
        ),
        row(
            Paired,
            R::FirmwareRead {
                offset: FLASH as u32 - 1,
                len: 2,
            },
            uni,
            err(ServiceError::OutOfRange {
                offset: FLASH as u32 - 1,
                len: 2,
            }),
            A::None,
            same,
        ),
        row(
            Paired,
            R::FirmwareRead {
                offset: 0,
                len: 129,
            },
            uni,
            err(ServiceError::OutOfRange {
                offset: 0,
                len: 129,
            }),
            A::None,
            same,
        ),
        row(
            Verified,
            R::FirmwareRead { offset: 2, len: 3 },
            uni,
            Some(ServiceReply::FirmwareData {
                offset: 2,
                data: heapless::Vec::from_slice(&img[2..5]).unwrap(),
            }),
            A::None,
            same,
        ),
        // time
        row(
            Paired,
            R::TimeGet { t1: 42 },
            uni,
            Some(ServiceReply::Time {
                t1: 42,
                t2: NOW,
                t3: NOW,
            }),
            A::None,
            same,
        ),
        row(
            Unpaired,
            R::TimeGet { t1: 42 },
            bc,
            Some(ServiceReply::Time {
                t1: 42,
                t2: NOW,
                t3: NOW,
            }),
            A::None,
            same,
        ),
        row(
            Paired,
            R::TimeSet {
                offset: 100.0,
                skew: 1e-4,
            },
            uni,
            Some(ServiceReply::Ack),
            A::None,
            |s| {
                s.status.synced = true;
                s.clock = Some((100f64.to_bits(), 1e-4f64.to_bits()));
            },
        ),
        row(
            Paired,
            R::TimeSet {
                offset: 100.0,
                skew: 1e-4,
            },
            bc,
            None,
            A::None,
            same,
        ),
        row(
            Paired,
            R::TimeSet {
                offset: f64::NAN,
                skew: 0.0,
            },
            uni,
            err(ServiceError::BadClock),
            A::None,
            same,
        ),
        row(
            Paired,
            R::TimeSet {
                offset: 0.0,
                skew: 0.5,
            },
            uni,
            err(ServiceError::BadClock),
            A::None,
            same,
        ),
        row(
            Paired,
            R::TimeSet {
                offset: 0.0,
                skew: f64::INFINITY,
            },
            uni,
            err(ServiceError::BadClock),
            A::None,
            same,
        ),
        // ports and payloads
        raw(
            Paired,
            9,
            &[0],
            uni,
            Some(ServiceReply::UnknownPort { port: 9 }),
        ),
        raw(
            Paired,
            0,
            &[0],
            uni,
            Some(ServiceReply::UnknownPort { port: 0 }),
        ),
        raw(
            Paired,
            10,
            &[7],
            uni,
            Some(ServiceReply::UnknownPort { port: 10 }),
        ),
        raw(
            Paired,
            255,
            &[],
            uni,
            Some(ServiceReply::UnknownPort { port: 255 }),
        ),
        raw(Unpaired, 9, &[0], bc, None),
        raw(Paired, port::STATUS, &[], uni, err(ServiceError::Malformed)),
        raw(
            Paired,
            port::STATUS,
            &[0xFF],
            uni,
            err(ServiceError::Malformed),
        ),
        raw(
            Paired,
            port::STATUS,
            &[0, 0],
            uni,
            err(ServiceError::Malformed),
        ),
        raw(
            Paired,
            port::IDENTIFY,
            &bytes(&R::Status),
            uni,
            err(ServiceError::WrongPort { port: 1 }),
        ),
        raw(
            Paired,
            port::TIME,
            &bytes(&R::Reset),
            uni,
            err(ServiceError::WrongPort { port: 5 }),
        ),
        raw(Paired, port::RESET, &bytes(&R::Reset), bc, None)
            .with(A::Reset, |s| s.status.uptime_us = 0),
        // A node with committed motion keeps its position: whatever would
        // lose it (reset, bootloader, a new address) waits until it is at rest.
        row(
            Moving,
            R::Status,
            uni,
            status(NodeState::Running, ADDR, true),
            A::None,
            same,
        ),
        row(
            Moving,
            R::Reset,
            uni,
            err(ServiceError::Busy),
            A::None,
            same,
        ),
        row(
            Moving,
            begin(&img, V2),
            uni,
            err(ServiceError::Busy),
            A::None,
            same,
        ),
        row(
            Moving,
            R::SetAddress {
                uid: UID,
                address: ADDR + 1,
            },
            uni,
            err(ServiceError::Busy),
            A::None,
            same,
        ),
        // The same address again changes nothing: answered.
        row(
            Moving,
            R::SetAddress {
                uid: UID,
                address: ADDR,
            },
            uni,
            Some(ServiceReply::Paired {
                uid: UID,
                address: ADDR,
            }),
            A::None,
            same,
        ),
        row(
            Moving,
            R::Identify { ms: 500 },
            uni,
            Some(ServiceReply::Ack),
            A::None,
            |s| s.blinking = true,
        ),
    ];
    for (i, r) in rows.into_iter().enumerate() {
        let mut s = start(r.start);
        let mut want = snap(&s);
        let h = s.handle(r.port, &r.payload, r.broadcast, NOW);
        // Reset restarts uptime at NOW; compare it at NOW.
        (r.change)(&mut want);
        assert_eq!(h.reply, r.reply, "row {i}: reply");
        assert_eq!(h.action, r.action, "row {i}: action");
        assert_eq!(snap(&s), want, "row {i}: state");
        if let Some(reply) = &h.reply {
            let mut buf = [0u8; MAX_MESSAGE];
            assert!(
                h.encode(&mut buf).unwrap().is_some(),
                "row {i}: {reply:?} fits"
            );
        }
    }
}

impl Row {
    fn with(mut self, action: Action, change: fn(&mut Snap)) -> Row {
        self.action = action;
        self.change = change;
        self
    }
}

/// A shared medium: every node sees every frame and keeps those for its
/// address or a broadcast, as an endpoint does.
fn deliver(nodes: &mut [Svc], dst: u16, r: &ServiceRequest) -> Vec<(usize, u16, ServiceReply)> {
    let payload = bytes(r);
    let mut replies = Vec::new();
    for (i, n) in nodes.iter_mut().enumerate() {
        let from_broadcast = dst == BROADCAST;
        if !from_broadcast && dst != n.address() {
            continue;
        }
        let src = n.address();
        let h = n.handle(r.port(), &payload, from_broadcast, NOW);
        if let Some(reply) = h.reply {
            replies.push((i, src, reply));
        }
    }
    replies
}

#[test]
fn pairing_three_nodes_on_one_bus() {
    let uids = [0x11, 0x22, 0x33];
    let mut nodes: Vec<Svc> = uids.iter().map(|&u| unpaired(u)).collect();

    // Scan: every unpaired node answers from address 0 with its own uid.
    let scan = deliver(&mut nodes, BROADCAST, &ServiceRequest::Info);
    let seen: Vec<(u16, u64)> = scan
        .iter()
        .map(|(_, src, r)| match r {
            ServiceReply::Info(i) => (*src, i.uid),
            other => panic!("scan reply {other:?}"),
        })
        .collect();
    assert_eq!(seen, vec![(0, 0x11), (0, 0x22), (0, 0x33)]);

    // A unicast to address 0 reaches every unpaired node and none answers.
    assert!(deliver(&mut nodes, 0, &ServiceRequest::Status).is_empty());

    assert!(deliver(&mut nodes, BROADCAST, &ServiceRequest::Pair { address: 7 }).is_empty());
    assert!(nodes.iter().all(|n| n.blinking(NOW) && n.pairing()));

    let h = nodes[1].press_button(NOW).unwrap();
    assert_eq!(
        h.reply,
        Some(ServiceReply::Paired {
            uid: 0x22,
            address: 7
        })
    );
    assert_eq!(h.action, Action::AddressChanged(7));

    assert!(deliver(&mut nodes, BROADCAST, &ServiceRequest::PairCancel).is_empty());
    for (i, n) in nodes.iter_mut().enumerate() {
        assert!(!n.blinking(NOW), "node {i} still blinking");
        assert!(
            n.press_button(NOW).is_none(),
            "node {i} paired after cancel"
        );
    }
    let addresses: Vec<u16> = nodes.iter().map(|n| n.address()).collect();
    assert_eq!(addresses, vec![0, 7, 0]);
    assert_eq!(nodes[1].store().record.unwrap().address, 7);
    assert_eq!(nodes[0].store().record.unwrap().address, 0);

    // The paired node now answers at its address; a second round skips it.
    let st = deliver(&mut nodes, 7, &ServiceRequest::Status);
    assert!(
        matches!(st.as_slice(), [(1, 7, ServiceReply::Status(s))] if s.paired && s.address == 7)
    );
    deliver(&mut nodes, BROADCAST, &ServiceRequest::Pair { address: 8 });
    assert!(!nodes[1].pairing());
    assert_eq!(
        nodes[2].press_button(NOW).unwrap().reply,
        Some(ServiceReply::Paired {
            uid: 0x33,
            address: 8
        })
    );
    deliver(&mut nodes, BROADCAST, &ServiceRequest::PairCancel);

    // Restarted from their stores, the nodes keep their addresses.
    let restarted: Vec<u16> = nodes
        .iter()
        .map(|n| Services::new(cfg(0), n.store().clone(), RamFlash::<FLASH>::new(), 0))
        .map(|n: Svc| n.address())
        .collect();
    assert_eq!(restarted, vec![0, 7, 8]);
}

#[test]
fn set_address_names_one_node_by_uid() {
    let mut nodes: Vec<Svc> = [0x11, 0x22].iter().map(|&u| unpaired(u)).collect();
    let r = deliver(
        &mut nodes,
        BROADCAST,
        &ServiceRequest::SetAddress {
            uid: 0x22,
            address: 300,
        },
    );
    assert_eq!(
        r,
        vec![(
            1,
            0,
            ServiceReply::Paired {
                uid: 0x22,
                address: 300
            }
        )]
    );
    assert_eq!(nodes[0].address(), 0);
    assert_eq!(nodes[1].address(), 300);
}

#[test]
fn firmware_upload_installs_the_new_version() {
    let img = firmware_image("stepper", V2, 1000);
    let mut s = paired(UID, ADDR);
    let h = request(&mut s, &begin(&img, V2), false);
    assert_eq!(h.action, Action::EnterBootloader);
    assert_eq!(s.status(NOW).state, NodeState::Bootloader);
    upload(&mut s, &img);
    // Read-back of every page.
    for (i, chunk) in img.chunks(PAGE_SIZE).enumerate() {
        let off = (i * PAGE_SIZE) as u32;
        let r = request(
            &mut s,
            &ServiceRequest::FirmwareRead {
                offset: off,
                len: chunk.len() as u8,
            },
            false,
        );
        assert_eq!(
            r.reply,
            Some(ServiceReply::FirmwareData {
                offset: off,
                data: heapless::Vec::from_slice(chunk).unwrap()
            })
        );
    }
    assert_eq!(s.info().firmware, V1, "nothing installed before start");
    assert_eq!(
        request(&mut s, &ServiceRequest::FirmwareVerify, false).reply,
        Some(ServiceReply::FirmwareVerified { version: V2 })
    );
    let h = request(&mut s, &ServiceRequest::FirmwareStart, false);
    assert_eq!(
        (h.reply, h.action),
        (Some(ServiceReply::Ack), Action::StartApplication)
    );
    assert_eq!(s.info().firmware, V2);
    assert_eq!(s.status(NOW).state, NodeState::Idle);
    // A second start has no upload to start.
    assert_eq!(
        request(&mut s, &ServiceRequest::FirmwareStart, false).reply,
        err(ServiceError::NoUpload)
    );
    let again: Svc = Services::new(cfg(UID), s.store().clone(), RamFlash::new(), 0);
    assert_eq!(again.info().firmware, V2);
}

/// A board takes only images naming it; a simulated node (no board) takes
/// any (it runs none of them).
#[test]
fn a_board_refuses_images_for_other_boards() {
    // (node's board, image's board, verify's answer)
    let cases = [
        (Some("mps2-an500"), Some("mps2-an500"), Ok(())),
        (
            Some("mps2-an500"),
            Some("teensy41"),
            Err(ServiceError::WrongBoard),
        ),
        (Some("mps2-an500"), None, Err(ServiceError::WrongBoard)),
        (None, Some("teensy41"), Ok(())),
        (None, None, Ok(())),
    ];
    for (node, img_board, want) in cases {
        let c = NodeConfig {
            board: node.map(kind),
            ..cfg(UID)
        };
        let mut s: Svc = Services::new(c, RamStore::default(), RamFlash::new(), START_US);
        request(
            &mut s,
            &ServiceRequest::SetAddress {
                uid: UID,
                address: ADDR,
            },
            false,
        );
        let img = board_image("stepper", img_board, V2, 700);
        request(&mut s, &begin(&img, V2), false);
        upload(&mut s, &img);
        let got = request(&mut s, &ServiceRequest::FirmwareVerify, false).reply;
        let want = match want {
            Ok(()) => Some(ServiceReply::FirmwareVerified { version: V2 }),
            Err(e) => err(e),
        };
        assert_eq!(got, want, "{node:?} {img_board:?}");
        assert_eq!(s.info().board.as_str(), node.unwrap_or(""));
    }
}

#[test]
fn a_resent_page_is_written_again() {
    let img = firmware_image("stepper", V2, 400);
    let mut s = paired(UID, ADDR);
    request(&mut s, &begin(&img, V2), false);
    upload(&mut s, &img[..256]);
    // The second page again (a retry), then the rest.
    let h = request(&mut s, &page(128, &img[128..256]), false);
    assert!(matches!(
        h.reply,
        Some(ServiceReply::FirmwareWritten {
            offset: 128,
            len: 128
        })
    ));
    for off in (256..img.len()).step_by(PAGE_SIZE) {
        let end = (off + PAGE_SIZE).min(img.len());
        request(&mut s, &page(off, &img[off..end]), false);
    }
    assert_eq!(
        request(&mut s, &ServiceRequest::FirmwareVerify, false).reply,
        Some(ServiceReply::FirmwareVerified { version: V2 })
    );
}

/// How an upload goes wrong, and the error verify must give.
/// A way to upload, named, with the error verify must give after it.
type BadUpload = (&'static str, Box<dyn Fn(&mut Svc)>, ServiceError);

fn bad_uploads() -> Vec<BadUpload> {
    let good = firmware_image("stepper", V2, 500);
    let g = good.clone();
    let corrupt_page = move |s: &mut Svc| {
        request(s, &begin(&g, V2), false);
        let mut bad = g.clone();
        bad[200] ^= 0x10;
        upload(s, &bad);
    };
    let g = good.clone();
    let flash_bit = move |s: &mut Svc| {
        request(s, &begin(&g, V2), false);
        upload(s, &g);
        s.flash_mut().bytes_mut()[300] ^= 1;
    };
    let g = good.clone();
    let short = move |s: &mut Svc| {
        request(s, &begin(&g, V2), false);
        upload(s, &g[..384]);
    };
    let laser = firmware_image("laser", V2, 500);
    let l = laser.clone();
    let wrong_kind = move |s: &mut Svc| {
        request(s, &begin(&l, V2), false);
        upload(s, &l);
    };
    // Announced CRC matches what was sent, but the payload was damaged before
    // the host computed it: only the image's own CRC catches it.
    let mut damaged = good.clone();
    damaged[MIN_HEADER_LEN + 10] ^= 0xFF;
    let d = damaged.clone();
    let damaged_payload = move |s: &mut Svc| {
        request(s, &begin(&d, V2), false);
        upload(s, &d);
    };
    let g = good.clone();
    let wrong_version = move |s: &mut Svc| {
        request(s, &begin(&g, V1), false);
        upload(s, &g);
    };
    let mut trailing = good.clone();
    trailing.extend_from_slice(&[0; 20]);
    let t = trailing.clone();
    let too_long = move |s: &mut Svc| {
        request(s, &begin(&t, V2), false);
        upload(s, &t);
    };
    let junk: Vec<u8> = vec![0x5A; 200];
    let j = junk.clone();
    let not_an_image = move |s: &mut Svc| {
        request(s, &begin(&j, V2), false);
        upload(s, &j);
    };
    // A header announcing no payload: nothing to install.
    let mut empty = good[..MIN_HEADER_LEN].to_vec();
    empty[28..32].copy_from_slice(&0u32.to_le_bytes());
    empty[32..36].copy_from_slice(&crc32c(&[]).to_le_bytes());
    let e = empty.clone();
    let empty_payload = move |s: &mut Svc| {
        request(s, &begin(&e, V2), false);
        upload(s, &e);
    };
    let mut bad_bit = good.clone();
    bad_bit[200] ^= 0x10;
    vec![
        (
            "empty payload",
            Box::new(empty_payload) as Box<dyn Fn(&mut Svc)>,
            ServiceError::BadImage(ImageError::EmptyPayload),
        ),
        (
            "corrupted page",
            Box::new(corrupt_page),
            ServiceError::CrcMismatch {
                expected: crc32c(&good),
                actual: crc32c(&bad_bit),
            },
        ),
        (
            "flash bit flip",
            Box::new(flash_bit),
            ServiceError::CrcMismatch {
                expected: crc32c(&good),
                actual: {
                    let mut b = good.clone();
                    b[300] ^= 1;
                    crc32c(&b)
                },
            },
        ),
        (
            "short",
            Box::new(short),
            ServiceError::SizeMismatch {
                expected: good.len() as u32,
                written: 384,
            },
        ),
        ("wrong kind", Box::new(wrong_kind), ServiceError::WrongKind),
        (
            "damaged payload",
            Box::new(damaged_payload),
            ServiceError::BadImage(ImageError::CrcMismatch {
                expected: crc32c(&good[MIN_HEADER_LEN..]),
                actual: crc32c(&damaged[MIN_HEADER_LEN..]),
            }),
        ),
        (
            "wrong version",
            Box::new(wrong_version),
            ServiceError::VersionMismatch { image: V2 },
        ),
        (
            "trailing bytes",
            Box::new(too_long),
            ServiceError::BadImage(ImageError::TrailingBytes),
        ),
        (
            "not an image",
            Box::new(not_an_image),
            ServiceError::BadImage(ImageError::BadMagic),
        ),
    ]
}

#[test]
fn bad_firmware_is_refused_and_the_old_version_stays() {
    for (name, go, want) in bad_uploads() {
        let mut s = paired(UID, ADDR);
        go(&mut s);
        assert_eq!(
            request(&mut s, &ServiceRequest::FirmwareVerify, false).reply,
            err(want),
            "{name}"
        );
        assert_eq!(
            request(&mut s, &ServiceRequest::FirmwareStart, false).reply,
            err(ServiceError::NotVerified),
            "{name}"
        );
        assert_eq!(s.info().firmware, V1, "{name}");
        assert_eq!(s.store().record.unwrap().firmware, V1, "{name}");
        assert_eq!(s.status(NOW).state, NodeState::Bootloader, "{name}");
        let h = request(&mut s, &ServiceRequest::Reset, false);
        assert_eq!(h.action, Action::Reset, "{name}");
        assert_eq!(
            s.status(NOW).state,
            NodeState::Idle,
            "{name}: the old application runs"
        );
        assert_eq!(s.info().firmware, V1, "{name}");
    }
}

#[test]
fn a_page_after_verify_needs_a_new_verify() {
    let mut s = start(Start::Verified);
    let img = firmware_image("stepper", V2, 300);
    request(&mut s, &page(0, &img[..128]), false);
    assert_eq!(
        request(&mut s, &ServiceRequest::FirmwareStart, false).reply,
        err(ServiceError::NotVerified)
    );
}

/// A node clock `local = offset + (1 + skew)·host`, exchanges with fixed
/// delays and jitter; the model the host sends back must turn the node's
/// local clock into host time.
#[test]
fn time_exchange_gives_the_node_host_time() {
    let true_offset = -3_456_789.0;
    let true_skew = 120e-6;
    let local_at = |host: f64| true_offset + (1.0 + true_skew) * host + 5e6;
    // Host clock starts later than the node's, so local values stay positive.
    let mut s = paired(UID, ADDR);
    let mut sync = ClockSync::new(SyncConfig::default());
    let mut rng = 0x2545_f491_4f6c_dd1du64;
    let mut jitter = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng % 400) as f64
    };
    let mut host = 10_000_000.0;
    for _ in 0..3000 {
        let t1 = host as u64;
        let arrive = t1 as f64 + 80.0 + jitter();
        let t2_local = local_at(arrive).floor() as u64;
        let req = ServiceRequest::TimeGet { t1 };
        let mut h = s.handle(port::TIME, &bytes(&req), true, t2_local);
        let leave = arrive + 30.0;
        h.reply
            .as_mut()
            .unwrap()
            .stamp_t3(local_at(leave).floor() as u64);
        let Some(ServiceReply::Time { t1: e1, t2, t3 }) = h.reply else {
            panic!("{:?}", h.reply)
        };
        assert_eq!((e1, t2), (t1, t2_local));
        let t4 = (leave + 80.0 + jitter()) as u64;
        sync.add(Exchange { t1, t2, t3, t4 })
            .expect("a sound clock");
        host += 10_000.0;
    }
    assert!(!s.synced());
    let m = sync.model();
    let set = ServiceRequest::TimeSet {
        offset: m.offset,
        skew: m.skew,
    };
    assert_eq!(
        s.handle(port::TIME, &bytes(&set), false, 0).reply,
        Some(ServiceReply::Ack)
    );
    assert!(s.status(NOW).synced);
    for host in [host, host + 1e6, host + 5e6] {
        let local = local_at(host);
        let got = s.host_time(local).unwrap();
        assert!((got - host).abs() < 20.0, "host {host}: node says {got}");
        assert!((s.local_time(host).unwrap() - local).abs() < 20.0);
    }
}

fn arb_request() -> impl Strategy<Value = ServiceRequest> {
    let kind = prop_oneof![Just("stepper"), Just("laser"), Just("")].prop_map(kind);
    let version = (0u16..3, 0u16..3, 0u16..3).prop_map(|(major, minor, patch)| Version {
        major,
        minor,
        patch,
    });
    prop_oneof![
        Just(ServiceRequest::Status),
        any::<u32>().prop_map(|ms| ServiceRequest::Identify { ms }),
        Just(ServiceRequest::Info),
        any::<u16>().prop_map(|address| ServiceRequest::Pair { address }),
        Just(ServiceRequest::PairCancel),
        (prop_oneof![Just(UID), any::<u64>()], any::<u16>())
            .prop_map(|(uid, address)| ServiceRequest::SetAddress { uid, address }),
        Just(ServiceRequest::Reset),
        (
            prop_oneof![0u32..600, any::<u32>()],
            any::<u32>(),
            kind,
            version
        )
            .prop_map(
                |(size, crc32c, kind, version)| ServiceRequest::FirmwareBegin {
                    size,
                    crc32c,
                    kind,
                    version
                }
            ),
        (
            prop_oneof![0u32..700, any::<u32>()],
            proptest::collection::vec(any::<u8>(), 0..=PAGE_SIZE)
        )
            .prop_map(|(offset, d)| page(offset as usize, &d)),
        (prop_oneof![0u32..5000, any::<u32>()], any::<u8>())
            .prop_map(|(offset, len)| ServiceRequest::FirmwareRead { offset, len }),
        Just(ServiceRequest::FirmwareVerify),
        Just(ServiceRequest::FirmwareStart),
        any::<u64>().prop_map(|t1| ServiceRequest::TimeGet { t1 }),
        (any::<f64>(), any::<f64>())
            .prop_map(|(offset, skew)| ServiceRequest::TimeSet { offset, skew }),
    ]
}

fn arb_start() -> impl Strategy<Value = Start> {
    prop_oneof![
        Just(Start::Unpaired),
        Just(Start::Paired),
        Just(Start::Uploading),
        Just(Start::Verified),
        Just(Start::Moving)
    ]
}

fn check_refusal_changes_nothing(
    s: &mut Svc,
    port: u8,
    payload: &[u8],
    broadcast: bool,
) -> Result<(), TestCaseError> {
    let before = snap(s);
    let h = s.handle(port, payload, broadcast, NOW);
    let mut buf = [0u8; MAX_MESSAGE];
    prop_assert!(h.encode(&mut buf).is_ok(), "reply too long: {:?}", h.reply);
    if matches!(
        h.reply,
        Some(ServiceReply::Error(_) | ServiceReply::UnknownPort { .. })
    ) {
        prop_assert_eq!(snap(s), before, "refused {:?} changed state", h.reply);
        prop_assert_eq!(h.action, Action::None);
    }
    if broadcast {
        prop_assert!(h.reply.as_ref().is_none_or(ServiceReply::answers_broadcast));
    }
    Ok(())
}

proptest! {
    #[test]
    fn arbitrary_payloads_on_every_port(
        st in arb_start(),
        port in 0u8..=12,
        variant in 0u8..16,
        tail in proptest::collection::vec(any::<u8>(), 0..200),
        broadcast in any::<bool>(),
    ) {
        let mut s = start(st);
        let mut payload = vec![variant];
        payload.extend(tail);
        check_refusal_changes_nothing(&mut s, port, &payload, broadcast)?;
    }

    #[test]
    fn arbitrary_requests_in_sequence(
        st in arb_start(),
        reqs in proptest::collection::vec((arb_request(), any::<bool>(), any::<bool>()), 1..12),
    ) {
        let mut s = start(st);
        for (r, broadcast, wrong_port) in reqs {
            let port = if wrong_port { (r.port() % 7) + 1 } else { r.port() };
            check_refusal_changes_nothing(&mut s, port, &bytes(&r), broadcast)?;
            if r == ServiceRequest::FirmwareStart && s.info().firmware != V1 {
                prop_assert!(!s.in_bootloader());
            }
        }
    }
}

/// A store that loads a record but cannot save.
#[derive(Clone)]
struct ReadOnlyStore(Option<Persisted>);

impl motet_node::Store for ReadOnlyStore {
    fn load(&mut self) -> Option<Persisted> {
        self.0
    }
    fn save(&mut self, _: &Persisted) -> Result<(), motet_node::StorageError> {
        Err(motet_node::StorageError::Device)
    }
}

#[test]
fn storage_failures_change_nothing() {
    let mut s = Services::new(cfg(UID), ReadOnlyStore(None), RamFlash::<FLASH>::new(), 0);
    assert_eq!(s.uid(), UID, "works unpaired in RAM without a store");
    s.handle(
        port::ADDRESS,
        &bytes(&ServiceRequest::Pair { address: 7 }),
        true,
        0,
    );
    let h = s.press_button(0).unwrap();
    assert_eq!(h.reply, err(ServiceError::Storage));
    assert_eq!(h.action, Action::None);
    assert_eq!(s.address(), 0);
    assert!(s.pairing(), "a second press may still succeed");

    let rec = Persisted {
        uid: UID,
        address: ADDR,
        firmware: V1,
    };
    let mut s = Services::new(
        cfg(UID),
        ReadOnlyStore(Some(rec)),
        RamFlash::<FLASH>::new(),
        0,
    );
    let set = ServiceRequest::SetAddress {
        uid: UID,
        address: 9,
    };
    assert_eq!(
        s.handle(port::ADDRESS, &bytes(&set), false, 0).reply,
        err(ServiceError::Storage)
    );
    assert_eq!(s.address(), ADDR);
    let img = firmware_image("stepper", V2, 200);
    let mut send = |r: &ServiceRequest| s.handle(r.port(), &bytes(r), false, 0).reply;
    send(&begin(&img, V2));
    for (i, c) in img.chunks(PAGE_SIZE).enumerate() {
        send(&page(i * PAGE_SIZE, c));
    }
    assert_eq!(
        send(&ServiceRequest::FirmwareVerify),
        Some(ServiceReply::FirmwareVerified { version: V2 })
    );
    assert_eq!(
        send(&ServiceRequest::FirmwareStart),
        err(ServiceError::Storage)
    );
    assert_eq!(s.firmware(), V1);
    assert!(s.in_bootloader());
}
