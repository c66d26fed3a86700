//! The Pico's memory map: 2 MB of QSPI flash seen at `XIP_BASE` (the
//! boot ROM runs the 256-byte second stage `boot2` from its start), and
//! 264 KB of SRAM.
//!
//! | flash address | size | what |
//! |---|---|---|
//! | 0x1000_0000 | 256 B | boot2 (rp2040-boot2, W25Q080), checksummed; the ROM enters it |
//! | 0x1000_0100 | 64 KB − 256 B | bootloader |
//! | 0x1001_0000 | 8 KB | identity record (uid, address), two sectors written in turn |
//! | 0x1001_2000 | 4 KB | the application's request to the bootloader |
//! | 0x1002_0000 | 896 KB | application slot: image header, payload at 0x1002_0100 (where the application is linked) |
//! | 0x1010_0000 | 896 KB | staging area for uploads |
//! | 0x101e_0000 | 128 KB | free |
//!
//! The `memory-*.x` files beside this crate say the same to the linker;
//! the tests hold them to these numbers.

use motet_firmware::board::{Layout, Region};

/// Where the flash appears in the address space (execute in place).
pub const XIP_BASE: u32 = 0x1000_0000;
/// The Pico's flash chip (W25Q16JV): 2 MB.
pub const FLASH_LEN: u32 = 2 * 1024 * 1024;
/// Erase unit: the chip's 4 KB sector (command 0x20).
pub const SECTOR: u32 = 4096;
/// Program unit: the chip's 256-byte page.
pub const PAGE: u32 = 256;
/// boot2 and the bootloader, from the start of flash.
pub const BOOTLOADER: Region = Region {
    start: 0,
    len: 0x1_0000,
};
/// SRAM: the striped 256 KB and the two 4 KB banks after it.
pub const RAM: (u32, u32) = (0x2000_0000, 0x2004_2000);

pub const LAYOUT: Layout = Layout {
    identity: Region {
        start: 0x1_0000,
        len: 2 * SECTOR,
    },
    request: Region {
        start: 0x1_2000,
        len: SECTOR,
    },
    app: Region {
        start: 0x2_0000,
        len: 0xE_0000,
    },
    app_header: 0x100,
    app_exec: XIP_BASE + 0x2_0100,
    ram: RAM,
    staging: Region {
        start: 0x10_0000,
        len: 0xE_0000,
    },
};

// A staged image fits the slot it is installed to.
const _: () = assert!(LAYOUT.staging.len >= LAYOUT.app.len);

/// The board's name in firmware images.
pub const BOARD: &str = "pico";
/// The RP2040's timer counts µs.
pub const TICKS_PER_US: u32 = 1;
