//! Kinematics: how joints (what actuators move) follow from machine-space points.
//!
//! A kinematics is one type implementing [`Kinematics`], in a file of its
//! own, listed once in [`table`]'s `kinematics!` invocation, which makes it
//! a variant of [`KinematicsKind`]: the value machine files name, the wire
//! carries and every layer dispatches through. The planner, the nodes, the
//! host and the simulator only ever see a [`JointMap`] per joint and a
//! [`JointPath`] per joint and segment; they never match on the kind.
//!
//! # Adding a kinematics
//!
//! 1. Write `kinematics/<name>.rs`: a `Copy` type holding the geometry, and
//!    its [`Kinematics`] impl (names, joints, the geometry keys it reads
//!    from the machine file's `[geometry]` table, inverse and forward maps,
//!    and the workspace it can reach). A joint linear in x and y says so in
//!    [`Kinematics::linear`] and is stepped in closed form; any other joint
//!    is stepped by bracketing its crossing along the segment, exact to the
//!    nanosecond, unless the kinematics gives a closed form
//!    ([`Kinematics::closed_form`], as polar does).
//! 2. Add one line to the `kinematics!` table in `table.rs`.
//!
//! Nothing else changes: machine files accept the name and its geometry,
//! the wire encodes it (docs/wire.md), the planner bounds its joints'
//! rates, the simulator checks its steps. `tests/kinematics_props.rs` runs
//! its round trip and rate bounds with the others.
//!
//! Kinematics here are planar: their joints replace the machine's x and y
//! axes; every other axis stays a joint of its own. Angles are in degrees.

mod cartesian;
mod corexy;
mod five_bar;
mod hbot;
mod path;
mod polar;
mod scara;
mod table;

pub use cartesian::Cartesian;
pub use corexy::CoreXY;
pub use five_bar::FiveBar;
pub use hbot::HBot;
pub use path::{ClosedForm, JointPath};
pub use polar::Polar;
pub use scara::Scara;
pub use table::KinematicsKind;

use crate::point::{Point, MAX_AXES};
use core::fmt;
use serde::{Deserialize, Serialize};

/// One joint of a kinematics: its name in machine files, and whether it is
/// an angle (degrees) or a length (mm).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JointSpec {
    pub name: &'static str,
    pub angle: bool,
}

impl JointSpec {
    pub const fn length(name: &'static str) -> JointSpec {
        JointSpec { name, angle: false }
    }
    pub const fn angle(name: &'static str) -> JointSpec {
        JointSpec { name, angle: true }
    }
}

/// One geometry value a kinematics reads from the machine file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Param {
    /// Its key in `[geometry]`.
    pub key: &'static str,
    /// What it is, with its unit, for errors and documentation.
    pub doc: &'static str,
    /// Its value when the file leaves it out; `None`: required.
    pub default: Option<f64>,
}

/// Why a geometry is refused: which key, and why.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeometryError {
    pub key: &'static str,
    pub reason: &'static str,
}

impl fmt::Display for GeometryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.key, self.reason)
    }
}

/// Why a point is out of a kinematics' reach.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Unreachable {
    /// Beyond what the arms can reach, or closer in than they fold.
    OutOfReach,
    /// Within the margin of a singularity, where a joint's rate per unit
    /// of path would be unbounded.
    NearSingularity,
}

impl fmt::Display for Unreachable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Unreachable::OutOfReach => "out of the arms' reach",
            Unreachable::NearSingularity => "too near a singularity (arms stretched or folded)",
        })
    }
}

/// A machine's planar kinematics: see the module documentation for how to
/// add one.
pub trait Kinematics: Copy + fmt::Debug + PartialEq {
    /// Its name in machine files (`kinematics = "…"`).
    const NAME: &'static str;
    /// The joints that replace x and y, in order (none: x and y are joints).
    const JOINTS: &'static [JointSpec];
    /// The geometry it reads from `[geometry]`, in the order
    /// [`Kinematics::from_params`] takes it.
    const PARAMS: &'static [Param];

    /// Builds it from [`Kinematics::PARAMS`]' values, in order.
    fn from_params(values: &[f64]) -> Result<Self, GeometryError>;

    /// Its geometry, in [`Kinematics::PARAMS`]' order.
    fn params(&self) -> [f64; MAX_PARAMS];

    /// Joint `j` at the plane point `(x, y)`; an angle on the branch
    /// nearest `reference`. `None` where the point is out of reach.
    fn inverse(&self, j: usize, x: f64, y: f64, reference: f64) -> Option<f64>;

    /// The plane point the joints put the tool at; `None` where they
    /// cannot meet.
    fn forward(&self, joints: [f64; 2]) -> Option<(f64, f64)>;

