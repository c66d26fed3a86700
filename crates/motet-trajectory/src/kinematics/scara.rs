//! SCARA: a two-link arm in the plane, shoulder at the origin. The shoulder
//! angle θ1 is the upper arm's from +x; the elbow angle θ2 is the forearm's
//! from the upper arm's direction. Which way the elbow bends is fixed per
//! machine (`elbow`), so every point has one pose.

use super::{
    nearest_turn, GeometryError, JointSpec, Kinematics, Param, Unreachable, Xyz, DEG, MAX_PARAMS,
};
use crate::math::{acos, atan2, cos, sin};
use serde::{Deserialize, Serialize};

/// A SCARA arm's geometry. Joints `shoulder` and `elbow` in degrees (see
/// the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scara {
    /// Upper arm length, shoulder to elbow, mm.
    pub l1: f64,
    /// Forearm length, elbow to tool, mm.
    pub l2: f64,
    /// +1: the elbow angle is positive (the forearm turned counter-clockwise
    /// from the upper arm); −1: negative.
    pub elbow: f64,
}

/// How close to stretched or folded (the cosine of the elbow angle) a
/// point may bring the arm: the joints' rates grow without bound there.
const MARGIN: f64 = 1e-3;

impl Scara {
    /// The elbow angle's cosine at `(x, y)`.
    fn elbow_cos(&self, x: f64, y: f64) -> f64 {
        (x * x + y * y - self.l1 * self.l1 - self.l2 * self.l2) / (2.0 * self.l1 * self.l2)
    }

    /// (θ1, θ2) in radians at `(x, y)`; `None` out of reach.
    pub fn angles(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let c2 = self.elbow_cos(x, y);
        if !(-1.0..=1.0).contains(&c2) {
            return None;
        }
        let t2 = self.elbow * acos(c2);
        let t1 = atan2(y, x) - atan2(self.l2 * sin(t2), self.l1 + self.l2 * cos(t2));
        Some((t1, t2))
    }
}

impl Kinematics for Scara {
    const NAME: &'static str = "scara";
    const JOINTS: &'static [JointSpec] = &[JointSpec::angle("shoulder"), JointSpec::angle("elbow")];
    const PARAMS: &'static [Param] = &[
        Param {
            key: "l1",
            doc: "upper arm length, shoulder to elbow (mm)",
            default: None,
        },
        Param {
            key: "l2",
            doc: "forearm length, elbow to tool (mm)",
            default: None,
        },
        Param {
            key: "elbow",
            doc: "1: the elbow angle positive (counter-clockwise), -1: negative",
            default: Some(1.0),
        },
    ];

    fn from_params(v: &[f64]) -> Result<Self, GeometryError> {
        let [l1, l2, elbow] = v else {
            return Err(GeometryError {
                key: "l1",
                reason: "scara takes l1, l2 and elbow",
            });
        };
        for (key, l) in [("l1", l1), ("l2", l2)] {
            if !(l.is_finite() && *l > 0.0) {
                return Err(GeometryError {
                    key,
                    reason: "must be a positive length",
                });
            }
        }
        if *elbow != 1.0 && *elbow != -1.0 {
            return Err(GeometryError {
                key: "elbow",
                reason: "must be 1 or -1",
            });
        }
        Ok(Scara {
            l1: *l1,
            l2: *l2,
            elbow: *elbow,
        })
    }

    fn params(&self) -> [f64; MAX_PARAMS] {
        [self.l1, self.l2, self.elbow, 0.0, 0.0, 0.0]
    }

    fn inverse(&self, j: usize, [x, y, _]: Xyz, reference: f64) -> Option<f64> {
        let (t1, t2) = self.angles(x, y)?;
        Some(nearest_turn(if j == 0 { t1 } else { t2 } * DEG, reference))
    }

    fn forward(&self, [t1, t2, z]: Xyz) -> Option<Xyz> {
        let (a, b) = (t1 / DEG, (t1 + t2) / DEG);
        Some([
            self.l1 * cos(a) + self.l2 * cos(b),
            self.l1 * sin(a) + self.l2 * sin(b),
            z,
        ])
    }

    fn reach(&self, [x, y, _]: Xyz) -> Result<(), Unreachable> {
        let c2 = self.elbow_cos(x, y);
        if !(-1.0..=1.0).contains(&c2) {
            Err(Unreachable::OutOfReach)
        } else if c2.abs() > 1.0 - MARGIN {
            Err(Unreachable::NearSingularity)
        } else {
            Ok(())
        }
    }
}
