//! The step queue: a lock-free single-producer single-consumer ring of
//! [`Op`]s between the background (producer) and the step interrupt
//! (consumer).
//!
//! `heapless::spsc` does the same job; this one exists for the interrupt's
//! cost per operation (measured in docs/firmware.md): the consumer keeps
//! its own copy of the head and of the last tail it saw, so taking an
//! operation reads the ring's shared indices only when its copy says the
//! ring is empty, and the capacity is a power of two (a mask, not a
//! division).

use crate::op::Op;
use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

/// A ring of `N` operations (`N` a power of two).
pub struct Ring<const N: usize> {
    slots: [UnsafeCell<Op>; N],
    /// Operations taken (the consumer's).
    head: AtomicU32,
    /// Operations put (the producer's).
    tail: AtomicU32,
    split: AtomicBool,
}

// SAFETY: a slot is written only by the producer while it is outside
// `head..tail` (free), and read only by the consumer while it is inside
// (published by the Release store of `tail`, seen with an Acquire load);
// each index has one writer.
unsafe impl<const N: usize> Sync for Ring<N> {}

impl<const N: usize> Default for Ring<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Ring<N> {
    const CHECK: () = assert!(N.is_power_of_two() && N <= 1 << 30);

    pub const fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let _ = Self::CHECK;
        Ring {
            // All zero bytes: a ring in a static lands in .bss, not in the image.
            slots: [const { UnsafeCell::new(Op::new(0, crate::op::OpKind::StepHigh, 0)) }; N],
            head: AtomicU32::new(0),
            tail: AtomicU32::new(0),
            split: AtomicBool::new(false),
        }
    }

    /// The two halves; once only (None after), so that each index keeps
    /// one writer.
    pub fn split(&self) -> Option<(Producer<'_>, Consumer<'_>)> {
        // A critical section, not `swap`: ARMv6-M (the Pico's Cortex-M0+)
        // has no compare-and-swap; the queue itself needs only loads and
        // stores. Each board brings its critical section (one core: masking
        // interrupts; the RP2040: a hardware spinlock too).
        let taken = critical_section::with(|_| {
            let taken = self.split.load(Ordering::Acquire);
            self.split.store(true, Ordering::Release);
            taken
        });
        if taken {
            return None;
        }
        let head = self.head.load(Ordering::Acquire);
        let tail = self.tail.load(Ordering::Acquire);
        Some((
            Producer {
                slots: &self.slots,
                head: &self.head,
                tail: &self.tail,
                put: tail,
                seen_head: head,
            },
            Consumer {
                slots: &self.slots,
                head: &self.head,
                tail: &self.tail,
                taken: head,
                seen_tail: tail,
            },
        ))
    }
}

// SAFETY: a half may move to the context that uses it (the interrupt, or
// another thread in tests): it writes only its own index and, for the
// producer, only free slots.
unsafe impl Send for Producer<'_> {}
unsafe impl Send for Consumer<'_> {}

/// The background's half.
pub struct Producer<'r> {
    slots: &'r [UnsafeCell<Op>],
    head: &'r AtomicU32,
    tail: &'r AtomicU32,
    put: u32,
    seen_head: u32,
}

impl Producer<'_> {
    pub fn capacity(&self) -> usize {
        self.slots.len()
    }

    /// Operations in the ring (the consumer may have taken some since).
    pub fn len(&self) -> usize {
        self.put.wrapping_sub(self.head.load(Ordering::Acquire)) as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Puts `op` at the back; gives it back when the ring is full.
    pub fn push(&mut self, op: Op) -> Result<(), Op> {
        let n = self.slots.len() as u32;
        if self.put.wrapping_sub(self.seen_head) == n {
            self.seen_head = self.head.load(Ordering::Acquire);
            if self.put.wrapping_sub(self.seen_head) == n {
                return Err(op);
            }
        }
        let slot = &self.slots[(self.put & (n - 1)) as usize];
        // SAFETY: the slot is free (outside head..tail): the consumer does
        // not read it until the tail below is published.
        unsafe { *slot.get() = op };
        self.put = self.put.wrapping_add(1);
        self.tail.store(self.put, Ordering::Release);
        Ok(())
    }
}

