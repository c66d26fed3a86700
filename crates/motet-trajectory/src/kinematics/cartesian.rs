//! Cartesian: x and y are joints of their own.

use super::{GeometryError, JointSpec, Kinematics, Param, Xyz, MAX_PARAMS};
use serde::{Deserialize, Serialize};

/// Cartesian kinematics: no joints of its own, every axis is stepped
/// directly (each one a [`super::JointMap::Linear`] row).
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

    fn inverse(&self, j: usize, p: Xyz, _: f64) -> Option<f64> {
        p.get(j).copied()
    }

    fn forward(&self, joints: Xyz) -> Option<Xyz> {
        Some(joints)
    }

    fn linear(&self, j: usize) -> Option<Xyz> {
        let mut c = [0.0; 3];
        *c.get_mut(j)? = 1.0;
        Some(c)
    }
}
