//! Message types.

use crate::control::{
    FaultKind, SampleBatch, SampleSource, SensorConfig, ServoConfig, ServoGains, ServoTest,
};
use crate::heater::HeaterConfig;
use crate::stream::{SegmentBatch, StreamConfig};
use heapless::Vec;
use motet_trajectory::{JointMap, Point, ProfileParams, MAX_AXES};
use serde::{Deserialize, Serialize};

/// Most steps per second a node takes on one channel, on average over a
/// segment: a node refuses a segment asking more (`Malformed`), and the host
/// plans within it (every joint's speed is held to this over its steps per
/// unit). A node spends work on every step; far beyond any step/direction
/// driver, it bounds what one message can make a node do.
pub const MAX_STEP_RATE: f64 = 2e6;

/// Largest encoded message, bytes. Fits a USB full-speed bulk packet pair and
/// CAN-FD's 64-byte frames after fragmentation.
pub const MAX_MESSAGE: usize = 192;

/// One axis's part of a segment: its value at the start and at the end.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AxisSpan {
    /// Index of the axis in the trajectory's [`Point`] (x, y, z, …; below [`MAX_AXES`]).
    pub axis: u8,
    /// The axis's value at the segment's start, in its unit (mm, or degrees for an angle).
    pub from: f64,
    /// The axis's value at the segment's end, same unit.
    pub to: f64,
}

/// A trajectory segment as a node receives it: only the axes it subscribes to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SegmentMsg {
    /// Sequence number of the segment in the trajectory; a node takes them in order.
    pub seq: u32,
    /// Start time, µs on the host clock.
    pub t0: f64,
    /// Speed along the path over the segment's time: length, entry, cruise and exit speeds,
    /// acceleration, jerk and dwell.
    pub profile: ProfileParams,
    /// The subscribed axes that are part of the move, each at most once; an axis a node reads but
    /// the segment leaves out keeps its value.
    pub axes: Vec<AxisSpan, MAX_AXES>,
}

/// How a node channel turns the trajectory into steps.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChannelConfig {
    /// The board channel id the steps go out on (`Board::step`'s channel).
    pub channel: u8,
    /// Which joint the channel follows: one axis (or a linear mix of axes), or a kinematic joint of
    /// a plane's axes.
    pub map: JointMap,
    /// Signed: negative inverts the direction output.
    pub steps_per_unit: f64,
    /// Step pulse width, µs: the step output stays high this long, and low
    /// at least this long between pulses ([`PULSE_US`]).
    pub pulse_us: f32,
    /// Direction set-up time, µs: the direction output settles this long
    /// before a step's rising edge ([`DIR_SETUP_US`]).
    pub dir_setup_us: f32,
}

/// Step pulse widths a node takes, µs.
pub const PULSE_US: core::ops::RangeInclusive<f32> = 0.1..=1000.0;
/// Direction set-up times a node takes, µs.
pub const DIR_SETUP_US: core::ops::RangeInclusive<f32> = 0.0..=1000.0;
/// Pulse width and direction set-up time when a machine file gives none,
/// µs: what common drivers (A4988, DRV8825) need.
pub const DEFAULT_PULSE_US: f32 = 2.0;
/// Direction set-up time when a machine file gives none, µs (as
/// [`DEFAULT_PULSE_US`]).
pub const DEFAULT_DIR_SETUP_US: f32 = 1.0;

impl ChannelConfig {
    /// Whether the step timing is one a node takes.
    pub fn timing_is_valid(&self) -> bool {
        PULSE_US.contains(&self.pulse_us) && DIR_SETUP_US.contains(&self.dir_setup_us)
    }
}

/// Which event track drives a tool output.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ToolConfig {
    /// The board's tool output id (`Board::set_tool`'s output).
    pub output: u8,
    /// The event track whose events set it.
    pub track: u8,
}

