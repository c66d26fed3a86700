//! The node application every board runs: the `motet_node::Endpoint` on a
//! serial link, a step engine on the interrupt path, the node's identity in
//! flash pages and the bootloader's checks, written once over the
//! [`board`] traits. Each board crate (`firmware/boards/*`) implements those
//! traits with its drivers and owns every register access: this crate
//! touches no hardware.
//!
//! The step engine has two halves joined by a lock-free single-producer
//! single-consumer ring ([`ring`]) of [`op::Op`]s: [`schedule`] (background: the node's
//! steps, at host times, turned into pin operations at timer ticks, with
//! each channel's pulse width and direction set-up time) and [`interrupt`]
//! (the step timer's interrupt: takes operations at their ticks and drives
//! pins).
#![no_std]
// Only the step ring holds unsafe code (its slots are shared between the
// background and the interrupt); everything else is safe.
#![deny(unsafe_code)]

pub mod app;
pub mod bench;
pub mod board;
pub mod boot;
pub mod clock;
pub mod frames;
pub mod interrupt;
pub mod op;
#[allow(unsafe_code)]
pub mod ring;
pub mod schedule;
pub mod staging;
pub mod store;
pub mod version;

pub use board::{Board, FlashPages, Layout, Pins, Region};
