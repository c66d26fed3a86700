//! Windowed nodes and the contingency tail: with seals in time a windowed node
//! steps exactly like a plain one; when the seals stop, every node comes to
//! rest at the committed window's end point, on the path, within the
//! acceleration limits, with its tools off from the tail's start.

use crate::common;

use common::*;
use motet_node::Node;
use motet_planner::Command;
use motet_trajectory::{Contingency, JointMap, ProfileKind, Segment};
use motet_wire::{HostMessage, NodeMessage, Refusal};

/// Runs at speed with corners of every sharpness and laser changes on the fly.
fn job() -> Vec<Command> {
    let mut cmds = vec![Command::Tool {
        tool: 1,
        value: 0.5,
    }];
    let pts = [
        (80.0, 0.0, 1.0),
        (95.0, 4.0, 1.0),
        (110.0, 4.5, 1.0),
        (112.0, 20.0, 1.0),
        (100.0, 30.0, 1.0),
        (101.0, 31.0, 1.5),
        (70.0, 32.0, 1.5),
        (70.5, 10.0, 1.5),
        (60.0, 5.0, 1.0),
        (40.0, 5.5, 1.0),
        (30.0, 25.0, 1.0),
        (31.0, 26.0, 1.0),
        (50.0, 40.0, 1.0),
        (90.0, 40.0, 1.0),
    ];
    for (i, &(x, y, z)) in pts.iter().enumerate() {
        if i % 3 == 2 {
            cmds.push(Command::Tool {
                tool: 1,
                value: 0.1 * i as f32,
            });
        }
        cmds.push(feed(x, y, z, 140.0));
    }
    cmds.push(Command::Tool {
        tool: 1,
        value: 0.0,
    });
    cmds
}

/// The plain stream turned windowed: `Windowed` after `Reset`, and a seal
/// after every `n` segments and at the end.
fn windowed(plain: &[HostMessage], n: u32) -> Vec<HostMessage> {
    let mut out = Vec::new();
    let mut seq = 0u32;
    for m in plain {
        out.push(m.clone());
        match m {
            HostMessage::Reset => out.push(HostMessage::Windowed { run: 1 }),
            HostMessage::Segment(_) => {
                seq += 1;
                if seq.is_multiple_of(n) {
                    out.push(HostMessage::Seal { next_seq: seq });
                }
            }
            _ => {}
        }
    }
    // Events after the last segment need a seal too.
    if !matches!(out.last(), Some(HostMessage::Seal { .. })) {
        out.push(HostMessage::Seal { next_seq: seq });
    }
    out
}

/// The stream as sent by a host that dies after its `w`th seal: what follows
/// it up to the next seal arrives but stays pending.
fn killed_after(stream: &[HostMessage], w: usize) -> Vec<HostMessage> {
    let seals: Vec<usize> = (0..stream.len())
        .filter(|&i| matches!(stream[i], HostMessage::Seal { .. }))
        .collect();
    let cut = seals.get(w + 1).copied().unwrap_or(stream.len());
    stream[..cut].to_vec()
}

fn sealed_count(stream: &[HostMessage]) -> u32 {
    stream
        .iter()
        .filter_map(|m| match m {
            HostMessage::Seal { next_seq } => Some(*next_seq),
            _ => None,
        })
        .next_back()
        .unwrap_or(0)
}

/// What the node should have run: the committed segments, with the tail.
fn executed(segs: &[Segment], committed: usize) -> (Vec<Segment>, Contingency) {
    let mut w = segs[..committed].to_vec();
    let c = Contingency::apply(&mut w).expect("every window of a planned job can stop");
    (w, c)
}

/// Joint value of channel `map` at time `t` on `segs`.
fn joint(segs: &[Segment], map: &JointMap, t: f64) -> f64 {
    joint_at(
        segs,
        map,
        t.clamp(segs[0].t0, segs.last().unwrap().t1()),
        0.0,
    )
}

