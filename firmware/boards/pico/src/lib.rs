//! motet's node firmware on the Raspberry Pi Pico (RP2040: two Cortex-M0+
//! cores, no FPU, 264 KB RAM, 2 MB QSPI flash).
//!
//! This crate is the only one of the firmware that touches the Pico's
//! hardware: registers are written in [`pins`], [`board`], [`flash`] and
//! [`usb`] (and through `rp2040-hal` at start); the node application
//! (`motet-firmware`) sees them through its `Board`, `Pins` and
//! `FlashPages` traits. The memory map is in [`layout`], which GPIO does
//! what in [`pin_table`]; both are plain data, tested on the host.
#![no_std]

pub mod layout;
pub mod pin_table;

#[cfg(target_arch = "arm")]
pub mod board;
#[cfg(target_arch = "arm")]
pub mod flash;
#[cfg(target_arch = "arm")]
pub mod pins;
#[cfg(target_arch = "arm")]
pub mod regs;
#[cfg(target_arch = "arm")]
pub mod usb;

#[cfg(test)]
mod tests;
