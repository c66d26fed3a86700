//! The background half of the step engine: the node's outputs, at host
//! times, become pin operations at local ticks in the step queue.
//!
//! Per step: the time is converted to a tick through the host's clock
//! model; a change of direction puts the direction edge the channel's
//! set-up time before the step (never while the previous pulse is high);
//! the step's rising edge waits, if it must, for the set-up time and for
//! the channel's minimum low time after the previous pulse; the falling
//! edge follows one pulse width later. The node hands outputs over in time
//! order, but a direction edge goes before the step it belongs to and a
//! falling edge after it, so operations wait in a small buffer sorted by
//! tick until no later output can come before them, then enter the queue.

use crate::board::Ticks;
use crate::clock::HostToTicks;
use crate::op::{before, later, Op, OpKind};
use crate::ring::Producer;
use motet_node::MAX_CHANNELS;

/// Operations held back for ordering (a power of two: the hold buffer is a
/// ring). Each channel has at most three in flight (direction, rising and
/// falling edge) within its set-up time; a poll's slice adds the rest.
const HELD: usize = 64;

/// A channel's pulse timing in ticks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timing {
    /// Step pulse width, and the least low time between pulses.
    pub pulse: Ticks,
    /// Direction set-up time before a rising edge.
    pub dir_setup: Ticks,
}

impl Timing {
    /// From µs (as the machine file gives them), rounded up to whole ticks,
    /// at least one.
    pub fn from_us(pulse_us: f32, dir_setup_us: f32, ticks_per_us: u32) -> Timing {
        let ticks = |us: f32| -> Ticks {
            let t = us * ticks_per_us as f32;
            let whole = t as Ticks;
            let up = if (whole as f32) < t { whole + 1 } else { whole };
            up.max(1)
        };
        Timing {
            pulse: ticks(pulse_us),
            dir_setup: ticks(dir_setup_us),
        }
    }
}

/// Defaults for channels the host did not time (graph channels): 2 µs
/// pulses, 1 µs set-up, what common drivers (A4988, DRV8825) need.
pub const DEFAULT_PULSE_US: f32 = 2.0;
pub const DEFAULT_DIR_SETUP_US: f32 = 1.0;

#[derive(Clone, Copy, Debug)]
struct Chan {
    timing: Timing,
    /// Direction output as last queued: 1 forward, 0 backward, 2 before
    /// the first step (a plain byte: this is read on every step).
    forward: u8,
    /// Falling edge of the last pulse, valid once `forward` is set.
    last_low: Ticks,
}

/// What the background did, for diagnostics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScheduleStats {
    pub steps: u32,
    pub tool_changes: u32,
    /// Steps whose rising edge had to wait for the set-up or low time.
    pub delayed: u32,
    /// The longest such wait, ticks.
    pub max_delay: Ticks,
    /// Operations lost because both the queue and the hold buffer were
    /// full (the main loop keeps room: never in a working build).
    pub lost: u32,
}

/// The producer half of the step engine.
pub struct Scheduler<'q> {
    queue: Producer<'q>,
    chans: [Chan; MAX_CHANNELS],
    held: Held,
    /// The longest set-up time of any channel: how far back an operation
    /// can land before the output that caused it.
    max_setup: Ticks,
    ticks_per_us: u32,
    stats: ScheduleStats,
}

impl<'q> Scheduler<'q> {
    pub fn new(queue: Producer<'q>, ticks_per_us: u32) -> Self {
        let t = Timing::from_us(DEFAULT_PULSE_US, DEFAULT_DIR_SETUP_US, ticks_per_us);
        Scheduler {
            queue,
            chans: [Chan {
                timing: t,
                forward: 2,
                last_low: 0,
            }; MAX_CHANNELS],
            held: Held::new(),
            max_setup: t.dir_setup,
            ticks_per_us,
            stats: ScheduleStats::default(),
        }
    }

    pub fn stats(&self) -> ScheduleStats {
        self.stats
    }

    /// Sets a channel's timing (from its configuration on the wire).
    pub fn set_timing(&mut self, channel: u8, pulse_us: f32, dir_setup_us: f32) {
        let t = Timing::from_us(pulse_us, dir_setup_us, self.ticks_per_us);
        if let Some(c) = self.chans.get_mut(channel as usize) {
            c.timing = t;
        }
        self.max_setup = self
            .chans
            .iter()
            .map(|c| c.timing.dir_setup)
            .max()
            .unwrap_or(0);
    }

    pub fn timing(&self, channel: u8) -> Option<Timing> {
        self.chans.get(channel as usize).map(|c| c.timing)
    }

