//! Trajectory math shared by the host and the nodes: points in machine space,
//! velocity profiles, time-stamped segments, kinematics and element chains.
//!
//! This crate is `no_std` without an allocator and never reads a clock: every
//! function takes the time it works on as an argument.
#![no_std]
// Unsafe only for the FPU's square-root instruction (`math::sqrt`).
#![deny(unsafe_code)]

pub mod chain;
pub mod contingency;
pub mod kinematics;
mod math;
pub mod point;
pub mod profile;
pub mod segment;
pub mod timing;

pub use chain::{ChainError, Element, ElementChain, Unit};
pub use contingency::{Contingency, TailError, TailWalk};
pub use kinematics::{JointMap, JointPath, KinematicsKind};
pub use point::{Point, MAX_AXES};
pub use profile::{Piece, Profile, ProfileKind, ProfileParams, PIECES};
pub use segment::Segment;
pub use timing::{PieceForm, PieceInverse, TimeCursor};

/// The square root every layer uses: `libm`'s, or the FPU's instruction
/// where the target has one (the same bits: both are correctly rounded).
pub use math::sqrt;
