//! Polar: a turntable and a radial arm. r = |(x, y)| in mm, θ = the angle
//! of (x, y) in degrees, unwrapped to stay continuous. Both joints have a
//! closed form along a line, so nodes solve their steps directly.

use super::{
    nearest_turn, ClosedForm, GeometryError, JointSpec, Kinematics, Param, Xyz, DEG, MAX_PARAMS,
};
use crate::math::{atan2, cos, hypot, sin};
use serde::{Deserialize, Serialize};

/// Polar kinematics: joints `r` (mm, from the turntable's centre at the
/// origin) and `theta` (degrees from +x); no geometry. θ's rate grows
/// without bound near the centre, so how close a path may pass is the
/// machine's `min_radius`, which the host checks.
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

    fn inverse(&self, j: usize, [x, y, _]: Xyz, reference: f64) -> Option<f64> {
        Some(if j == 0 {
            hypot(x, y)
        } else {
            nearest_turn(atan2(y, x) * DEG, reference)
        })
    }

    fn forward(&self, [r, theta, z]: Xyz) -> Option<Xyz> {
        let t = theta / DEG;
        Some([r * cos(t), r * sin(t), z])
    }

    fn closed_form(&self, j: usize, p0: Xyz, w: Xyz, reference: f64) -> Option<ClosedForm> {
        let (p0, w) = ((p0[0], p0[1]), (w[0], w[1]));
        Some(if j == 0 {
            ClosedForm::Radius { p0, w }
        } else {
            ClosedForm::Angle {
                p0,
                w,
                theta0: self.inverse(1, [p0.0, p0.1, 0.0], reference)?,
            }
        })
    }

    fn gradient_bound(&self, j: usize) -> Option<f64> {
        // |∇r| = 1 everywhere; the angle's grows without bound at the centre.
        (j == 0).then_some(1.0)
    }

    /// Everywhere: the centre is reachable, and how close a path may pass
    /// is the machine's `min_radius`, checked by the host.
    const LIMITED_REACH: bool = false;

    fn reach(&self, _: Xyz) -> Result<(), super::Unreachable> {
        Ok(())
    }
}