    /// Places in the queue still free.
    pub fn room(&self) -> usize {
        self.queue.capacity() - self.queue.len()
    }

    /// Operations queued for the interrupt.
    pub fn queued(&self) -> usize {
        self.queue.len()
    }

    /// Operations waiting here for their turn.
    pub fn held(&self) -> usize {
        self.held.len
    }

    /// The node's outputs converted with `clock`, as a `motet_node::Board`.
    pub fn outputs<'s>(&'s mut self, clock: HostToTicks) -> Outputs<'s, 'q> {
        Outputs { sched: self, clock }
    }

    /// Moves every held operation before tick `horizon` into the queue:
    /// call with the tick of the time the node has run up to, less nothing
    /// (the set-up time is accounted for here).
    pub fn release(&mut self, ran_to: Ticks) {
        let horizon = ran_to.wrapping_sub(self.max_setup);
        self.release_before(horizon);
    }

    fn release_before(&mut self, horizon: Ticks) {
        // A batch under one release store: the interrupt sees them together.
        let mut room = self.queue.room();
        while room > 0 {
            let Some(op) = self.held.first() else {
                break;
            };
            if !before(op.at, horizon) {
                break;
            }
            self.queue.put_unpublished(op);
            self.held.pop();
            room -= 1;
        }
        self.queue.publish();
    }

    /// Holds `op` in tick order.
    #[inline]
    fn hold(&mut self, op: Op) {
        if self.held.len == HELD {
            // Out of room: the earliest goes to the queue now.
            if let Some(first) = self.held.first() {
                if self.queue.push(first).is_err() {
                    self.stats.lost += 1;
                }
            }
            self.held.pop();
        }
        self.held.insert(op);
    }

    /// A step on `channel` at tick `t`.
    #[inline]
    pub fn step(&mut self, channel: u8, forward: bool, t: Ticks) {
        let Some(c) = self.chans.get(channel as usize).copied() else {
            return;
        };
        let started = c.forward != 2;
        let mut rise = t;
        if started {
            rise = later(rise, c.last_low.wrapping_add(c.timing.pulse));
        }
        let mut dir = None;
        if c.forward != forward as u8 {
            let mut at = t.wrapping_sub(c.timing.dir_setup);
            if started {
                at = later(at, c.last_low);
            }
            rise = later(rise, at.wrapping_add(c.timing.dir_setup));
            dir = Some(at);
        }
        if rise != t {
            self.stats.delayed += 1;
            self.stats.max_delay = self.stats.max_delay.max(rise.wrapping_sub(t));
        }
        let low = rise.wrapping_add(c.timing.pulse);
        if let Some(at) = dir {
            let kind = if forward {
                OpKind::DirForward
            } else {
                OpKind::DirBackward
            };
            self.hold(Op::new(at, kind, channel));
        }
        self.hold(Op::new(rise, OpKind::StepHigh, channel));
        self.hold(Op::new(low, OpKind::StepLow, channel));
        let ch = &mut self.chans[channel as usize];
        ch.forward = forward as u8;
        ch.last_low = low;
        self.stats.steps += 1;
    }

    /// Tool output `output` to `value` (clamped to 0..=1 of full scale) at
    /// tick `t`.
    pub fn tool(&mut self, output: u8, value: f32, t: Ticks) {
        let v = if value.is_nan() {
            0.0
        } else {
            value.clamp(0.0, 1.0)
        };
        let mut op = Op::new(t, OpKind::Tool, output);
        op.arg = (v * 65535.0 + 0.5) as u16;
        self.hold(op);
        self.stats.tool_changes += 1;
    }
}

/// Operations held back, in tick order, in a ring: the earliest leaves
/// from the front at no cost, and an operation comes in from the back,
/// shifting only those due after it (few: outputs come nearly in order).
struct Held {
    ops: [Op; HELD],
    head: usize,
    len: usize,
}

impl Held {
    const fn new() -> Held {
        Held {
            ops: [Op::new(0, OpKind::StepLow, 0); HELD],
            head: 0,
            len: 0,
        }
    }

    #[inline(always)]
    fn slot(&self, i: usize) -> usize {
        (self.head + i) & (HELD - 1)
    }

    fn first(&self) -> Option<Op> {
        (self.len > 0).then(|| self.ops[self.head])
    }

    fn pop(&mut self) {
        if self.len > 0 {
            self.head = (self.head + 1) & (HELD - 1);
            self.len -= 1;
        }
    }