/// Every step of `run` lies where the executed trajectory crosses a
/// half-step boundary (so the node really ran the tail, not the plan), the
/// channel ends at the step nearest the stop point, and the path acceleration
/// measured from step times stays within each segment's limit.
fn check_run(
    machine: &Machine,
    exec: &[Segment],
    planned: &[Segment],
    stop: &[f64; 6],
    run: &Run,
    what: &str,
) {
    let end = exec.last().unwrap().t1();
    for (ci, c) in machine.channels.iter().enumerate() {
        let spu = c.steps_per_unit.abs();
        let invert = c.steps_per_unit < 0.0;
        let mut pos = (c.map.value(&machine.start, 0.0) * spu).round() as i64;
        let times: Vec<f64> = run
            .steps()
            .into_iter()
            .filter(|s| s.0 == c.channel)
            .map(|(_, forward, t)| {
                let positive = forward != invert;
                let boundary = pos as f64 + if positive { 0.5 } else { -0.5 };
                pos += if positive { 1 } else { -1 };
                let at = joint(exec, &c.map, t) * spu;
                // Crossing times are solved in closed form: only rounding.
                assert!(
                    (at - boundary).abs() < 1e-6,
                    "{what}: channel {ci} stepped at {t} where the joint is {at} steps, not {boundary}"
                );
                assert!(t <= end, "{what}: step at {t} after the stop at {end}");
                t
            })
            .collect();
        let want = (c.map.value(stop, 0.0) * spu).round() as i64;
        assert_eq!(run.positions[ci], pos, "{what}");
        assert_eq!(pos, want, "{what}: channel {ci} off the stop point");
        // Mean speeds over neighbouring step intervals differ by a weighted
        // mean of the acceleration between them (the weights sum to 1), so
        // within one straight segment the estimate is bounded by the limit
        // exactly; the tolerance only covers rounding of µs times near 1e6
        // (≈1e-10 µs on intervals ≥ 1 µs).
        for w in times.windows(3) {
            let Some(i) = exec.iter().position(|s| s.t0 <= w[0] && w[2] <= s.t1()) else {
                continue;
            };
            let seg = &exec[i];
            let rate = (c.map.value(&seg.end, 0.0) - c.map.value(&seg.start, 0.0)).abs()
                / seg.profile.length();
            if rate < 1e-9 {
                continue;
            }
            let v1 = 1.0 / (spu * (w[1] - w[0]) * 1e-6);
            let v2 = 1.0 / (spu * (w[2] - w[1]) * 1e-6);
            let a = (v2 - v1) / ((w[2] - w[0]) * 0.5e-6) / rate;
            let limit = planned[i].profile.params().accel;
            assert!(
                a.abs() <= limit * (1.0 + 1e-6) + 1e-3,
                "{what}: channel {ci} path accel {a} over {limit} at {}",
                w[1]
            );
        }
    }
}

fn plain_and_segments(machine: &Machine, profile: ProfileKind) -> (Vec<HostMessage>, Vec<Segment>) {
    let planned = plan(limits(profile), machine.start, &job());
    (machine.stream(&planned), segments(&planned))
}

fn tool_outputs(run: &Run) -> Vec<(u8, f32, f64)> {
    run.out
        .iter()
        .filter_map(|o| match *o {
            Out::Tool {
                output,
                value,
                time,
            } => Some((output, value, time)),
            _ => None,
        })
        .collect()
}

#[test]
fn seals_in_time_step_exactly_like_a_plain_node() {
    for machine in [cartesian(), corexy()] {
        for profile in [ProfileKind::Trapezoid, ProfileKind::SCurve] {
            let (plain, segs) = plain_and_segments(&machine, profile);
            let end = segs.last().unwrap().t1();
            for n in [1, 3, 8] {
                let what = format!("{} {profile:?} n={n}", machine.name);
                let a = run(&mut Node::<16>::new(), &plain, Drive::Jump);
                let b = run(&mut Node::<16>::new(), &windowed(&plain, n), Drive::Jump);
                let steps = |r: &Run| {
                    r.steps()
                        .iter()
                        .map(|s| (s.0, s.1, s.2.to_bits()))
                        .collect::<Vec<_>>()
                };
                assert!(!a.steps().is_empty());
                assert_eq!(steps(&a), steps(&b), "{what}");
                assert_eq!(a.positions, b.positions, "{what}");
                assert_eq!(b.status.underruns, 0, "{what}");
                // Tools alike until the end, where the windowed node, having
                // reached the end of what was sealed, turns them off.
                let before = |r: &Run| {
                    tool_outputs(r)
                        .into_iter()
                        .filter(|t| t.2 < end)
                        .collect::<Vec<_>>()
                };
                assert_eq!(before(&a), before(&b), "{what}");
                assert!(
                    b.status.stopped,
                    "{what}: the end of the last window is a stop"
                );
            }
        }
    }
}

