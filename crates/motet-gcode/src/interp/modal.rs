//! The interpreter's state as a controller reports it (grbl's `$G` and
//! `$#`), and the position it takes from the machine after motion it did
//! not plan (a jog, a stop on the path).

use motet_trajectory::Point;

use super::{Interp, ToolState};
use crate::codes::{Motion, Plane};

/// The modal state between lines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Modal {
    /// Motion mode: `G0`, `G1`, `G2`, `G3`, or none yet.
    pub motion: Option<&'static str>,
    /// Coordinate system in use, 0 = G54 … 5 = G59.
    pub coordinate_system: usize,
    /// The work offsets G54…G59, machine axis order.
    pub work_offsets: [Point; 6],
    /// The G92 offset.
    pub g92: Point,
    /// machine = program + this (work offset + G92).
    pub offset: Point,
    /// Plane: 17, 18 or 19.
    pub plane: u8,
    /// G20 (inches) instead of G21.
    pub inches: bool,
    /// G91 instead of G90.
    pub relative: bool,
    /// G93 instead of G94.
    pub inverse_time: bool,
    /// Feed, machine units per second (G94), if one was given.
    pub feed: Option<f64>,
    /// Tool: 0 off (M5), 3 on (M3), 4 power follows speed (M4).
    pub tool_mode: u8,
    /// Tool power 0..=1 while on.
    pub tool_value: f32,
    /// Coolant on (M7/M8).
    pub coolant: bool,
    /// The position after the last line, machine coordinates.
    pub machine: Point,
}

impl Interp {
    pub(crate) fn modal(&self) -> Modal {
        let (tool_mode, tool_value) = match self.tool_state {
            ToolState::Off => (0, 0.0),
            ToolState::On(v) => (3, v),
            ToolState::PerSpeed(v, _) => (4, v),
        };
        Modal {
            motion: self.motion.map(Motion::name),
            coordinate_system: self.cs,
            work_offsets: self.wcs,
            g92: self.g92,
            offset: self.offset,
            plane: match self.plane {
                Plane::Xy => 17,
                Plane::Zx => 18,
                Plane::Yz => 19,
            },
            inches: self.inch,
            relative: self.relative,
            inverse_time: self.inverse_time,
            feed: self.feed,
            tool_mode,
            tool_value,
            coolant: self.coolant_on,
            machine: self.machine,
        }
    }

    pub(crate) fn set_machine_position(&mut self, p: Point) {
        self.machine = p;
    }
}
