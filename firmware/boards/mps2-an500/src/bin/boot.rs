//! The emulated board's bootloader: installs an image the application
//! staged and asked for, checks the installed application and starts it;
//! with none, installs the factory image the emulator loaded.
#![no_std]
#![no_main]

use core::panic::PanicInfo;
use cortex_m::peripheral::SCB;
use cortex_m_rt::entry;
use motet_board_mps2_an500::console::line;
use motet_board_mps2_an500::flash::{EmulatedFlash, Factory};
use motet_board_mps2_an500::irq::{self, Vector};
use motet_board_mps2_an500::layout::{BOARD, LAYOUT};
use motet_board_mps2_an500::uart::Uart;
use motet_firmware::boot;
use motet_wire::service::kind::STEPPER;

#[link_section = ".vector_table.interrupts"]
#[no_mangle]
#[used]
static __INTERRUPTS: [Vector; irq::LINES] = irq::default_vectors();

#[entry]
fn main() -> ! {
    Uart::UART1.init(false);
    let mut flash = EmulatedFlash;
    if boot::requested(&flash, &LAYOUT) {
        match boot::install(
            &EmulatedFlash,
            LAYOUT.staging.start,
            &mut flash,
            &LAYOUT,
            BOARD,
            STEPPER,
        ) {
            Ok(h) => line(format_args!(
                "boot: installed firmware {} ({} bytes)",
                h.version, h.payload_len
            )),
            Err(e) => line(format_args!(
                "boot: staged image refused ({e}); the installed application stays"
            )),
        }
        if let Err(e) = boot::clear_request(&mut flash, &LAYOUT) {
            line(format_args!("boot: cannot clear the request: {e}"));
        }
    }
    match boot::check_installed(&flash, &LAYOUT, BOARD, STEPPER) {
        Ok(h) => start(h.version),
        Err(e) => {
            line(format_args!(
                "boot: no application to start ({e}); installing the factory image"
            ));
            match boot::install(&Factory, 0, &mut flash, &LAYOUT, BOARD, STEPPER) {
                Ok(h) => start(h.version),
                Err(e) => {
                    line(format_args!("boot: no factory image either ({e}); halted"));
                    loop {
                        cortex_m::asm::wfi();
                    }
                }
            }
        }
    }
}

fn start(v: motet_wire::service::Version) -> ! {
    line(format_args!("boot: starting firmware {v}"));
    // SAFETY: the application slot passed the checks: its vector table
    // starts at `app_exec` with a stack in RAM and a reset handler in it.
    unsafe {
        (*SCB::PTR).vtor.write(LAYOUT.app_exec);
        cortex_m::asm::bootload(LAYOUT.app_exec as *const u32)
    }
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    line(format_args!("boot: panic: {info}"));
    loop {
        cortex_m::asm::wfi();
    }
}
