//! The step interrupt's outputs: step pins on GPIO0 bits 0–7, direction
//! pins on bits 8–15 (the CMSDK AHB GPIO's masked byte access: one store
//! sets one pin and leaves the others), tool outputs as duties. QEMU
//! implements no GPIO and no PWM on this machine: the stores go to the
//! GPIO block's addresses as on the FPGA board and are ignored; what the
//! pins did is counted by the step engine (`Counters`) and the duties are
//! kept in [`TOOL_DUTY`].

use crate::irq::Irq;
use crate::timer;
use core::ptr::write_volatile;
use core::sync::atomic::{AtomicU16, Ordering::Relaxed};
use motet_firmware::board::{Pins, Ticks};

const GPIO0: u32 = 0x4001_0000;
/// Masked access to bits 0–7: address offset 0x400 + (mask << 2).
const MASK_LOW: u32 = GPIO0 + 0x400;
/// Masked access to bits 8–15: address offset 0x800 + (mask << 2).
const MASK_HIGH: u32 = GPIO0 + 0x800;

/// Tool outputs' duties, 0..=65535.
pub static TOOL_DUTY: [AtomicU16; 4] = [const { AtomicU16::new(0) }; 4];

pub struct Mps2Pins;

#[inline(always)]
fn store(addr: u32, v: u32) {
    // SAFETY: a masked data address of GPIO0.
    unsafe { write_volatile(addr as *mut u32, v) }
}

impl Pins for Mps2Pins {
    #[inline(always)]
    fn now(&self) -> Ticks {
        timer::now()
    }

    #[inline(always)]
    fn step_high(&mut self, channel: u8) {
        store(MASK_LOW + ((1u32 << (channel & 7)) << 2), 0xFF);
    }

    #[inline(always)]
    fn step_low(&mut self, channel: u8) {
        store(MASK_LOW + ((1u32 << (channel & 7)) << 2), 0);
    }

    #[inline(always)]
    fn set_dir(&mut self, channel: u8, forward: bool) {
        let v = if forward { 0xFF00 } else { 0 };
        store(MASK_HIGH + ((1u32 << (channel & 7)) << 2), v);
    }

    #[inline(always)]
    fn set_tool(&mut self, output: u8, duty: u16) {
        if let Some(d) = TOOL_DUTY.get(output as usize) {
            d.store(duty, Relaxed);
        }
    }

    #[inline(always)]
    fn arm(&mut self, at: Ticks) {
        let delta = at.wrapping_sub(timer::now()) as i32;
        if delta > 1 {
            timer::compare_in(delta as u32);
        } else {
            cortex_m::peripheral::NVIC::pend(Irq::Timer1);
        }
    }

    #[inline(always)]
    fn disarm(&mut self) {
        timer::compare_off();
    }
}

/// Every step pin low, direction pins low, tools off (at start and after a
/// fault).
pub fn all_off() {
    let mut p = Mps2Pins;
    for ch in 0..8 {
        p.step_low(ch);
        p.set_dir(ch, false);
    }
    for d in TOOL_DUTY.iter() {
        d.store(0, Relaxed);
    }
}
