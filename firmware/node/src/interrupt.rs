//! The step timer's interrupt: the consumer half of the step engine.
//!
//! Per operation it reads the queue's head, waits (spinning) when the head
//! is due within a few ticks, or else sets the timer's compare to the head's
//! tick and returns; a due operation drives its pin and leaves the queue.
//! A step costs two operations (the rising and the falling edge of its
//! pulse) and a third when the direction changes. Nothing here computes a
//! step time: the background solved it, converted it to a tick and spaced
//! the edges by the channel's pulse width and direction set-up time.

use crate::board::{Pins, Ticks};
use crate::op::OpKind;
use crate::ring::Consumer;
use core::sync::atomic::{AtomicU32, Ordering::Relaxed};
use motet_node::MAX_CHANNELS;

/// What the interrupt did, for the background and for diagnostics. Only
/// the interrupt writes these (plain loads and stores, no read-modify-write
/// atomics needed on a single core).
#[derive(Debug, Default)]
pub struct Counters {
    /// Rising edges per channel: the steps the pins made.
    pub pulses: [AtomicU32; MAX_CHANNELS],
    pub tool_changes: AtomicU32,
    /// Operations carried out more than `late` ticks after their tick (the
    /// queue ran dry or the interrupt was held off).
    pub late: AtomicU32,
    /// The latest of those, ticks.
    pub max_late: AtomicU32,
}

impl Counters {
    pub const fn new() -> Counters {
        Counters {
            pulses: [const { AtomicU32::new(0) }; MAX_CHANNELS],
            tool_changes: AtomicU32::new(0),
            late: AtomicU32::new(0),
            max_late: AtomicU32::new(0),
        }
    }

    /// Pulses per channel so far.
    pub fn pulses(&self) -> [u32; MAX_CHANNELS] {
        core::array::from_fn(|i| self.pulses[i].load(Relaxed))
    }

    #[inline(always)]
    fn bump(c: &AtomicU32) {
        c.store(c.load(Relaxed).wrapping_add(1), Relaxed);
    }

    /// Off the common path: an operation `by` ticks late.
    #[inline(never)]
    #[cold]
    fn note_late(&self, by: u32) {
        Self::bump(&self.late);
        if by > self.max_late.load(Relaxed) {
            self.max_late.store(by, Relaxed);
        }
    }
}

/// The interrupt's state: the queue's consumer half and its counters.
pub struct StepInterrupt<'q> {
    queue: Consumer<'q>,
    counters: &'q Counters,
    /// An operation due within this many ticks is waited for here rather
    /// than through another interrupt (entry and exit cost more).
    spin: Ticks,
    /// An operation this many ticks past its tick counts as late.
    late: Ticks,
}

impl<'q> StepInterrupt<'q> {
    pub fn new(queue: Consumer<'q>, counters: &'q Counters, spin: Ticks, late: Ticks) -> Self {
        StepInterrupt {
            queue,
            counters,
            spin,
            late,
        }
    }

    /// The interrupt handler's body: carries out every operation due now
    /// and arms the timer for the next.
    #[inline]
    pub fn run<P: Pins>(&mut self, pins: &mut P) {
        let (spin, late, counters) = (self.spin, self.late, self.counters);
        let mut next = 0;
        let dry = self.queue.take_while(|op| {
            let wait = op.at.wrapping_sub(pins.now()) as i32;
            if wait > 0 {
                if wait as u32 > spin {
                    next = op.at;
                    return false;
                }
                while (op.at.wrapping_sub(pins.now()) as i32) > 0 {}
            } else if (wait.unsigned_abs()) > late {
                counters.note_late(wait.unsigned_abs());
            }
            match op.kind {
                OpKind::StepHigh => {
                    pins.step_high(op.index);
                    Counters::bump(&counters.pulses[(op.index & 7) as usize]);
                }
                OpKind::StepLow => pins.step_low(op.index),
                OpKind::DirForward => pins.set_dir(op.index, true),
                OpKind::DirBackward => pins.set_dir(op.index, false),
                OpKind::Tool => {
                    pins.set_tool(op.index, op.arg);
                    Counters::bump(&counters.tool_changes);
                }
            }
            true
        });
        if dry {
            pins.disarm();
        } else {
            pins.arm(next);
        }
    }
}
