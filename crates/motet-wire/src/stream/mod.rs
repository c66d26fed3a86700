//! Compact segment batches: several consecutive segments in one message.
//!
//! A [`crate::HostMessage::Segment`] spends 66–172 bytes on one segment: every
//! position, time and speed as an f64. A batch sends what the node cannot
//! derive, as integers: end positions as deltas in position quanta, speeds and
//! accelerations in their own quanta, the start time and entry speed only
//! where they do not follow from the previous segment, the path length only
//! where the node cannot compute it from the axes it sees.
//!
//! Both ends rebuild every segment with the same code, so they agree bit for
//! bit, provided the host sends segments that are exactly representable:
//! [`Quantizer`] turns planned segments into such segments, and the host keeps
//! those as its record of the trajectory.
//!
//! # Bytes of a batch
//! First sequence number (varint), then per segment:
//!
//! | field | when | encoding |
//! |---|---|---|
//! | flags | always | u8, bits below |
//! | moving axes | `MASK` | u8 bit mask; otherwise the previous segment's |
//! | t0, v0 | `START` | f64 µs, varint speed quanta; otherwise the previous end time and exit speed
//! |
//! | length | `LENGTH` | varint position quanta; 0 = a dwell, its seconds follow as f64 |
//! | accel | `ACCEL` | varint accel quanta; otherwise the previous segment's |
//! | jerk | `JERK` | varint accel quanta; otherwise the previous segment's |
//! | v1 | `V1` | varint speed quanta; otherwise v0 |
//! | vc | `VC` mode 0 | varint speed quanta; mode 1 = v0, 2 = v1, 3 = the previous segment's vc |
//! | end positions | each moving axis: the path axes ascending, then the others ascending | zigzag varint: the move in quanta less its prediction |
//!
//! Without `LENGTH` the length is the path distance (over the configured path
//! axes) between the segment's ends rounded to whole position quanta.
//!
//! Each axis's move is predicted from the axis's earlier moves in the stream
//! (`predict.rs`: none, the last move, the last move plus its change, or the
//! last move scaled by the path lengths, whichever has missed least lately),
//! and only the miss is sent. The path axes come first, so that a riding
//! axis (an extruder) is predicted knowing the segment's length. A stream
//! without a previous segment (its first, or after a plain segment or a new
//! position) predicts from no history.

mod decode;
mod encode;
mod predict;
mod quantize;
mod varint;

pub use decode::BatchReader;
pub use encode::{Batch, BatchEncoder};
pub use predict::History;
pub use quantize::Quantizer;

use heapless::Vec;
use motet_trajectory::point::distance_masked;
use motet_trajectory::{Point, Segment, MAX_AXES};
use serde::{Deserialize, Serialize};

/// Bytes a batch may carry: [`crate::MAX_MESSAGE`] less the message's variant
/// index and the two-byte length prefix.
pub const BATCH_BYTES: usize = crate::MAX_MESSAGE - 3;

pub(crate) const F_START: u8 = 1 << 0;
pub(crate) const F_MASK: u8 = 1 << 1;
pub(crate) const F_LENGTH: u8 = 1 << 2;
pub(crate) const F_ACCEL: u8 = 1 << 3;
pub(crate) const F_JERK: u8 = 1 << 4;
pub(crate) const F_V1: u8 = 1 << 5;
pub(crate) const VC_SHIFT: u8 = 6;
pub(crate) const VC_EXPLICIT: u8 = 0;
pub(crate) const VC_V0: u8 = 1;
pub(crate) const VC_V1: u8 = 2;
pub(crate) const VC_PREVIOUS: u8 = 3;

/// The quanta a node rebuilds batched segments with, set by
/// [`crate::HostMessage::ConfigureStream`]. Every node of a machine must get
/// the same values, so that their segments agree in time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StreamConfig {
    /// Position quantum, machine units.
    pub quantum: f64,
    /// Speed quantum, units/s.
    pub speed_quantum: f64,
    /// Acceleration (units/s²) and jerk (units/s³) quantum.
    pub accel_quantum: f64,
    /// Axes whose distance is the path length (bit i: axis i). A node that
    /// sees all of them derives the length; 0: the length is always sent.
    pub path_mask: u8,
}

impl Default for StreamConfig {
    fn default() -> Self {
        StreamConfig {
            quantum: 1e-4,
            speed_quantum: 1e-3,
            accel_quantum: 1e-3,
            path_mask: 0,
        }
    }
}

impl StreamConfig {
    /// Positive, finite quanta and a mask naming only axes a point has.
    pub fn is_valid(&self) -> bool {
        let q = |x: f64| x.is_finite() && x > 0.0;
        q(self.quantum)
            && q(self.speed_quantum)
            && q(self.accel_quantum)
            && self.path_mask >> MAX_AXES == 0
    }

