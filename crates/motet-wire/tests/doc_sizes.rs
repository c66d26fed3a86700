//! The byte counts docs/wire.md gives for messages and frames.

use motet_wire::frame::{self, Flags, Header, MAX_FRAME, OVERHEAD};
use motet_wire::{encode, HostMessage, NodeMessage, Refusal};

fn len<T: serde::Serialize>(m: &T) -> usize {
    let mut buf = [0u8; 256];
    encode(m, &mut buf).unwrap().len()
}

#[test]
fn documented_sizes() {
    let ev = HostMessage::Event {
        track: 1,
        time: 99.5,
        value: 0.25,
    };
    let mut buf = [0u8; 64];
    assert_eq!(
        encode(&ev, &mut buf).unwrap(),
        &[5, 1, 0, 0, 0, 0, 0, 0xe0, 0x58, 0x40, 0, 0, 0x80, 0x3e]
    );
    let host: [(HostMessage, usize); 7] = [
        (
            HostMessage::ConfigureStream(motet_wire::StreamConfig::default()),
            26,
        ),
        (
            HostMessage::Segments(motet_wire::SegmentBatch {
                bytes: heapless::Vec::from_slice(&[0; motet_wire::stream::BATCH_BYTES]).unwrap(),
            }),
            192,
        ),
        (HostMessage::Reset, 1),
        (HostMessage::Status, 1),
        (HostMessage::SetPosition { position: [1.0; 6] }, 49),
        (
            HostMessage::EventPerSpeed {
                track: 0,
                time: 1.0,
                value: 1.0,
                feed: 1.0,
            },
            18,
        ),
        (
            HostMessage::GraphParam {
                component: 1,
                param: 2,
                value: 3.0,
            },
            11,
        ),
    ];
    for (m, n) in host {
        assert_eq!(len(&m), n, "{m:?}");
    }
    let node = [
        (
            NodeMessage::Status {
                segment_space: 0,
                event_space: 0,
                next_seq: 0,
                underruns: 0,
            },
            5,
        ),
        (
            NodeMessage::Status {
                segment_space: u16::MAX,
                event_space: u16::MAX,
                next_seq: u32::MAX,
                underruns: u32::MAX,
            },
            17,
        ),
        (
            NodeMessage::Refused {
                reason: Refusal::QueueFull,
            },
            2,
        ),
        (
            NodeMessage::Refused {
                reason: Refusal::OutOfOrder {
                    expected: u32::MAX,
                    got: u32::MAX,
                },
            },
            12,
        ),
    ];
    for (m, n) in node {
        assert_eq!(len(&m), n, "{m:?}");
    }
    // The event in a frame: 14 + 16 bytes.
    let h = Header {
        dst: 2,
        src: 1,
        port: 10,
        flags: Flags::DATA | Flags::ACK,
        seq: 1,
        ack: 1,
    };
    let mut out = [0u8; MAX_FRAME];
    let payload = encode(&ev, &mut buf).unwrap().to_vec();
    assert_eq!(
        frame::encode(&h, &payload, &mut out).unwrap(),
        14 + OVERHEAD
    );
    assert_eq!(OVERHEAD, 16);
}
