//! Cartesian: x and y are joints of their own.

use super::{GeometryError, JointSpec, Kinematics, Param, MAX_PARAMS};
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cartesian;

impl Kinematics for Cartesian {
    const NAME: &'static str = "cartesian";
    const JOINTS: &'static [JointSpec] = &[];
    const PARAMS: &'static [Param] = &[];

    fn from_params(_: &[f64]) -> Result<Self, GeometryError> {
        Ok(Cartesian)
    }

    fn params(&self) -> [f64; MAX_PARAMS] {
        [0.0; MAX_PARAMS]
    }

    fn inverse(&self, j: usize, x: f64, y: f64, _: f64) -> Option<f64> {
        Some(if j == 0 { x } else { y })
    }

    fn forward(&self, [x, y]: [f64; 2]) -> Option<(f64, f64)> {
        Some((x, y))
    }

    fn linear(&self, j: usize) -> Option<[f64; 2]> {
        Some(if j == 0 { [1.0, 0.0] } else { [0.0, 1.0] })
    }
}
