//! Polar: a turntable and a radial arm. r = |(x, y)| in mm, θ = the angle
//! of (x, y) in degrees, unwrapped to stay continuous. Both joints have a
//! closed form along a line, so nodes solve their steps directly.

use super::{
    nearest_turn, ClosedForm, GeometryError, JointSpec, Kinematics, Param, DEG, MAX_PARAMS,
};
use crate::math::{atan2, cos, hypot, sin};
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Polar;

impl Kinematics for Polar {
    const NAME: &'static str = "polar";
    const JOINTS: &'static [JointSpec] = &[JointSpec::length("r"), JointSpec::angle("theta")];
    const PARAMS: &'static [Param] = &[];

    fn from_params(_: &[f64]) -> Result<Self, GeometryError> {
        Ok(Polar)
    }

    fn params(&self) -> [f64; MAX_PARAMS] {
        [0.0; MAX_PARAMS]
    }

    fn inverse(&self, j: usize, x: f64, y: f64, reference: f64) -> Option<f64> {
        Some(if j == 0 {
            hypot(x, y)
        } else {
            nearest_turn(atan2(y, x) * DEG, reference)
        })
    }

    fn forward(&self, [r, theta]: [f64; 2]) -> Option<(f64, f64)> {
        let t = theta / DEG;
        Some((r * cos(t), r * sin(t)))
    }

    fn closed_form(
        &self,
        j: usize,
        p0: (f64, f64),
        w: (f64, f64),
        reference: f64,
    ) -> Option<ClosedForm> {
        Some(if j == 0 {
            ClosedForm::Radius { p0, w }
        } else {
            ClosedForm::Angle {
                p0,
                w,
                theta0: self.inverse(1, p0.0, p0.1, reference)?,
            }
        })
    }

    /// The centre is reachable; how close a path may pass is the machine's
    /// `min_radius`, checked by the host.
    fn reach(&self, _: f64, _: f64) -> Result<(), super::Unreachable> {
        Ok(())
    }
}
