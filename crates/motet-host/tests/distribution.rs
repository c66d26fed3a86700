//! Distribution of the trajectory to nodes, for every example machine: who
//! subscribes to what, what `route` sends each node, and how `setup` begins
//! and ends.

use motet_host::{Distributor, Machine};
use motet_planner::{Command, Move, MoveKind, Planned, Planner, ToolEvent};
use motet_trajectory::{KinematicsKind, Point, Profile, Segment, MAX_AXES};
use motet_wire::{ChannelConfig, HostMessage, ToolConfig};
use std::path::PathBuf;

fn machine(file: &str) -> Machine {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(file);
    Machine::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// (example, [(node, axes it reads by name, tool tracks it reads)])
type Subs = (
    &'static str,
    &'static [(&'static str, &'static [&'static str], &'static [u8])],
);

const SUBSCRIPTIONS: &[Subs] = &[
    ("plotter.toml", &[("ebb", &["x", "y"], &[0])]),
    ("printer.toml", &[("mainboard", &["x", "y", "z", "e"], &[])]),
    ("laser.toml", &[("gantry", &["x", "y"], &[0])]),
    (
        "clay-printer.toml",
        &[("table", &["x", "y"], &[]), ("tower", &["z", "e"], &[])],
    ),
    (
        "gestalt-3axis.toml",
        &[
            ("x_node", &["x"], &[]),
            ("y_node", &["y"], &[]),
            ("z_node", &["z"], &[0]),
        ],
    ),
];

fn mask(m: &Machine, axes: &[&str]) -> u8 {
    axes.iter()
        .map(|a| 1u8 << m.axis(a).unwrap())
        .fold(0, |k, b| k | b)
}

/// A segment whose axis values are all different, so that a wrong axis shows.
fn segment(k: usize) -> Segment {
    let mut start = [0.0; MAX_AXES];
    let mut end = [0.0; MAX_AXES];
    for i in 0..MAX_AXES {
        start[i] = (10 * k + i) as f64;
        end[i] = (10 * k + i) as f64 + 0.5;
    }
    Segment {
        t0: 1000.0 * k as f64,
        start,
        end,
        profile: Profile::new(1.0, 0.0, 1.0, 0.0, 10.0, 0.0),
    }
}

#[test]
fn nodes_subscribe_to_the_axes_their_joints_read() {
    for (file, nodes) in SUBSCRIPTIONS {
        let m = machine(file);
        let d = Distributor::new(&m);
        assert_eq!(d.subscriptions.len(), nodes.len(), "{file}");
        assert_eq!(m.nodes.len(), nodes.len(), "{file}");
        for ((spec, sub), (name, axes, tracks)) in m.nodes.iter().zip(&d.subscriptions).zip(*nodes)
        {
            assert_eq!(spec.name, *name, "{file}");
            assert_eq!(
                sub.axes,
                mask(&m, axes),
                "{file}: node {name} axes {:#b}",
                sub.axes
            );
            assert_eq!(sub.tracks, *tracks, "{file}: node {name} tracks");
        }
        // Together the nodes read every axis some actuator needs.
        let all = d.subscriptions.iter().fold(0, |k, s| k | s.axes);
        assert_eq!(all, (1u8 << m.axes.len()) - 1, "{file}");
    }
}

#[test]
fn segments_go_to_every_subscribed_node_with_only_its_axes_and_its_own_sequence() {
    for (file, _) in SUBSCRIPTIONS {
        let m = machine(file);
        let mut d = Distributor::new(&m);
        let masks: Vec<u8> = d.subscriptions.iter().map(|s| s.axes).collect();
        for k in 0..5 {
            let s = segment(k);
            for (node, &mask) in masks.iter().enumerate() {
                let msg = d.route(node, &Planned::Segment(s));
                let Some(HostMessage::Segment(msg)) = msg else {
                    panic!("{file}: node {node} got {msg:?} for segment {k}");
                };
                assert_eq!(msg.seq, k as u32, "{file}: node {node}");
                assert_eq!(msg.t0, s.t0);
                assert_eq!(msg.profile, s.profile.params());
                let axes: Vec<u8> = msg.axes.iter().map(|a| a.axis).collect();
                let want: Vec<u8> = (0..MAX_AXES as u8)
                    .filter(|i| mask & (1 << i) != 0)
                    .collect();
                assert_eq!(axes, want, "{file}: node {node}");
                for a in &msg.axes {
                    assert_eq!(
                        (a.from, a.to),
                        (s.start[a.axis as usize], s.end[a.axis as usize]),
                        "{file}"
                    );
                }
            }
        }
    }
}

