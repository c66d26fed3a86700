//! A host that dies mid-job: real example machines and jobs, planned at full
//! speed, fed to windowed nodes window by window; the host stops sending at
//! several times. Every node must come to rest at the last committed
//! window's end point, having followed the path (the contingency tail) to it
//! within the acceleration limits.

use motet_host::{Distributor, Machine};
use motet_node::{Board, Node};
use motet_planner::{Planned, Planner};
use motet_sim::path::PathRecorder;
use motet_sim::plant::{Output, Plant, Stamped};
use motet_trajectory::{Contingency, Segment};
use motet_wire::{encode, HostMessage, MAX_MESSAGE};
use std::path::{Path, PathBuf};

const QUEUE: usize = 64;
/// Segments per seal.
const WINDOW: usize = 6;
/// How far ahead of the machine the host sends, µs: a streaming host keeps
/// a bounded lead, so a kill finds windows still at speed.
const HORIZON: f64 = 150_000.0;

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

const PRINTER_JOB: &str = "G21 G90 M83
G0 X20 Y20 Z0.3 F9000
G1 X120 Y20 E4 F9000
G1 X125 Y22 E0.3
G1 X125 Y120 E4
G1 X60 Y125 E3
G1 X20 Y60 E3
G1 X21 Y21 E2
G0 X200 Y200 F18000
G1 X150 Y200 E2 F6000
";

/// Collects one node's outputs as the plant's, with the node's channel and
/// tool numbers turned into the machine's actuators and tools.
struct Collect<'a> {
    actuators: &'a [usize],
    tools: &'a [usize],
    out: &'a mut Vec<Stamped>,
}

impl Board for Collect<'_> {
    fn step(&mut self, channel: u8, forward: bool, at_us: f64) {
        let actuator = self.actuators[channel as usize];
        self.out.push(Stamped {
            time: at_us,
            output: Output::Step { actuator, forward },
        });
    }
    fn set_tool(&mut self, output: u8, value: f32, at_us: f64) {
        let tool = self.tools[output as usize];
        self.out.push(Stamped {
            time: at_us,
            output: Output::Tool { tool, value },
        });
    }
}

fn plan(machine: &Machine, gcode: &str) -> Vec<Planned> {
    let parsed =
        motet_gcode::parse(gcode, &machine.job_target(), &Default::default()).expect("job parses");
    let mut planner = Planner::new(machine.limits(), machine.start, 0.0);
    let mut out = Vec::new();
    for c in &parsed.commands {
        planner.push(&c.item).expect("plannable");
        while let Some(p) = planner.pop() {
            out.push(p);
        }
    }
    planner.finish();
    while let Some(p) = planner.pop() {
        out.push(p);
    }
    out
}

fn send(node: &mut Node<QUEUE>, m: &HostMessage) {
    let mut buf = [0u8; MAX_MESSAGE];
    let reply = node.handle(encode(m, &mut buf).unwrap());
    // A seal is answered with the node's status; anything else is a refusal.
    assert!(
        !matches!(reply, Some(motet_wire::NodeMessage::Refused { .. })),
        "{m:?} refused: {reply:?}"
    );
}

/// Whether all the node holds is pending (never to run without a seal).
fn only_pending(node: &Node<QUEUE>) -> bool {
    let st = node.status();
    node.queued() == st.next_seq.wrapping_sub(st.committed) as usize
}

