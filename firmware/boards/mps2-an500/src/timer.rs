//! CMSDK APB timers at the 25 MHz system clock: Timer0 runs free as the
//! tick counter (the µs clock), Timer1 is the step interrupt's compare.

use core::ptr::{read_volatile, write_volatile};
use motet_firmware::board::Ticks;

const CTRL: u32 = 0x00;
const VALUE: u32 = 0x04;
const RELOAD: u32 = 0x08;
const INTCLEAR: u32 = 0x0C;

const ENABLE: u32 = 1 << 0;
const INT_EN: u32 = 1 << 3;

const TIMER0: u32 = 0x4000_0000;
const TIMER1: u32 = 0x4000_1000;

fn write(base: u32, off: u32, v: u32) {
    // SAFETY: a register of one of the board's CMSDK timers.
    unsafe { write_volatile((base + off) as *mut u32, v) }
}

/// Starts Timer0 counting down from 2³² − 1 for ever, and stops Timer1.
pub fn init() {
    write(TIMER0, CTRL, 0);
    write(TIMER0, RELOAD, u32::MAX);
    write(TIMER0, VALUE, u32::MAX);
    write(TIMER0, CTRL, ENABLE);
    write(TIMER1, CTRL, 0);
    write(TIMER1, RELOAD, u32::MAX);
    write(TIMER1, INTCLEAR, 1);
}

/// The tick counter: Timer0 counts down, so ticks are its complement.
#[inline(always)]
pub fn now() -> Ticks {
    // SAFETY: Timer0's value register.
    !unsafe { read_volatile((TIMER0 + VALUE) as *const u32) }
}

/// Timer1 interrupts `delta` ticks from now.
#[inline(always)]
pub fn compare_in(delta: u32) {
    write(TIMER1, VALUE, delta);
    write(TIMER1, CTRL, ENABLE | INT_EN);
}

#[inline(always)]
pub fn compare_off() {
    write(TIMER1, CTRL, 0);
}

#[inline(always)]
pub fn compare_clear() {
    write(TIMER1, INTCLEAR, 1);
}
