//! Linear delta (rostock style, as Klipper's `delta`): three carriages
//! ride vertical towers standing at `radius` from the centre, at 210°, 330°
//! and 90° (towers a, b and c); each pulls the effector by a rod `arm` long.
//! A carriage's height is `z + √(arm² − d²)`, with `d` the horizontal
//! distance from the tool to its tower. The three joints replace x, y and z.

use super::{GeometryError, JointSpec, Kinematics, Param, Unreachable, Xyz, MAX_PARAMS};
use crate::math::{cos, sin, sqrt};
use serde::{Deserialize, Serialize};

/// A delta's geometry: the towers' distance from the centre and the rods'
/// length, mm (the effector's and carriages' offsets folded into `radius`,
/// as Klipper's `delta_radius`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Delta {
    /// Horizontal distance from the centre to each tower's rod joint, mm.
    pub radius: f64,
    /// Rod length, carriage joint to effector joint, mm.
    pub arm: f64,
}

/// The towers' angles from +x, degrees, in joint order.
const TOWERS: [f64; 3] = [210.0, 330.0, 90.0];

/// The flattest a rod may lie, as the sine of its angle above the
/// horizontal: flat, a carriage's rate per mm of tool travel is unbounded;
/// at this angle (about 20°) it is below 3.
const MIN_ROD_SINE: f64 = 0.342;

impl Delta {
    /// Tower `j`'s position in the plane.
    fn tower(&self, j: usize) -> (f64, f64) {
        let a = TOWERS[j].to_radians();
        (self.radius * cos(a), self.radius * sin(a))
    }

    /// `arm² − d²` for tower `j` at `(x, y)`: the rod's vertical extent,
    /// squared.
    fn rise2(&self, j: usize, x: f64, y: f64) -> f64 {
        let (tx, ty) = self.tower(j);
        let (dx, dy) = (x - tx, y - ty);
        self.arm * self.arm - dx * dx - dy * dy
    }
}

impl Kinematics for Delta {
    const NAME: &'static str = "delta";
    const JOINTS: &'static [JointSpec] = &[
        JointSpec::length("a"),
        JointSpec::length("b"),
        JointSpec::length("c"),
    ];
    const PARAMS: &'static [Param] = &[
        Param {
            key: "radius",
            doc: "horizontal distance from the centre to each tower's rod joint (mm)",
            default: None,
        },
        Param {
            key: "arm",
            doc: "rod length, carriage to effector (mm)",
            default: None,
        },
    ];

    fn from_params(v: &[f64]) -> Result<Self, GeometryError> {
        let [radius, arm] = v else {
            return Err(GeometryError {
                key: "radius",
                reason: "delta takes radius and arm",
            });
        };
        for (key, l) in [("radius", radius), ("arm", arm)] {
            if !(l.is_finite() && *l > 0.0) {
                return Err(GeometryError {
                    key,
                    reason: "must be a positive length",
                });
            }
        }
        // At the centre every rod must stand clear of flat, or no point
        // would be in reach.
        if *radius >= arm * sqrt(1.0 - MIN_ROD_SINE * MIN_ROD_SINE) {
            return Err(GeometryError {
                key: "arm",
                reason: "must be longer than radius / cos(20°): the rods would lie almost flat at the centre",
            });
        }
        Ok(Delta {
            radius: *radius,
            arm: *arm,
        })
    }

    fn params(&self) -> [f64; MAX_PARAMS] {
        [self.radius, self.arm, 0.0, 0.0, 0.0, 0.0]
    }

    fn inverse(&self, j: usize, [x, y, z]: Xyz, _: f64) -> Option<f64> {
        let r2 = self.rise2(j, x, y);
        (r2 >= 0.0).then(|| z + sqrt(r2))
    }

    /// Trilateration: the point `arm` from the three carriage joints, below
    /// them.
    fn forward(&self, [a, b, c]: Xyz) -> Option<Xyz> {
        let p = [a, b, c];
        let centre = |j: usize| {
            let (x, y) = self.tower(j);
            [x, y, p[j]]
        };
        let (p1, p2, p3) = (centre(0), centre(1), centre(2));
        let sub = |u: Xyz, v: Xyz| [u[0] - v[0], u[1] - v[1], u[2] - v[2]];
        let dot = |u: Xyz, v: Xyz| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
        let scale = |u: Xyz, k: f64| [u[0] * k, u[1] * k, u[2] * k];
        let e21 = sub(p2, p1);
        let d = sqrt(dot(e21, e21));
        let ex = scale(e21, 1.0 / d);
        let e31 = sub(p3, p1);
        let i = dot(ex, e31);
        let ey_raw = sub(e31, scale(ex, i));
        let j = sqrt(dot(ey_raw, ey_raw));
        let ey = scale(ey_raw, 1.0 / j);
        let ez = [
            ex[1] * ey[2] - ex[2] * ey[1],
            ex[2] * ey[0] - ex[0] * ey[2],
            ex[0] * ey[1] - ex[1] * ey[0],
        ];
        // Equal rods: the spheres' radical planes give x and y directly.
        let u = 0.5 * d;
        let v = (i * i + j * j - 2.0 * i * u) / (2.0 * j);
        let w2 = self.arm * self.arm - u * u - v * v;
        if !(w2 >= 0.0 && d > 0.0 && j > 0.0) {
            return None;
        }
        let w = sqrt(w2);
        let base = [0, 1, 2].map(|k| p1[k] + ex[k] * u + ey[k] * v);
        // The effector hangs below the carriages: the root on ez's lower side.
        let sign = if ez[2] > 0.0 { -1.0 } else { 1.0 };
        Some([0, 1, 2].map(|k| base[k] + sign * w * ez[k]))
    }

    fn gradient_bound(&self, _: usize) -> Option<f64> {
        // |∇h| = 1 / sin(rod angle), largest where the rod is flattest.
        Some(1.0 / MIN_ROD_SINE)
    }

    fn reach(&self, [x, y, _]: Xyz) -> Result<(), Unreachable> {
        let a2 = self.arm * self.arm;
        let mut near = false;
        for j in 0..3 {
            let r2 = self.rise2(j, x, y);
            if r2 < 0.0 {
                return Err(Unreachable::OutOfReach);
            }
            near |= r2 < a2 * MIN_ROD_SINE * MIN_ROD_SINE;
        }
        match near {
            true => Err(Unreachable::NearSingularity),
            false => Ok(()),
        }
    }
}
