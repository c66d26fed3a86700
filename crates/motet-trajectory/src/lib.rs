//! Trajectory math shared by the host and the nodes: points in machine space,
//! velocity profiles, time-stamped segments, kinematics and element chains.
//!
//! This crate is `no_std` without an allocator and never reads a clock: every
//! function takes the time it works on as an argument.
#![no_std]
#![forbid(unsafe_code)]

pub mod chain;
pub mod kinematics;
pub mod point;
pub mod profile;
pub mod segment;
mod math;

pub use point::{Point, MAX_AXES};






