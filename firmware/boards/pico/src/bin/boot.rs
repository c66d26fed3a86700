//! The Pico's bootloader, after boot2 at the start of flash: installs an
//! image the application staged and asked for, checks the installed
//! application and starts it. With none, it installs the image in the
//! staging area if one passes the checks (the first image arrives there,
//! with an install request, in the `.uf2` copied to the BOOTSEL drive);
//! with neither it halts, LED on (docs/firmware.md).
#![no_std]
#![no_main]

use core::panic::PanicInfo;
use cortex_m::peripheral::SCB;
use cortex_m_rt::entry;
use motet_board_pico::flash::{self, QspiFlash};
use motet_board_pico::layout::{BOARD, LAYOUT};
use motet_board_pico::pin_table::LED;
use motet_board_pico::regs;
use motet_firmware::boot;
use motet_wire::service::kind::STEPPER;

/// The second stage the boot ROM copies to RAM and runs: it sets up the
/// flash chip for fast quad reads (the Pico's W25Q16JV).
#[link_section = ".boot2"]
#[used]
pub static BOOT2: [u8; 256] = rp2040_boot2::BOOT_LOADER_W25Q080;

#[entry]
fn main() -> ! {
    flash::init();
    let mut f = QspiFlash;
    if boot::requested(&f, &LAYOUT) {
        // A refused image leaves the installed application.
        let _ = boot::install(
            &QspiFlash,
            LAYOUT.staging.start,
            &mut f,
            &LAYOUT,
            BOARD,
            STEPPER,
        );
        let _ = boot::clear_request(&mut f, &LAYOUT);
    }
    let ok = boot::check_installed(&f, &LAYOUT, BOARD, STEPPER).is_ok()
        || boot::install(
            &QspiFlash,
            LAYOUT.staging.start,
            &mut f,
            &LAYOUT,
            BOARD,
            STEPPER,
        )
        .is_ok();
    if ok {
        // SAFETY: the application slot passed the checks: its vector table
        // starts at `app_exec` with a stack in RAM and a reset handler in it.
        unsafe {
            (*SCB::PTR).vtor.write(LAYOUT.app_exec);
            cortex_m::asm::bootload(LAYOUT.app_exec as *const u32)
        }
    }
    halt()
}

/// Nothing to start: the LED on, and wait for a person with a `.uf2`.
fn halt() -> ! {
    // SAFETY: IO_BANK0 GPIO25_CTRL (function 5: SIO), the SIO's output
    // enable and set registers: the LED pin only, after the pads' reset
    // (the bootloader releases IO_BANK0 and PADS_BANK0 from reset first).
    unsafe {
        let resets_clr = (0x4000_c000u32 + 0x3000) as *mut u32;
        resets_clr.write_volatile((1 << 5) | (1 << 8));
        while ((0x4000_c008u32) as *const u32).read_volatile() & ((1 << 5) | (1 << 8))
            != ((1 << 5) | (1 << 8))
        {}
        ((0x4001_4004u32 + 8 * LED as u32) as *mut u32).write_volatile(5);
        (0xd000_0024u32 as *mut u32).write_volatile(1 << LED);
    }
    regs::write(regs::SIO_GPIO_OUT_SET, 1 << LED);
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(_info: &PanicInfo) -> ! {
    halt()
}
