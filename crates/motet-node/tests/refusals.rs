//! Refusals leave the node untouched, and a Status request reports the queues.

use crate::common;

use common::*;
use motet_node::{Node, NodeStatus};
use motet_planner::Command;
use motet_trajectory::{JointMap, ProfileKind, MAX_AXES};
use motet_wire::{
    decode, AxisSpan, ChannelConfig, HostMessage, NodeMessage, Refusal, SegmentMsg, ToolConfig,
};
use proptest::prelude::*;

fn job() -> Vec<Command> {
    let mut cmds = vec![Command::Tool {
        tool: 0,
        value: 1.0,
    }];
    let turns: Vec<(f64, f64, f64)> = (0..10)
        .map(|i| (35.0, 50.0 + 5.0 * i as f64, 1.0))
        .collect();
    cmds.extend(ring_moves(START, &turns, 110.0));
    cmds.push(Command::Tool {
        tool: 0,
        value: 0.0,
    });
    cmds.extend(ring_moves(
        START,
        &[(-40.0, 90.0, 2.0), (-40.0, 60.0, 1.0)],
        80.0,
    ));
    cmds
}

fn stream() -> Vec<HostMessage> {
    polar().stream(&plan(limits(ProfileKind::SCurve), START, &job()))
}

/// Everything observable about a node's state without running it.
fn snapshot<const Q: usize>(
    node: &mut Node<Q>,
) -> (NodeStatus, Vec<i64>, usize, Option<u64>, Option<u64>) {
    (
        node.status(),
        node.channels().iter().map(|c| c.position()).collect(),
        node.queued(),
        node.front_end().map(f64::to_bits),
        node.next_deadline().map(f64::to_bits),
    )
}

/// Sends `bytes` and checks the refusal and that nothing changed.
fn refuse<const Q: usize>(node: &mut Node<Q>, bytes: &[u8], reason: Refusal, what: &str) {
    let before = snapshot(node);
    assert_eq!(
        node.handle(bytes),
        Some(NodeMessage::Refused { reason }),
        "{what}"
    );
    assert_eq!(
        snapshot(node),
        before,
        "{what}: state changed by a refused message"
    );
}

/// Deterministic garbage.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0 >> 33
    }
    fn garbage(&mut self) -> Vec<u8> {
        let n = (self.next() % 200) as usize;
        (0..n).map(|_| self.next() as u8).collect()
    }
}

fn bad_channels() -> Vec<ChannelConfig> {
    let mut out = Vec::new();
    for spu in [0.0, -0.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        out.push(channel(0, JointMap::axis(0), spu));
    }
    // Maps that name axes a point does not have, or have non-finite coefficients.
    out.push(channel(0, JointMap::polar_radius(MAX_AXES as u8, 1), 40.0));
    out.push(channel(1, JointMap::polar_angle(0, 200), 8.0));
    let mut coeffs = [0.0; MAX_AXES];
    coeffs[1] = f64::NAN;
    out.push(channel(2, JointMap::Linear { coeffs }, 40.0));
    out
}