    /// Puts `op` after every operation not later than it; there must be
    /// room.
    #[inline]
    fn insert(&mut self, op: Op) {
        let mut i = self.len;
        while i > 0 {
            let prev = self.ops[self.slot(i - 1)];
            if !before(op.at, prev.at) {
                break;
            }
            let to = self.slot(i);
            self.ops[to] = prev;
            i -= 1;
        }
        let at = self.slot(i);
        self.ops[at] = op;
        self.len += 1;
    }
}

const _: () = assert!(HELD.is_power_of_two());

/// The node's `Board` while the background polls it: every output goes to
/// the scheduler at its tick.
pub struct Outputs<'s, 'q> {
    sched: &'s mut Scheduler<'q>,
    clock: HostToTicks,
}

impl motet_node::Board for Outputs<'_, '_> {
    fn step(&mut self, channel: u8, forward: bool, at_us: f64) {
        let t = self.clock.ticks(at_us);
        self.sched.step(channel, forward, t);
    }

    fn set_tool(&mut self, output: u8, value: f32, at_us: f64) {
        let t = self.clock.ticks(at_us);
        self.sched.tool(output, value, t);
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::ring::{Consumer, Ring};
    use std::vec::Vec as StdVec;

    fn drain(q: &mut Consumer<'_>) -> StdVec<Op> {
        let mut v = StdVec::new();
        while let Some(op) = q.front() {
            q.pop();
            v.push(op);
        }
        v
    }

    #[test]
    fn edges_are_spaced_by_pulse_and_setup() {
        let q: Ring<256> = Ring::new();
        let (p, mut c) = q.split().unwrap();
        // 10 ticks per µs: 2 µs pulse = 20 ticks, 1 µs set-up = 10.
        let mut s = Scheduler::new(p, 10);
        s.set_timing(0, 2.0, 1.0);
        s.set_timing(1, 5.0, 3.0);
        // (channel, forward, tick)
        let steps = [
            (0, true, 1000),
            (1, false, 1005),
            (0, true, 1030),  // too soon: waits for 20 low ticks (1040)
            (0, false, 1100), // reversal: dir at 1090, rise at 1100
            (1, true, 1040),  // reversal too soon after its pulse (low at 1055)
        ];
        for (ch, f, t) in steps {
            s.step(ch, f, t);
        }
        s.release(5000);
        let ops = drain(&mut c);
        let want = [
            Op::new(975, OpKind::DirBackward, 1),
            Op::new(990, OpKind::DirForward, 0),
            Op::new(1000, OpKind::StepHigh, 0),
            Op::new(1005, OpKind::StepHigh, 1),
            Op::new(1020, OpKind::StepLow, 0),
            Op::new(1040, OpKind::StepHigh, 0),
            Op::new(1055, OpKind::StepLow, 1),
            Op::new(1055, OpKind::DirForward, 1),
            Op::new(1060, OpKind::StepLow, 0),
            Op::new(1090, OpKind::DirBackward, 0),
            Op::new(1100, OpKind::StepHigh, 0),
            Op::new(1105, OpKind::StepHigh, 1),
            Op::new(1120, OpKind::StepLow, 0),
            Op::new(1155, OpKind::StepLow, 1),
        ];
        assert_eq!(ops, want);
        let st = s.stats();
        assert_eq!((st.steps, st.delayed, st.max_delay), (5, 2, 65));
    }

    #[test]
    fn nothing_is_released_that_a_later_output_could_precede() {
        let q: Ring<64> = Ring::new();
        let (p, mut c) = q.split().unwrap();
        let mut s = Scheduler::new(p, 10);
        s.set_timing(0, 2.0, 1.0);
        s.step(0, true, 100);
        // Run up to tick 105: a later step's direction edge may land at 95,
        // so only what comes before it is final.
        s.release(105);
        assert_eq!(drain(&mut c), [Op::new(90, OpKind::DirForward, 0)]);
        s.release(125);
        assert_eq!(drain(&mut c), [Op::new(100, OpKind::StepHigh, 0)]);
        s.release(131);
        assert_eq!(drain(&mut c), [Op::new(120, OpKind::StepLow, 0)]);
    }

    #[test]
    fn ticks_wrap() {
        let q: Ring<64> = Ring::new();
        let (p, mut c) = q.split().unwrap();
        let mut s = Scheduler::new(p, 10);
        s.set_timing(0, 2.0, 1.0);
        let t = u32::MAX - 5;
        s.step(0, true, t);
        s.step(0, true, t.wrapping_add(40));
        s.release(t.wrapping_add(1000));
        let ops = drain(&mut c);
        assert_eq!(ops.len(), 5);
        for w in ops.windows(2) {
            assert!(before(w[0].at, w[1].at), "{ops:?}");
        }
    }
}