#[test]
fn sequence_numbers_count_per_node() {
    // Routing to one node does not advance another's numbering.
    let m = machine("clay-printer.toml");
    let mut d = Distributor::new(&m);
    let seqs: Vec<(usize, u32)> = [0, 0, 1, 0, 1, 1, 1]
        .into_iter()
        .enumerate()
        .map(
            |(k, node)| match d.route(node, &Planned::Segment(segment(k))) {
                Some(HostMessage::Segment(s)) => (node, s.seq),
                other => panic!("{other:?}"),
            },
        )
        .collect();
    assert_eq!(
        seqs,
        [(0, 0), (0, 1), (1, 0), (0, 2), (1, 1), (1, 2), (1, 3)]
    );
    // Events do not consume sequence numbers.
    let e = Planned::Event(ToolEvent {
        time: 0.0,
        tool: 0,
        value: 1.0,
        per_speed: None,
    });
    assert_eq!(d.route(0, &e), None);
    match d.route(0, &Planned::Segment(segment(9))) {
        Some(HostMessage::Segment(s)) => assert_eq!(s.seq, 3),
        other => panic!("{other:?}"),
    }
}

#[test]
fn events_go_only_to_the_node_with_that_tool() {
    for (file, nodes) in SUBSCRIPTIONS {
        let m = machine(file);
        let mut d = Distributor::new(&m);
        for tool in 0..3u8 {
            let e = ToolEvent {
                time: 1234.5,
                tool,
                value: 0.25,
                per_speed: None,
            };
            for (node, (name, _, tracks)) in nodes.iter().enumerate() {
                let got = d.route(node, &Planned::Event(e));
                let want = tracks.contains(&tool).then_some(HostMessage::Event {
                    track: tool,
                    time: 1234.5,
                    value: 0.25,
                });
                assert_eq!(got, want, "{file}: node {name}, tool {tool}");
            }
        }
    }
}

#[test]
fn setup_resets_configures_and_sets_the_position() {
    for (file, _) in SUBSCRIPTIONS {
        let m = machine(file);
        let d = Distributor::new(&m);
        let mut start: Point = m.start;
        start[0] += 1.5;
        for (node, spec) in m.nodes.iter().enumerate() {
            let msgs = d.setup(&m, node, &start);
            assert_eq!(msgs.first(), Some(&HostMessage::Reset), "{file}");
            assert_eq!(
                msgs.last(),
                Some(&HostMessage::SetPosition { position: start }),
                "{file}"
            );
            assert_eq!(
                msgs.len(),
                2 + spec.actuators.len() + spec.tools.len(),
                "{file}"
            );
            let mut want = vec![HostMessage::Reset];
            for (ch, &a) in spec.actuators.iter().enumerate() {
                let act = &m.actuators[a];
                want.push(HostMessage::ConfigureChannel(ChannelConfig {
                    channel: ch as u8,
                    map: m.joints[act.joint].map,
                    steps_per_unit: act.steps_per_unit,
                    pulse_us: act.pulse_us,
                    dir_setup_us: act.dir_setup_us,
                }));
            }
            for (output, &t) in spec.tools.iter().enumerate() {
                want.push(HostMessage::ConfigureTool(ToolConfig {
                    output: output as u8,
                    track: t as u8,
                }));
            }
            want.push(HostMessage::SetPosition { position: start });
            assert_eq!(msgs, want, "{file}: node {}", spec.name);
        }
    }
}

#[test]
fn the_clay_table_node_drives_turntable_then_arm() {
    let m = machine("clay-printer.toml");
    let d = Distributor::new(&m);
    let msgs = d.setup(&m, 0, &m.start);
    let channels: Vec<(u8, f64)> = msgs
        .iter()
        .filter_map(|x| match x {
            HostMessage::ConfigureChannel(c) => Some((c.channel, c.steps_per_unit)),
            _ => None,
        })
        .collect();
    assert_eq!(channels.len(), 2);
    assert_eq!(channels[0].0, 0);
    assert!(
        (channels[0].1 - 6.0 * 3200.0 / 360.0).abs() < 1e-9,
        "{channels:?}"
    );
    assert_eq!(channels[1], (1, 400.0));
}

