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
    pub steps: Vec<StepOut, MAX_FRAME_STEPS>,
    pub ports: [Signals; MAX_HW],
}

impl FrameOut {
    pub fn clear(&mut self) {
        self.steps.clear();
        self.ports = [Signals::NONE; MAX_HW];
    }
}

/// Everything a component may look at while it runs.
pub struct Ctx<'a, 'b, const Q: usize> {
    pub comp: u8,
    /// Frame time, µs (host clock).
    pub now_us: f64,
    /// Frame period, seconds.
    pub dt: f64,
    pub inputs: &'a Inputs,
    pub segments: &'a Deque<Segment, Q>,
    pub out: &'a mut FrameOut,
    pub tape: &'a mut Tape<'b>,
}