/// Every kind of bad message a node can get at this point of the stream.
fn inject<const Q: usize>(node: &mut Node<Q>, msgs: &[HostMessage], at: Moment, rng: &mut Lcg) {
    match at {
        Moment::BeforeSend(i) => {
            let msg = &msgs[i];
            let good = bytes(msg);
            for _ in 0..4 {
                let g = rng.garbage();
                if decode::<HostMessage>(&g).is_err() {
                    refuse(node, &g, Refusal::Malformed, "garbage");
                }
            }
            for n in 0..good.len() {
                refuse(
                    node,
                    &good[..n],
                    Refusal::Malformed,
                    &format!("message {i} truncated to {n} bytes"),
                );
            }
            let mut long = good.clone();
            long.push(0);
            refuse(node, &long, Refusal::Malformed, "trailing byte");
            for c in bad_channels() {
                refuse(
                    node,
                    &bytes(&HostMessage::ConfigureChannel(c)),
                    Refusal::BadConfig,
                    &format!("{c:?}"),
                );
            }
            for v in [f64::NAN, f64::INFINITY] {
                let mut p = START;
                p[1] = v;
                refuse(
                    node,
                    &bytes(&HostMessage::SetPosition { position: p }),
                    Refusal::Malformed,
                    &format!("SetPosition {v}"),
                );
                refuse(
                    node,
                    &bytes(&HostMessage::Event {
                        track: 0,
                        time: v,
                        value: 1.0,
                    }),
                    Refusal::Malformed,
                    &format!("event at {v}"),
                );
            }
            refuse(
                node,
                &bytes(&HostMessage::Event {
                    track: 0,
                    time: 5.0,
                    value: f32::NAN,
                }),
                Refusal::Malformed,
                "NaN event value",
            );
            if node.queued() > 0 {
                refuse(
                    node,
                    &bytes(&HostMessage::SetPosition { position: START }),
                    Refusal::NotAtRest,
                    "SetPosition while moving",
                );
                let c = polar().channels[0];
                refuse(
                    node,
                    &bytes(&HostMessage::ConfigureChannel(c)),
                    Refusal::BadConfig,
                    "ConfigureChannel while moving",
                );
            }
            if let HostMessage::Segment(s) = msg {
                for got in [s.seq + 1, s.seq.wrapping_sub(1), s.seq + 1000, u32::MAX] {
                    let m = HostMessage::Segment(SegmentMsg {
                        seq: got,
                        ..s.clone()
                    });
                    refuse(
                        node,
                        &bytes(&m),
                        Refusal::OutOfOrder {
                            expected: s.seq,
                            got,
                        },
                        "wrong seq",
                    );
                }
                let mut bad = vec![
                    SegmentMsg {
                        t0: f64::NAN,
                        ..s.clone()
                    },
                    SegmentMsg {
                        t0: f64::INFINITY,
                        ..s.clone()
                    },
                ];
                let mut p = s.profile;
                p.vc = f64::NAN;
                bad.push(SegmentMsg {
                    profile: p,
                    ..s.clone()
                });
                let mut axes = s.axes.clone();
                axes[0] = AxisSpan {
                    axis: 0,
                    from: f64::NEG_INFINITY,
                    to: 1.0,
                };
                bad.push(SegmentMsg { axes, ..s.clone() });
                let mut axes = s.axes.clone();
                axes[0].axis = MAX_AXES as u8;
                bad.push(SegmentMsg { axes, ..s.clone() });
                for b in bad {
                    refuse(
                        node,
                        &bytes(&HostMessage::Segment(b)),
                        Refusal::Malformed,
                        "bad segment",
                    );
                }
            }
        }
        Moment::Blocked(i) => {
            // The queue is full: the right next message is refused, later accepted.
            refuse(
                node,
                &bytes(&msgs[i]),
                Refusal::QueueFull,
                &format!("message {i} into a full queue"),
            );
        }
    }
}

#[test]
fn refusals_change_nothing() {
    let msgs = stream();
    for drive in [Drive::Jump, Drive::Frames(40.0)] {
        let reference = run(&mut Node::<3>::new(), &msgs, drive);
        let mut rng = Lcg(7);
        let mut blocked = 0;
        let mut node = Node::<3>::new();
        let r = run_with(&mut node, &msgs, drive, &mut |node, at| {
            blocked += matches!(at, Moment::Blocked(_)) as usize;
            inject(node, &msgs, at, &mut rng);
        });
        assert!(blocked > 10, "the queue was never full");
        assert_eq!(r.keys(), reference.keys(), "{drive:?}");
        assert_eq!(r.positions, reference.positions);
        assert_eq!(r.status, reference.status);
    }
}

#[test]
fn full_event_queue_refuses() {
    let mut node = Node::<2>::new();
    send(&mut node, &HostMessage::Reset);
    send(
        &mut node,
        &HostMessage::ConfigureTool(ToolConfig {
            output: 0,
            track: 0,
        }),
    );
    for t in [10.0, 20.0] {
        assert_eq!(
            send(
                &mut node,
                &HostMessage::Event {
                    track: 0,
                    time: t,
                    value: 1.0
                }
            ),
            None
        );
    }
    refuse(
        &mut node,
        &bytes(&HostMessage::Event {
            track: 0,
            time: 30.0,
            value: 0.0,
        }),
        Refusal::QueueFull,
        "third event",
    );
    let mut rec = Recorder::default();
    node.poll(15.0, &mut rec);
    assert_eq!(
        send(
            &mut node,
            &HostMessage::Event {
                track: 0,
                time: 30.0,
                value: 0.0
            }
        ),
        None
    );
    node.poll(100.0, &mut rec);
    assert_eq!(
        rec.out.iter().map(Out::time).collect::<Vec<_>>(),
        vec![10.0, 20.0, 30.0]
    );
}

