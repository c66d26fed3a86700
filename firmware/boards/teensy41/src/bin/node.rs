//! The node application on a Teensy 4.1: the step engine's queue and
//! interrupt, the vector table's handlers, and `motet_firmware::app::run`.
#![no_std]
#![no_main]

use core::panic::PanicInfo;
use core::ptr::addr_of_mut;
use cortex_m::peripheral::{NVIC, SCB};
use cortex_m_rt::{entry, exception, ExceptionFrame};
// The i.MX RT start-up (watchdog off, FlexRAM banks, copies to ITCM and DTCM).
use imxrt_rt as _;
use motet_board_teensy41::board::{self, Teensy41};
use motet_board_teensy41::flash::NorFlash;
use motet_board_teensy41::layout::{LAYOUT, TICKS_PER_US};
use motet_board_teensy41::pins::{self, TeensyPins};
use motet_board_teensy41::{timer, usb};
use motet_firmware::app::{self, AppConfig};
use motet_firmware::interrupt::{Counters, StepInterrupt};
use motet_firmware::ring::Ring;
use motet_firmware::{boot, version};
use motet_wire::service::{kind, Version};
use teensy4_bsp::ral::Interrupt;

/// This build's version, reported when no bootloader installed it (the
/// image's header gives the version otherwise).
const BUILD_VERSION: Version = match version::parse(env!("CARGO_PKG_VERSION")) {
    Some(v) => v,
    None => panic!("the crate's version is not MAJOR.MINOR.PATCH"),
};

/// The step queue: 4096 operations, 32 KB: 4 ms of four channels at
/// 100 kHz with direction changes to spare.
static STEP_RING: Ring<4096> = Ring::new();
/// The step interrupt's state and pins, set once before its line is
/// unmasked.
static mut STEP: Option<(StepInterrupt<'static>, TeensyPins)> = None;
static COUNTERS: Counters = Counters::new();

/// The step interrupt (GPT1's compare 1).
#[no_mangle]
unsafe extern "C" fn GPT1() {
    timer::compare_clear();
    // SAFETY: set in `main` before this line was unmasked; only this
    // interrupt touches it afterwards.
    if let Some((s, p)) = (*addr_of_mut!(STEP)).as_mut() {
        s.run(p);
    }
}

#[no_mangle]
unsafe extern "C" fn USB_OTG1() {
    usb::on_interrupt();
}

#[entry]
fn main() -> ! {
    let cp = cortex_m::Peripherals::take().unwrap_or_else(|| SCB::sys_reset());
    let res = teensy4_bsp::board::t41(teensy4_bsp::board::instances());
    let (board, step_pins) = Teensy41::new(res, cp.SYST);
    let Some((producer, consumer)) = STEP_RING.split() else {
        SCB::sys_reset()
    };
    // An edge due within 1 µs is waited for in the handler (a 600 MHz M7
    // enters an interrupt in 12 cycles; the spin saves the second entry
    // of a short pulse).
    let step = StepInterrupt::new(consumer, &COUNTERS, TICKS_PER_US, TICKS_PER_US);
    unsafe {
        *addr_of_mut!(STEP) = Some((step, step_pins));
        NVIC::unmask(Interrupt::GPT1);
    }
    let version = boot::installed_header(&NorFlash, &LAYOUT).map_or(BUILD_VERSION, |h| h.version);
    app::run(
        board,
        producer,
        &COUNTERS,
        AppConfig::new(kind::STEPPER, version),
    )
}

#[exception]
fn SysTick() {
    board::on_systick();
}

/// Step pins low, drivers disabled, restart: the bootloader starts the
/// application again, which knows no run (the host finds the node lost).
#[exception]
unsafe fn HardFault(_ef: &ExceptionFrame) -> ! {
    pins::gpio_off();
    SCB::sys_reset()
}

#[panic_handler]
fn panic(_info: &PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    pins::gpio_off();
    SCB::sys_reset()
}
