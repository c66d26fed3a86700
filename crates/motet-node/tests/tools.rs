//! Tool events: exact times, only the outputs configured for the track, in time
//! order with the steps.

use crate::common;

use common::*;
use motet_node::Node;
use motet_planner::{Command, Planned};
use motet_trajectory::ProfileKind;
use motet_wire::ToolConfig;

fn job() -> Vec<Command> {
    let mut cmds = vec![Command::Tool {
        tool: 0,
        value: 1.0,
    }];
    let turns: Vec<(f64, f64, f64)> = (0..12)
        .map(|i| (25.0, if i % 2 == 0 { 50.0 } else { 80.0 }, 1.0))
        .collect();
    for (i, m) in ring_moves(START, &turns, 100.0).into_iter().enumerate() {
        // The laser (track 1) and track 2 change on the fly where moves start;
        // the pen (track 0) stops the machine.
        cmds.push(Command::Tool {
            tool: 1,
            value: 0.1 * i as f32,
        });
        if i % 4 == 3 {
            cmds.push(Command::Tool {
                tool: 2,
                value: 0.5,
            });
            cmds.push(Command::Tool {
                tool: 0,
                value: (i % 8 == 3) as u8 as f32,
            });
        }
        cmds.push(m);
    }
    cmds.push(Command::Tool {
        tool: 1,
        value: 0.0,
    });
    cmds.push(Command::Tool {
        tool: 0,
        value: 0.0,
    });
    cmds
}

#[test]
fn tool_events_fire_exactly_on_their_outputs() {
    // Outputs 0 and 5 follow track 0, output 2 track 1; no output follows track 2.
    let tools = vec![
        ToolConfig {
            output: 0,
            track: 0,
        },
        ToolConfig {
            output: 2,
            track: 1,
        },
        ToolConfig {
            output: 5,
            track: 0,
        },
    ];
    for profile in [ProfileKind::Trapezoid, ProfileKind::SCurve] {
        let planned = plan(limits(profile), START, &job());
        let events: Vec<_> = planned
            .iter()
            .filter_map(|p| match p {
                Planned::Event(e) => Some(*e),
                _ => None,
            })
            .collect();
        assert!(
            events.iter().any(|e| e.tool == 2),
            "job has events without outputs"
        );
        // What the board must see, in order: each event on each of its outputs.
        let mut expected = Vec::new();
        for e in &events {
            for t in tools.iter().filter(|t| t.track == e.tool) {
                expected.push(Out::Tool {
                    output: t.output,
                    value: e.value,
                    time: e.time,
                });
            }
        }
        for base in [cartesian(), corexy(), polar()] {
            let machine = Machine {
                tools: tools.clone(),
                ..base
            };
            let msgs = machine.stream(&planned);
            for drive in [Drive::Frames(40.0), Drive::Jump] {
                let what = format!("{} {profile:?} {drive:?}", machine.name);
                let mut node = Node::<4>::new();
                let r = run(&mut node, &msgs, drive);
                let tool_outs: Vec<Out> = r
                    .out
                    .iter()
                    .copied()
                    .filter(|o| matches!(o, Out::Tool { .. }))
                    .collect();
                assert_eq!(
                    tool_outs.iter().map(Out::key).collect::<Vec<_>>(),
                    expected.iter().map(Out::key).collect::<Vec<_>>(),
                    "{what}"
                );
                // Interleaved in time order with the steps; a change at the same
                // time as a step comes first.
                assert!(r.steps().len() > 1000, "{what}");
                for w in r.out.windows(2) {
                    assert!(
                        w[0].time() <= w[1].time(),
                        "{what}: {:?} then {:?}",
                        w[0],
                        w[1]
                    );
                    if w[0].time() == w[1].time() {
                        assert!(
                            !matches!((w[0], w[1]), (Out::Step { .. }, Out::Tool { .. })),
                            "{what}: step before tool at one time"
                        );
                    }
                }
                // Nothing before a pen change comes after it, nothing after before.
                for (i, o) in r.out.iter().enumerate() {
                    if let Out::Tool {
                        output: 0, time, ..
                    } = *o
                    {
                        assert!(r.out[..i].iter().all(|p| p.time() <= time));
                        assert!(r.out[i + 1..].iter().all(|p| p.time() >= time));
                    }
                }
                assert_eq!(r.status.event_space, 4, "{what}: events left over");
            }
        }
    }
}

