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
    let host = [
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
        (
            HostMessage::SegmentsSealed(motet_wire::SegmentBatch {
                bytes: heapless::Vec::from_slice(&[0; motet_wire::stream::BATCH_BYTES]).unwrap(),
            }),
            192,
        ),
        (
            HostMessage::SegmentsSealed(motet_wire::SegmentBatch {
                bytes: heapless::Vec::from_slice(&[0]).unwrap(),
            }),
            3,
        ),
        (HostMessage::Reset, 1),
        (
            HostMessage::ConfigureChannel(motet_wire::ChannelConfig {
                channel: 0,
                map: motet_trajectory::JointMap::polar_radius(0, 1),
                steps_per_unit: 80.0,
                pulse_us: 2.0,
                dir_setup_us: 1.0,
            }),
            24,
        ),
        (
            HostMessage::ConfigureChannel(motet_wire::ChannelConfig {
                channel: 0,
                map: motet_trajectory::KinematicsKind::Delta(motet_trajectory::kinematics::Delta {
                    radius: 100.0,
                    arm: 250.0,
                })
                .joint_map(0, [0, 1, 2]),
                steps_per_unit: 80.0,
                pulse_us: 2.0,
                dir_setup_us: 1.0,
            }),
            40,
        ),
        (
            HostMessage::ConfigureChannel(motet_wire::ChannelConfig {
                channel: 0,
                map: motet_trajectory::KinematicsKind::FiveBar(
                    motet_trajectory::kinematics::FiveBar::new(60.0, 80.0, 80.0, 120.0, 120.0),
                )
                .joint_map(0, [0, 1, 2]),
                steps_per_unit: 80.0,
                pulse_us: 2.0,
                dir_setup_us: 1.0,
            }),
            72,
        ),
        (
            HostMessage::ConfigureChannel(motet_wire::ChannelConfig {
                channel: 0,
                map: motet_trajectory::JointMap::Linear { coeffs: [1.0; 6] },
                steps_per_unit: 80.0,
                pulse_us: 2.0,
                dir_setup_us: 1.0,
            }),
            67,
        ),
        (HostMessage::Windowed { run: 0 }, 2),
        (HostMessage::Windowed { run: u32::MAX }, 6),
        (HostMessage::Where, 1),
        (HostMessage::TallyGet, 1),
        (HostMessage::Seal { next_seq: 0 }, 2),
        (HostMessage::Seal { next_seq: u32::MAX }, 6),
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
    closed_loop_sizes();
    let node = [
        (
            NodeMessage::Status {
                segment_space: 0,
                event_space: 0,
                next_seq: 0,
                underruns: 0,
                committed: 0,
                stopped: false,
                run: 0,
            },
            8,
        ),
        (
            NodeMessage::Status {
                segment_space: u16::MAX,
                event_space: u16::MAX,
                next_seq: u32::MAX,
                underruns: u32::MAX,
                committed: u32::MAX,
                stopped: true,
                run: u32::MAX,
            },
            28,
        ),
        (
            NodeMessage::Position {
                run: u32::MAX,
                committed: u32::MAX,
                stopped: true,
                queued: u16::MAX,
                at: [0.0; 6],
            },
            63,
        ),
        (
            NodeMessage::Tally {
                steps: [0; 8],
                tool_changes: 0,
                hash: 0,
            },
            11,
        ),
        (
            NodeMessage::Tally {
                steps: [u32::MAX; 8],
                tool_changes: u32::MAX,
                hash: u64::MAX,
            },
            56,
        ),
        (
            NodeMessage::Refused {
                reason: Refusal::QueueFull,
            },
            2,
        ),
        (
            NodeMessage::Refused {
                reason: Refusal::TailStarted,
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

mod services {
    use super::len;
    use motet_wire::frame::{self, Flags, Header, MAX_FRAME, OVERHEAD};
    use motet_wire::image::ImageError;
    use motet_wire::service::{
        Info, Kind, NodeState, ServiceError as E, ServiceReply as P, ServiceRequest as R, Status,
        Version, PAGE_SIZE,
    };
    use motet_wire::{encode, MAX_MESSAGE};

    fn kind(n: usize) -> Kind {
        let mut k = Kind::new();
        for _ in 0..n {
            k.push('k').unwrap();
        }
        k
    }

    const VMIN: Version = Version {
        major: 0,
        minor: 0,
        patch: 0,
    };
    const VMAX: Version = Version {
        major: u16::MAX,
        minor: u16::MAX,
        patch: u16::MAX,
    };

    fn data(n: usize) -> heapless::Vec<u8, PAGE_SIZE> {
        heapless::Vec::from_slice(&vec![0xA5; n]).unwrap()
    }

    fn info(k: usize, big: bool) -> Info {
        let (w, b) = if big { (u16::MAX, u64::MAX) } else { (0, 0) };
        Info {
            kind: kind(k),
            firmware: if big { VMAX } else { VMIN },
            uid: b,
            address: w,
            protocol_min: w,
            protocol_max: w,
            queue_capacity: w,
            channels: 255,
            tools: 255,
            board: kind(k),
            max_step_hz: if big { u32::MAX } else { 0 },
        }
    }

    /// The "total" ranges of the service tables: (smallest, largest) of each variant.
    #[test]
    fn documented_service_sizes() {
        let requests: Vec<(R, R, usize, usize)> = vec![
            (R::Status, R::Status, 1, 1),
            (R::Identify { ms: 0 }, R::Identify { ms: u32::MAX }, 2, 6),
            (R::Info, R::Info, 1, 1),
            (R::Pair { address: 2 }, R::Pair { address: 0xFFEF }, 2, 4),
            (R::PairCancel, R::PairCancel, 1, 1),
            (
                R::SetAddress { uid: 0, address: 2 },
                R::SetAddress {
                    uid: u64::MAX,
                    address: 0xFFEF,
                },
                3,
                14,
            ),
            (R::Reset, R::Reset, 1, 1),
            (
                R::FirmwareBegin {
                    size: 0,
                    crc32c: 0,
                    kind: kind(0),
                    version: VMIN,
                },
                R::FirmwareBegin {
                    size: u32::MAX,
                    crc32c: u32::MAX,
                    kind: kind(16),
                    version: VMAX,
                },
                7,
                37,
            ),
            (
                R::FirmwarePage {
                    offset: 0,
                    data: data(0),
                },
                R::FirmwarePage {
                    offset: u32::MAX,
                    data: data(PAGE_SIZE),
                },
                3,
                136,
            ),
            (
                R::FirmwareRead { offset: 0, len: 0 },
                R::FirmwareRead {
                    offset: u32::MAX,
                    len: 128,
                },
                3,
                7,
            ),
            (R::FirmwareVerify, R::FirmwareVerify, 1, 1),
            (R::FirmwareStart, R::FirmwareStart, 1, 1),
            (R::TimeGet { t1: 0 }, R::TimeGet { t1: u64::MAX }, 2, 11),
            (
                R::TimeSet {
                    offset: 0.0,
                    skew: 0.0,
                },
                R::TimeSet {
                    offset: 0.0,
                    skew: 0.0,
                },
                17,
                17,
            ),
        ];
        assert_eq!(requests.len(), 14, "one row per request variant");
        for (lo, hi, a, b) in requests {
            assert_eq!((len(&lo), len(&hi)), (a, b), "{lo:?}");
        }

        let status = |big: bool| Status {
            state: NodeState::Bootloader,
            address: if big { u16::MAX } else { 0 },
            paired: true,
            link_up: true,
            synced: true,
            uptime_us: if big { u64::MAX } else { 0 },
            drift: big.then_some(motet_wire::service::Drift {
                ppb: i32::MIN,
                span_s: u32::MAX,
            }),
        };
        let replies: Vec<(P, P, usize, usize)> = vec![
            (P::Ack, P::Ack, 1, 1),
            (
                P::Error(E::Malformed),
                P::Error(E::BadImage(ImageError::CrcMismatch {
                    expected: u32::MAX,
                    actual: u32::MAX,
                })),
                2,
                13,
            ),
            (
                P::UnknownPort { port: 0 },
                P::UnknownPort { port: 255 },
                2,
                2,
            ),
            (P::Status(status(false)), P::Status(status(true)), 8, 29),
            (P::Info(info(0, false)), P::Info(info(16, true)), 14, 73),
            (
                P::Paired { uid: 0, address: 2 },
                P::Paired {
                    uid: u64::MAX,
                    address: 0xFFEF,
                },
                3,
                14,
            ),
            (
                P::FirmwareWritten { offset: 0, len: 0 },
                P::FirmwareWritten {
                    offset: u32::MAX,
                    len: 128,
                },
                3,
                7,
            ),
            (
                P::FirmwareData {
                    offset: 0,
                    data: data(0),
                },
                P::FirmwareData {
                    offset: u32::MAX,
                    data: data(PAGE_SIZE),
                },
                3,
                136,
            ),
            (
                P::FirmwareVerified { version: VMIN },
                P::FirmwareVerified { version: VMAX },
                4,
                10,
            ),
            (
                P::Time {
                    t1: 0,
                    t2: 0,
                    t3: 0,
                },
                P::Time {
                    t1: u64::MAX,
                    t2: u64::MAX,
                    t3: u64::MAX,
                },
                4,
                31,
            ),
        ];
        assert_eq!(replies.len(), 10, "one row per reply variant");
        for (lo, hi, a, b) in replies {
            assert_eq!((len(&lo), len(&hi)), (a, b), "{lo:?}");
            assert!(b <= MAX_MESSAGE);
        }

        // ServiceError rows, each at its largest (the error's own bytes).
        let errors: [(E, usize); 19] = [
            (E::Malformed, 1),
            (E::WrongPort { port: 255 }, 2),
            (E::BadAddress { address: u16::MAX }, 4),
            (E::AlreadyPaired, 1),
            (E::WrongUid { uid: u64::MAX }, 11),
            (E::NoUpload, 1),
            (E::TooLarge { capacity: u32::MAX }, 6),
            (E::WrongKind, 1),
            (
                E::OutOfRange {
                    offset: u32::MAX,
                    len: u32::MAX,
                },
                11,
            ),
            (E::OutOfOrder { expected: u32::MAX }, 6),
            (
                E::SizeMismatch {
                    expected: u32::MAX,
                    written: u32::MAX,
                },
                11,
            ),
            (
                E::CrcMismatch {
                    expected: u32::MAX,
                    actual: u32::MAX,
                },
                11,
            ),
            (E::BadImage(ImageError::UnknownFormat { format: 9 }), 3),
            (E::VersionMismatch { image: VMAX }, 10),
            (E::NotVerified, 1),
            (E::Storage, 1),
            (E::BadClock, 1),
            (E::Busy, 1),
            (E::WrongBoard, 1),
        ];
        for (e, n) in errors {
            assert_eq!(len(&e), n, "{e:?}");
        }

        // The examples.
        let mut buf = [0u8; 16];
        assert_eq!(
            encode(&R::Pair { address: 7 }, &mut buf).unwrap(),
            &[0x03, 0x07]
        );
        let t = encode(&R::TimeGet { t1: 1000 }, &mut buf).unwrap().to_vec();
        assert_eq!(t, [0x0c, 0xe8, 0x07]);
        let h = Header {
            dst: motet_wire::frame::BROADCAST,
            src: 1,
            port: 7,
            flags: Flags::NONE,
            seq: 0,
            ack: 0,
        };
        let mut out = [0u8; MAX_FRAME];
        assert_eq!(frame::encode(&h, &t, &mut out).unwrap(), 3 + OVERHEAD);
        assert_eq!(OVERHEAD, 16);
    }
}

/// The closed-loop rows of docs/wire.md's message tables.
fn closed_loop_sizes() {
    use motet_wire::control::*;
    let gains = ServoGains {
        kp: 0.01,
        ki: 1.0,
        kd: 1e-4,
        kv: 1e-4,
        ka: 1e-6,
        kf: 0.01,
        integral_limit: 0.3,
        output_limit: 1.0,
        derivative_hz: 0.0,
        lead: 0.0,
    };
    let servo = ServoConfig {
        channel: 0,
        map: motet_trajectory::JointMap::axis(0),
        counts_per_unit: 100.0,
        rate_hz: 10_000.0,
        gains,
        following_limit: 40.0,
    };
    let samples = |n: usize, delta: i32, err: i16| {
        NodeMessage::Samples(SampleBatch {
            source: SampleSource::Servo(1),
            t0: 1e6,
            period_us: 5000.0,
            dropped: 0,
            data: SampleData::Servo {
                base: 0,
                samples: (0..n)
                    .map(|_| ServoSample {
                        delta,
                        error_lo: err,
                        error_hi: err,
                    })
                    .collect(),
            },
        })
    };
    let host = [
        (HostMessage::ConfigureServo(servo), 107),
        (HostMessage::ServoGains { channel: 0, gains }, 42),
        (
            HostMessage::Sampling {
                source: SampleSource::Sensor(0),
                every: 50,
            },
            4,
        ),
        (
            HostMessage::Sampling {
                source: SampleSource::Servo(0),
                every: u32::MAX,
            },
            8,
        ),
        (
            HostMessage::ConfigureSensor(SensorConfig {
                sensor: 0,
                rate_hz: 1000.0,
            }),
            6,
        ),
        (
            HostMessage::ServoTest {
                channel: 0,
                test: ServoTest::Step {
                    duty: 0.2,
                    duration_ms: 100,
                },
            },
            8,
        ),
        (
            HostMessage::ServoTest {
                channel: 0,
                test: ServoTest::Relay {
                    amplitude: 0.2,
                    hysteresis: 2.0,
                    duration_ms: 60_000,
                },
            },
            14,
        ),
    ];
    for (m, n) in host {
        assert_eq!(len(&m), n, "{m:?}");
    }
    let node = [
        (
            NodeMessage::Fault {
                source: SampleSource::Servo(0),
                kind: FaultKind::Following,
                at: 1.0,
                value: 41.0,
            },
            16,
        ),
        (samples(0, 0, 0), 19),
        // A sample as a decimated print's usually is: a 2-byte delta,
        // 1-byte errors.
        (samples(32, 500, 20), 19 + 32 * 4),
        (
            NodeMessage::Samples(SampleBatch {
                source: SampleSource::Sensor(0),
                t0: 1e6,
                period_us: 5000.0,
                dropped: 0,
                data: SampleData::Values((0..40).map(|i| i as f32).collect()),
            }),
            18 + 160,
        ),
    ];
    for (m, n) in node {
        assert_eq!(len(&m), n, "{m:?}");
    }
}
