//! The step interrupt's side (`Pins`): step and direction edges through
//! the SIO's set and clear registers (one store each), tool duties into a
//! PWM slice's compare register, and alarm 0 of the 1 MHz timer.

use crate::pin_table::{pwm_of, DIR_MASK, STEP_MASK, TOOL};
use crate::regs::{self, read, write};
use motet_firmware::board::{Pins, Ticks};
use rp2040_hal::pac::{Interrupt, NVIC};

/// The pins; a unit value: the registers are the state.
pub struct PicoPins;

impl Pins for PicoPins {
    #[inline(always)]
    fn now(&self) -> Ticks {
        read(regs::TIMER_RAWL)
    }

    #[inline(always)]
    fn step_high(&mut self, channel: u8) {
        if let Some(&m) = STEP_MASK.get(channel as usize) {
            write(regs::SIO_GPIO_OUT_SET, m);
        }
    }

    #[inline(always)]
    fn step_low(&mut self, channel: u8) {
        if let Some(&m) = STEP_MASK.get(channel as usize) {
            write(regs::SIO_GPIO_OUT_CLR, m);
        }
    }

    #[inline(always)]
    fn set_dir(&mut self, channel: u8, forward: bool) {
        if let Some(&m) = DIR_MASK.get(channel as usize) {
            let reg = if forward {
                regs::SIO_GPIO_OUT_SET
            } else {
                regs::SIO_GPIO_OUT_CLR
            };
            write(reg, m);
        }
    }

    fn set_tool(&mut self, output: u8, duty: u16) {
        if let Some(&gpio) = TOOL.get(output as usize) {
            set_duty(gpio, duty);
        }
    }

    #[inline(always)]
    fn arm(&mut self, at: Ticks) {
        // The alarm fires when the counter equals it: one that is already
        // behind would wait for the counter to wrap, so pend at once.
        write(regs::TIMER_ALARM0, at);
        if (at.wrapping_sub(read(regs::TIMER_RAWL)) as i32) <= 0 {
            NVIC::pend(Interrupt::TIMER_IRQ_0);
        }
    }

    fn disarm(&mut self) {
        write(regs::TIMER_ARMED, 1);
    }
}

/// A tool output's duty (0..=65535 of the slice's 65535 top).
pub fn set_duty(gpio: u8, duty: u16) {
    let (slice, ch) = pwm_of(gpio);
    let cc = regs::pwm_cc(slice);
    let shift = 16 * ch as u32;
    write(cc, (read(cc) & !(0xffff << shift)) | (duty as u32) << shift);
}

/// Every step, direction and tool output low (a fault, a restart).
pub fn all_off() {
    let mut m = 0;
    for s in STEP_MASK.iter().chain(DIR_MASK.iter()) {
        m |= s;
    }
    write(regs::SIO_GPIO_OUT_CLR, m);
    for &t in &TOOL {
        set_duty(t, 0);
    }
}

/// Sets every pin of the pin table to its function (IO_BANK0 and
/// PADS_BANK0 must be out of reset): step, direction and LED as SIO
/// outputs, low; the button as an input with its pull-up; the analog pins
/// with their digital input off; the tool pins to their PWM slice.
pub fn configure() {
    use crate::pin_table::{ANALOG, BUTTON, DIR, LED, STEP};
    let outputs = STEP.iter().chain(DIR.iter()).chain(core::iter::once(&LED));
    let mut oe = 0;
    for &g in outputs {
        oe |= 1 << g;
        write(regs::pad(g), regs::PAD_DRIVE_4MA | regs::PAD_SCHMITT);
        write(regs::gpio_ctrl(g), regs::FUNC_SIO);
    }
    write(regs::SIO_GPIO_OUT_CLR, oe);
    write(regs::SIO_GPIO_OE_SET, oe);
    write(
        regs::pad(BUTTON),
        regs::PAD_IE | regs::PAD_PUE | regs::PAD_SCHMITT,
    );
    write(regs::gpio_ctrl(BUTTON), regs::FUNC_SIO);
    for &g in &ANALOG {
        write(regs::pad(g), regs::PAD_OD);
        write(regs::gpio_ctrl(g), regs::FUNC_NULL);
    }
    for &g in &TOOL {
        write(regs::pad(g), regs::PAD_DRIVE_4MA);
        write(regs::gpio_ctrl(g), regs::FUNC_PWM);
    }
}