/// Runs the job with a streaming host until `kill` (µs), then lets the
/// nodes run on their own until idle. The host keeps `HORIZON` ahead of the
/// machine, sends every item to all nodes at once, and seals after `WINDOW`
/// segments, or earlier when the committed window's tail start (from
/// [`Contingency`], as a network driver computes it) is near. Returns the
/// nodes, the plant's outputs and the segments sent.
fn run_killed(
    machine: &Machine,
    planned: &[Planned],
    kill: f64,
) -> (Vec<Node<QUEUE>>, Vec<Stamped>, Vec<Segment>) {
    let mut nodes: Vec<Node<QUEUE>> = machine.nodes.iter().map(|_| Node::new()).collect();
    let mut dist = Distributor::new(machine);
    for (k, node) in nodes.iter_mut().enumerate() {
        let mut setup = dist.setup(machine, k, &machine.start);
        setup.insert(1, HostMessage::Windowed { run: 1 });
        for m in &setup {
            send(node, m);
        }
    }
    let frame = machine
        .nodes
        .iter()
        .map(|n| n.frame_us)
        .fold(f64::INFINITY, f64::min);
    let mut sent: Vec<Segment> = Vec::new();
    let mut committed = 0usize;
    let mut next = 0usize;
    let mut out = Vec::new();
    let mut now = 0.0;
    loop {
        // The committed window's tail must never start while the host
        // lives: whenever its start is within `HORIZON`, the host sends
        // further, past its horizon if need be, and seals.
        let mut progress = now < kill;
        while progress {
            // A window ending at rest stops the nodes at its end, so its
            // end is the deadline as well.
            let deadline = match committed {
                0 => f64::INFINITY,
                n => Contingency::of(&sent[..n]).unwrap().start_time,
            };
            let urgent = deadline < now + HORIZON;
            progress = false;
            while let Some(item) = planned.get(next) {
                if let Planned::Segment(s) = item {
                    let ahead = s.t0 > now + HORIZON && !urgent;
                    if ahead || sent.len() - committed >= WINDOW {
                        break;
                    }
                }
                let room = nodes.iter().all(|n| {
                    let st = n.status();
                    st.segment_space > 0 && st.event_space > 0
                });
                if !room {
                    break;
                }
                for (k, node) in nodes.iter_mut().enumerate() {
                    if let Some(m) = dist.route(k, item) {
                        send(node, &m);
                    }
                }
                let segment = matches!(item, Planned::Segment(_));
                if let Planned::Segment(s) = item {
                    sent.push(*s);
                }
                next += 1;
                progress = true;
                if urgent && segment {
                    break;
                }
            }
            let pending = sent.len() - committed;
            // Pending work due soon is sealed whatever the window's size.
            let due = sent
                .get(committed)
                .is_some_and(|s| s.t0 < now + HORIZON / 2.0);
            if pending > 0 && (pending >= WINDOW || urgent || due || next == planned.len()) {
                let seal = HostMessage::Seal {
                    next_seq: sent.len() as u32,
                };
                for node in nodes.iter_mut() {
                    send(node, &seal);
                }
                committed = sent.len();
                progress = true;
            }
        }
        let idle = nodes
            .iter_mut()
            .all(|n| n.next_deadline().is_none() && only_pending(n));
        if idle && (next == planned.len() || now >= kill) {
            break;
        }
        now += frame;
        for (k, node) in nodes.iter_mut().enumerate() {
            let spec = &machine.nodes[k];
            node.poll(
                now,
                &mut Collect {
                    actuators: &spec.actuators,
                    tools: &spec.tools,
                    out: &mut out,
                },
            );
        }
    }
    (nodes, out, sent)
}