/// An event queued alone (no segments) fires when its time comes, on every
/// output that follows its track, and a later reconfiguration moves it.
#[test]
fn events_without_motion() {
    let mut node = Node::<4>::new();
    let mut rec = Recorder::default();
    for m in [
        motet_wire::HostMessage::Reset,
        motet_wire::HostMessage::ConfigureTool(ToolConfig {
            output: 1,
            track: 3,
        }),
        motet_wire::HostMessage::ConfigureTool(ToolConfig {
            output: 2,
            track: 3,
        }),
        motet_wire::HostMessage::Event {
            track: 3,
            time: 1000.25,
            value: 0.75,
        },
        motet_wire::HostMessage::Event {
            track: 4,
            time: 1500.0,
            value: 1.0,
        },
        motet_wire::HostMessage::Event {
            track: 3,
            time: 2000.5,
            value: 0.0,
        },
    ] {
        assert_eq!(send(&mut node, &m), None);
    }
    assert_eq!(node.next_deadline(), Some(1000.25));
    node.poll(1000.25, &mut rec);
    assert!(rec.out.is_empty(), "nothing before 1000.25 µs");
    node.poll(1000.5, &mut rec);
    assert_eq!(
        rec.out,
        vec![
            Out::Tool {
                output: 1,
                value: 0.75,
                time: 1000.25
            },
            Out::Tool {
                output: 2,
                value: 0.75,
                time: 1000.25
            }
        ]
    );
    // Output 2 now follows track 4.
    assert_eq!(
        send(
            &mut node,
            &motet_wire::HostMessage::ConfigureTool(ToolConfig {
                output: 2,
                track: 4
            })
        ),
        None
    );
    rec.out.clear();
    node.poll(1e9, &mut rec);
    assert_eq!(
        rec.out,
        vec![
            Out::Tool {
                output: 2,
                value: 1.0,
                time: 1500.0
            },
            Out::Tool {
                output: 1,
                value: 0.0,
                time: 2000.5
            }
        ]
    );
    assert_eq!(node.next_deadline(), None);
}

/// A laser whose power follows the speed stays quiet through a dwell, and
/// the node's next deadline jumps over it: a dwell costs the same work
/// whether it lasts a second or a day.
#[test]
fn a_per_speed_output_sleeps_through_a_dwell() {
    let job = |dwell: f64| {
        vec![
            Command::ToolPerSpeed {
                tool: 1,
                value: 0.8,
                feed: 50.0,
            },
            feed(70.0, 0.0, 1.0, 50.0),
            Command::Dwell { seconds: dwell },
            feed(80.0, 5.0, 1.0, 50.0),
            Command::Tool {
                tool: 1,
                value: 0.0,
            },
        ]
    };
    let machine = cartesian();
    let mut polls = Vec::new();
    for dwell in [1.0, 600.0, 86_400.0] {
        let planned = plan(limits(ProfileKind::Trapezoid), START, &job(dwell));
        let dwell_seg = segments(&planned)
            .into_iter()
            .find(|s| s.profile.length() == 0.0)
            .expect("a dwell segment");
        let mut node = Node::<8>::new();
        let r = run(&mut node, &machine.stream(&planned), Drive::Jump);
        // Nothing changes while the machine stands still, once the refresh
        // after the stop has set the power to zero.
        let settled = dwell_seg.t0 + motet_node::tool::PER_SPEED_UPDATE_US;
        let during: Vec<&Out> = r
            .out
            .iter()
            .filter(|o| o.time() > settled && o.time() < dwell_seg.t1())
            .collect();
        assert!(during.is_empty(), "dwell {dwell} s: {during:?}");
        // The laser ramps with the speed on both moves and ends off.
        let laser: Vec<f32> = r
            .out
            .iter()
            .filter_map(|o| match *o {
                Out::Tool {
                    output: 1, value, ..
                } => Some(value),
                _ => None,
            })
            .collect();
        assert!(laser.len() > 10, "dwell {dwell} s: {laser:?}");
        assert_eq!(laser.last(), Some(&0.0));
        polls.push(r.polls);
    }
    assert!(
        polls.iter().all(|&p| p.abs_diff(polls[0]) <= 2),
        "polls grow with the dwell: {polls:?}"
    );
}
