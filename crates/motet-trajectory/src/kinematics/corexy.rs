//! CoreXY: two motors on crossed belts, a = x + y, b = x − y.

use super::{GeometryError, JointSpec, Kinematics, Param, Xyz, MAX_PARAMS};
use serde::{Deserialize, Serialize};

/// CoreXY kinematics: joints `a` = x + y and `b` = x − y, mm of belt; both
/// linear, so stepped in closed form. No geometry.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CoreXY;

impl Kinematics for CoreXY {
    const NAME: &'static str = "corexy";
    const JOINTS: &'static [JointSpec] = &[JointSpec::length("a"), JointSpec::length("b")];
    const PARAMS: &'static [Param] = &[];

    fn from_params(_: &[f64]) -> Result<Self, GeometryError> {
        Ok(CoreXY)
    }

    fn params(&self) -> [f64; MAX_PARAMS] {
        [0.0; MAX_PARAMS]
    }

    fn inverse(&self, j: usize, [x, y, _]: Xyz, _: f64) -> Option<f64> {
        Some(if j == 0 { x + y } else { x - y })
    }

    fn forward(&self, [a, b, z]: Xyz) -> Option<Xyz> {
        Some([0.5 * (a + b), 0.5 * (a - b), z])
    }

    fn linear(&self, j: usize) -> Option<Xyz> {
        Some(if j == 0 {
            [1.0, 1.0, 0.0]
        } else {
            [1.0, -1.0, 0.0]
        })
    }
}