#[test]
fn a_node_with_only_a_tool_gets_events_but_no_segments() {
    let text = r#"
name = "tool node"
[axes.x]
travel = [0, 100]
max_velocity = 100
max_acceleration = 1000
[actuators.xm]
joint = "x"
chain = [{ leadscrew = { lead = 8.0 } }, { stepper = { step_angle = 1.8 } }]
[tools.pen]
kind = "pen"
[nodes.motion]
actuators = ["xm"]
[nodes.servo]
tools = ["pen"]
"#;
    let m = Machine::parse(text, std::path::Path::new("t.toml")).unwrap();
    let mut d = Distributor::new(&m);
    assert_eq!(d.subscriptions[0].axes, 0b1);
    assert_eq!(d.subscriptions[1].axes, 0);
    assert_eq!(d.route(1, &Planned::Segment(segment(0))), None);
    let e = Planned::Event(ToolEvent {
        time: 5.0,
        tool: 0,
        value: 1.0,
        per_speed: None,
    });
    assert_eq!(d.route(0, &e), None);
    assert_eq!(
        d.route(1, &e),
        Some(HostMessage::Event {
            track: 0,
            time: 5.0,
            value: 1.0
        })
    );
    // Its setup has no channels.
    assert_eq!(d.setup(&m, 1, &m.start).len(), 3);
}

/// A planned job routed to every node: each node's segments are numbered
/// 0, 1, 2, … without gaps, are continuous on its axes, and every event
/// reaches exactly the node with its tool.
#[test]
fn a_planned_job_is_routed_consistently() {
    for (file, nodes) in SUBSCRIPTIONS {
        let m = machine(file);
        let mut planner = Planner::new(m.limits(), m.start, 0.0);
        let mut target = m.start;
        let tools = m.tools.len() as u8;
        for k in 0..12 {
            for (i, a) in m.axes.iter().enumerate() {
                let (lo, hi) = if a.travel[0].is_finite() {
                    (a.travel[0], a.travel[1])
                } else {
                    (0.0, 50.0)
                };
                // Around the middle of the travel, away from any polar centre.
                let phase = k as f64 * 0.7 + i as f64;
                target[i] = lo + (hi - lo) * (0.5 + 0.3 * phase.sin());
                if m.kinematics == KinematicsKind::POLAR && i < 2 {
                    let angle = k as f64 * 0.4;
                    target[i] = 80.0 * if i == 0 { angle.cos() } else { angle.sin() };
                }
            }
            planner
                .push(&Command::Move(Move {
                    target,
                    feed: 20.0,
                    kind: MoveKind::Feed,
                }))
                .unwrap();
            if tools > 0 && k % 4 == 1 {
                planner
                    .push(&Command::Tool {
                        tool: 0,
                        value: (k % 2) as f32,
                    })
                    .unwrap();
            }
        }
        planner.finish();
        let mut d = Distributor::new(&m);
        let mut seqs = vec![0u32; nodes.len()];
        let mut last: Vec<Option<Point>> = vec![None; nodes.len()];
        let (mut segments, mut events) = (0, 0);
        while let Some(item) = planner.pop() {
            let mut receivers = 0;
            for node in 0..nodes.len() {
                match (d.route(node, &item), &item) {
                    (Some(HostMessage::Segment(msg)), Planned::Segment(s)) => {
                        assert_eq!(msg.seq, seqs[node], "{file}");
                        seqs[node] += 1;
                        let mut p = last[node].unwrap_or(m.start);
                        for a in &msg.axes {
                            let i = a.axis as usize;
                            assert!(
                                (a.from - p[i]).abs() < 1e-9,
                                "{file}: node {node} jumps on axis {i}"
                            );
                            assert_eq!(a.to, s.end[i]);
                            p[i] = a.to;
                        }
                        last[node] = Some(p);
                        receivers += 1;
                    }
                    (Some(HostMessage::Event { track, .. }), Planned::Event(e)) => {
                        assert_eq!(track, e.tool);
                        receivers += 1;
                    }
                    (None, _) => {}
                    (msg, item) => panic!("{file}: {msg:?} for {item:?}"),
                }
            }
            match item {
                Planned::Segment(_) => {
                    segments += 1;
                    assert_eq!(
                        receivers,
                        nodes.len(),
                        "{file}: every node here reads some axis"
                    );
                }
                Planned::Event(_) => {
                    events += 1;
                    assert_eq!(receivers, 1, "{file}: an event goes to exactly one node");
                }
                Planned::Aux(_) | Planned::Pause { .. } => assert_eq!(receivers, 0),
            }
        }
        assert!(segments >= 12, "{file}: {segments} segments");
        assert_eq!(events > 0, tools > 0, "{file}: {events} events");
        assert!(
            seqs.iter().all(|&s| s == segments),
            "{file}: {seqs:?} of {segments}"
        );
    }
}
