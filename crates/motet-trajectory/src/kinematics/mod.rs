//! Kinematics: how joints (what actuators move) follow from machine-space points.
//!
//! A kinematics is one type implementing [`Kinematics`], in a file of its
//! own, listed once in the `kinematics!` table below, which makes it
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
//!    and the workspace it can reach). A joint linear in x, y and z says so in
//!    [`Kinematics::linear`] and is stepped in closed form; any other joint
//!    is stepped by bracketing its crossing along the segment, exact to the
//!    nanosecond, unless the kinematics gives a closed form
//!    ([`Kinematics::closed_form`], as polar and delta do).
//! 2. Add one line, `<name>::<Type>`, to the `kinematics!` table in this
//!    file: it declares the module and makes the kind a variant of
//!    [`KinematicsKind`].
//!
//! Nothing else changes: machine files accept the name and its geometry,
//! the wire encodes it (docs/wire.md), the planner bounds its joints'
//! rates, the simulator checks its steps. `tests/kinematics_props.rs` runs
//! its round trip, solve, turns and rate and gradient bounds with the
//! others once a geometry is added to its list.
//!
//! A kinematics works on the tool point `[x, y, z]` ([`Xyz`]). Its joints
//! replace the first of the machine's x, y and z axes: planar kinds (two
//! joints) replace x and y and ignore z, a delta's three carriages replace
//! all three; every other axis stays a joint of its own. Angles are in
//! degrees.

#[macro_use]
mod table;
mod path;

// The table of kinematics: each kind's file (a module of this one) and its
// type, once. The order is the wire's (docs/wire.md).
kinematics! {
    cartesian::Cartesian,
    corexy::CoreXY,
    hbot::HBot,
    polar::Polar,
    five_bar::FiveBar,
    scara::Scara,
    delta::Delta,
}

pub use delta::Carriage;
pub use path::{ClosedForm, JointPath};

use crate::point::{Point, MAX_AXES};
use core::fmt;
use serde::{Deserialize, Serialize};

/// One joint of a kinematics: its name in machine files, and whether it is
/// an angle (degrees) or a length (mm).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JointSpec {
    /// The name a machine file's actuator gives as its `joint` (`a`,
    /// `theta`, `shoulder`, ...).
    pub name: &'static str,
    /// An angle in degrees (unwrapped along a path, stepped through a chain
    /// starting at degrees) rather than a length in mm.
    pub angle: bool,
}

impl JointSpec {
    /// A joint measured in mm (a carriage, a belt, a radius).
    pub const fn length(name: &'static str) -> JointSpec {
        JointSpec { name, angle: false }
    }
    /// A joint measured in degrees (a turntable, a shoulder, an elbow).
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
    /// The `[geometry]` key at fault, as the machine file spells it; the
    /// host adds the file and line.
    pub key: &'static str,
    /// What the value must be ("must be a positive length", ...).
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

/// A tool point `[x, y, z]` in machine space (mm).
pub type Xyz = [f64; 3];

/// A machine's kinematics: see the module documentation for how to add
/// one.
pub trait Kinematics: Copy + fmt::Debug + PartialEq {
    /// Its name in machine files (`kinematics = "…"`).
    const NAME: &'static str;
    /// The joints that replace the first of x, y and z, in order: two
    /// replace x and y (planar kinematics), three replace x, y and z (a
    /// delta); none: every axis is its own joint.
    const JOINTS: &'static [JointSpec];
    /// The geometry it reads from `[geometry]`, in the order
    /// [`Kinematics::from_params`] takes it.
    const PARAMS: &'static [Param];

    /// Builds it from [`Kinematics::PARAMS`]' values, in order.
    fn from_params(values: &[f64]) -> Result<Self, GeometryError>;

    /// Its geometry, in [`Kinematics::PARAMS`]' order.
    fn params(&self) -> [f64; MAX_PARAMS];

    /// Joint `j` at the tool point `p`; an angle on the branch nearest
    /// `reference`. `None` where the point is out of reach.
    fn inverse(&self, j: usize, p: Xyz, reference: f64) -> Option<f64>;

    /// The tool point from the joints: the kinematics' joints in order,
    /// then the tool coordinates they leave alone (a planar kinematics
    /// takes `[j0, j1, z]`). `None` where the joints cannot meet.
    fn forward(&self, joints: Xyz) -> Option<Xyz>;

    /// The coefficients of x, y and z when joint `j` is linear in them:
    /// such a joint is a row of coefficients, stepped in closed form.
    fn linear(&self, _j: usize) -> Option<Xyz> {
        None
    }

