//! Shared helpers for the node's integration tests: a recording board, machines
//! made of channel maps, a planner front end, the message stream a host would send
//! and a driver that feeds a node while it drains, either frame by frame or by
//! jumping to the node's own deadlines.
#![allow(dead_code)]

use motet_node::{Board, Node, NodeStatus};
use motet_planner::{AxisLimits, Command, Limits, Move, MoveKind, Planned, Planner, ToolTiming};
use motet_trajectory::{JointMap, KinematicsKind, Point, ProfileKind, Segment, MAX_AXES};
use motet_wire::{
    encode, AxisSpan, ChannelConfig, HostMessage, NodeMessage, SegmentMsg, ToolConfig, MAX_MESSAGE,
};

/// One output a node gave its board.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Out {
    Step {
        channel: u8,
        forward: bool,
        time: f64,
    },
    Tool {
        output: u8,
        value: f32,
        time: f64,
    },
}

impl Out {
    pub fn time(&self) -> f64 {
        match *self {
            Out::Step { time, .. } | Out::Tool { time, .. } => time,
        }
    }

    /// Bit-exact identity (times compared by bits).
    pub fn key(&self) -> (u8, u8, u64, u64) {
        match *self {
            Out::Step {
                channel,
                forward,
                time,
            } => (0, channel, forward as u64, time.to_bits()),
            Out::Tool {
                output,
                value,
                time,
            } => (1, output, value.to_bits() as u64, time.to_bits()),
        }
    }
}

/// A board that records everything.
#[derive(Default, Debug)]
pub struct Recorder {
    pub out: Vec<Out>,
}

impl Board for Recorder {
    fn step(&mut self, channel: u8, forward: bool, at_us: f64) {
        self.out.push(Out::Step {
            channel,
            forward,
            time: at_us,
        });
    }
    fn set_tool(&mut self, output: u8, value: f32, at_us: f64) {
        self.out.push(Out::Tool {
            output,
            value,
            time: at_us,
        });
    }
}

pub fn pt(x: f64, y: f64, z: f64) -> Point {
    let mut p = [0.0; MAX_AXES];
    p[0] = x;
    p[1] = y;
    p[2] = z;
    p
}

/// Limits of a three-axis machine (x, y, z) with three tools: 0 a pen (stops,
/// settles), 1 a laser (on the fly), 2 another on-the-fly output.
pub fn limits(profile: ProfileKind) -> Limits {
    let jerk = match profile {
        ProfileKind::Trapezoid => None,
        ProfileKind::SCurve => Some(60_000.0),
    };
    let axis = |v: f64, a: f64| AxisLimits {
        max_velocity: v,
        max_acceleration: a,
        max_jerk: jerk,
        path: true,
    };
    Limits {
        axes: vec![axis(150.0, 2500.0), axis(150.0, 2500.0), axis(20.0, 400.0)],
        joints: vec![],
        junction_deviation: 0.05,
        profile,
        tools: vec![
            ToolTiming {
                stop: true,
                settle: 0.02,
            },
            ToolTiming {
                stop: false,
                settle: 0.0,
            },
            ToolTiming {
                stop: false,
                settle: 0.0,
            },
        ],
        lookahead: 24,
        stop_horizon: 0,
        min_move_s: 0.0,
        max_move_s: 0.0,
    }
}

pub fn feed(x: f64, y: f64, z: f64, f: f64) -> Command {
    Command::Move(Move {
        target: pt(x, y, z),
        feed: f,
        kind: MoveKind::Feed,
    })
}

pub fn rapid(x: f64, y: f64, z: f64) -> Command {
    Command::Move(Move {
        target: pt(x, y, z),
        feed: 0.0,
        kind: MoveKind::Rapid,
    })
}

/// Plans `cmds` from rest at `start`, clock at 0.
pub fn plan(limits: Limits, start: Point, cmds: &[Command]) -> Vec<Planned> {
    let mut p = Planner::new(limits, start, 0.0);
    let mut out = Vec::new();
    for c in cmds {
        p.push(c).expect("plannable command");
        while let Some(x) = p.pop() {
            out.push(x);
        }
    }
    p.finish();
    while let Some(x) = p.pop() {
        out.push(x);
    }
    out
}

pub fn segments(planned: &[Planned]) -> Vec<Segment> {
    planned
        .iter()
        .filter_map(|p| match p {
            Planned::Segment(s) => Some(*s),
            _ => None,
        })
        .collect()
}

/// Points on a ring about the polar centre: each move turns by less than 60° so
/// that its chord stays at least `r_min·cos 30°` from the centre.
pub fn ring_moves(start: Point, steps: &[(f64, f64, f64)], feed_rate: f64) -> Vec<Command> {
    let mut angle = start[1].atan2(start[0]);
    steps
        .iter()
        .map(|&(turn_deg, r, z)| {
            assert!(turn_deg.abs() < 60.0);
            angle += turn_deg.to_radians();
            feed(r * angle.cos(), r * angle.sin(), z, feed_rate)
        })
        .collect()
}

