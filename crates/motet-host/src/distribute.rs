//! Distribution: which messages each node gets.
//!
//! A node subscribes to the position tracks (axes) its channels' joints depend
//! on and to the event tracks of its tools. Each planned segment goes to every
//! node with at least one subscribed axis, carrying only those axes.

use crate::machine::Machine;
use motet_planner::Planned;
use motet_trajectory::{Point, MAX_AXES};
use motet_wire::{AxisSpan, ChannelConfig, HostMessage, SegmentMsg, ToolConfig};

/// One node's subscriptions.
#[derive(Clone, Debug, PartialEq)]
pub struct Subscription {
    /// Bit i set: the node reads machine axis i.
    pub axes: u8,
    /// Tool indices whose event tracks the node reads.
    pub tracks: Vec<u8>,
    /// Next segment sequence number for this node.
    next_seq: u32,
}

/// Routes the trajectory to nodes.
#[derive(Clone, Debug)]
pub struct Distributor {
    pub subscriptions: Vec<Subscription>,
}

impl Distributor {
    pub fn new(machine: &Machine) -> Distributor {
        let subscriptions = machine
            .nodes
            .iter()
            .map(|n| {
                let mut axes = 0u8;
                for &a in &n.actuators {
                    axes |= machine.joints[machine.actuators[a].joint].map.axis_mask();
                }
                Subscription {
                    axes,
                    tracks: n.tools.iter().map(|&t| t as u8).collect(),
                    next_seq: 0,
                }
            })
            .collect();
        Distributor { subscriptions }
    }

    /// Messages that configure node `node` for a machine at rest at `start`.
    pub fn setup(&self, machine: &Machine, node: usize, start: &Point) -> Vec<HostMessage> {
        let spec = &machine.nodes[node];
        let mut out = vec![HostMessage::Reset];
        for (ch, &a) in spec.actuators.iter().enumerate() {
            let act = &machine.actuators[a];
            out.push(HostMessage::ConfigureChannel(ChannelConfig {
                channel: ch as u8,
                map: machine.joints[act.joint].map,
                steps_per_unit: act.steps_per_unit,
            }));
        }
        for (output, &t) in spec.tools.iter().enumerate() {
            out.push(HostMessage::ConfigureTool(ToolConfig {
                output: output as u8,
                track: t as u8,
            }));
        }
        out.push(HostMessage::SetPosition { position: *start });
        out
    }

    /// Sequence number of the next segment for node `node`; `None` for a node
    /// that reads no axis (it gets no segments, so no seals either).
    pub fn next_seq(&self, node: usize) -> Option<u32> {
        let s = &self.subscriptions[node];
        (s.axes != 0).then_some(s.next_seq)
    }

    /// The message node `node` needs for `item`, if any.
    pub fn route(&mut self, node: usize, item: &Planned) -> Option<HostMessage> {
        let sub = &mut self.subscriptions[node];
        match item {
            Planned::Segment(s) => {
                if sub.axes == 0 {
                    return None;
                }
                let mut axes = heapless::Vec::new();
                for i in 0..MAX_AXES {
                    if sub.axes & (1 << i) != 0 {
                        // Cannot overflow: at most MAX_AXES entries.
                        let _ = axes.push(AxisSpan {
                            axis: i as u8,
                            from: s.start[i],
                            to: s.end[i],
                        });
                    }
                }
                let seq = sub.next_seq;
                sub.next_seq = sub.next_seq.wrapping_add(1);
                Some(HostMessage::Segment(SegmentMsg {
                    seq,
                    t0: s.t0,
                    profile: s.profile.params(),
                    axes,
                }))
            }
            Planned::Event(e) => sub.tracks.contains(&e.tool).then(|| match e.per_speed {
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
            // No node drives auxiliary channels yet, and pauses are the host's.
            Planned::Aux(_) | Planned::Pause { .. } => None,
        }
    }
}