impl Producer<'_> {
    /// Room for how many more operations (the consumer may free more
    /// meanwhile).
    #[inline]
    pub fn room(&mut self) -> usize {
        let n = self.slots.len() as u32;
        if self.put.wrapping_sub(self.seen_head) == n {
            self.seen_head = self.head.load(Ordering::Acquire);
        }
        (n - self.put.wrapping_sub(self.seen_head)) as usize
    }

    /// Puts `op` at the back without publishing it: the consumer sees it
    /// at the next [`Producer::publish`] (or [`Producer::push`]). There
    /// must be room ([`Producer::room`]).
    #[inline]
    pub fn put_unpublished(&mut self, op: Op) {
        let n = self.slots.len() as u32;
        debug_assert!(self.put.wrapping_sub(self.seen_head) < n);
        let slot = &self.slots[(self.put & (n - 1)) as usize];
        // SAFETY: the caller made sure of room, so the slot is free
        // (outside head..tail): the consumer does not read it until the
        // tail is published.
        unsafe { *slot.get() = op };
        self.put = self.put.wrapping_add(1);
    }

    /// Publishes every operation put: one release store for a batch.
    #[inline]
    pub fn publish(&mut self) {
        self.tail.store(self.put, Ordering::Release);
    }
}

/// The interrupt's half.
pub struct Consumer<'r> {
    slots: &'r [UnsafeCell<Op>],
    head: &'r AtomicU32,
    tail: &'r AtomicU32,
    taken: u32,
    seen_tail: u32,
}

impl Consumer<'_> {
    /// The front operation, if any.
    #[inline(always)]
    pub fn front(&mut self) -> Option<Op> {
        if self.taken == self.seen_tail {
            self.seen_tail = self.tail.load(Ordering::Acquire);
            if self.taken == self.seen_tail {
                return None;
            }
        }
        let mask = self.slots.len() as u32 - 1;
        // SAFETY: inside head..tail: written and published by the producer,
        // which does not touch it until the head moves past it.
        Some(unsafe { *self.slots.get_unchecked((self.taken & mask) as usize).get() })
    }

    /// Drops the front operation (after [`Consumer::front`] gave one).
    #[inline(always)]
    pub fn pop(&mut self) {
        self.taken = self.taken.wrapping_add(1);
        self.head.store(self.taken, Ordering::Release);
    }

    /// Takes operations from the front while `f` accepts them (`f` gets
    /// each one before it is taken; returning false leaves it at the
    /// front). Returns true when the ring ran dry. The indices stay in
    /// registers for the whole run: the interrupt's loop.
    #[inline(always)]
    pub fn take_while(&mut self, mut f: impl FnMut(&Op) -> bool) -> bool {
        let mask = self.slots.len() as u32 - 1;
        let mut taken = self.taken;
        let mut seen = self.seen_tail;
        let dry = loop {
            if taken == seen {
                seen = self.tail.load(Ordering::Acquire);
                if taken == seen {
                    break true;
                }
            }
            // SAFETY: inside head..tail (see `front`).
            let op = unsafe { *self.slots.get_unchecked((taken & mask) as usize).get() };
            if !f(&op) {
                break false;
            }
            taken = taken.wrapping_add(1);
            self.head.store(taken, Ordering::Release);
        };
        self.taken = taken;
        self.seen_tail = seen;
        dry
    }

    pub fn len(&self) -> usize {
        self.tail.load(Ordering::Acquire).wrapping_sub(self.taken) as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::op::OpKind;

    #[test]
    fn fifo_full_and_wrapping() {
        let ring: Ring<8> = Ring::new();
        let (mut p, mut c) = ring.split().unwrap();
        assert!(ring.split().is_none());
        let op = |i: u32| Op::new(i, OpKind::StepHigh, (i % 8) as u8);
        let mut next_in = 0;
        let mut next_out = 0;
        for round in 0..100u32 {
            // Fill to the brim, then take some: indices wrap many times.
            while p.push(op(next_in)).is_ok() {
                next_in += 1;
            }
            assert_eq!(p.len(), 8);
            for _ in 0..(round % 8 + 1) {
                assert_eq!(c.front(), Some(op(next_out)));
                c.pop();
                next_out += 1;
            }
        }
        while let Some(o) = c.front() {
            assert_eq!(o, op(next_out));
            c.pop();
            next_out += 1;
        }
        assert_eq!(next_in, next_out);
        assert!(c.is_empty() && p.is_empty());
    }

    #[test]
    fn a_producer_and_a_consumer_on_two_threads() {
        static RING: Ring<64> = Ring::new();
        let (mut p, mut c) = RING.split().unwrap();
        let n = 200_000u32;
        std::thread::scope(|s| {
            s.spawn(move || {
                for i in 0..n {
                    let mut o = Op::new(i, OpKind::Tool, 1);
                    while let Err(back) = p.push(o) {
                        o = back;
                        std::hint::spin_loop();
                    }
                }
            });
            let mut want = 0;
            while want < n {
                if let Some(o) = c.front() {
                    assert_eq!(o.at, want);
                    c.pop();
                    want += 1;
                }
            }
        });
    }
}
