//! H-bot: one H-shaped belt, the same joint math as CoreXY (Gestalt:
//! ΔX = ½(ΔA+ΔB), ΔY = ½(ΔA−ΔB)); the difference is mechanical (racking),
//! not kinematic, so it is CoreXY's under its own name.

use super::{CoreXY, GeometryError, JointSpec, Kinematics, Param, Xyz, MAX_PARAMS};
use serde::{Deserialize, Serialize};

/// H-bot kinematics: CoreXY's joints `a` and `b` under the name `hbot`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HBot;

impl Kinematics for HBot {
    const NAME: &'static str = "hbot";
    const JOINTS: &'static [JointSpec] = CoreXY::JOINTS;
    const PARAMS: &'static [Param] = &[];

    fn from_params(_: &[f64]) -> Result<Self, GeometryError> {
        Ok(HBot)
    }

    fn params(&self) -> [f64; MAX_PARAMS] {
        [0.0; MAX_PARAMS]
    }

    fn inverse(&self, j: usize, p: Xyz, r: f64) -> Option<f64> {
        CoreXY.inverse(j, p, r)
    }

    fn forward(&self, joints: Xyz) -> Option<Xyz> {
        CoreXY.forward(joints)
    }

    fn linear(&self, j: usize) -> Option<Xyz> {
        CoreXY.linear(j)
    }
}