    /// The length a node derives for a move between `start` and `end`, if it
    /// can: a whole number (≥ 1) of position quanta.
    pub fn derived_length(&self, start: &Point, end: &Point) -> Option<f64> {
        self.derived_quanta(start, end)
            .map(|n| n as f64 * self.quantum)
    }

    /// [`StreamConfig::derived_length`] in position quanta.
    pub fn derived_quanta(&self, start: &Point, end: &Point) -> Option<i64> {
        if self.path_mask == 0 {
            return None;
        }
        let n = libm::round(distance_masked(start, end, self.path_mask) / self.quantum);
        (1.0..9.0e15).contains(&n).then_some(n as i64)
    }

    /// The axes of `mask` in the order a batch carries them: the path axes
    /// ascending, then the others ascending.
    pub(crate) fn axis_order(&self, mask: u8) -> impl Iterator<Item = usize> + '_ {
        let path = (0..MAX_AXES).filter(move |i| self.path_mask & (1 << i) != 0);
        let rest = (0..MAX_AXES).filter(move |i| self.path_mask & (1 << i) == 0);
        path.chain(rest).filter(move |i| mask & (1 << i) != 0)
    }
}

/// The segments of one [`crate::HostMessage::Segments`], encoded.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SegmentBatch {
    /// The batch's encoding (see this module's description), at most [`BATCH_BYTES`].
    pub bytes: Vec<u8, BATCH_BYTES>,
}

/// What the previous segment of a stream left behind: the context the next
/// one is encoded against. Encoder and decoder keep one each, in step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamState {
    /// End of the previous segment (the machine's position at rest after a
    /// `SetPosition`).
    pub tail: Point,
    /// End time of the previous segment, µs on the host clock: the next one starts there unless it
    /// says otherwise.
    pub t1: f64,
    /// Exit speed of the previous segment, units/s: the next one's entry speed.
    pub v1: f64,
    /// Cruise speed of the previous segment, units/s, which the next may repeat.
    pub vc: f64,
    /// Acceleration of the previous segment, units/s², which the next may repeat.
    pub accel: f64,
    /// Jerk of the previous segment, units/s³, which the next may repeat.
    pub jerk: f64,
    /// The axes the previous segment moved (bit per axis), which the next may repeat.
    pub mask: u8,
    /// Each axis's earlier moves, which predict its next (used only while
    /// `valid`).
    pub history: History,
    /// A previous segment exists: without one, the next segment carries its
    /// start time and speed.
    pub valid: bool,
}

impl StreamState {
    /// A stream at rest at `tail`, before any segment.
    pub const fn at(tail: Point) -> StreamState {
        StreamState {
            tail,
            t1: 0.0,
            v1: 0.0,
            vc: 0.0,
            accel: 0.0,
            jerk: 0.0,
            mask: 0,
            history: History::new(),
            valid: false,
        }
    }

    /// The history the next segment is predicted from: none without a
    /// previous segment.
    pub(crate) fn history(&self) -> History {
        if self.valid {
            self.history
        } else {
            History::new()
        }
    }

    /// Steps past `seg` (mask: the axes that moved in it; history: with its
    /// moves recorded).
    pub(crate) fn advance(&mut self, seg: &Segment, mask: u8, history: History) {
        let p = seg.profile.params();
        *self = StreamState {
            tail: seg.end,
            t1: seg.t1(),
            v1: p.v1,
            vc: p.vc,
            accel: p.accel,
            jerk: p.jerk,
            mask,
            history,
            valid: true,
        };
    }
}

/// Why a segment could not be put into a batch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StreamError {
    /// A value is not a whole number of its quantum (the segment did not come
    /// from a [`Quantizer`] with the same configuration), or too large.
    NotQuantized,
    /// One segment alone does not fit in a batch.
    TooLarge,
}

impl core::fmt::Display for StreamError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            StreamError::NotQuantized => {
                f.write_str("segment value is not a whole number of its quantum")
            }
            StreamError::TooLarge => f.write_str("segment does not fit in a batch"),
        }
    }
}

impl core::error::Error for StreamError {}

/// `v` as a whole number of `q`, if it is one (and fits 2⁵³).
pub(crate) fn whole(v: f64, q: f64) -> Option<i64> {
    let n = libm::round(v / q);
    (n.abs() < 9.0e15 && n * q == v).then_some(n as i64)
}

/// Quanta index of a position: the integer the next delta counts from.
pub(crate) fn index(v: f64, q: f64) -> Option<i64> {
    let n = libm::round(v / q);
    (n.abs() < 9.0e15).then_some(n as i64)
}
