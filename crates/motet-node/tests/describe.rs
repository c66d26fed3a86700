//! The description service (port 8): every part of a module's description,
//! the board's default before one is given, who answers when (paired,
//! unpaired, broadcast, another uid), and the announcement a node sends
//! when it starts.

use motet_node::endpoint::Endpoint;
use motet_node::{NodeConfig, Persisted, RamFlash, RamStore, Services};
use motet_wire::describe::{
    Assembler, Channel, ChannelSpec, DescribePart, Description, Identity, JointAxis, Limits,
    ModuleKind, Placement, IDENTITY_HTM,
};
use motet_wire::frame::{self, Flags, Header, BROADCAST, MAX_FRAME, MAX_RAW};
use motet_wire::service::{port, Kind, ServiceError, ServiceReply, ServiceRequest, Version};
use motet_wire::{decode, encode};

const UID: u64 = 0x00c0_ffee_0000_0042;
const OTHER: u64 = 0x0bad;

fn cfg() -> NodeConfig {
    NodeConfig {
        kind: Kind::try_from("stepper").unwrap(),
        uid: UID,
        firmware: Version::default(),
        protocol_min: 1,
        protocol_max: 1,
        queue_capacity: 64,
        channels: 2,
        tools: 1,
        board: Kind::try_from("teensy41").ok(),
        max_step_hz: 400_000,
    }
}

fn store(address: Option<u16>) -> RamStore {
    RamStore {
        record: address.map(|address| Persisted {
            uid: UID,
            address,
            firmware: Version::default(),
        }),
        saves: 0,
    }
}

type Svc = Services<RamStore, RamFlash<256>>;

fn services(address: Option<u16>) -> Svc {
    Services::new(cfg(), store(address), RamFlash::new(), 0)
}

fn x_axis() -> Description {
    let mut htm = IDENTITY_HTM;
    htm[11] = -111.0;
    let mut channels = heapless::Vec::new();
    channels
        .push(Channel {
            drives: "joint".try_into().unwrap(),
            spec: ChannelSpec::Step {
                lead: 5.0,
                ratio: 1.0,
                step_angle: 1.8,
                microstep: 16,
                invert: false,
                max_step_hz: 100_000,
            },
        })
        .unwrap();
    Description {
        kind: ModuleKind::StepperAxis,
        described: true,
        identity: Identity {
            name: "x".try_into().unwrap(),
            model: "rail 300".try_into().unwrap(),
            hardware: "rev 1".try_into().unwrap(),
        },
        placement: Placement {
            htm,
            joint: JointAxis::X,
        },
        limits: Limits {
            max_velocity: 40.0,
            max_acceleration: 400.0,
            travel: [0.0, 300.0],
            resolution: 0.01,
            accuracy: 0.05,
            home: 0.0,
        },
        channels,
    }
}

fn ask(s: &mut Svc, uid: Option<u64>, part: u8, broadcast: bool) -> Option<ServiceReply> {
    let mut buf = [0u8; 64];
    let req = ServiceRequest::Describe { uid, part };
    let bytes = encode(&req, &mut buf).unwrap();
    s.handle(port::DESCRIBE, bytes, broadcast, 1000).reply
}

/// The whole description, read a part at a time as a host does.
fn read_all(s: &mut Svc, uid: Option<u64>, broadcast: bool) -> Description {
    let Some(ServiceReply::Description {
        part: 0,
        data: DescribePart::Head(head),
    }) = ask(s, uid, 0, broadcast)
    else {
        panic!("no head")
    };
    assert_eq!(head.uid, UID);
    let mut a = Assembler::new(head).unwrap();
    for i in 1..head.parts {
        match ask(s, uid, i, broadcast) {
            Some(ServiceReply::Description { part, data }) if part == i => a.take(i, data).unwrap(),
            other => panic!("part {i}: {other:?}"),
        }
    }
    a.finish().unwrap()
}

