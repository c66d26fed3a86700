//! What a frame reads from the hardware and what it emits.

use heapless::{Deque, Vec};
use motet_trajectory::Segment;

use super::record::Tape;
use super::wire::Signals;

/// Hardware inputs of each kind a graph can read (encoders, analog pins,
/// digital pins, motion-stream input ports).
pub const MAX_HW: usize = 8;
/// Most steps one frame emits (one per channel at most).
pub const MAX_FRAME_STEPS: usize = 32;

/// Hardware readings for a frame, filled by the caller (firmware or simulator).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inputs {
    /// Quadrature encoder counts.
    pub encoders: [i64; MAX_HW],
    /// Analog readings, raw (e.g. 0..1023).
    pub analog: [f32; MAX_HW],
    /// Digital pin levels (true = pressed / active).
    pub digital: [bool; MAX_HW],
    /// Motion streams decoded from input ports this frame.
    pub streams: [Signals; MAX_HW],
}

impl Default for Inputs {
    fn default() -> Self {
        Inputs {
            encoders: [0; MAX_HW],
            analog: [0.0; MAX_HW],
            digital: [false; MAX_HW],
            streams: [Signals::NONE; MAX_HW],
        }
    }
}

/// One step a channel emitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepOut {
    /// The channel's component index.
    pub channel: u8,
    /// Direction output (after inversion).
    pub forward: bool,
}

/// What a frame emits: the steps, and per output port the signals to encode on
/// the wire ([`super::wire::encode`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameOut {
    /// The steps of the frame's channels, in run order.
    pub steps: Vec<StepOut, MAX_FRAME_STEPS>,
    /// Per motion-stream output port (by hardware index), the steps to encode this frame.
    pub ports: [Signals; MAX_HW],
}

impl FrameOut {
    /// Empties it for the next frame.
    pub fn clear(&mut self) {
        self.steps.clear();
        self.ports = [Signals::NONE; MAX_HW];
    }
}

/// Everything a component may look at while it runs.
pub struct Ctx<'a, 'b, const Q: usize> {
    /// The running component's index.
    pub comp: u8,
    /// Frame time, µs (host clock).
    pub now_us: f64,
    /// Frame period, seconds.
    pub dt: f64,
    /// This frame's hardware readings.
    pub inputs: &'a Inputs,
    /// The node's segment queue, for a trajectory reader.
    pub segments: &'a Deque<Segment, Q>,
    /// Where the frame's steps and stream outputs go.
    pub out: &'a mut FrameOut,
    /// The recording tape, for a recorder or player.
    pub tape: &'a mut Tape<'b>,
}
