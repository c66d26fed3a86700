//! Description files, property-tested: any description written out reads
//! back the same when it holds, and is refused at a line of the file naming
//! a field when it does not; the wire's parts give it back too.

use motet_host::module::check::problems;
use motet_host::module::{description_toml, parse_description};
use motet_wire::describe::{
    Assembler, Channel, ChannelSpec, Description, HeaterChannel, Identity, JointAxis, Limits,
    ModuleKind, Placement, ServoGains, ToolKind,
};
use proptest::prelude::*;

fn f(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => lo..hi,
        1 => Just(0.0f32),
        1 => Just(-1.0f32),
    ]
}

fn spec() -> impl Strategy<Value = ChannelSpec> {
    prop_oneof![
        (
            f(0.5, 20.0),
            f(0.5, 50.0),
            prop_oneof![Just(1.8f32), Just(0.9)],
            1u16..300,
            any::<bool>(),
            0u32..200_000
        )
            .prop_map(
                |(lead, ratio, step_angle, microstep, invert, max_step_hz)| ChannelSpec::Step {
                    lead,
                    ratio,
                    step_angle,
                    microstep,
                    invert,
                    max_step_hz
                }
            ),
        (
            f(0.5, 20.0),
            f(0.5, 5.0),
            1u32..5000,
            any::<bool>(),
            f(-2.0, 2.0),
            0u32..100
        )
            .prop_map(
                |(lead, ratio, encoder_lines, invert, kp, following_limit)| ChannelSpec::Servo {
                    lead,
                    ratio,
                    encoder_lines,
                    invert,
                    gains: ServoGains {
                        rate_hz: 10_000,
                        kp,
                        ki: 0.5,
                        kd: 0.0,
                        kv: 1.0,
                        ka: 0.0,
                        integral_limit: 0.3,
                        output_limit: 1.0,
                        following_limit
                    },
                }
            ),
        (0usize..3, f(0.0, 30_000.0), f(0.0, 2.0)).prop_map(|(k, max, settle)| ChannelSpec::Tool {
            tool: [ToolKind::Spindle, ToolKind::Laser, ToolKind::Pen][k],
            max,
            settle
        }),
        (0u8..3, f(20.0, 400.0), f(0.0, 100.0)).prop_map(|(i, max_c, time_constant)| {
            ChannelSpec::Heater {
                channel: [
                    HeaterChannel::Hotend(i),
                    HeaterChannel::Bed,
                    HeaterChannel::Chamber,
                ][usize::from(i % 3)],
                max_c,
                time_constant,
            }
        }),
        (f(0.0, 1000.0)).prop_map(|rate_hz| ChannelSpec::Sensor {
            quantity: "force".try_into().unwrap(),
            unit: "N".try_into().unwrap(),
            rate_hz
        }),
        Just(ChannelSpec::Input {
            input: "button".try_into().unwrap()
        }),
    ]
}

fn description() -> impl Strategy<Value = Description> {
    (
        0usize..7,
        0usize..6,
        (0usize..4, f(-500.0, 500.0), f(-500.0, 500.0)),
        (
            f(-200.0, 10.0),
            f(0.0, 400.0),
            f(0.1, 200.0),
            f(1.0, 5000.0),
            f(0.001, 0.1),
            f(0.001, 0.5),
            f(-10.0, 300.0),
        ),
        prop::collection::vec(("joint|tool|hotend", spec()), 0..4),
    )
        .prop_map(
            |(kind, joint, (turn, tx, tz), (lo, hi, v, a, res, acc, home), channels)| {
                let kind = ModuleKind::ALL[kind];
                // A quarter turn about z, k times: rigid, and exact in f32.
                let (s, c) = [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0)][turn];
                let htm = [
                    c, -s, 0.0, tx, s, c, 0.0, 0.0, 0.0, 0.0, 1.0, tz, 0.0, 0.0, 0.0, 1.0,
                ];
                let limits = if kind.is_axis() {
                    Limits {
                        max_velocity: v,
                        max_acceleration: a,
                        travel: [lo, hi],
                        resolution: res,
                        accuracy: acc,
                        home,
                    }
                } else {
                    Limits::default()
                };
                let mut list = heapless::Vec::new();
                for (d, s) in channels {
                    let _ = list.push(Channel {
                        drives: d.as_str().try_into().unwrap(),
                        spec: s,
                    });
                }
                Description {
                    kind,
                    described: true,
                    identity: Identity {
                        name: "m1".try_into().unwrap(),
                        model: "a \"quoted\" model".try_into().unwrap(),
                        hardware: heapless::String::new(),
                    },
                    placement: Placement {
                        htm,
                        joint: JointAxis::ALL[joint],
                    },
                    limits,
                    channels: list,
                }
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, .. ProptestConfig::default() })]

    #[test]
    fn written_descriptions_read_back_or_are_refused_where_they_fail(d in description()) {
        let text = description_toml(&d, "");
        let holds = problems(&d).is_empty();
        match parse_description(&text, "p.toml") {
            Ok(back) => {
                prop_assert!(holds, "accepted a description with problems {:?}\n{text}", problems(&d));
                prop_assert_eq!(&back, &d);
            }
            Err(e) => {
                prop_assert!(!holds || e.line > 0, "{e}\n{text}");
                prop_assert!(e.line > 0, "an error with no line: {e}\n{text}");
                prop_assert!(e.to_string().starts_with("p.toml:"), "{e}");
            }
        }
        // And through the wire's parts, in reverse.
        let mut a = Assembler::new(d.head(9)).unwrap();
        for i in (1..d.parts()).rev() {
            a.take(i, d.part(9, i).unwrap()).unwrap();
        }
        prop_assert_eq!(a.finish().unwrap(), d);
    }

    #[test]
    fn arbitrary_text_never_panics(text in "[a-z_=\\[\\]{}\", .0-9\\n-]{0,300}") {
        let _ = parse_description(&text, "t.toml");
    }
}