#[test]
fn a_node_serves_the_description_it_was_given_part_by_part() {
    let mut s = services(Some(5));
    let d = x_axis();
    s.set_description(d.clone());
    for (uid, broadcast) in [(None, false), (Some(UID), false), (None, true)] {
        assert_eq!(read_all(&mut s, uid, broadcast), d, "{uid:?} {broadcast}");
    }
    assert_eq!(
        ask(&mut s, None, d.parts(), false),
        Some(ServiceReply::Error(ServiceError::NoPart {
            parts: d.parts()
        }))
    );
}

#[test]
fn before_one_is_given_a_board_describes_its_channels() {
    let mut s = services(Some(5));
    let d = read_all(&mut s, None, false);
    assert_eq!(
        d,
        Description::default_for("stepper", "teensy41", 2, 1, 400_000)
    );
    assert!(!d.described);
}

#[test]
fn who_answers() {
    let mut s = services(Some(5));
    // Another node named: an error unicast, silence on a broadcast.
    assert_eq!(
        ask(&mut s, Some(OTHER), 0, false),
        Some(ServiceReply::Error(ServiceError::WrongUid { uid: UID }))
    );
    assert_eq!(ask(&mut s, Some(OTHER), 0, true), None);
    // An unpaired node answers a unicast only when it names its uid (the
    // frame reached every unpaired node on the medium), and any broadcast.
    let mut u = services(None);
    assert_eq!(ask(&mut u, None, 0, false), None);
    assert_eq!(ask(&mut u, Some(OTHER), 0, false), None);
    assert!(matches!(
        ask(&mut u, Some(UID), 0, false),
        Some(ServiceReply::Description {
            part: 0,
            data: DescribePart::Head(_)
        })
    ));
    assert!(matches!(
        ask(&mut u, None, 3, true),
        Some(ServiceReply::Description {
            part: 3,
            data: DescribePart::Limits(_)
        })
    ));
    // A Describe on another port is refused there.
    assert_eq!(
        u.handle(port::INFO, &[14, 0, 0], true, 0).reply,
        None,
        "a broadcast refusal is silent"
    );
    let mut p = services(Some(5));
    let wrong = p.handle(port::INFO, &[14, 0, 0], false, 0).reply;
    assert_eq!(
        wrong,
        Some(ServiceReply::Error(ServiceError::WrongPort {
            port: port::DESCRIBE
        }))
    );
}

#[test]
fn a_node_announces_its_head_when_it_starts() {
    let mut ep: Endpoint<RamStore, RamFlash<256>, 8> =
        Endpoint::new(cfg(), store(Some(7)), RamFlash::new(), 0);
    ep.set_description(x_axis());
    let mut out = [0u8; MAX_FRAME];
    assert!(
        ep.transmit(0, &mut out).is_none(),
        "nothing before it announces"
    );
    ep.announce();
    let sent = ep.transmit(0, &mut out).expect("the announcement").to_vec();
    let mut raw = [0u8; MAX_RAW];
    let f = frame::decode(&sent, &mut raw).unwrap();
    assert_eq!(
        (f.header.dst, f.header.src, f.header.port, f.header.flags),
        (1, 7, port::DESCRIBE, Flags::NONE)
    );
    assert_eq!(
        decode::<ServiceReply>(f.payload).unwrap(),
        ServiceReply::Description {
            part: 0,
            data: DescribePart::Head(x_axis().head(UID))
        }
    );
    // And it answers a broadcast describe from the host as a datagram.
    let mut buf = [0u8; 64];
    let req = encode(&ServiceRequest::Describe { uid: None, part: 1 }, &mut buf).unwrap();
    let h = Header {
        dst: BROADCAST,
        src: 1,
        port: port::DESCRIBE,
        flags: Flags::NONE,
        seq: 0,
        ack: 0,
    };
    let mut fr = [0u8; MAX_FRAME];
    let n = frame::encode(&h, req, &mut fr).unwrap();
    ep.on_frame(&fr[..n], 10);
    let sent = ep.transmit(10, &mut out).expect("the identity").to_vec();
    let f = frame::decode(&sent, &mut raw).unwrap();
    assert!(matches!(
        decode::<ServiceReply>(f.payload).unwrap(),
        ServiceReply::Description { part: 1, data: DescribePart::Identity(Identity { name, .. }) } if name == "x"
    ));
}