/// Host → node.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum HostMessage {
    /// Forget all configuration, segments and events.
    Reset,
    /// Set up (or replace, by `channel` id) a step channel. Only valid with an empty segment queue
    /// (`BadConfig` otherwise, as for values out of range).
    ConfigureChannel(ChannelConfig),
    /// Set up (or replace, by `output` id) a tool output.
    ConfigureTool(ToolConfig),
    /// The machine is at rest at this point: set every channel's step count from
    /// it without stepping. Only valid with an empty segment queue.
    SetPosition {
        /// The machine-space point, every axis, in axis units.
        position: Point,
    },
    /// One segment, next in sequence.
    Segment(SegmentMsg),
    /// An event-track change at a time.
    Event {
        /// The event track the change is on; it sets every tool output driven by this track.
        track: u8,
        /// When the change takes effect, µs on the host clock.
        time: f64,
        /// The new value, in the tool's unit (a laser's power, a spindle's speed;
        /// 0 is off).
        value: f32,
    },
    /// An event-track change whose output follows the path speed: the tool
    /// gives `value × speed / feed`, capped at `value` (laser power per mm).
    EventPerSpeed {
        /// As in `Event`.
        track: u8,
        /// As in `Event`, µs on the host clock.
        time: f64,
        /// The value at or above path speed `feed`, and its cap.
        value: f32,
        /// Path speed at which the output reaches `value`, units/s; finite and above 0 (`Malformed`
        /// otherwise).
        feed: f32,
    },
    /// Ask for a [`NodeMessage::Status`].
    Status,
    /// Start describing a dataflow graph (frame period in µs). The node builds
    /// it aside; the running graph (if any) keeps running until
    /// [`HostMessage::GraphCommit`].
    GraphBegin {
        /// Core frame period, µs; at least 1.
        frame_us: f64,
    },
    /// Add a component (its index is the count of components added before it).
    /// `params` are the kind's construction values in the order listed on
    /// [`GraphKind`].
    GraphAdd {
        /// The component kind.
        kind: GraphKind,
        /// Its construction values (see [`GraphKind`]); trailing ones left out take their defaults.
        params: Vec<f64, MAX_GRAPH_PARAMS>,
    },
    /// `world` world units are `block` units of the port.
    GraphRatio {
        /// The port whose unit is set.
        port: GraphPort,
        /// World units (mm, degrees) matching `block` port units.
        world: f64,
        /// Port units matching `world`.
        block: f64,
    },
    /// Map the output `from` onto the input `to`; with `tap`, the input `to`
    /// pulls from the port `from` (fan-out by pull).
    GraphMap {
        /// The output port mapped from.
        from: GraphPort,
        /// The input port mapped onto.
        to: GraphPort,
        /// Whether changes add onto the input or its value overwrites it.
        mode: GraphMode,
        /// Pull: `to` reads `from` when it runs, for an output with several readers.
        tap: bool,
    },
    /// Validate the graph described since [`HostMessage::GraphBegin`] and swap it
    /// in; refused (the running graph untouched) if any step or the whole failed.
    GraphCommit,
    /// Change a parameter of a component of the running graph.
    GraphParam {
        /// Index of the component, in order of [`HostMessage::GraphAdd`].
        component: u8,
        /// Index of the parameter in the component's declaration.
        param: u8,
        /// The new value, in the parameter's unit.
        value: f64,
    },
    /// A reading from outside: encoder count, analog value or button level.
    GraphInput {
        /// Which kind of input.
        kind: GraphInputKind,
        /// Which input of that kind, below `MAX_HW` (8).
        index: u8,
        /// The reading, as the kind describes.
        value: f64,
    },
    /// Remove the running graph (and any graph being built).
    GraphClear,
    /// Windowed mode (until `Reset`) for the run `run`: segments and events
    /// are held pending until a [`HostMessage::Seal`] commits them, and the
    /// committed window always ends at rest through its contingency tail.
    /// The node reports `run` until it is reset or restarted, so that a host
    /// resuming the run knows the node still holds its position. Only valid
    /// with an empty segment queue.
    Windowed {
        /// The run's number, reported back in `Status` and `Position`; 0 means
        /// none, so a host numbers its runs from 1.
        run: u32,
    },
    /// Commit every pending segment and event. `next_seq` is the sequence
    /// number after the last pending segment; a mismatch is refused
    /// (`OutOfOrder`), as is a seal once the committed window's tail has
    /// started (`TailStarted`). Taken without a reply: the link's
    /// acknowledgement of the frame that carried it is the host's
    /// confirmation (a refusal comes back as one).
    Seal {
        /// The sequence number after the last pending segment: the node's `next_seq`.
        next_seq: u32,
    },
    /// The quanta [`HostMessage::Segments`] are rebuilt with. Only valid with
    /// an empty segment queue.
    ConfigureStream(StreamConfig),
    /// Consecutive segments, compactly (see [`crate::stream`]): taken whole or
    /// refused whole.
    Segments(SegmentBatch),
    /// Ask for a [`NodeMessage::Position`].
    Where,
    /// Ask for a [`NodeMessage::Tally`] (refused `BadConfig` by a node that
    /// keeps none).
    TallyGet,
    /// Set up (or replace, by `channel` id) a servo channel: a position
    /// loop on an encoder. Only valid with an empty segment queue.
    ConfigureServo(ServoConfig),
    /// New gains for a servo channel, taken at its next tick, moving or
    /// not (`BadConfig`: no such servo, or a gain out of range).
    ServoGains {
        /// The servo's board channel id.
        channel: u8,
        /// The gains.
        gains: ServoGains,
    },
    /// Send a source's samples upstream, one every `every` ticks of it
    /// (0: none), as [`NodeMessage::Samples`].
    Sampling {
        /// The servo, sensor or heater.
        source: SampleSource,
        /// Ticks a sample.
        every: u32,
    },
    /// Set up (or replace, by `sensor`) a sensor channel.
    ConfigureSensor(SensorConfig),
    /// Run a tuning test on a servo at rest (`NotAtRest` with segments
    /// queued, `BadConfig` for no such servo or a test out of range).
    ServoTest {
        /// The servo's board channel id.
        channel: u8,
        /// The test.
        test: ServoTest,
    },
    /// Set up (or replace, by `heater` index) a heater channel, switched
    /// off until an event on its track sets a target (`BadConfig`: a value
    /// out of range, a drive output a servo or another heater has, no room,
    /// or segments queued).
    ConfigureHeater(HeaterConfig),
    /// A window's last segments and its seal in one message: the batch as
    /// [`HostMessage::Segments`] takes it, then a [`HostMessage::Seal`] at
    /// the node's `next_seq` after it (no sequence number of its own: it is
    /// the batch's end). Refused before anything changes when the node
    /// takes no seal (not windowed, stopped, closed) or the batch is
    /// refused; a window whose tail should have started is refused
    /// `TailStarted` with the batch left pending, as the two messages
    /// would. Saves the seal's own frame: on a print every window is one
    /// frame.
    SegmentsSealed(SegmentBatch),
}

