//! The Teensy 4.1's flash map: 8 MB of QSPI NOR (Winbond W25Q64JV: 4 KB
//! sectors, 256-byte pages) at 0x6000_0000, read through FlexSPI.
//!
//! | offset | size | what |
//! |---|---|---|
//! | 0x00_0000 | 64 KB | bootloader: FlexSPI configuration block at 0, image vector table at 0x1000 (the boot ROM's), code |
//! | 0x01_0000 | 1 MB | factory image, as the Teensy loader wrote it (header and payload, as uploaded) |
//! | 0x11_0000 | 8 KB | identity record (uid, address), two sectors written in turn |
//! | 0x11_2000 | 4 KB | the application's request to the bootloader |
//! | 0x12_0000 | 1 MB | application slot: image header, payload at 0x12_0400 (where the application is linked) |
//! | 0x22_0000 | 1 MB | staging area for uploads |
//! | 0x7C_0000 | 256 KB | the Teensy's own (EEPROM emulation, the restore program): never touched |
//!
//! The firmware erases and programs only [`WRITABLE`]: the bootloader and
//! the factory image are the Teensy loader's to write.

use motet_firmware::board::{Layout, Region};

/// Where the flash is mapped (FlexSPI's AHB window).
pub const FLASH_BASE: u32 = 0x6000_0000;
/// The flash chip's size.
pub const FLASH_LEN: u32 = crate::link::FLASH_LEN;
/// Erase unit.
pub const SECTOR: u32 = 4096;
/// Program unit.
pub const PAGE: u32 = 256;
/// What the Teensy loader accepts for a Teensy 4.1 (the top 256 KB are the
/// board's own).
pub const LOADABLE: Region = Region {
    start: 0,
    len: FLASH_LEN - 256 * 1024,
};

/// The bootloader, booted by the i.MX RT boot ROM.
pub const BOOTLOADER: Region = Region {
    start: 0,
    len: 0x1_0000,
};
/// The factory image: an image file (header, then payload) the bootloader
/// installs when the slot holds no runnable application.
pub const FACTORY: Region = Region {
    start: 0x1_0000,
    len: 0x10_0000,
};
/// What the firmware may erase and program: identity, request, slot, staging.
pub const WRITABLE: Region = Region {
    start: 0x11_0000,
    len: 0x21_0000,
};

/// DTCM (the application's stack and static data): 10 of the 16 FlexRAM
/// banks of 32 KB, as `build.rs` configures them.
pub const DTCM: (u32, u32) = (0x2000_0000, 0x2000_0000 + 10 * 32 * 1024);

/// Room for the image header before the payload: the payload starts with
/// the application's vector table, which `VTOR` needs on a 1 KB boundary
/// (176 entries on the RT1062).
pub const APP_HEADER: u32 = 0x400;

pub const LAYOUT: Layout = Layout {
    identity: Region {
        start: 0x11_0000,
        len: 2 * SECTOR,
    },
    request: Region {
        start: 0x11_2000,
        len: SECTOR,
    },
    app: Region {
        start: 0x12_0000,
        len: 0x10_0000,
    },
    app_header: APP_HEADER,
    app_exec: FLASH_BASE + 0x12_0000 + APP_HEADER,
    ram: DTCM,
    staging: Region {
        start: 0x22_0000,
        len: 0x10_0000,
    },
};

/// The board's name in firmware images.
pub const BOARD: &str = "teensy41";

/// GPT1 counts the 24 MHz crystal undivided.
pub const TICKS_PER_US: u32 = 24;

/// Where the application is linked (`build.rs`): its flash partition, by
/// offset from [`FLASH_BASE`], and its length.
pub const APP_LINK: Region = Region {
    start: LAYOUT.app.start + APP_HEADER,
    len: LAYOUT.app.len - APP_HEADER,
};

#[cfg(test)]
mod tests {
    use super::*;

    fn named() -> Vec<(&'static str, Region)> {
        vec![
            ("bootloader", BOOTLOADER),
            ("factory", FACTORY),
            ("identity", LAYOUT.identity),
            ("request", LAYOUT.request),
            ("app", LAYOUT.app),
            ("staging", LAYOUT.staging),
        ]
    }

    #[test]
    fn regions_are_whole_sectors_inside_what_the_loader_accepts() {
        for (name, r) in named() {
            assert_eq!(r.start % SECTOR, 0, "{name} starts mid-sector");
            assert_eq!(r.len % SECTOR, 0, "{name} ends mid-sector");
            assert!(r.len > 0, "{name} is empty");
            assert!(
                r.end() <= LOADABLE.end(),
                "{name} runs past {:#x}",
                LOADABLE.end()
            );
        }
    }

    #[test]
    fn regions_do_not_overlap() {
        let regions = named();
        for (i, (a, ra)) in regions.iter().enumerate() {
            for (b, rb) in &regions[i + 1..] {
                assert!(
                    ra.end() <= rb.start || rb.end() <= ra.start,
                    "{a} {ra:x?} overlaps {b} {rb:x?}"
                );
            }
        }
    }

    #[test]
    fn the_firmware_writes_only_its_own_regions() {
        let inside = |r: Region| r.start >= WRITABLE.start && r.end() <= WRITABLE.end();
        for (name, r) in named() {
            let writable = matches!(name, "identity" | "request" | "app" | "staging");
            assert_eq!(inside(r), writable, "{name}");
        }
    }

    #[test]
    fn identity_takes_two_sectors_and_request_one() {
        assert_eq!(LAYOUT.identity.len, 2 * SECTOR);
        assert_eq!(LAYOUT.request.len, SECTOR);
    }

    #[test]
    fn the_application_runs_where_it_is_linked() {
        assert_eq!(LAYOUT.app_exec, FLASH_BASE + APP_LINK.start);
        assert_eq!(APP_LINK.start, LAYOUT.app.start + LAYOUT.app_header);
        assert_eq!(APP_LINK.end(), LAYOUT.app.end());
        // What build.rs gives the linker.
        assert_eq!(
            (APP_LINK.start, APP_LINK.len),
            (crate::link::APP_OFFSET, crate::link::APP_LEN)
        );
        // VTOR takes the vector table on a 1 KB boundary.
        assert_eq!(LAYOUT.app_exec % 1024, 0);
        // The image header fits in front of the payload.
        assert!(LAYOUT.app_header as usize >= motet_wire::image::MAX_HEADER_LEN);
    }

    #[test]
    fn staging_and_factory_hold_any_image_the_slot_takes() {
        let image = LAYOUT.app.len - APP_HEADER + motet_wire::image::MAX_HEADER_LEN as u32;
        assert!(LAYOUT.staging.len >= image);
        assert!(FACTORY.len >= image);
    }

    #[test]
    fn the_stack_lies_in_dtcm() {
        assert_eq!(LAYOUT.ram, DTCM);
        assert_eq!(DTCM.1 - DTCM.0, 320 * 1024);
    }
}