    /// Joint `j` along the line `p0 + w·s` in closed form, when there is
    /// one; otherwise nodes bracket each step's crossing.
    fn closed_form(&self, _j: usize, _p0: Xyz, _w: Xyz, _reference: f64) -> Option<ClosedForm> {
        None
    }

    /// The most joint `j` can change per mm of tool travel anywhere in the
    /// reach, when that is bounded: what bounds its speed from the axes'
    /// and the smallest move that steps it.
    fn gradient_bound(&self, _j: usize) -> Option<f64> {
        None
    }

    /// Whether [`Kinematics::reach`] can refuse a point: false for a
    /// kinematics that reaches everywhere, whose moves the host then does
    /// not sample.
    const LIMITED_REACH: bool = true;

    /// Whether `p` can be reached with a margin from every singularity.
    fn reach(&self, p: Xyz) -> Result<(), Unreachable> {
        match (0..Self::JOINTS.len()).all(|j| self.inverse(j, p, 0.0).is_some()) {
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
    /// `joint = Σ coeffs[i] · p[i]`: cartesian, CoreXY, any kinematic matrix.
    /// Stepped in closed form.
    Linear {
        /// Joint units per unit of each machine axis, indexed like a
        /// [`Point`]; 0 for axes the joint ignores.
        coeffs: [f64; MAX_AXES],
    },
    /// Joint `joint` of a kinematics, of the point's axes `axes` (x, y and
    /// z; z is [`NO_AXIS`] on a machine without one).
    Kinematic {
        /// The kinematics with its geometry.
        kinematics: KinematicsKind,
        /// Index into the kinematics' [`Kinematics::JOINTS`].
        joint: u8,
        /// Indices of the machine axes that are the tool point's x, y and
        /// z ([`tool_point`]); [`JointMap::is_valid`] checks them.
        axes: [u8; 3],
    },
}

/// In [`JointMap::Kinematic`]'s axes: the machine has no such axis (its
/// coordinate reads as 0).
pub const NO_AXIS: u8 = u8::MAX;

impl JointMap {
    /// A joint that is exactly machine axis `axis`.
    pub fn axis(axis: usize) -> JointMap {
        let mut coeffs = [0.0; MAX_AXES];
        coeffs[axis] = 1.0;
        JointMap::Linear { coeffs }
    }

    /// A polar machine's radius joint, of axes `x` and `y`.
    pub fn polar_radius(x: u8, y: u8) -> JointMap {
        JointMap::Kinematic {
            kinematics: KinematicsKind::POLAR,
            joint: 0,
            axes: [x, y, NO_AXIS],
        }
    }

    /// A polar machine's angle joint, of axes `x` and `y`.
    pub fn polar_angle(x: u8, y: u8) -> JointMap {
        JointMap::Kinematic {
            kinematics: KinematicsKind::POLAR,
            joint: 1,
            axes: [x, y, NO_AXIS],
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
            JointMap::Kinematic {
                kinematics,
                joint,
                axes,
            } => kinematics
                .inverse(joint as usize, tool_point(axes, p), reference)
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
            JointMap::Kinematic {
                kinematics, axes, ..
            } => axes[..kinematics.joints().len().max(2)]
                .iter()
                .filter(|a| (**a as usize) < MAX_AXES)
                .fold(0, |m, a| m | (1 << a)),
        }
    }

    /// Whether it only names axes a point has, with finite coefficients and
    /// a geometry its kinematics accepts: what a node checks before taking
    /// it (a map naming axis 6 would index out of every point; a NaN
    /// coefficient would make a channel that never steps).
    pub fn is_valid(&self) -> bool {
        match *self {
            JointMap::Linear { coeffs } => coeffs.iter().all(|c| c.is_finite()),
            JointMap::Kinematic {
                kinematics,
                joint,
                axes: [x, y, z],
            } => {
                let named = |a: u8| (a as usize) < MAX_AXES;
                let z_ok = match kinematics.joints().len() > 2 {
                    true => named(z) && z != x && z != y,
                    false => z == NO_AXIS || (named(z) && z != x && z != y),
                };
                named(x)
                    && named(y)
                    && x != y
                    && z_ok
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
            JointMap::Kinematic {
                kinematics, joint, ..
            } => kinematics
                .joints()
                .get(joint as usize)
                .is_some_and(|j| j.angle),
        }
    }
}

/// The tool point `[x, y, z]` of `p`, given the indices of its x, y and z
/// axes (z reads 0 where it is [`NO_AXIS`]).
#[inline]
pub fn tool_point(axes: [u8; 3], p: &Point) -> Xyz {
    let at = |a: u8| p.get(a as usize).copied().unwrap_or(0.0);
    [at(axes[0]), at(axes[1]), at(axes[2])]
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