/// Most construction values a [`HostMessage::GraphAdd`] carries.
pub const MAX_GRAPH_PARAMS: usize = 8;

/// A port of a graph component: component index, port index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct GraphPort {
    /// Index of the component, in order of [`HostMessage::GraphAdd`].
    pub comp: u8,
    /// Index of the port on the component (its kind's declaration lists them).
    pub port: u8,
}

/// Mapping mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum GraphMode {
    /// Changes of the output add onto the input (a position the input also moves on its own).
    Incremental,
    /// The output's value overwrites the input each frame.
    Absolute,
}

/// Which hardware input a [`HostMessage::GraphInput`] sets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum GraphInputKind {
    /// Quadrature count (rounded to an integer).
    Encoder,
    /// Raw analog reading.
    Analog,
    /// Digital level: nonzero is pressed.
    Digital,
    /// Motion-stream input: the value's bits are the signals (active in bits
    /// 0..7, forward in bits 8..15) for the next frame.
    Stream,
}

/// A component kind: its position in the node's table of components
/// (`motet_node::graph::COMPONENTS`, the `components!` table in
/// `motet-node/src/graph/component.rs`), one byte on the wire. The
/// construction values of [`HostMessage::GraphAdd`] each kind takes (names,
/// defaults for trailing ones left out, ranges) are declared with the kind in
/// `motet-node` (`graph::declare`; `examples/dance/README.md` renders them):
/// a flag is nonzero for true, an input kind's first value is its hardware
/// index. A node refuses a kind beyond its table.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct GraphKind(pub u8);