/// The observer's verdict on the outputs against `exec`, and the largest path
/// acceleration measured from step times within straight segments, as a
/// fraction of each segment's planned limit.
fn observe(
    machine: &Machine,
    exec: &[Segment],
    planned: &[Segment],
    out: &mut [Stamped],
) -> (f64, f64, f64) {
    let mut plant = Plant::new(machine, PathRecorder::new(0, 1, 0.1));
    for s in exec {
        plant.planned(*s);
    }
    out.sort_by(|a, b| a.time.total_cmp(&b.time));
    plant.apply(out);
    let stats = plant.actuator_stats();
    let dev = stats
        .iter()
        .map(|s| s.max_deviation_steps)
        .fold(0.0, f64::max);
    let err = stats
        .iter()
        .map(|s| s.max_step_error_us)
        .fold(0.0, f64::max);
    let mut worst: f64 = 0.0;
    for (i, a) in machine.actuators.iter().enumerate() {
        let map = machine.joints[a.joint].map;
        let spu = a.steps_per_unit.abs();
        let times: Vec<f64> = out
            .iter()
            .filter(|o| matches!(o.output, Output::Step { actuator, .. } if actuator == i))
            .map(|o| o.time)
            .collect();
        // The difference of the mean speeds over two neighbouring step
        // intervals, over half their span, is a weighted mean of the
        // acceleration (weights summing to 1): within one straight segment
        // it is bounded by the limit exactly, up to rounding.
        for w in times.windows(3) {
            let Some(j) = exec.iter().position(|s| s.t0 <= w[0] && w[2] <= s.t1()) else {
                continue;
            };
            let seg = &exec[j];
            let rate = (map.value(&seg.end, 0.0) - map.value(&seg.start, 0.0)).abs()
                / seg.profile.length();
            if rate.is_nan() || rate <= 1e-9 {
                continue;
            }
            let v1 = 1e6 / (spu * (w[1] - w[0]));
            let v2 = 1e6 / (spu * (w[2] - w[1]));
            let accel = (v2 - v1) / ((w[2] - w[0]) * 0.5e-6) / rate;
            worst = worst.max(accel.abs() / planned[j].profile.params().accel);
        }
    }
    (dev, err, worst)
}

#[test]
fn killed_host_leaves_every_node_at_rest_on_the_path() {
    let gestalt = std::fs::read_to_string(examples().join("jobs/gestalt-3d.gcode")).unwrap();
    let jobs = [
        ("gestalt-3axis.toml", gestalt.as_str()),
        ("printer.toml", PRINTER_JOB),
    ];
    for (file, gcode) in jobs {
        let machine = Machine::load(&examples().join(file)).unwrap();
        let planned = plan(&machine, gcode);
        let segs: Vec<Segment> = planned
            .iter()
            .filter_map(|p| match p {
                Planned::Segment(s) => Some(*s),
                _ => None,
            })
            .collect();
        let end = segs.last().unwrap().t1();
        let mut tails = 0;
        for frac in [0.01, 0.05, 0.2, 0.35, 0.5, 0.65, 0.8, 0.95] {
            let kill = frac * end;
            let what = format!("{file} killed at {kill:.0} µs");
            let (mut nodes, mut out, sent) = run_killed(&machine, &planned, kill);
            let st: Vec<_> = nodes.iter().map(|n| n.status()).collect();
            let committed = st[0].committed as usize;
            if committed == 0 {
                // Killed before its first seal: nothing ever moved.
                assert!(out.is_empty(), "{what}");
                continue;
            }
            assert_eq!(&sent[..committed], &segs[..committed]);
            let mut exec = segs[..committed].to_vec();
            let c = Contingency::apply(&mut exec).unwrap();
            tails += c.has_tail() as usize;
            for s in &st {
                // Stopped at the tail's start, or at the end of a window
                // that ends at rest.
                assert!(s.stopped, "{what}");
                assert_eq!(s.committed as usize, committed, "{what}: nodes disagree");
                assert_eq!(s.underruns, 0, "{what}");
            }
            // Every node at rest exactly at the step nearest the stop point.
            for (k, node) in nodes.iter_mut().enumerate() {
                assert_eq!(node.queued(), 0, "{what}: pending dropped");
                for (ch, &a) in node.channels().iter().zip(&machine.nodes[k].actuators) {
                    let act = &machine.actuators[a];
                    let want = machine.joints[act.joint].map.value(&c.stop, 0.0)
                        * act.steps_per_unit.abs();
                    assert_eq!(ch.position(), want.round() as i64, "{what}: {}", act.name);
                }
            }
            let (dev, err, accel) = observe(&machine, &exec, &segs, &mut out);
            assert!(dev <= 0.5 + 1e-6, "{what}: {dev} steps off the path");
            assert!(err < 0.01, "{what}: steps {err} µs off their crossings");
            assert!(accel <= 1.0 + 1e-6, "{what}: path accel {accel}× the limit");
            assert!(
                out.iter().all(|o| o.time <= exec.last().unwrap().t1()),
                "{what}: output after the stop"
            );
        }
        assert!(tails >= 3, "{file}: the kills must hit windows at speed");
    }
}
