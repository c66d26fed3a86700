//! The byte counts docs/wire.md gives for a module's description on port 8.

use motet_wire::describe::{
    Channel, ChannelSpec, DescribePart, Description, HeaterChannel, Identity, JointAxis, Limits,
    ModuleKind, Placement, ServoGains, ToolKind, IDENTITY_HTM,
};
use motet_wire::encode;
use motet_wire::service::{ServiceReply, ServiceRequest};

fn len<T: serde::Serialize>(m: &T) -> usize {
    let mut buf = [0u8; 256];
    encode(m, &mut buf).unwrap().len()
}

fn reply(part: u8, data: DescribePart) -> usize {
    len(&ServiceReply::Description { part, data })
}

fn channel(spec: ChannelSpec) -> usize {
    reply(
        4,
        DescribePart::Channel(Channel {
            drives: "joint".try_into().unwrap(),
            spec,
        }),
    )
}

#[test]
fn documented_sizes() {
    let mut buf = [0u8; 64];
    assert_eq!(
        encode(&ServiceRequest::Describe { uid: None, part: 0 }, &mut buf).unwrap(),
        &[0x0e, 0x00, 0x00]
    );
    assert_eq!(
        len(&ServiceRequest::Describe {
            uid: Some(u64::MAX),
            part: 4
        }),
        13
    );
    let x = Description {
        kind: ModuleKind::StepperAxis,
        described: true,
        identity: Identity {
            name: "x".try_into().unwrap(),
            model: "MRMT base module".try_into().unwrap(),
            hardware: heapless::String::new(),
        },
        placement: Placement {
            htm: IDENTITY_HTM,
            joint: JointAxis::X,
        },
        limits: Limits::default(),
        channels: heapless::Vec::new(),
    };
    let head = |uid| reply(0, DescribePart::Head(x.head(uid)));
    // Reply, part, variant, kind, uid, parts, digest, described.
    let d = digest_len(x.digest());
    assert_eq!((head(0), head(u64::MAX)), (6 + 1 + d, 6 + 10 + d));
    assert_eq!(reply(1, DescribePart::Identity(x.identity.clone())), 23);
    assert_eq!(reply(2, DescribePart::Placement(x.placement)), 68);
    assert_eq!(reply(3, DescribePart::Limits(x.limits)), 31);
    let step = ChannelSpec::Step {
        lead: 5.0,
        ratio: 1.0,
        step_angle: 1.8,
        microstep: 8,
        invert: false,
        max_step_hz: 100_000,
    };
    assert_eq!(channel(step), 27);
    let servo = ChannelSpec::Servo {
        lead: 5.0,
        ratio: 1.0,
        encoder_lines: 1000,
        invert: false,
        gains: ServoGains {
            rate_hz: 10_000,
            following_limit: 40,
            ..Default::default()
        },
    };
    assert_eq!(channel(servo), 52);
    let tool = ChannelSpec::Tool {
        tool: ToolKind::Spindle,
        max: 24000.0,
        settle: 1.0,
    };
    assert_eq!(channel(tool), 19);
    let heater = ChannelSpec::Heater {
        channel: HeaterChannel::Hotend(0),
        max_c: 275.0,
        time_constant: 20.0,
    };
    assert_eq!(channel(heater), 20);
}

fn digest_len(d: u32) -> usize {
    let mut n = 1;
    let mut v = d >> 7;
    while v > 0 {
        n += 1;
        v >>= 7;
    }
    n
}