#[test]
fn killed_host_stops_every_channel_at_the_window_end() {
    for machine in [cartesian(), corexy()] {
        for profile in [ProfileKind::Trapezoid, ProfileKind::SCurve] {
            let (plain, segs) = plain_and_segments(&machine, profile);
            let full = windowed(&plain, 2);
            let windows = full
                .iter()
                .filter(|m| matches!(m, HostMessage::Seal { .. }))
                .count();
            let mut tails = 0;
            for w in 0..windows {
                let what = format!("{} {profile:?} killed after window {w}", machine.name);
                let sent = killed_after(&full, w);
                let committed = sealed_count(&sent) as usize;
                let (exec, c) = executed(&segs, committed);
                tails += c.has_tail() as usize;
                let mut node = Node::<16>::new();
                let r = run(&mut node, &sent, Drive::Jump);
                // Stopped at the tail's start, or at the end of a window
                // that ends at rest.
                assert!(r.status.stopped, "{what}");
                assert_eq!(r.status.committed as usize, committed, "{what}");
                assert_eq!(
                    r.status.next_seq as usize, committed,
                    "{what}: pending dropped"
                );
                assert_eq!(r.status.segment_space, 16, "{what}");
                assert_eq!(c.stop, segs[committed - 1].end, "{what}");
                // Asked where it is, the node names the run, the window
                // and the point it rests at.
                assert_eq!(
                    send(&mut node, &HostMessage::Where),
                    Some(NodeMessage::Position {
                        run: 1,
                        committed: committed as u32,
                        stopped: true,
                        queued: 0,
                        at: c.stop,
                    }),
                    "{what}"
                );
                check_run(&machine, &exec, &segs, &c.stop, &r, &what);
                // Tools went to 0 at the tail's start and did nothing after.
                let tools = tool_outputs(&r);
                for out in machine.tools.iter().map(|t| t.output) {
                    let last = tools
                        .iter()
                        .rev()
                        .find(|t| t.0 == out)
                        .expect("tool output");
                    assert_eq!(
                        (last.1, last.2),
                        (0.0, c.start_time),
                        "{what}: output {out}"
                    );
                }
                assert!(tools.iter().all(|t| t.2 <= c.start_time), "{what}");
            }
            assert!(
                tails > windows / 2,
                "most windows of a job at speed need a tail"
            );
        }
    }
}

#[test]
fn two_nodes_stop_at_the_same_path_point() {
    let both = cartesian();
    let x = Machine {
        name: "x",
        channels: vec![both.channels[0]],
        ..both.clone()
    };
    let y = Machine {
        name: "y",
        channels: vec![both.channels[1]],
        tools: vec![],
        ..both.clone()
    };
    let profile = ProfileKind::Trapezoid;
    let planned = plan(limits(profile), both.start, &job());
    let segs = segments(&planned);
    let seals = windowed(&x.stream(&planned), 3)
        .iter()
        .filter(|m| matches!(m, HostMessage::Seal { .. }))
        .count();
    let mut tested = 0;
    for w in 0..seals {
        let committed = sealed_count(&killed_after(&windowed(&x.stream(&planned), 3), w));
        if !executed(&segs, committed as usize).1.has_tail() {
            continue;
        }
        tested += 1;
        let mut stops = Vec::new();
        let mut starts = Vec::new();
        for m in [&x, &y] {
            let sent = killed_after(&windowed(&m.stream(&planned), 3), w);
            let committed = sealed_count(&sent) as usize;
            let (exec, c) = executed(&segs, committed);
            // All of it fits the queue: sent before the node runs.
            let mut node = Node::<64>::new();
            for m in &sent {
                assert!(
                    !matches!(send(&mut node, m), Some(NodeMessage::Refused { .. })),
                    "{m:?}"
                );
            }
            starts.push(node.tail_start().expect("a committed window"));
            let r = run(&mut node, &[], Drive::Jump);
            check_run(
                m,
                &exec,
                &segs,
                &c.stop,
                &r,
                &format!("{} window {w}", m.name),
            );
            stops.push((r.status.committed, c.stop));
            let last_step = r.steps().last().map(|s| s.2).unwrap_or(0.0);
            assert!(last_step <= exec.last().unwrap().t1());
        }
        assert_eq!(stops[0], stops[1], "window {w}");
        // Both take over at the same time, the one the host computes.
        let host = executed(&segs, stops[0].0 as usize).1.start_time;
        assert_eq!(starts, [host, host], "window {w}");
    }
    assert!(tested >= 3, "windows at speed: {tested}");
}