/// A node's configuration.
#[derive(Clone, Debug)]
pub struct Machine {
    pub name: &'static str,
    pub channels: Vec<ChannelConfig>,
    pub tools: Vec<ToolConfig>,
    pub start: Point,
}

pub fn channel(channel: u8, map: JointMap, steps_per_unit: f64) -> ChannelConfig {
    ChannelConfig {
        channel,
        map,
        steps_per_unit,
        pulse_us: motet_wire::message::DEFAULT_PULSE_US,
        dir_setup_us: motet_wire::message::DEFAULT_DIR_SETUP_US,
    }
}

/// One channel of every joint kind: x, y, both CoreXY belts, polar radius
/// and angle, z; `spu` their steps per unit.
pub fn all_kinds(spu: [f64; 7]) -> Vec<ChannelConfig> {
    let k = KinematicsKind::COREXY;
    vec![
        channel(0, JointMap::axis(0), spu[0]),
        channel(1, JointMap::axis(1), spu[1]),
        channel(2, k.joint_map(0, [0, 1, 2]), spu[2]),
        channel(3, k.joint_map(1, [0, 1, 2]), spu[3]),
        channel(4, JointMap::polar_radius(0, 1), spu[4]),
        channel(5, JointMap::polar_angle(0, 1), spu[5]),
        channel(6, JointMap::axis(2), spu[6]),
    ]
}

pub const START: [f64; MAX_AXES] = [60.0, 0.0, 1.0, 0.0, 0.0, 0.0];

pub fn default_tools() -> Vec<ToolConfig> {
    vec![
        ToolConfig {
            output: 0,
            track: 0,
        },
        ToolConfig {
            output: 1,
            track: 1,
        },
    ]
}

pub fn cartesian() -> Machine {
    Machine {
        name: "cartesian",
        channels: vec![
            channel(0, JointMap::axis(0), 40.0),
            channel(1, JointMap::axis(1), -40.0),
            channel(2, JointMap::axis(2), 200.0),
        ],
        tools: default_tools(),
        start: START,
    }
}

pub fn corexy() -> Machine {
    let k = KinematicsKind::COREXY;
    Machine {
        name: "corexy",
        channels: vec![
            channel(0, k.joint_map(0, [0, 1, 2]), 40.0),
            channel(1, k.joint_map(1, [0, 1, 2]), -40.0),
            channel(2, JointMap::axis(2), -200.0),
        ],
        tools: default_tools(),
        start: START,
    }
}

pub fn polar() -> Machine {
    Machine {
        name: "polar",
        channels: vec![
            channel(0, JointMap::polar_radius(0, 1), 40.0),
            channel(1, JointMap::polar_angle(0, 1), -8.0),
            channel(2, JointMap::axis(2), 200.0),
        ],
        tools: default_tools(),
        start: START,
    }
}

impl Machine {
    /// Axes the node's channels read.
    pub fn axis_mask(&self) -> u8 {
        self.channels.iter().fold(0, |m, c| m | c.map.axis_mask())
    }

    pub fn setup(&self) -> Vec<HostMessage> {
        let mut out = vec![HostMessage::Reset];
        out.extend(
            self.channels
                .iter()
                .map(|c| HostMessage::ConfigureChannel(*c)),
        );
        out.extend(self.tools.iter().map(|t| HostMessage::ConfigureTool(*t)));
        out.push(HostMessage::SetPosition {
            position: self.start,
        });
        out
    }

    /// Setup followed by every planned segment (subscribed axes only, seq from 0)
    /// and every event (all tracks, whether the node has an output for it or not).
    pub fn stream(&self, planned: &[Planned]) -> Vec<HostMessage> {
        let mask = self.axis_mask();
        let mut out = self.setup();
        let mut seq = 0u32;
        for p in planned {
            match p {
                Planned::Segment(s) => out.push(HostMessage::Segment(segment_msg(s, seq, mask))),
                Planned::Event(e) => out.push(match e.per_speed {
                    None => HostMessage::Event {
                        track: e.tool,
                        time: e.time,
                        value: e.value,
                    },
                    Some(feed) => HostMessage::EventPerSpeed {
                        track: e.tool,
                        time: e.time,
                        value: e.value,
                        feed: feed as f32,
                    },
                }),
                Planned::Aux(_) | Planned::Pause { .. } => {}
            }
            if let Planned::Segment(_) = p {
                seq += 1;
            }
        }
        out
    }
}

pub fn segment_msg(s: &Segment, seq: u32, mask: u8) -> SegmentMsg {
    let mut axes = heapless::Vec::new();
    for i in 0..MAX_AXES {
        if mask & (1 << i) != 0 {
            axes.push(AxisSpan {
                axis: i as u8,
                from: s.start[i],
                to: s.end[i],
            })
            .unwrap();
        }
    }
    SegmentMsg {
        seq,
        t0: s.t0,
        profile: s.profile.params(),
        axes,
    }
}

