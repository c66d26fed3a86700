//! The two pieces of QEMU's nRF51 the measurement uses: TIMER0 as a
//! free-running 16 MHz counter (its compare channel 1 is the step
//! interrupt's alarm) and the interrupt line numbers.
//!
//! Under `-icount shift=0` every instruction advances the emulated clock
//! by 1 ns, so one tick of the 16 MHz counter is 62.5 instructions.

use core::ptr::{read_volatile, write_volatile};
use cortex_m::interrupt::InterruptNumber;

const TIMER0: usize = 0x4000_8000;
const TASKS_START: usize = TIMER0;
const TASKS_CAPTURE0: usize = TIMER0 + 0x040;
const EVENTS_COMPARE1: usize = TIMER0 + 0x144;
const INTENSET: usize = TIMER0 + 0x304;
const MODE: usize = TIMER0 + 0x504;
const BITMODE: usize = TIMER0 + 0x508;
const PRESCALER: usize = TIMER0 + 0x510;
const CC0: usize = TIMER0 + 0x540;
const CC1: usize = TIMER0 + 0x544;

/// Instructions per tick, as a fraction: 1000 ns / 16 ticks.
pub const INSTRUCTIONS_PER_TICK: (u64, u64) = (125, 2);

/// The nRF51's interrupt lines the bench uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum Irq {
    Timer0 = 8,
}

// SAFETY: TIMER0's line on the nRF51 (below its 32).
unsafe impl InterruptNumber for Irq {
    fn number(self) -> u16 {
        self as u16
    }
}

fn write(addr: usize, v: u32) {
    // SAFETY: a TIMER0 register of the nRF51.
    unsafe { write_volatile(addr as *mut u32, v) }
}

/// Starts TIMER0: timer mode, 32 bits, 16 MHz; compare 1 interrupts.
pub fn init() {
    write(MODE, 0);
    write(BITMODE, 3);
    write(PRESCALER, 0);
    write(INTENSET, 1 << 17);
    write(TASKS_START, 1);
}

/// The counter (a capture into CC[0], then its read: two accesses, as a
/// timer read on the RP2040 is one).
#[inline(always)]
pub fn now() -> u32 {
    write(TASKS_CAPTURE0, 1);
    // SAFETY: TIMER0's CC[0].
    unsafe { read_volatile(CC0 as *const u32) }
}

/// Compare 1 at `at`.
#[inline(always)]
pub fn set_compare(at: u32) {
    write(CC1, at);
}

/// Clears compare 1's event (in its interrupt).
#[inline(always)]
pub fn compare_clear() {
    write(EVENTS_COMPARE1, 0);
}

/// Ticks to instructions.
pub fn instructions(ticks: u64) -> u64 {
    ticks * INSTRUCTIONS_PER_TICK.0 / INSTRUCTIONS_PER_TICK.1
}