/// A segment whose steps no channel could take in its time (found by
/// fuzzing: a channel of coefficient 4.8e232 kept `poll` stepping for good)
/// is refused with nothing changed; the same move in a sane time is taken.
#[test]
fn segments_too_fast_to_step_are_refused() {
    let cases = [
        // (map, steps per unit, move along x, duration in s, taken)
        (JointMap::axis(0), 100.0, 1e7, 1.0, false),
        (JointMap::axis(0), 100.0, 1e7, 1e4, true),
        (JointMap::axis(0), 1e6, 1.0, 1e-3, false),
        (JointMap::axis(0), 1e6, 1.0, 1.0, true),
        (
            JointMap::Linear {
                coeffs: [1.0, -4.8e232, 0.0, 0.0, 0.0, 0.0],
            },
            100.0,
            0.0,
            1.0,
            false,
        ),
    ];
    for (i, &(map, spu, dx, seconds, taken)) in cases.iter().enumerate() {
        let mut node = Node::<4>::new();
        send(&mut node, &HostMessage::Reset);
        assert_eq!(
            send(
                &mut node,
                &HostMessage::ConfigureChannel(channel(0, map, spu))
            ),
            None
        );
        let (start, mut end) = ([0.0f64; MAX_AXES], [0.0f64; MAX_AXES]);
        end[0] = dx;
        // Along y for the case that moves x by nothing: the huge coefficient.
        if dx == 0.0 {
            end[1] = 1.0;
        }
        let length = (end[0] - start[0]).abs().max((end[1] - start[1]).abs());
        let v = length / seconds;
        let seg = motet_trajectory::Segment {
            t0: 0.0,
            start,
            end,
            profile: motet_trajectory::Profile::new(length, v, v, v, 1.0, 0.0),
        };
        let msg = bytes(&HostMessage::Segment(segment_msg(&seg, 0, 0b11)));
        let case = format!("case {i}: {map:?} at {spu} steps/unit, {length} in {seconds} s");
        if taken {
            assert_eq!(node.handle(&msg), None, "{case}");
        } else {
            refuse(&mut node, &msg, Refusal::Malformed, &case);
        }
    }
}

fn status_reply<const Q: usize>(node: &mut Node<Q>) -> NodeStatus {
    match send(node, &HostMessage::Status) {
        Some(NodeMessage::Status {
            segment_space,
            event_space,
            next_seq,
            underruns,
            committed,
            stopped,
            run,
        }) => NodeStatus {
            segment_space: segment_space as usize,
            event_space: event_space as usize,
            next_seq,
            underruns,
            committed,
            stopped,
            run,
        },
        other => panic!("no status: {other:?}"),
    }
}

fn status_tracks_queue<const Q: usize>() {
    let msgs = stream();
    let mut node = Node::<Q>::new();
    assert_eq!(
        status_reply(&mut node),
        NodeStatus {
            segment_space: Q,
            event_space: Q,
            next_seq: 0,
            underruns: 0,
            committed: 0,
            stopped: false,
            run: 0,
        }
    );
    let mut seen = 0;
    run_with(&mut node, &msgs, Drive::Jump, &mut |node, _| {
        let st = status_reply(node);
        assert_eq!(st, node.status());
        assert_eq!(st.segment_space, Q - node.queued());
        seen += 1;
    });
    assert!(seen > 0);
    let segs = msgs
        .iter()
        .filter(|m| matches!(m, HostMessage::Segment(_)))
        .count() as u32;
    assert_eq!(
        status_reply(&mut node),
        NodeStatus {
            segment_space: Q,
            event_space: Q,
            next_seq: segs,
            underruns: 0,
            committed: segs,
            stopped: false,
            run: 0,
        }
    );
    // A Status request changes nothing either.
    let before = snapshot(&mut node);
    status_reply(&mut node);
    assert_eq!(snapshot(&mut node), before);
}

