//! A module's description in parts: every part fits one reply and round
//! trips, the parts in any order give the description back, parts out of
//! place or from another description are refused, the digest follows every
//! part, and a board's default lists its channels undescribed.

use heapless::{String, Vec};
use motet_wire::describe::*;
use motet_wire::service::{ServiceReply, ServiceRequest};
use motet_wire::{decode, encode, MAX_MESSAGE};

/// `s` cut to the capacity of `String<N>`.
fn short<const N: usize>(s: &str) -> String<N> {
    let mut out = String::new();
    for c in s.chars() {
        if out.push(c).is_err() {
            break;
        }
    }
    out
}
fn label(s: &str) -> Label {
    short(s)
}

/// The widest description: every part at its largest.
fn widest() -> Description {
    let gains = ServoGains {
        rate_hz: u32::MAX,
        kp: f32::MAX,
        ki: f32::MIN,
        kd: 1.5,
        kv: 2.5,
        ka: 3.5,
        integral_limit: 0.3,
        output_limit: 1.0,
        following_limit: u32::MAX,
    };
    let mut channels = Vec::new();
    for _ in 0..MAX_MODULE_CHANNELS {
        channels
            .push(Channel {
                drives: label("0123456789abcdef"),
                spec: ChannelSpec::Servo {
                    lead: 5.0,
                    ratio: 3.0,
                    encoder_lines: u32::MAX,
                    invert: true,
                    gains,
                },
            })
            .unwrap();
    }
    Description {
        kind: ModuleKind::ServoAxis,
        described: true,
        identity: Identity {
            name: short("0123456789abcdef"),
            model: short("0123456789abcdef0123456789abcdef"),
            hardware: label("0123456789abcdef"),
        },
        placement: Placement {
            htm: [f32::MAX; 16],
            joint: JointAxis::NegZ,
        },
        limits: Limits {
            max_velocity: f32::MAX,
            max_acceleration: f32::MAX,
            travel: [f32::MIN, f32::MAX],
            resolution: 1.0,
            accuracy: 1.0,
            home: 0.0,
        },
        channels,
    }
}

#[test]
fn every_part_fits_one_reply_and_round_trips() {
    let d = widest();
    let mut buf = [0u8; MAX_MESSAGE];
    for i in 0..d.parts() {
        let reply = ServiceReply::Description {
            part: i,
            data: d.part(u64::MAX, i).unwrap(),
        };
        let bytes = encode(&reply, &mut buf).unwrap();
        assert!(
            bytes.len() <= MAX_MESSAGE,
            "part {i}: {} bytes",
            bytes.len()
        );
        assert_eq!(decode::<ServiceReply>(bytes).unwrap(), reply);
    }
    assert_eq!(d.part(1, d.parts()), None);
    let req = ServiceRequest::Describe {
        uid: Some(u64::MAX),
        part: 255,
    };
    assert_eq!(
        decode::<ServiceRequest>(encode(&req, &mut buf).unwrap()).unwrap(),
        req
    );
}

#[test]
fn parts_in_any_order_give_the_description_back() {
    let d = widest();
    let head = d.head(7);
    let mut a = Assembler::new(head).unwrap();
    for i in (1..d.parts()).rev() {
        assert_eq!(a.missing(), Some(1));
        a.take(i, d.part(7, i).unwrap()).unwrap();
    }
    assert_eq!(a.missing(), None);
    assert_eq!(a.finish().unwrap(), d);
}

#[test]
fn parts_out_of_place_or_from_another_description_are_refused() {
    let d = widest();
    let mut a = Assembler::new(d.head(7)).unwrap();
    // Limits where the placement goes, a channel where the limits go.
    assert_eq!(
        a.take(2, d.part(7, 3).unwrap()),
        Err(DescribeError::WrongPart { index: 2 })
    );
    assert_eq!(
        a.take(3, d.part(7, 4).unwrap()),
        Err(DescribeError::WrongPart { index: 3 })
    );
    assert_eq!(
        a.take(d.parts(), d.part(7, 4).unwrap()),
        Err(DescribeError::WrongPart { index: d.parts() })
    );
    assert_eq!(a.finish(), Err(DescribeError::Missing { index: 1 }));
    // Every part, but the limits of another description.
    for i in 1..d.parts() {
        a.take(i, d.part(7, i).unwrap()).unwrap();
    }
    let mut other = d.limits;
    other.home = 1.0;
    a.take(3, DescribePart::Limits(other)).unwrap();
    assert!(matches!(a.finish(), Err(DescribeError::Digest { .. })));
    for parts in [0, 3, FIXED_PARTS + MAX_MODULE_CHANNELS as u8 + 1] {
        let h = Head { parts, ..d.head(7) };
        assert_eq!(
            Assembler::new(h).err(),
            Some(DescribeError::BadHead { parts })
        );
    }
}

#[test]
fn the_digest_follows_every_part_and_the_kind() {
    let d = widest();
    let base = d.digest();
    let mut changed = Vec::<Description, 8>::new();
    let mut c = d.clone();
    c.identity.name = short("x");
    changed.push(c).unwrap();
    let mut c = d.clone();
    c.placement.htm[3] = 1.0;
    changed.push(c).unwrap();
    let mut c = d.clone();
    c.limits.travel[1] = 1.0;
    changed.push(c).unwrap();
    let mut c = d.clone();
    c.channels.pop();
    changed.push(c).unwrap();
    let mut c = d.clone();
    c.kind = ModuleKind::Rotary;
    changed.push(c).unwrap();
    let mut c = d.clone();
    c.described = false;
    changed.push(c).unwrap();
    for c in &changed {
        assert_ne!(c.digest(), base, "{c:?}");
    }
    assert_eq!(d.head(1).digest, d.head(2).digest);
}

#[test]
fn a_boards_default_lists_its_channels_undescribed() {
    let d = Description::default_for("stepper", "teensy41", 3, 2, 500_000);
    assert!(!d.described);
    assert_eq!(d.kind, ModuleKind::StepperAxis);
    assert_eq!(d.channels.len(), 5);
    assert_eq!(d.channels[4].drives.as_str(), "output 1");
    assert!(matches!(
        d.channels[0].spec,
        ChannelSpec::Step {
            max_step_hz: 500_000,
            ..
        }
    ));
    let many = Description::default_for("sim", "", 8, 4, 0);
    assert_eq!(many.channels.len(), MAX_MODULE_CHANNELS);
    assert_eq!(
        Description::default_for("x", "", 0, 1, 0).kind,
        ModuleKind::Tool
    );
}

#[test]
fn names_parse_back() {
    for k in ModuleKind::ALL {
        assert_eq!(ModuleKind::parse(k.name()), Some(k));
    }
    for a in JointAxis::ALL {
        assert_eq!(JointAxis::parse(a.name()), Some(a));
    }
    for t in ToolKind::ALL {
        assert_eq!(ToolKind::parse(t.name()), Some(t));
    }
    assert_eq!(ModuleKind::parse("conveyor"), None);
}

proptest::proptest! {
    #[test]
    fn arbitrary_bytes_never_panic_the_parts(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..200)) {
        if let Ok(DescribePart::Head(h)) = decode::<DescribePart>(&bytes) {
            let _ = Assembler::new(h);
        }
    }
}
