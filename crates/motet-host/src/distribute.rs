//! Distribution: which messages each node gets.
//!
//! A node subscribes to the position tracks (axes) its channels' joints depend
//! on and to the event tracks of its tools and heaters. Each planned segment
//! goes to every node with at least one subscribed axis, carrying only those
//! axes; a temperature change goes to the node that drives its heater, as
//! an event on the heater's track.

use crate::machine::Machine;
use motet_planner::Planned;
use motet_trajectory::{Point, MAX_AXES};
use motet_wire::stream::{BatchEncoder, Quantizer, StreamError};
use motet_wire::{AxisSpan, ChannelConfig, HostMessage, SegmentMsg, StreamConfig, ToolConfig};

/// One node's subscriptions.
#[derive(Clone, Debug, PartialEq)]
pub struct Subscription {
    /// Bit i set: the node reads machine axis i.
    pub axes: u8,
    /// Tool indices whose event tracks the node reads.
    pub tracks: Vec<u8>,
    /// Next segment sequence number for this node.
    next_seq: u32,
    /// The heaters it drives: the temperature channel each follows and
    /// the event track its targets go on.
    pub heaters: Vec<(motet_planner::AuxChannel, u8)>,
}

/// A message for a node and the segments it carries (for queue room).
#[derive(Clone, Debug, PartialEq)]
pub struct Outgoing {
    /// The message as the node receives it.
    pub message: HostMessage,
    /// Segments it adds to the node's queue (0 for events and setup): what
    /// the sender must have room for before sending it.
    pub segments: usize,
}

/// Routes the trajectory to nodes.
#[derive(Clone, Debug)]
pub struct Distributor {
    /// One per node, in [`Machine::nodes`]' order.
    pub subscriptions: Vec<Subscription>,
    stream: StreamConfig,
    quantizer: Quantizer,
    encoders: Vec<BatchEncoder>,
}

impl Distributor {
    /// Subscriptions for every node of `machine`, and a batched stream
    /// started with the machine at rest at its `start`.
    pub fn new(machine: &Machine) -> Distributor {
        let subscriptions = machine
            .nodes
            .iter()
            .enumerate()
            .map(|(k, n)| {
                let mut axes = 0u8;
                for &a in &n.actuators {
                    axes |= machine.joints[machine.actuators[a].joint].map.axis_mask();
                }
                Subscription {
                    axes,
                    tracks: n.tools.iter().map(|&t| t as u8).collect(),
                    next_seq: 0,
                    heaters: crate::heater_loop::on_node(machine, k)
                        .into_iter()
                        .map(|h| {
                            let track = crate::heater_loop::HEATER_TRACK_BASE + h as u8;
                            (machine.heaters[h].channel, track)
                        })
                        .collect(),
                }
            })
            .collect();
        let stream = StreamConfig {
            path_mask: machine.limits().path_mask(),
            ..StreamConfig::default()
        };
        let mut d = Distributor {
            subscriptions,
            stream,
            quantizer: Quantizer::new(stream, machine.start),
            encoders: vec![],
        };
        d.start_stream(machine, &machine.start);
        d
    }

    /// Restarts the batched stream of every node for a machine at rest at
    /// `start` (after the nodes got [`Distributor::stream_setup`]).
    fn start_stream(&mut self, machine: &Machine, start: &Point) {
        self.quantizer = Quantizer::new(self.stream, *start);
        for sub in self.subscriptions.iter_mut() {
            sub.next_seq = 0;
        }
        self.encoders = machine
            .nodes
            .iter()
            .zip(&self.subscriptions)
            .map(|(n, sub)| {
                // Half the node's queue: a batch is bounded by its bytes
                // first (a print's 25 segments fill one), and a node still
                // holds half its queue while the next fills.
                let most = (n.queue / 2).max(1);
                BatchEncoder::new(self.stream, sub.axes, *start, 0, most)
            })
            .collect();
    }

    /// Messages that configure every node for batched segments
    /// ([`Distributor::quantize`], [`Distributor::route_batched`]) on a
    /// machine at rest at `start`: [`Distributor::setup`] and the stream's
    /// quanta. Restarts the stream.
    pub fn stream_setup(&mut self, machine: &Machine, start: &Point) -> Vec<Vec<HostMessage>> {
        self.start_stream(machine, start);
        (0..machine.nodes.len())
            .map(|k| {
                let mut m = self.setup(machine, k, start);
                m.insert(m.len() - 1, HostMessage::ConfigureStream(self.stream));
                m
            })
            .collect()
    }