#[test]
fn status_reports_queue_space() {
    status_tracks_queue::<2>();
    status_tracks_queue::<8>();
    status_tracks_queue::<64>();
    // Mid-stream, by hand.
    let msgs = stream();
    let mut node = Node::<8>::new();
    let mut segs = 0;
    for m in &msgs {
        if matches!(m, HostMessage::Segment(_)) {
            if segs == 5 {
                break;
            }
            segs += 1;
        }
        assert_eq!(send(&mut node, m), None);
        let st = status_reply(&mut node);
        assert_eq!((st.segment_space, st.next_seq), (8 - segs as usize, segs));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Byte strings that are not messages, sprinkled into a valid stream, are
    /// refused and change nothing.
    #[test]
    fn garbage_in_the_stream_changes_nothing(
        junk in prop::collection::vec((any::<u16>(), prop::collection::vec(any::<u8>(), 0..120)), 1..60),
        jump in any::<bool>(),
    ) {
        let msgs = stream();
        let drive = if jump { Drive::Jump } else { Drive::Frames(40.0) };
        let reference = run(&mut Node::<4>::new(), &msgs, drive);
        let mut node = Node::<4>::new();
        let mut pending: Vec<(usize, Vec<u8>)> = junk
            .into_iter()
            .filter(|(_, b)| decode::<HostMessage>(b).is_err())
            .map(|(at, b)| (at as usize % msgs.len(), b))
            .collect();
        pending.sort_by_key(|p| p.0);
        let r = run_with(&mut node, &msgs, drive, &mut |node, at| {
            if let Moment::BeforeSend(i) = at {
                while let Some((_, b)) = pending.first().filter(|p| p.0 <= i) {
                    let b = b.clone();
                    pending.remove(0);
                    refuse(node, &b, Refusal::Malformed, "garbage");
                }
            }
        });
        prop_assert_eq!(r.keys(), reference.keys());
        prop_assert_eq!(r.positions, reference.positions);
    }

    /// Any bytes at all, decodable or not, never make a running node panic.
    #[test]
    fn arbitrary_bytes_never_panic(
        junk in prop::collection::vec((any::<u16>(), prop::collection::vec(any::<u8>(), 0..80)), 1..40),
    ) {
        let msgs = stream();
        let mut node = Node::<4>::new();
        let mut junk = junk;
        let mut rec = Recorder::default();
        for (k, m) in msgs.iter().enumerate() {
            let _ = send(&mut node, m);
            for (at, b) in junk.iter_mut() {
                if *at as usize % msgs.len() == k {
                    let _ = node.handle(b);
                }
            }
            node.poll(k as f64 * 50_000.0, &mut rec);
            let _ = node.next_deadline();
        }
    }
}

fn small() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => -500.0..500.0f64,
        1 => Just(0.0),
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
    ]
}

fn arb_map() -> impl Strategy<Value = JointMap> {
    prop_oneof![
        prop::array::uniform6(small()).prop_map(|coeffs| JointMap::Linear { coeffs }),
        (0..10u8, 0..10u8).prop_map(|(x, y)| JointMap::polar_radius(x, y)),
        (0..10u8, 0..10u8).prop_map(|(x, y)| JointMap::polar_angle(x, y)),
    ]
}

fn arb_message() -> impl Strategy<Value = HostMessage> {
    prop_oneof![
        (0..10u8, arb_map(), small(), any::<f32>(), any::<f32>()).prop_map(
            |(channel, map, steps_per_unit, pulse_us, dir_setup_us)| {
                HostMessage::ConfigureChannel(ChannelConfig {
                    channel,
                    map,
                    steps_per_unit,
                    pulse_us,
                    dir_setup_us,
                })
            }
        ),
        prop::array::uniform6(small()).prop_map(|position| HostMessage::SetPosition { position }),
        (0..4u8, small(), any::<f32>()).prop_map(|(track, time, value)| HostMessage::Event {
            track,
            time,
            value
        }),
        (
            0..4u32,
            small(),
            prop::array::uniform7(small()),
            prop::collection::vec((0..8u8, small(), small()), 0..6)
        )
            .prop_map(|(seq, t0, p, axes)| {
                let profile = motet_trajectory::ProfileParams {
                    length: p[0].abs(),
                    v0: p[1].abs(),
                    vc: p[2].abs(),
                    v1: p[3].abs(),
                    accel: p[4].abs(),
                    jerk: p[5].abs(),
                    dwell: p[6].abs().min(1.0),
                };
                let axes = axes
                    .into_iter()
                    .map(|(axis, from, to)| AxisSpan { axis, from, to })
                    .collect();
                HostMessage::Segment(SegmentMsg {
                    seq,
                    t0: t0.abs() * 1e3,
                    profile,
                    axes,
                })
            }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Well-formed messages with arbitrary (including absurd) contents never make
    /// a node panic or stop answering.
    #[test]
    fn odd_messages_never_panic(msgs in prop::collection::vec(arb_message(), 1..12)) {
        let mut node = Node::<4>::new();
        for m in polar().setup() {
            send(&mut node, &m);
        }
        let mut rec = Recorder::default();
        for (k, m) in msgs.iter().enumerate() {
            let _ = send(&mut node, m);
            let _ = node.next_deadline();
            node.poll(k as f64 * 1e5, &mut rec);
            prop_assert!(rec.out.len() < 5_000_000);
        }
        if let Some(d) = node.next_deadline() {
            prop_assert!(!d.is_nan(), "deadline NaN");
        }
    }
}