    /// `(coefficient of x, coefficient of y)` when joint `j` is linear in
    /// them: such a joint is a row of coefficients, stepped in closed form.
    fn linear(&self, _j: usize) -> Option<[f64; 2]> {
        None
    }

    /// Joint `j` along the line `p0 + w·s` in closed form, when there is
    /// one; otherwise nodes bracket each step's crossing.
    fn closed_form(
        &self,
        _j: usize,
        _p0: (f64, f64),
        _w: (f64, f64),
        _reference: f64,
    ) -> Option<ClosedForm> {
        None
    }

    /// Whether `(x, y)` can be reached with a margin from every
    /// singularity.
    fn reach(&self, x: f64, y: f64) -> Result<(), Unreachable> {
        match (0..Self::JOINTS.len()).all(|j| self.inverse(j, x, y, 0.0).is_some()) {
            true => Ok(()),
            false => Err(Unreachable::OutOfReach),
        }
    }
}

/// The most geometry values any kinematics has.
pub const MAX_PARAMS: usize = 6;

/// How one joint's value follows from a point in machine space.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum JointMap {
    /// joint = Σ coeffs[i] · p[i]: cartesian, CoreXY, any kinematic matrix.
    Linear { coeffs: [f64; MAX_AXES] },
    /// Joint `joint` of a planar kinematics, of the point's axes `x` and `y`.
    Plane {
        kinematics: KinematicsKind,
        joint: u8,
        x: u8,
        y: u8,
    },
}

impl JointMap {
    /// A joint that is exactly machine axis `axis`.
    pub fn axis(axis: usize) -> JointMap {
        let mut coeffs = [0.0; MAX_AXES];
        coeffs[axis] = 1.0;
        JointMap::Linear { coeffs }
    }

    /// A polar machine's radius joint, of axes `x` and `y`.
    pub fn polar_radius(x: u8, y: u8) -> JointMap {
        JointMap::Plane {
            kinematics: KinematicsKind::POLAR,
            joint: 0,
            x,
            y,
        }
    }

    /// A polar machine's angle joint, of axes `x` and `y`.
    pub fn polar_angle(x: u8, y: u8) -> JointMap {
        JointMap::Plane {
            kinematics: KinematicsKind::POLAR,
            joint: 1,
            x,
            y,
        }
    }

    /// The joint's value at `p`. For angles, the branch nearest `reference`.
    /// NaN where the point is out of the kinematics' reach.
    pub fn value(&self, p: &Point, reference: f64) -> f64 {
        match *self {
            JointMap::Linear { coeffs } => {
                let mut v = 0.0;
                for i in 0..MAX_AXES {
                    v += coeffs[i] * p[i];
                }
                v
            }
            JointMap::Plane {
                kinematics,
                joint,
                x,
                y,
            } => kinematics
                .inverse(joint as usize, p[x as usize], p[y as usize], reference)
                .unwrap_or(f64::NAN),
        }
    }

    /// Axes whose positions the joint depends on, as a bit mask.
    pub fn axis_mask(&self) -> u8 {
        match *self {
            JointMap::Linear { coeffs } => {
                let mut m = 0;
                for (i, c) in coeffs.iter().enumerate() {
                    if *c != 0.0 {
                        m |= 1 << i;
                    }
                }
                m
            }
            JointMap::Plane { x, y, .. } => (1 << x) | (1 << y),
        }
    }

    /// Whether it only names axes a point has, with finite coefficients and
    /// a geometry its kinematics accepts: what a node checks before taking
    /// it (a map naming axis 6 would index out of every point; a NaN
    /// coefficient would make a channel that never steps).
    pub fn is_valid(&self) -> bool {
        match *self {
            JointMap::Linear { coeffs } => coeffs.iter().all(|c| c.is_finite()),
            JointMap::Plane {
                kinematics,
                joint,
                x,
                y,
            } => {
                (x as usize) < MAX_AXES
                    && (y as usize) < MAX_AXES
                    && x != y
                    && (joint as usize) < kinematics.joints().len()
                    && kinematics.is_valid()
            }
        }
    }

    /// Whether the joint is an angle (degrees), which a straight line turns
    /// by less than half a turn.
    pub fn is_angle(&self) -> bool {
        match *self {
            JointMap::Linear { .. } => false,
            JointMap::Plane {
                kinematics, joint, ..
            } => kinematics
                .joints()
                .get(joint as usize)
                .is_some_and(|j| j.angle),
        }
    }
}

/// `angle + 360·k` nearest to `reference` (degrees).
#[inline]
pub fn nearest_turn(angle: f64, reference: f64) -> f64 {
    let turns = crate::math::round((reference - angle) / 360.0);
    angle + 360.0 * turns
}

const DEG: f64 = 180.0 / core::f64::consts::PI;

#[cfg(test)]
mod tests;
