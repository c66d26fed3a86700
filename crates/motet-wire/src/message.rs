//! Message types.

use heapless::Vec;
use motet_trajectory::{JointMap, Point, ProfileParams, MAX_AXES};
use serde::{Deserialize, Serialize};

/// Largest encoded message, bytes. Fits a USB full-speed bulk packet pair and
/// CAN-FD's 64-byte frames after fragmentation.
pub const MAX_MESSAGE: usize = 192;

/// One axis's part of a segment: its value at the start and at the end.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AxisSpan {
    pub axis: u8,
    pub from: f64,
    pub to: f64,
}

/// A trajectory segment as a node receives it: only the axes it subscribes to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SegmentMsg {
    /// Sequence number of the segment in the trajectory; a node takes them in order.
    pub seq: u32,
    /// Start time, µs on the host clock.
    pub t0: f64,
    pub profile: ProfileParams,
    pub axes: Vec<AxisSpan, MAX_AXES>,
}

/// How a node channel turns the trajectory into steps.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChannelConfig {
    pub channel: u8,
    pub map: JointMap,
    /// Signed: negative inverts the direction output.
    pub steps_per_unit: f64,
}

/// Which event track drives a tool output.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ToolConfig {
    pub output: u8,
    pub track: u8,
}

/// Host → node.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum HostMessage {
    /// Forget all configuration, segments and events.
    Reset,
    ConfigureChannel(ChannelConfig),
    ConfigureTool(ToolConfig),
    /// The machine is at rest at this point: set every channel's step count from
    /// it without stepping. Only valid with an empty segment queue.
    SetPosition {
        position: Point,
    },
    Segment(SegmentMsg),
    /// An event-track change at a time.
    Event {
        track: u8,
        time: f64,
        value: f32,
    },
    /// An event-track change whose output follows the path speed: the tool
    /// gives `value × speed / feed`, capped at `value` (laser power per mm).
    EventPerSpeed {
        track: u8,
        time: f64,
        value: f32,
        feed: f32,
    },
    /// Ask for a [`NodeMessage::Status`].
    Status,
}

/// Node → host.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum NodeMessage {
    Status {
        /// Free places in the segment queue.
        segment_space: u16,
        /// Free places in the event queue.
        event_space: u16,
        /// Next segment sequence number the node expects.
        next_seq: u32,
        /// Times the node ran out of segments while moving.
        underruns: u32,
    },
    /// A message was refused; nothing in the queues changed.
    Refused { reason: Refusal },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Refusal {
    Malformed,
    QueueFull,
    OutOfOrder { expected: u32, got: u32 },
    BadConfig,
    NotAtRest,
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
                map: JointMap::PolarAngle { x: 0, y: 1 },
                steps_per_unit: -44.4,
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
        ];
        let mut buf = [0u8; MAX_MESSAGE];
        for m in msgs {
            let bytes = encode(&m, &mut buf).unwrap();
            let back: HostMessage = decode(bytes).unwrap();
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
