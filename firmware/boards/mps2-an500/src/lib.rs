//! motet's node firmware on QEMU's `mps2-an500` machine (an ARM MPS2 board
//! with the AN500 FPGA image: a Cortex-M7 with the double-precision FPU,
//! CMSDK UARTs and timers). The emulated board the test suite drives.
//!
//! This crate is the only one of the firmware that touches hardware here:
//! registers are written in [`uart`], [`timer`], [`pins`], [`flash`] and
//! [`board`]; the node application (`motet-firmware`) sees them through its
//! `Board`, `Pins` and `FlashPages` traits. The memory map is in [`layout`].
#![no_std]

pub mod board;
pub mod console;
pub mod flash;
pub mod irq;
pub mod layout;
pub mod pins;
pub mod timer;
pub mod uart;
