//! GPT1 runs free on the 24 MHz crystal (the tick counter, the µs clock);
//! its compare channel 1 is the step interrupt. Free-running mode: a
//! compare never resets the counter.

use motet_firmware::board::Ticks;
use teensy4_bsp::hal::gpt::{ClockSource, Gpt, Mode};

const GPT1: u32 = 0x401E_C000;
const SR: u32 = GPT1 + 0x08;
const IR: u32 = GPT1 + 0x0C;
const OCR1: u32 = GPT1 + 0x10;
const CNT: u32 = GPT1 + 0x24;
/// Output compare 1's flag and interrupt enable.
const OF1: u32 = 1 << 0;

/// Starts GPT1 counting the crystal's 24 MHz undivided, compare off.
pub fn init(gpt: &mut Gpt) {
    gpt.disable();
    gpt.set_clock_source(ClockSource::CrystalOscillator);
    gpt.set_divider(1);
    gpt.set_divider_24mhz(1);
    gpt.set_mode(Mode::FreeRunning);
    gpt.set_reset_on_enable(true);
    gpt.set_rollover_interrupt_enable(false);
    gpt.enable();
    compare_off();
}

#[inline(always)]
fn write(addr: u32, v: u32) {
    // SAFETY: a GPT1 register.
    unsafe { core::ptr::write_volatile(addr as *mut u32, v) }
}

/// The tick counter.
#[inline(always)]
pub fn now() -> Ticks {
    // SAFETY: GPT1's counter, read-only.
    unsafe { core::ptr::read_volatile(CNT as *const u32) }
}

/// Compare 1 at `at`. Returns false when `at` had passed by the time the
/// compare was set (the caller pends the interrupt itself).
#[inline(always)]
pub fn compare_at(at: Ticks) -> bool {
    write(OCR1, at);
    write(SR, OF1);
    write(IR, OF1);
    (at.wrapping_sub(now()) as i32) > 0
}

#[inline(always)]
pub fn compare_off() {
    write(IR, 0);
    write(SR, OF1);
}

#[inline(always)]
pub fn compare_clear() {
    write(SR, OF1);
}
