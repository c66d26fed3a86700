//! The node application on the emulated board: the step engine's queue and
//! interrupt, the vector table, and `motet_firmware::app::run`.
#![no_std]
#![no_main]

use core::panic::PanicInfo;
use core::ptr::addr_of_mut;
use cortex_m::peripheral::{NVIC, SCB};
use cortex_m_rt::{entry, exception, ExceptionFrame};
use motet_board_mps2_an500::board::{self, Mps2};
use motet_board_mps2_an500::flash::EmulatedFlash;
use motet_board_mps2_an500::irq::{self, Irq, Vector};
use motet_board_mps2_an500::layout::{LAYOUT, TICKS_PER_US};
use motet_board_mps2_an500::pins::{self, Mps2Pins};
use motet_board_mps2_an500::{console, timer};
use motet_firmware::app::{self, AppConfig};
use motet_firmware::interrupt::{Counters, StepInterrupt};
use motet_firmware::ring::Ring;
use motet_firmware::{boot, version};
use motet_wire::service::{kind, Version};

/// This build's version, reported when no bootloader installed it (the
/// image's header gives the version otherwise).
const BUILD_VERSION: Version = match version::parse(env!("CARGO_PKG_VERSION")) {
    Some(v) => v,
    None => panic!("the crate's version is not MAJOR.MINOR.PATCH"),
};

/// The step queue: 4096 operations, 32 KB: 4 ms of four channels at
/// 100 kHz with direction changes to spare.
static STEP_RING: Ring<4096> = Ring::new();
/// The step interrupt's state, set once before its line is unmasked.
static mut STEP: Option<StepInterrupt<'static>> = None;
static COUNTERS: Counters = Counters::new();

unsafe extern "C" fn uart0_rx() {
    board::on_uart0_rx();
}

unsafe extern "C" fn uart0_tx() {
    board::on_uart0_tx();
}

/// The step interrupt.
unsafe extern "C" fn timer1() {
    timer::compare_clear();
    // SAFETY: set in `main` before this line was unmasked; only this
    // interrupt touches it afterwards.
    if let Some(s) = (*addr_of_mut!(STEP)).as_mut() {
        s.run(&mut Mps2Pins);
    }
}

#[link_section = ".vector_table.interrupts"]
#[no_mangle]
#[used]
static __INTERRUPTS: [Vector; irq::LINES] = {
    let mut v = irq::default_vectors();
    v[Irq::Uart0Rx as usize] = Vector { handler: uart0_rx };
    v[Irq::Uart0Tx as usize] = Vector { handler: uart0_tx };
    v[Irq::Timer1 as usize] = Vector { handler: timer1 };
    v
};

#[entry]
fn main() -> ! {
    let p = cortex_m::Peripherals::take().unwrap_or_else(|| SCB::sys_reset());
    pins::all_off();
    let board = Mps2::new(p.SYST);
    let Some((producer, consumer)) = STEP_RING.split() else {
        SCB::sys_reset()
    };
    // An edge due within 3 µs is waited for in the handler: a pulse's
    // falling edge is taken in the interrupt that raised it (QEMU's timer
    // interrupts cost far more than a real M7's 12-cycle entry).
    let step = StepInterrupt::new(consumer, &COUNTERS, 3 * TICKS_PER_US, TICKS_PER_US);
    unsafe {
        *addr_of_mut!(STEP) = Some(step);
        NVIC::unmask(Irq::Timer1);
    }
    let version =
        boot::installed_header(&EmulatedFlash, &LAYOUT).map_or(BUILD_VERSION, |h| h.version);
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

/// Outputs off, say why, restart: the bootloader starts the application
/// again, which knows no run (the host finds the node lost).
#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    pins::all_off();
    console::line(format_args!("motet: hard fault at {:#010x}", ef.pc()));
    SCB::sys_reset()
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    pins::all_off();
    console::line(format_args!("motet: panic: {info}"));
    SCB::sys_reset()
}
