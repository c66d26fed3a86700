//! The emulated board's memory map.
//!
//! QEMU's mps2-an500 has RAM only. What the firmware treats as flash is
//! the 16 MB PSRAM at 0x6000_0000, which no QEMU loader writes: it keeps
//! what the firmware wrote across the system resets the application uses
//! to restart into its bootloader (QEMU copies `-kernel` and `-device
//! loader` images again on every reset, so nothing that must survive one
//! lives where they load).
//!
//! | address | size | what |
//! |---|---|---|
//! | 0x0000_0000 | 64 KB | bootloader (`-kernel`), vector table at reset |
//! | 0x0001_0000 | 8 B | the board's uid, written by the emulator (`-device loader,addr=0x10000,data=…,data-len=8`) |
//! | 0x0010_0000 | ≤ 1 MB | factory image, as a programmer left it (`-device loader,file=…,addr=0x100000,force-raw=on`) |
//! | 0x2000_0000 | 512 KB | RAM (application or bootloader) |
//! | 0x6000_0000 | 8 KB | flash: identity record, two sectors |
//! | 0x6000_2000 | 4 KB | flash: the application's request to the bootloader |
//! | 0x6001_0000 | 512 KB | flash: application slot, header then payload at 0x6001_0100 |
//! | 0x6009_0000 | 512 KB | flash: staging area for uploads |

use motet_firmware::board::{Layout, Region};

/// Where the emulated flash starts.
pub const FLASH_BASE: u32 = 0x6000_0000;
/// The emulated flash the firmware manages.
pub const FLASH_LEN: u32 = 0x0011_0000;
/// Erase unit of the emulated flash (a common NOR sector).
pub const SECTOR: u32 = 4096;
/// The uid word the emulator writes.
pub const UID_ADDR: u32 = 0x0001_0000;
/// Where the factory image is loaded.
pub const FACTORY_ADDR: u32 = 0x0010_0000;
pub const FACTORY_LEN: u32 = 0x0010_0000;

pub const LAYOUT: Layout = Layout {
    identity: Region {
        start: 0,
        len: 2 * SECTOR,
    },
    request: Region {
        start: 0x2000,
        len: SECTOR,
    },
    app: Region {
        start: 0x1_0000,
        len: 0x8_0000,
    },
    app_header: 0x100,
    app_exec: FLASH_BASE + 0x1_0100,
    ram: (0x2000_0000, 0x2008_0000),
    staging: Region {
        start: 0x9_0000,
        len: 0x8_0000,
    },
};

/// The board's name in firmware images.
pub const BOARD: &str = "mps2-an500";
/// Ticks of the CMSDK timers per µs (QEMU's 25 MHz system clock).
pub const TICKS_PER_US: u32 = 25;