    /// The planned item as the batched stream carries it: a segment
    /// quantized (see [`Quantizer`]), other times moved onto the quantized
    /// timeline. This is the trajectory the nodes run: record it.
    pub fn quantize(&mut self, item: &Planned) -> Planned {
        let q = &mut self.quantizer;
        match *item {
            Planned::Segment(s) => Planned::Segment(q.segment(&s)),
            Planned::Event(mut e) => {
                e.time = q.time(e.time);
                Planned::Event(e)
            }
            Planned::Aux(mut a) => {
                a.time = q.time(a.time);
                Planned::Aux(a)
            }
            Planned::Pause { time, optional } => Planned::Pause {
                time: q.time(time),
                optional,
            },
        }
    }

    /// The messages node `node` gets for a quantized item, batching segments:
    /// a batch goes out when full, before an event and before a pause or
    /// auxiliary change (the host waits there); [`Distributor::flush`] sends
    /// the rest.
    pub fn route_batched(
        &mut self,
        node: usize,
        item: &Planned,
    ) -> Result<Vec<Outgoing>, StreamError> {
        let mut out = vec![];
        match item {
            Planned::Segment(s) => {
                if self.subscriptions[node].axes == 0 {
                    return Ok(out);
                }
                let b = self.encoders[node].push(s)?;
                let sub = &mut self.subscriptions[node];
                sub.next_seq = sub.next_seq.wrapping_add(1);
                if let Some(b) = b {
                    out.push(Outgoing {
                        segments: b.segments,
                        message: HostMessage::Segments(b.batch),
                    });
                }
            }
            Planned::Event(_) => {
                out.extend(self.flush(node));
                out.extend(self.route(node, item).map(|message| Outgoing {
                    message,
                    segments: 0,
                }));
            }
            Planned::Aux(_) => {
                out.extend(self.flush(node));
                out.extend(self.route(node, item).map(|message| Outgoing {
                    message,
                    segments: 0,
                }));
            }
            Planned::Pause { .. } => out.extend(self.flush(node)),
        }
        Ok(out)
    }

    /// Every node that takes segments has its open batch nearly full (or
    /// none open): a window that ends here goes out in full frames.
    pub fn batches_nearly_full(&self) -> bool {
        self.encoders
            .iter()
            .zip(&self.subscriptions)
            .filter(|(_, s)| s.axes != 0)
            .all(|(e, _)| e.pending() == 0 || e.nearly_full())
    }

    /// The batch node `node` has waiting, if any.
    pub fn flush(&mut self, node: usize) -> Option<Outgoing> {
        self.encoders[node].flush().map(|b| Outgoing {
            segments: b.segments,
            message: HostMessage::Segments(b.batch),
        })
    }

    /// Messages that configure node `node` for a machine at rest at `start`.
    pub fn setup(&self, machine: &Machine, node: usize, start: &Point) -> Vec<HostMessage> {
        let spec = &machine.nodes[node];
        let mut out = vec![HostMessage::Reset];
        for (ch, &a) in spec.actuators.iter().enumerate() {
            let act = &machine.actuators[a];
            if let Some(servo) = &act.servo {
                let map = machine.joints[act.joint].map;
                out.push(HostMessage::ConfigureServo(servo.config(
                    ch as u8,
                    map,
                    act.steps_per_unit,
                )));
                continue;
            }
            out.push(HostMessage::ConfigureChannel(ChannelConfig {
                channel: ch as u8,
                map: machine.joints[act.joint].map,
                steps_per_unit: act.steps_per_unit,
                pulse_us: act.pulse_us,
                dir_setup_us: act.dir_setup_us,
            }));
        }
        out.extend(crate::heater_loop::setup(machine, node));
        for (output, &t) in spec.tools.iter().enumerate() {
            out.push(HostMessage::ConfigureTool(ToolConfig {
                output: output as u8,
                track: t as u8,
            }));
        }
        out.extend(crate::loops::setup(machine, node));
        out.push(HostMessage::SetPosition { position: *start });
        out
    }

    /// Whether node `node` takes `item` as an event (a tool's change, a
    /// temperature for a heater it drives): a windowed node holds it
    /// pending until the next seal.
    pub fn takes_event(&self, node: usize, item: &Planned) -> bool {
        let sub = &self.subscriptions[node];
        match item {
            Planned::Event(e) => sub.tracks.contains(&e.tool),
            Planned::Aux(a) => sub.heaters.iter().any(|(c, _)| *c == a.channel),
            _ => false,
        }
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
            // A temperature for a heater the node drives; other auxiliary
            // channels are no node's, and pauses are the host's.
            Planned::Aux(a) => {
                sub.heaters
                    .iter()
                    .find(|(c, _)| *c == a.channel)
                    .map(|&(_, track)| HostMessage::Event {
                        track,
                        time: a.time,
                        value: a.value,
                    })
            }
            Planned::Pause { .. } => None,
        }
    }
}