#[test]
fn late_seal_is_refused_and_pending_work_is_dropped() {
    let machine = cartesian();
    let planned = plan(limits(ProfileKind::Trapezoid), machine.start, &job());
    let segs = segments(&planned);
    let full = windowed(&machine.stream(&planned), 4);
    let sent = killed_after(&full, 1);
    let committed = sealed_count(&sent);
    let mut node = Node::<16>::new();
    for m in &sent {
        assert!(
            !matches!(send(&mut node, m), Some(NodeMessage::Refused { .. })),
            "{m:?}"
        );
    }
    let pending_seq = node.status().next_seq;
    assert!(pending_seq > committed, "the next window is pending");
    // A seal naming the wrong end changes nothing.
    assert_eq!(
        send(
            &mut node,
            &HostMessage::Seal {
                next_seq: committed
            }
        ),
        Some(NodeMessage::Refused {
            reason: Refusal::OutOfOrder {
                expected: pending_seq,
                got: committed
            }
        })
    );
    assert_eq!(node.status().committed, committed);
    let (_, c) = executed(&segs, committed as usize);
    assert_eq!(node.tail_start(), Some(c.start_time));
    let mut rec = Recorder::default();
    node.poll(next_after(c.start_time), &mut rec);
    let before = node.status();
    assert!(before.stopped);
    assert_eq!(before.next_seq, committed, "pending segments dropped");
    assert_eq!(
        send(
            &mut node,
            &HostMessage::Seal {
                next_seq: pending_seq
            }
        ),
        Some(NodeMessage::Refused {
            reason: Refusal::TailStarted
        })
    );
    let next = sent
        .iter()
        .skip_while(|m| !matches!(m, HostMessage::Seal { next_seq } if *next_seq == committed))
        .find(|m| matches!(m, HostMessage::Segment(_)))
        .cloned()
        .unwrap();
    let HostMessage::Segment(mut next) = next else {
        unreachable!()
    };
    next.seq = committed;
    assert_eq!(
        send(&mut node, &HostMessage::Segment(next.clone())),
        Some(NodeMessage::Refused {
            reason: Refusal::Stopped
        })
    );
    assert_eq!(node.status(), before, "refusals change nothing");
    // While the tail runs the position cannot be set; once at rest it can,
    // and the node takes segments again.
    assert_eq!(
        send(&mut node, &HostMessage::SetPosition { position: c.stop }),
        Some(NodeMessage::Refused {
            reason: Refusal::NotAtRest
        })
    );
    let mut rec = Recorder::default();
    while node.queued() > 0 {
        let t = node.next_deadline().or(node.front_end()).unwrap();
        node.poll(next_after(t), &mut rec);
    }
    assert_eq!(
        send(&mut node, &HostMessage::SetPosition { position: c.stop }),
        None
    );
    assert!(!node.status().stopped);
    assert_eq!(send(&mut node, &HostMessage::Segment(next)), None);
}

#[test]
fn seal_outside_windowed_mode_and_windowed_while_moving_are_refused() {
    let machine = cartesian();
    let planned = plan(limits(ProfileKind::Trapezoid), machine.start, &job());
    let plain = machine.stream(&planned);
    let mut node = Node::<16>::new();
    let first_segment = plain
        .iter()
        .position(|m| matches!(m, HostMessage::Segment(_)))
        .unwrap();
    for m in &plain[..=first_segment] {
        send(&mut node, m);
    }
    assert_eq!(
        send(&mut node, &HostMessage::Seal { next_seq: 1 }),
        Some(NodeMessage::Refused {
            reason: Refusal::BadConfig
        })
    );
    assert_eq!(
        send(&mut node, &HostMessage::Windowed { run: 1 }),
        Some(NodeMessage::Refused {
            reason: Refusal::NotAtRest
        })
    );
    // Not windowed: the queue runs without seals.
    assert!(node.next_deadline().is_some());
}

#[test]
fn a_moving_node_refuses_reset_and_forgets_its_run_only_at_rest() {
    let machine = cartesian();
    let (plain, _) = plain_and_segments(&machine, ProfileKind::Trapezoid);
    let full = windowed(&plain, 2);
    // The first window sealed: the node has committed motion.
    let first_seal = full
        .iter()
        .position(|m| matches!(m, HostMessage::Seal { .. }))
        .unwrap();
    let mut node = Node::<16>::new();
    for m in &full[..=first_seal] {
        send(&mut node, m);
    }
    let queued = |node: &mut Node<16>| match send(node, &HostMessage::Where) {
        Some(NodeMessage::Position { run, queued, .. }) => (run, queued),
        other => panic!("no position: {other:?}"),
    };
    assert_eq!(queued(&mut node), (1, 2));
    assert_eq!(
        send(&mut node, &HostMessage::Reset),
        Some(NodeMessage::Refused {
            reason: Refusal::NotAtRest
        })
    );
    // Nothing changed: the window still runs to its end.
    assert_eq!(queued(&mut node), (1, 2));
    let mut board = Recorder::default();
    node.poll(f64::MAX / 4.0, &mut board);
    assert_eq!(queued(&mut node), (1, 0));
    assert!(!board.out.is_empty(), "the committed window ran");
    // At rest, a reset is taken and the run is gone with it.
    assert_eq!(send(&mut node, &HostMessage::Reset), None);
    assert_eq!(queued(&mut node), (0, 0));
}
