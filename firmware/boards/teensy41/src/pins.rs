//! The step interrupt's outputs: step and direction through the fast GPIO
//! ports (one store to `DR_SET` or `DR_CLEAR` per edge), the drivers'
//! shared enable, and the tool outputs on FlexPWM3 submodule 1 as servo
//! pulses (50 Hz, 1–2 ms).

use crate::pinmap::{GpioPin, DIR, ENABLE, STEP, TOOLS};
use crate::timer;
use core::ptr::write_volatile;
use cortex_m::peripheral::NVIC;
use motet_firmware::board::{Pins, Ticks};
use teensy4_bsp::hal::flexpwm::{
    Channel, ClockSelect, Mask, PairOperation, Prescaler, Pwm, ValueRegister, SM,
};
use teensy4_bsp::ral::Interrupt;

/// FlexPWM counts the 150 MHz IPG clock / 128: 1.171875 MHz.
const PWM_HZ: u32 = 150_000_000 / 128;
/// One 50 Hz period (20 ms), in PWM counts.
const PERIOD: i16 = (PWM_HZ / 50) as i16;
/// 1 ms, the servo's pulse at duty 0 (2 ms at full duty).
const MS: u32 = PWM_HZ / 1000;
const SUBMODULE: SM = SM::SM1;

#[inline(always)]
fn store(addr: u32, v: u32) {
    // SAFETY: a fast GPIO port's DR_SET or DR_CLEAR: a 1 bit changes that
    // pin only.
    unsafe { write_volatile(addr as *mut u32, v) }
}

#[inline(always)]
fn high(p: &GpioPin) {
    store(p.set_addr(), p.mask());
}

#[inline(always)]
fn low(p: &GpioPin) {
    store(p.clear_addr(), p.mask());
}

/// The servo pulse for `duty` (0..=65535 of full travel), in PWM counts.
pub const fn servo_counts(duty: u16) -> i16 {
    (MS + MS * duty as u32 / 65535) as i16
}

pub struct TeensyPins {
    pwm: Pwm,
}

impl TeensyPins {
    /// Takes FlexPWM3 (its pads are muxed by `board`): submodule 1 at
    /// 50 Hz, outputs A and B on, no pulse yet.
    pub fn new(mut pwm: Pwm) -> TeensyPins {
        pwm.set_run(Mask::empty());
        pwm.set_clock_select(SUBMODULE, ClockSelect::Ipg);
        pwm.set_prescaler(SUBMODULE, Prescaler::Prescaler128);
        pwm.set_pair_operation(SUBMODULE, PairOperation::Independent);
        pwm.set_debug_enable(SUBMODULE, true);
        pwm.set_wait_enable(SUBMODULE, true);
        pwm.set_initial_count(SUBMODULE, 0);
        pwm.set_value(SUBMODULE, ValueRegister::Val1, PERIOD - 1);
        for ch in [Channel::A, Channel::B] {
            pwm.set_turn_on(SUBMODULE, ch, 0);
            pwm.set_turn_off(SUBMODULE, ch, 0);
            pwm.set_output_enable(Mask::SM1, ch);
        }
        pwm.set_load_ok(Mask::SM1);
        pwm.set_run(Mask::SM1);
        TeensyPins { pwm }
    }

    fn pulse(&mut self, output: u8, counts: i16) {
        let Some(t) = TOOLS.get(output as usize) else {
            return;
        };
        let ch = if t.b { Channel::B } else { Channel::A };
        self.pwm.set_turn_off(SUBMODULE, ch, counts);
        self.pwm.set_load_ok(Mask::SM1);
    }

    /// Step pins low, tools without pulses, drivers disabled.
    pub fn all_off(&mut self) {
        gpio_off();
        for t in 0..TOOLS.len() as u8 {
            self.pulse(t, 0);
        }
    }
}

/// Step pins low and the drivers disabled (EN high): what a fault leaves.
/// Only GPIO stores, safe from any context.
pub fn gpio_off() {
    for p in &STEP {
        low(p);
    }
    high(&ENABLE);
}

impl Pins for TeensyPins {
    #[inline(always)]
    fn now(&self) -> Ticks {
        timer::now()
    }

    #[inline(always)]
    fn step_high(&mut self, channel: u8) {
        if let Some(p) = STEP.get(channel as usize) {
            high(p);
        }
    }

    #[inline(always)]
    fn step_low(&mut self, channel: u8) {
        if let Some(p) = STEP.get(channel as usize) {
            low(p);
        }
    }

    #[inline(always)]
    fn set_dir(&mut self, channel: u8, forward: bool) {
        if let Some(p) = DIR.get(channel as usize) {
            if forward {
                high(p)
            } else {
                low(p)
            }
        }
    }

    fn set_tool(&mut self, output: u8, duty: u16) {
        self.pulse(output, servo_counts(duty));
    }

    #[inline(always)]
    fn arm(&mut self, at: Ticks) {
        if !timer::compare_at(at) {
            NVIC::pend(Interrupt::GPT1);
        }
    }

    #[inline(always)]
    fn disarm(&mut self) {
        timer::compare_off();
    }
}

const _: () = assert!(PERIOD as u32 == PWM_HZ / 50 && PWM_HZ / 50 < i16::MAX as u32);
const _: () = assert!(servo_counts(0) as u32 == MS && servo_counts(65535) as u32 == 2 * MS);