/// Node → host.
// Samples are the large variant; without an allocator there is no box,
// and a message is held one at a time (a node's upstream queue holds four).
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum NodeMessage {
    /// The node's queues and sequence numbers: the answer to `Status`.
    Status {
        /// Free places in the segment queue.
        segment_space: u16,
        /// Free places in the event queue.
        event_space: u16,
        /// Next segment sequence number the node expects.
        next_seq: u32,
        /// Times the node ran out of segments while moving.
        underruns: u32,
        /// Sequence number after the last committed segment: the machine
        /// stops at that segment's end if nothing more is sealed.
        committed: u32,
        /// The committed window's tail has started (or its end was reached):
        /// the node takes no segments until `SetPosition` or `Reset`.
        stopped: bool,
        /// The run of [`HostMessage::Windowed`]; 0 when the node has none
        /// (never windowed, reset, or restarted).
        run: u32,
    },
    /// A message was refused; nothing in the queues changed.
    Refused {
        /// Why, and so what the host does about it.
        reason: Refusal,
    },
    /// Where the node is on its run's trajectory (answers
    /// [`HostMessage::Where`]).
    Position {
        /// As in `Status`: 0 when the node holds no run (its position is then
        /// unknown to it).
        run: u32,
        /// As in `Status`: the sequence number after the last committed segment.
        committed: u32,
        /// As in `Status`: the node stopped on its committed window's tail.
        stopped: bool,
        /// Segments still queued: nonzero while the node moves.
        queued: u16,
        /// Where the queued trajectory ends (at rest, once `queued` is 0), on
        /// the axes the node reads; other axes are as the host last set them.
        at: Point,
    },
    /// What the node's outputs did since its last `Reset`: steps per channel,
    /// tool changes, and a 64-bit hash of every output and its time's bits in
    /// order (`motet_node::tally`). Equal tallies: the same outputs at the
    /// same times.
    Tally {
        /// Steps per channel, by board channel id (ids 8 and up are hashed but
        /// not counted).
        steps: [u32; 8],
        /// Tool output changes, every output together.
        tool_changes: u32,
        /// The running hash of every output and its time (see `motet_node::tally`).
        hash: u64,
    },
    /// A loop stopped driving (sent unasked, once): a servo's following
    /// error or limit switch, a sensor that stopped reporting. A windowed
    /// node also takes no more seals and brakes on its committed tail.
    Fault {
        /// The loop.
        source: SampleSource,
        /// Why.
        kind: FaultKind,
        /// Host time of the tick that found it, µs.
        at: f64,
        /// The following error (counts) for a servo; 0 otherwise.
        value: f32,
    },
    /// Samples of one source (sent unasked, see [`HostMessage::Sampling`]).
    Samples(SampleBatch),
    /// A heater has been within its ready window of `target` for its
    /// residency since the target was set (sent unasked, once a target): a
    /// wait for it is over.
    HeaterReady {
        /// The heater's index.
        heater: u8,
        /// Host time of the tick that found it ready, µs.
        at: f64,
        /// The target it is ready at, °C.
        target: f32,
    },
}

