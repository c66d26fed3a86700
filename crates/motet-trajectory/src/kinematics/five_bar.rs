//! Five-bar linkage (a parallel SCARA; Stepdance's drawing arm and
//! pantograph): base pivots at `(0, 0)` and `(s, 0)`; proximal links `l1`
//! (left) and `l2` (right) at angles θ1, θ2 from +x; distal links `l3`
//! (left) and `l4` (right) meet at the joint above the elbows (the +y side
//! of the line from the left elbow to the right); the stylus sits on the
//! left distal link extended by `ext` beyond the joint. Elbows point
//! outward. The motion-stream graph's `fivebar` component uses this same
//! geometry.

use super::{
    nearest_turn, GeometryError, JointSpec, Kinematics, Param, Unreachable, Xyz, DEG, MAX_PARAMS,
};
use crate::math::{acos, atan2, cos, hypot, sin, sqrt};
use serde::{Deserialize, Serialize};

/// A five-bar linkage's geometry, mm (see the module documentation for
/// the layout). Joints `theta1` and `theta2` are the proximal links' angles
/// from +x, degrees.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FiveBar {
    /// Distance from the left base pivot `(0, 0)` to the right one
    /// `(s, 0)`, mm.
    pub s: f64,
    /// Left proximal link, left pivot to left elbow, mm.
    pub l1: f64,
    /// Right proximal link, right pivot to right elbow, mm.
    pub l2: f64,
    /// Left distal link, left elbow to the joint, mm.
    pub l3: f64,
    /// Right distal link, right elbow to the joint, mm.
    pub l4: f64,
    /// The stylus's distance beyond the joint along the left distal link,
    /// mm (0: the stylus is at the joint).
    pub ext: f64,
}

/// How near to stretched or folded a link pair may come (the cosine at
/// the pivot), and how near to parallel the distal links (the sine of the
/// angle between them): the joints' rates, or the stylus's, grow without
/// bound there.
const MARGIN: f64 = 1e-3;
const PARALLEL: f64 = 0.05;

/// A solved pose: angles in radians, and how far from each singularity.
struct Pose {
    t1: f64,
    t2: f64,
    /// Cosines at the left and right pivots.
    c1: f64,
    c2: f64,
    /// Sine of the angle between the distal links.
    parallel: f64,
}

impl FiveBar {
    /// Pivots `s` apart, links `l1`..`l4`, no extension.
    pub fn new(s: f64, l1: f64, l2: f64, l3: f64, l4: f64) -> FiveBar {
        FiveBar {
            s,
            l1,
            l2,
            l3,
            l4,
            ext: 0.0,
        }
    }

    /// The stylus point for angles in radians; `None` when the distal links
    /// cannot meet.
    pub fn point(&self, t1: f64, t2: f64) -> Option<(f64, f64)> {
        let (e1x, e1y) = (self.l1 * cos(t1), self.l1 * sin(t1));
        let (e2x, e2y) = (self.s + self.l2 * cos(t2), self.l2 * sin(t2));
        let (dx, dy) = (e2x - e1x, e2y - e1y);
        let d = hypot(dx, dy);
        if d == 0.0 || d > self.l3 + self.l4 || d < (self.l3 - self.l4).abs() {
            return None;
        }
        let a = (self.l3 * self.l3 - self.l4 * self.l4 + d * d) / (2.0 * d);
        let h = sqrt((self.l3 * self.l3 - a * a).max(0.0));
        let (ux, uy) = (dx / d, dy / d);
        let px = e1x + a * ux - h * uy;
        let py = e1y + a * uy + h * ux;
        let k = (self.l3 + self.ext) / self.l3;
        Some((e1x + (px - e1x) * k, e1y + (py - e1y) * k))
    }

    /// Angles in radians for a stylus point, elbows outward (the left
    /// elbow counter-clockwise of the left pivot→joint line, the right one
    /// clockwise); `None` out of reach.
    pub fn angles(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        self.pose(x, y).map(|p| (p.t1, p.t2))
    }

