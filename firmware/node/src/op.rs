//! What the background queues for the step interrupt: one pin operation at
//! one tick. Eight bytes, so a queue of 4096 is 32 KB.

use crate::board::{Pins, Ticks};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum OpKind {
    StepHigh = 0,
    StepLow = 1,
    DirForward = 2,
    DirBackward = 3,
    Tool = 4,
}

/// A pin operation due at tick `at`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Op {
    pub at: Ticks,
    pub kind: OpKind,
    /// Channel or tool output.
    pub index: u8,
    /// Tool duty (0..=65535); 0 otherwise.
    pub arg: u16,
}

impl Op {
    pub const fn new(at: Ticks, kind: OpKind, index: u8) -> Op {
        Op {
            at,
            kind,
            index,
            arg: 0,
        }
    }

    /// Carries the operation out on `pins`.
    #[inline(always)]
    pub fn apply<P: Pins>(&self, pins: &mut P) {
        match self.kind {
            OpKind::StepHigh => pins.step_high(self.index),
            OpKind::StepLow => pins.step_low(self.index),
            OpKind::DirForward => pins.set_dir(self.index, true),
            OpKind::DirBackward => pins.set_dir(self.index, false),
            OpKind::Tool => pins.set_tool(self.index, self.arg),
        }
    }
}

/// `a` is before `b` on the wrapping tick counter (they are less than 2³¹
/// ticks apart: 85 s at 25 MHz, 7 s at 600 MHz… the queue covers ms).
#[inline(always)]
pub fn before(a: Ticks, b: Ticks) -> bool {
    (a.wrapping_sub(b) as i32) < 0
}

/// The later of two ticks.
#[inline(always)]
pub fn later(a: Ticks, b: Ticks) -> Ticks {
    if before(a, b) {
        b
    } else {
        a
    }
}