/// Why a node refused a [`HostMessage`] (in [`NodeMessage::Refused`]); a
/// refused message changed nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Refusal {
    /// The bytes did not decode as a message, or a value in it is out of range (a NaN time, an axis
    /// past [`MAX_AXES`], a segment faster than [`MAX_STEP_RATE`]).
    Malformed,
    /// No room in the segment or event queue: send again once the node reports space.
    QueueFull,
    /// A segment or seal whose sequence number is not the next expected.
    OutOfOrder {
        /// The sequence number the node expects next.
        expected: u32,
        /// The sequence number the message carried.
        got: u32,
    },
    /// A configuration the node cannot take: a value out of range, no room for another channel or
    /// tool, a change with segments queued, a tally asked of a node that keeps none.
    BadConfig,
    /// `Reset`, `SetPosition` or `Windowed` with segments queued: the node is
    /// moving, or will.
    NotAtRest,
    /// A graph message was refused: a bad component, port, ratio, mapping or
    /// parameter, a graph that does not validate at commit, or a graph message
    /// out of place (building without `GraphBegin`, a parameter with no graph).
    BadGraph,
    /// The node stopped on its contingency tail; `SetPosition` or `Reset`
    /// first.
    Stopped,
    /// A seal came after the committed window's tail started, or would
    /// commit a window whose tail start has already passed.
    TailStarted,
    /// The run was stopped for every node (a group stop, or a member of
    /// the group fell silent): the node takes no more seals.
    Closed,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{decode, encode};
    use motet_trajectory::profile::fastest;

    #[test]
    fn messages_round_trip() {
        let mut axes = Vec::new();
        axes.push(AxisSpan {
            axis: 0,
            from: 1.5,
            to: -3.25,
        })
        .unwrap();
        axes.push(AxisSpan {
            axis: 3,
            from: 0.0,
            to: 0.04,
        })
        .unwrap();
        let msgs = [
            HostMessage::Reset,
            HostMessage::ConfigureChannel(ChannelConfig {
                channel: 2,
                map: JointMap::polar_angle(0, 1),
                steps_per_unit: -44.4,
                pulse_us: 2.5,
                dir_setup_us: 0.0,
            }),
            HostMessage::ConfigureTool(ToolConfig {
                output: 0,
                track: 1,
            }),
            HostMessage::SetPosition {
                position: [1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
            },
            HostMessage::Segment(SegmentMsg {
                seq: 7,
                t0: 123456.75,
                profile: fastest(4.0, 0.0, 3.0, 50.0, 1000.0, 0.0).params(),
                axes,
            }),
            HostMessage::Event {
                track: 1,
                time: 99.5,
                value: 0.25,
            },
            HostMessage::Status,
            HostMessage::GraphBegin { frame_us: 40.0 },
            HostMessage::GraphAdd {
                kind: GraphKind(0),
                params: Vec::from_slice(&[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]).unwrap(),
            },
            HostMessage::GraphRatio {
                port: GraphPort { comp: 1, port: 2 },
                world: 25.4,
                block: 2874.0,
            },
            HostMessage::GraphMap {
                from: GraphPort { comp: 0, port: 0 },
                to: GraphPort { comp: 3, port: 1 },
                mode: GraphMode::Absolute,
                tap: true,
            },
            HostMessage::GraphCommit,
            HostMessage::GraphParam {
                component: 4,
                param: 2,
                value: -0.5,
            },
            HostMessage::GraphInput {
                kind: GraphInputKind::Encoder,
                index: 1,
                value: -1234.0,
            },
            HostMessage::GraphClear,
            HostMessage::Windowed { run: 0xdead_beef },
            HostMessage::Seal { next_seq: 300 },
            HostMessage::ConfigureStream(StreamConfig {
                quantum: 1e-3,
                speed_quantum: 1e-2,
                accel_quantum: 0.5,
                path_mask: 0b111,
            }),
            HostMessage::Segments(SegmentBatch {
                bytes: Vec::from_slice(&[3, 0x21, 7, 0x80, 1]).unwrap(),
            }),
            HostMessage::Where,
            HostMessage::TallyGet,
            HostMessage::SegmentsSealed(SegmentBatch {
                bytes: Vec::from_slice(&[9, 0x21, 7, 0x80, 1]).unwrap(),
            }),
        ];
        let mut buf = [0u8; MAX_MESSAGE];
        for m in msgs {
            let bytes = encode(&m, &mut buf).unwrap();
            let back: HostMessage = decode(bytes).unwrap();
            assert_eq!(back, m);
        }
        let replies = [
            NodeMessage::Status {
                segment_space: 3,
                event_space: 60,
                next_seq: 1000,
                underruns: 1,
                committed: 990,
                stopped: true,
                run: 7,
            },
            NodeMessage::Position {
                run: u32::MAX,
                committed: 990,
                stopped: false,
                queued: 3,
                at: [1.5, -2.0, 0.0, 1e300, -0.0, 7.0],
            },
            NodeMessage::Refused {
                reason: Refusal::Stopped,
            },
            NodeMessage::Refused {
                reason: Refusal::TailStarted,
            },
            NodeMessage::Tally {
                steps: [0, 1, u32::MAX, 3, 4, 5, 6, 7],
                tool_changes: 9,
                hash: 0xdead_beef_0123_4567,
            },
        ];
        for m in replies {
            let bytes = encode(&m, &mut buf).unwrap();
            let back: NodeMessage = decode(bytes).unwrap();
            assert_eq!(back, m);
        }
    }

    #[test]
    fn largest_message_fits() {
        let mut axes = Vec::new();
        for i in 0..MAX_AXES as u8 {
            axes.push(AxisSpan {
                axis: i,
                from: 1e300,
                to: -1e300,
            })
            .unwrap();
        }
        let m = HostMessage::Segment(SegmentMsg {
            seq: u32::MAX,
            t0: 1e300,
            profile: fastest(4.0, 0.0, 3.0, 50.0, 1000.0, 0.0).params(),
            axes,
        });
        let mut buf = [0u8; MAX_MESSAGE];
        assert!(encode(&m, &mut buf).is_ok());
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..300)) {
            let _ = decode::<HostMessage>(&bytes);
            let _ = decode::<NodeMessage>(&bytes);
        }
    }
}