pub fn bytes(msg: &HostMessage) -> Vec<u8> {
    let mut buf = [0u8; MAX_MESSAGE];
    encode(msg, &mut buf)
        .expect("message fits MAX_MESSAGE")
        .to_vec()
}

pub fn send<const Q: usize>(node: &mut Node<Q>, msg: &HostMessage) -> Option<NodeMessage> {
    node.handle(&bytes(msg))
}

/// Whether the node has room for `msg` now.
pub fn has_room<const Q: usize>(node: &Node<Q>, msg: &HostMessage) -> bool {
    let st = node.status();
    match msg {
        HostMessage::Segment(_) => st.segment_space > 0,
        HostMessage::Event { .. } => st.event_space > 0,
        _ => true,
    }
}

/// How the driver advances time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Drive {
    /// Poll at every multiple of this many µs.
    Frames(f64),
    /// Poll just past the node's next deadline (or the end of its oldest segment).
    Jump,
}

/// Where the driver is, for hooks that inject messages.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Moment {
    /// Message `i` of the stream is about to be sent.
    BeforeSend(usize),
    /// Message `i` does not fit; the driver is about to poll.
    Blocked(usize),
}

pub struct Run {
    pub out: Vec<Out>,
    pub status: NodeStatus,
    pub positions: Vec<i64>,
    pub polls: usize,
    /// Time the node was last polled up to.
    pub now: f64,
}

impl Run {
    pub fn steps(&self) -> Vec<(u8, bool, f64)> {
        self.out
            .iter()
            .filter_map(|o| match *o {
                Out::Step {
                    channel,
                    forward,
                    time,
                } => Some((channel, forward, time)),
                Out::Tool { .. } => None,
            })
            .collect()
    }

    pub fn keys(&self) -> Vec<(u8, u8, u64, u64)> {
        self.out.iter().map(Out::key).collect()
    }
}

/// The smallest float above `t`.
pub fn next_after(t: f64) -> f64 {
    if t == 0.0 {
        f64::from_bits(1)
    } else if t > 0.0 {
        f64::from_bits(t.to_bits() + 1)
    } else {
        f64::from_bits(t.to_bits() - 1)
    }
}

/// Feeds `msgs` to `node` in order, each as soon as it fits, and polls until the
/// node has nothing left to do. Every message must be accepted.
pub fn run<const Q: usize>(node: &mut Node<Q>, msgs: &[HostMessage], drive: Drive) -> Run {
    run_with(node, msgs, drive, &mut |_, _| {})
}

/// [`run`] with a hook called before every send and whenever the stream is
/// blocked on a full queue.
pub fn run_with<const Q: usize>(
    node: &mut Node<Q>,
    msgs: &[HostMessage],
    drive: Drive,
    hook: &mut dyn FnMut(&mut Node<Q>, Moment),
) -> Run {
    let mut rec = Recorder::default();
    let mut next = 0;
    let mut now = 0.0f64;
    let mut frame = 0u64;
    let mut polls = 0;
    loop {
        while next < msgs.len() && has_room(node, &msgs[next]) {
            hook(node, Moment::BeforeSend(next));
            let reply = send(node, &msgs[next]);
            assert!(
                reply.is_none() || matches!(reply, Some(NodeMessage::Status { .. })),
                "message {next} ({:?}) refused: {reply:?}",
                msgs[next]
            );
            next += 1;
        }
        if next < msgs.len() {
            hook(node, Moment::Blocked(next));
        }
        let until = match drive {
            Drive::Frames(f) => {
                if next == msgs.len() && node.queued() == 0 && node.next_deadline().is_none() {
                    break;
                }
                frame += 1;
                frame as f64 * f
            }
            Drive::Jump => {
                let d = node.next_deadline();
                let f = node.front_end().filter(|&f| f >= now);
                let target = match (d, f) {
                    (Some(d), Some(f)) => d.min(f),
                    (Some(d), None) => d,
                    (None, Some(f)) => f,
                    (None, None) if node.queued() > 0 => now,
                    (None, None) => {
                        assert_eq!(
                            next,
                            msgs.len(),
                            "node idle but message {next} does not fit"
                        );
                        break;
                    }
                };
                next_after(target.max(now))
            }
        };
        node.poll(until, &mut rec);
        now = until;
        polls += 1;
        assert!(polls < 20_000_000, "driver does not terminate");
    }
    Run {
        out: rec.out,
        status: node.status(),
        positions: node.channels().iter().map(|c| c.position()).collect(),
        polls,
        now,
    }
}

/// Ideal joint value (in joint units) of `map` at time `t` on the trajectory
/// `segs` (contiguous in time), angles on the branch nearest `reference`.
pub fn joint_at(segs: &[Segment], map: &JointMap, t: f64, reference: f64) -> f64 {
    let k = segs.partition_point(|s| s.t0 <= t).saturating_sub(1);
    map.value(&segs[k].position_at(t), reference)
}