    fn pose(&self, x: f64, y: f64) -> Option<Pose> {
        // Left arm: a rigid link of l3 + ext from the left elbow to the stylus.
        let l = self.l3 + self.ext;
        let d1 = hypot(x, y);
        let c1 = (self.l1 * self.l1 + d1 * d1 - l * l) / (2.0 * self.l1 * d1);
        if d1 == 0.0 || !(-1.0..=1.0).contains(&c1) {
            return None;
        }
        let t1 = atan2(y, x) + acos(c1);
        let (e1x, e1y) = (self.l1 * cos(t1), self.l1 * sin(t1));
        // The joint, l3 along the left distal link.
        let (px, py) = (e1x + (x - e1x) * self.l3 / l, e1y + (y - e1y) * self.l3 / l);
        let (rx, ry) = (px - self.s, py);
        let d2 = hypot(rx, ry);
        let c2 = (self.l2 * self.l2 + d2 * d2 - self.l4 * self.l4) / (2.0 * self.l2 * d2);
        if d2 == 0.0 || !(-1.0..=1.0).contains(&c2) {
            return None;
        }
        let t2 = atan2(ry, rx) - acos(c2);
        let (e2x, e2y) = (self.s + self.l2 * cos(t2), self.l2 * sin(t2));
        let (ax, ay) = (px - e1x, py - e1y);
        let (bx, by) = (px - e2x, py - e2y);
        let parallel = (ax * by - ay * bx).abs() / (self.l3 * self.l4);
        Some(Pose {
            t1,
            t2,
            c1,
            c2,
            parallel,
        })
    }
}

impl Kinematics for FiveBar {
    const NAME: &'static str = "fivebar";
    const JOINTS: &'static [JointSpec] = &[JointSpec::angle("theta1"), JointSpec::angle("theta2")];
    const PARAMS: &'static [Param] = &[
        Param {
            key: "s",
            doc: "distance from the left pivot to the right one, along +x (mm)",
            default: None,
        },
        Param {
            key: "l1",
            doc: "left proximal link (mm)",
            default: None,
        },
        Param {
            key: "l2",
            doc: "right proximal link (mm)",
            default: None,
        },
        Param {
            key: "l3",
            doc: "left distal link, elbow to joint (mm)",
            default: None,
        },
        Param {
            key: "l4",
            doc: "right distal link, elbow to joint (mm)",
            default: None,
        },
        Param {
            key: "ext",
            doc: "the stylus's distance beyond the joint along the left distal link (mm)",
            default: Some(0.0),
        },
    ];

    fn from_params(v: &[f64]) -> Result<Self, GeometryError> {
        let [s, l1, l2, l3, l4, ext] = v else {
            return Err(GeometryError {
                key: "s",
                reason: "fivebar takes s, l1, l2, l3, l4 and ext",
            });
        };
        for (key, l) in [("l1", l1), ("l2", l2), ("l3", l3), ("l4", l4)] {
            if !(l.is_finite() && *l > 0.0) {
                return Err(GeometryError {
                    key,
                    reason: "must be a positive length",
                });
            }
        }
        if !s.is_finite() {
            return Err(GeometryError {
                key: "s",
                reason: "must be a finite length",
            });
        }
        if !(ext.is_finite() && l3 + ext > 0.0) {
            return Err(GeometryError {
                key: "ext",
                reason: "must be finite, and l3 + ext positive",
            });
        }
        Ok(FiveBar {
            s: *s,
            l1: *l1,
            l2: *l2,
            l3: *l3,
            l4: *l4,
            ext: *ext,
        })
    }

    fn params(&self) -> [f64; MAX_PARAMS] {
        [self.s, self.l1, self.l2, self.l3, self.l4, self.ext]
    }

    fn inverse(&self, j: usize, [x, y, _]: Xyz, reference: f64) -> Option<f64> {
        let (t1, t2) = self.angles(x, y)?;
        Some(nearest_turn(if j == 0 { t1 } else { t2 } * DEG, reference))
    }

    fn forward(&self, [t1, t2, z]: Xyz) -> Option<Xyz> {
        let (x, y) = self.point(t1 / DEG, t2 / DEG)?;
        Some([x, y, z])
    }

    fn reach(&self, [x, y, _]: Xyz) -> Result<(), Unreachable> {
        let p = self.pose(x, y).ok_or(Unreachable::OutOfReach)?;
        if p.c1.abs() > 1.0 - MARGIN || p.c2.abs() > 1.0 - MARGIN || p.parallel < PARALLEL {
            Err(Unreachable::NearSingularity)
        } else {
            Ok(())
        }
    }
}
