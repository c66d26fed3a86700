//! motet's node firmware on a Teensy 4.1 (NXP i.MX RT1062: a 600 MHz
//! Cortex-M7 with the double-precision FPU, 1 MB RAM, 8 MB QSPI flash).
//!
//! This crate is the only one of the firmware that touches the Teensy's
//! hardware: registers are written in [`timer`], [`pins`], [`flash`],
//! [`usb`], [`inputs`] and [`board`]; the node application
//! (`motet-firmware`) sees them through its `Board`, `Pins` and
//! `FlashPages` traits. The flash map is in [`layout`], the pins in
//! [`pinmap`]; both build on the host too, where their tests run.
#![cfg_attr(not(test), no_std)]

pub mod layout;
pub mod link;
pub mod pinmap;

#[cfg(target_os = "none")]
pub mod board;
#[cfg(target_os = "none")]
pub mod flash;
#[cfg(target_os = "none")]
pub mod inputs;
#[cfg(target_os = "none")]
pub mod pins;
#[cfg(target_os = "none")]
pub mod timer;
#[cfg(target_os = "none")]
pub mod usb;
