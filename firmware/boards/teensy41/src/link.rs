//! Where the two binaries are linked, by offset from the start of flash:
//! read by `build.rs` (which writes the linker scripts) and by `layout`
//! (whose tests check the two agree). Plain constants only.

/// The flash chip's size.
pub const FLASH_LEN: u32 = 8 * 1024 * 1024;
/// The application's payload: its vector table first.
pub const APP_OFFSET: u32 = 0x12_0400;
/// Room for the payload (the slot less the header in front of it).
pub const APP_LEN: u32 = 0x10_0000 - 0x400;
