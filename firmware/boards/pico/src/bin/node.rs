//! The node application on the Pico: clocks, pins, USB, the step engine's
//! queue and interrupt, and `motet_firmware::app::run`. The bootloader
//! starts it from the application slot (0x1002_0100).
#![no_std]
#![no_main]

use core::panic::PanicInfo;
use core::ptr::addr_of_mut;
use cortex_m_rt::{entry, exception, ExceptionFrame};
use motet_board_pico::board::{self, Pico};
use motet_board_pico::flash::{self, QspiFlash};
use motet_board_pico::layout::{LAYOUT, TICKS_PER_US};
use motet_board_pico::pins::{self, PicoPins};
use motet_board_pico::{regs, usb};
use motet_firmware::app::{self, AppConfig};
use motet_firmware::interrupt::{Counters, StepInterrupt};
use motet_firmware::ring::Ring;
use motet_firmware::{boot, version};
use motet_wire::service::{kind, Version};
use rp2040_hal::clocks::init_clocks_and_plls;
use rp2040_hal::pac::{self, interrupt, Interrupt, NVIC};
use rp2040_hal::{Sio, Watchdog};

/// This build's version, reported when no bootloader installed it.
const BUILD_VERSION: Version = match version::parse(env!("CARGO_PKG_VERSION")) {
    Some(v) => v,
    None => panic!("the crate's version is not MAJOR.MINOR.PATCH"),
};

/// The Pico's crystal.
const XTAL_HZ: u32 = 12_000_000;

/// The step queue: 4096 operations, 32 KB.
static STEP_RING: Ring<4096> = Ring::new();
/// The step interrupt's state, set once before its line is unmasked.
static mut STEP: Option<StepInterrupt<'static>> = None;
static COUNTERS: Counters = Counters::new();

/// The step interrupt (alarm 0).
#[interrupt]
fn TIMER_IRQ_0() {
    regs::write(regs::TIMER_INTR, 1);
    // SAFETY: set in `main` before this line was unmasked; only this
    // interrupt touches it afterwards.
    if let Some(s) = unsafe { (*addr_of_mut!(STEP)).as_mut() } {
        s.run(&mut PicoPins);
    }
}

/// The main loop's wake-up (alarm 1).
#[interrupt]
fn TIMER_IRQ_1() {
    board::on_alarm1();
}

#[interrupt]
fn USBCTRL_IRQ() {
    usb::on_irq();
}

#[entry]
fn main() -> ! {
    let Some(mut p) = pac::Peripherals::take() else {
        board::restart()
    };
    #[cfg(feature = "rom-double")]
    if rp2040_hal::rom_data::rom_version_number() < 2 {
        // The f64 routines this build calls are not in this chip's ROM.
        loop {
            cortex_m::asm::wfi();
        }
    }
    let mut watchdog = Watchdog::new(p.WATCHDOG);
    let Ok(clocks) = init_clocks_and_plls(
        XTAL_HZ,
        p.XOSC,
        p.CLOCKS,
        p.PLL_SYS,
        p.PLL_USB,
        &mut p.RESETS,
        &mut watchdog,
    ) else {
        board::restart()
    };
    // Pins::new takes IO_BANK0 and PADS_BANK0 out of reset; the pins are
    // then set from the pin table.
    let sio = Sio::new(p.SIO);
    let _ = rp2040_hal::gpio::Pins::new(p.IO_BANK0, p.PADS_BANK0, sio.gpio_bank0, &mut p.RESETS);
    pins::configure();
    let _adc = rp2040_hal::Adc::new(p.ADC, &mut p.RESETS);
    // The tool outputs' PWM slice (pin_table::TOOL_SLICE): 16-bit top,
    // free-running (125 MHz / 65536: 1.9 kHz).
    let mut slices = rp2040_hal::pwm::Slices::new(p.PWM, &mut p.RESETS);
    slices.pwm7.set_top(u16::MAX);
    slices.pwm7.enable();
    pins::all_off();

    flash::init();
    let uid = flash::unique_id();
    let _timer = rp2040_hal::Timer::new(p.TIMER, &mut p.RESETS, &clocks);
    usb::init(
        rp2040_hal::usb::UsbBus::new(
            p.USBCTRL_REGS,
            p.USBCTRL_DPRAM,
            clocks.usb_clock,
            true,
            &mut p.RESETS,
        ),
        uid,
    );

    let Some((producer, consumer)) = STEP_RING.split() else {
        board::restart()
    };
    // An edge due within 2 µs is waited for in the handler (entry and exit
    // cost about 30 cycles on the M0+).
    let step = StepInterrupt::new(consumer, &COUNTERS, 2 * TICKS_PER_US, 2 * TICKS_PER_US);
    // SAFETY: the step interrupt's state is set before its line is
    // unmasked; priorities: steps first, the USB below.
    unsafe {
        *addr_of_mut!(STEP) = Some(step);
        let mut cp = cortex_m::Peripherals::steal();
        cp.NVIC.set_priority(Interrupt::TIMER_IRQ_0, 0);
        cp.NVIC.set_priority(Interrupt::TIMER_IRQ_1, 0x80);
        cp.NVIC.set_priority(Interrupt::USBCTRL_IRQ, 0x80);
        regs::write(regs::TIMER_INTE, regs::read(regs::TIMER_INTE) | 1);
        NVIC::unmask(Interrupt::TIMER_IRQ_0);
    }
    usb::start();
    let board = Pico::new(uid);
    let version = boot::installed_header(&QspiFlash, &LAYOUT).map_or(BUILD_VERSION, |h| h.version);
    app::run(
        board,
        producer,
        &COUNTERS,
        AppConfig::new(kind::STEPPER, version),
    )
}

/// Outputs off, restart: the bootloader starts the application again,
/// which knows no run (the host finds the node lost).
#[exception]
unsafe fn HardFault(_ef: &ExceptionFrame) -> ! {
    pins::all_off();
    board::restart()
}

#[panic_handler]
fn panic(_info: &PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    pins::all_off();
    board::restart()
}
