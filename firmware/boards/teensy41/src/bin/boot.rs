//! The Teensy 4.1's bootloader, booted by the i.MX RT boot ROM from the
//! start of flash: installs an image the application staged and asked
//! for, checks the installed application and starts it; with none, installs
//! the factory image the Teensy loader wrote.
#![no_std]
#![no_main]

use core::panic::PanicInfo;
use cortex_m::peripheral::SCB;
use cortex_m_rt::entry;
// The i.MX RT start-up (watchdog off, FlexRAM banks, copies to ITCM and DTCM).
use imxrt_rt as _;
use motet_board_teensy41::flash::{Factory, NorFlash};
use motet_board_teensy41::layout::{BOARD, LAYOUT};
use motet_firmware::boot;
use motet_wire::service::kind::STEPPER;
// The FlexSPI configuration block the boot ROM reads (teensy4-fcb, through
// the BSP) and the interrupt vectors.
use teensy4_bsp as _;

#[entry]
fn main() -> ! {
    let mut flash = NorFlash;
    if boot::requested(&flash, &LAYOUT) {
        // A refused image leaves the installed application; the request is
        // cleared either way (nothing here can report it: the application
        // reports the version that runs, and the host compares).
        let _ = boot::install(
            &NorFlash,
            LAYOUT.staging.start,
            &mut flash,
            &LAYOUT,
            BOARD,
            STEPPER,
        );
        let _ = boot::clear_request(&mut flash, &LAYOUT);
    }
    if boot::check_installed(&flash, &LAYOUT, BOARD, STEPPER).is_ok()
        || boot::install(&Factory, 0, &mut flash, &LAYOUT, BOARD, STEPPER).is_ok()
    {
        start()
    }
    // No application and no factory image: nothing answers on the link;
    // the Teensy loader (its button) still reaches the board.
    loop {
        cortex_m::asm::wfi();
    }
}

fn start() -> ! {
    // SAFETY: the application slot passed the checks: its vector table
    // starts at `app_exec` with a stack in DTCM and a reset handler in it.
    unsafe {
        (*SCB::PTR).vtor.write(LAYOUT.app_exec);
        cortex_m::asm::bootload(LAYOUT.app_exec as *const u32)
    }
}

#[panic_handler]
fn panic(_info: &PanicInfo) -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}
