//! The Pico as the node application sees it (`Board`): the USB link, the
//! 1 MHz timer (alarm 1 wakes the sleeping main loop), the QSPI flash, the
//! LED and button through the SIO, the ADC, and a watchdog reset into the
//! bootloader.

use crate::flash::QspiFlash;
use crate::layout::{BOARD, LAYOUT, TICKS_PER_US};
use crate::pin_table::{self, adc_of, ANALOG, BUTTON, LED};
use crate::regs::{self, read, write};
use crate::usb;
use core::sync::atomic::Ordering::Relaxed;
use motet_firmware::board::{Board, Inputs, Layout, Ticks};
use rp2040_hal::pac::{Interrupt, NVIC};

pub struct Pico {
    uid: u64,
}

impl Pico {
    /// The board, once its clocks, pins, USB and flash are set up (the
    /// application's `main` does that with the HAL).
    pub fn new(uid: u64) -> Pico {
        // Alarm 1 ends a sleep; its interrupt only clears itself.
        write(regs::TIMER_INTE, read(regs::TIMER_INTE) | 0b10);
        // SAFETY: the handler is the binary's (`TIMER_IRQ_1`).
        unsafe { NVIC::unmask(Interrupt::TIMER_IRQ_1) };
        Pico { uid }
    }
}

/// Alarm 1's interrupt: the main loop's wake-up.
pub fn on_alarm1() {
    write(regs::TIMER_INTR, 0b10);
}

fn adc_read(input: u8) -> u16 {
    // AINSEL, enabled, one conversion (2 µs at the ADC's 48 MHz).
    write(regs::ADC_CS, (input as u32) << 12 | 1 | 1 << 2);
    let start = read(regs::TIMER_RAWL);
    while read(regs::ADC_CS) & 1 << 8 == 0 {
        if read(regs::TIMER_RAWL).wrapping_sub(start) > 20 {
            return 0;
        }
    }
    read(regs::ADC_RESULT) as u16 & 0xfff
}

impl Board for Pico {
    const NAME: &'static str = BOARD;
    const TICKS_PER_US: u32 = TICKS_PER_US;
    const CHANNELS: u8 = pin_table::CHANNELS as u8;
    const TOOLS: u8 = pin_table::TOOLS as u8;
    /// Four channels at once within one M0+ core with room for the link
    /// (about 54,000 steps/s in all in fixed-point time, docs/firmware.md):
    /// the background bounds the node, not the pins.
    const MAX_STEP_HZ: u32 = 10_000;
    const LAYOUT: Layout = LAYOUT;
    // An M0+ has no FPU: fixed-point time.
    const FIXED_TIME_US: f64 = motet_firmware::board::NO_FPU_FIXED_TIME_US;
    type Flash = QspiFlash;

    fn uid(&self) -> u64 {
        self.uid
    }

    fn ticks(&self) -> Ticks {
        read(regs::TIMER_RAWL)
    }

    fn link_read(&mut self, buf: &mut [u8]) -> usize {
        usb::read(buf)
    }

    fn link_write(&mut self, bytes: &[u8]) {
        usb::write(bytes);
    }

    fn link_flush(&mut self) {
        // Bounded: a port nobody reads must not hold a restart back.
        let start = read(regs::TIMER_RAWL);
        while !usb::drained() && read(regs::TIMER_RAWL).wrapping_sub(start) < 200_000 {
            NVIC::pend(Interrupt::USBCTRL_IRQ);
        }
    }

    fn flash(&self) -> QspiFlash {
        QspiFlash
    }

    fn set_led(&mut self, on: bool) {
        let reg = if on {
            regs::SIO_GPIO_OUT_SET
        } else {
            regs::SIO_GPIO_OUT_CLR
        };
        write(reg, 1 << LED);
    }

    fn button(&mut self) -> bool {
        // To ground, pulled up: pressed reads low.
        read(regs::SIO_GPIO_IN) & 1 << BUTTON == 0
    }

    fn read_inputs(&mut self, inputs: &mut Inputs) {
        for (i, &gpio) in ANALOG.iter().enumerate() {
            if let Some(ch) = adc_of(gpio) {
                inputs.analog[i] = adc_read(ch) as f32;
            }
        }
        inputs.digital[0] = self.button();
    }

    fn kick_steps(&mut self) {
        NVIC::pend(Interrupt::TIMER_IRQ_0);
    }

    fn sleep_until(&mut self, until: Ticks) {
        write(regs::TIMER_ALARM1, until);
        loop {
            // Interrupts masked while deciding: WFI still returns on one
            // that becomes pending, which runs once they are unmasked.
            let done = cortex_m::interrupt::free(|_| {
                let left = until.wrapping_sub(read(regs::TIMER_RAWL)) as i32;
                if left <= 0 || usb::FRAME_END.load(Relaxed) {
                    return true;
                }
                cortex_m::asm::wfi();
                false
            });
            if done {
                write(regs::TIMER_ARMED, 0b10);
                return;
            }
        }
    }

    fn restart(&mut self) -> ! {
        restart()
    }
}

/// A watchdog reset of everything but the oscillators: the chip starts
/// from the boot ROM, boot2 and the bootloader, as after power-up.
pub fn restart() -> ! {
    write(regs::PSM_WDSEL, regs::PSM_WDSEL_ALL_BUT_OSC);
    write(regs::WATCHDOG_CTRL, 1 << 31);
    loop {
        cortex_m::asm::nop();
    }
}
