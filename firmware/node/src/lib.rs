//! The node application every board runs: the `motet_node::Endpoint` on a
//! serial link, a step engine on the interrupt path, the node's identity in
//! flash pages and the bootloader's checks, written once over the
//! [`board`] traits. Each board crate (`firmware/boards/*`) implements those
//! traits with its drivers and owns every register access: this crate
//! touches no hardware.
//!
//! The step engine has two halves joined by a lock-free single-producer
//! single-consumer queue of [`op::Op`]s: [`schedule`] (background: the node's
//! steps, at host times, turned into pin operations at timer ticks, with
//! each channel's pulse width and direction set-up time) and [`interrupt`]
//! (the step timer's interrupt: takes operations at their ticks and drives
//! pins).
#![no_std]
#![forbid(unsafe_code)]

pub mod app;
pub mod board;
pub mod boot;
pub mod clock;
pub mod frames;
pub mod interrupt;
pub mod op;
pub mod schedule;
pub mod staging;
pub mod store;
pub mod version;

pub use board::{Board, FlashPages, Layout, Pins, Region};
