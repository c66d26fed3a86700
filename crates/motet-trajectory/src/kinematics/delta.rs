//! Linear delta (rostock style, as Klipper's `delta`): three carriages
//! ride vertical towers standing at `radius` from the centre, at 210°, 330°
//! and 90° (towers a, b and c); each pulls the effector by a rod `arm` long.
//! A carriage's height is `z + √(arm² − d²)`, with `d` the horizontal
//! distance from the tool to its tower. The three joints replace x, y and z.
//!
//! Along a straight line a carriage has a closed form ([`Carriage`]): it
//! rises and falls at most once (z is linear and the rod's rise concave),
//! and its crossing of a height is a root of a quadratic, so nodes solve
//! each step directly.

use super::{
    ClosedForm, GeometryError, JointSpec, Kinematics, Param, Unreachable, Xyz, MAX_PARAMS,
};
use crate::math::sqrt;
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

/// The towers' directions from the centre, in joint order: 210°, 330° and
/// 90° from +x.
const TOWERS: [(f64, f64); 3] = [
    (-0.866_025_403_784_438_6, -0.5),
    (0.866_025_403_784_438_6, -0.5),
    (0.0, 1.0),
];

/// The flattest a rod may lie, as the sine of its angle above the
/// horizontal: flat, a carriage's rate per mm of tool travel is unbounded;
/// at this angle (about 20°) it is below 3.
const MIN_ROD_SINE: f64 = 0.342;

impl Delta {
    /// Tower `j`'s position in the plane.
    fn tower(&self, j: usize) -> (f64, f64) {
        let (cx, cy) = TOWERS[j];
        (self.radius * cx, self.radius * cy)
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

    fn closed_form(&self, j: usize, p0: Xyz, w: Xyz, _: f64) -> Option<ClosedForm> {
        let (tx, ty) = self.tower(j);
        Some(ClosedForm::Carriage(Carriage {
            a: [p0[0] - tx, p0[1] - ty],
            z0: p0[2],
            w,
            arm2: self.arm * self.arm,
        }))
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

/// One carriage along the line `p0 + w·s`: its height is
/// `h(s) = z0 + wz·s + √R(s)` with `R(s) = arm² − |a + (wx, wy)·s|²`, `a`
/// the line's start relative to the tower in the plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Carriage {
    a: [f64; 2],
    z0: f64,
    w: Xyz,
    arm2: f64,
}

impl Carriage {
    /// `R(s)`: the rod's vertical extent, squared.
    #[inline]
    fn rise2(&self, s: f64) -> f64 {
        let (x, y) = (self.a[0] + self.w[0] * s, self.a[1] + self.w[1] * s);
        self.arm2 - x * x - y * y
    }

    /// The height at `s` (NaN where the rod cannot reach).
    #[inline]
    pub fn value(&self, s: f64) -> f64 {
        let r2 = self.rise2(s);
        if r2 < 0.0 {
            return f64::NAN;
        }
        self.z0 + self.w[2] * s + sqrt(r2)
    }

    /// Where the carriage turns (its one maximum: `h` is concave), if the
    /// line has one: `h'(s) = wz − (b + q·s)/√R(s) = 0`, with `q` the
    /// squared horizontal rate and `b = a·(wx, wy)`.
    pub fn turn(&self) -> Option<f64> {
        let [wx, wy, wz] = self.w;
        let q = wx * wx + wy * wy;
        let b = self.a[0] * wx + self.a[1] * wy;
        if q == 0.0 {
            // Straight up or down: monotone.
            return None;
        }
        if wz == 0.0 {
            return Some(-b / q);
        }
        // Squared: q·s² + 2b·s + (b² − wz²·C)/|w|² = 0, C = R(0); the root
        // where b + q·s has wz's sign is the turn.
        let c0 = self.rise2(0.0);
        let ww = q + wz * wz;
        let disc = b * b - q * (b * b - wz * wz * c0) / ww;
        if disc < 0.0 {
            return None;
        }
        let root = sqrt(disc);
        let s = if wz > 0.0 {
            (-b + root) / q
        } else {
            (-b - root) / q
        };
        Some(s)
    }

    /// The distance in `[lo, hi]` (a leg where the carriage is monotone) at
    /// which it is at height `target`: where the line meets the sphere of
    /// radius `arm` around the carriage's joint, on its lower half,
    /// `|w|²·s² + 2(b − D·wz)·s + D² − C = 0` with `D = target − z0`.
    pub fn solve(&self, target: f64, lo: f64, hi: f64) -> f64 {
        let [wx, wy, wz] = self.w;
        let ww = wx * wx + wy * wy + wz * wz;
        if ww == 0.0 {
            return lo;
        }
        let d = target - self.z0;
        let half_b = self.a[0] * wx + self.a[1] * wy - d * wz;
        let c = d * d - self.rise2(0.0);
        let disc = (half_b * half_b - ww * c).max(0.0);
        // Both roots without cancellation: q' = −(B + sign(B)·√disc).
        let k = -(half_b + sqrt(disc).copysign(half_b));
        let roots = [k / ww, if k != 0.0 { c / k } else { k / ww }];
        // The root in the leg, on the sphere's lower half (the carriage
        // above the tool); the nearer to the leg if rounding puts both out.
        let mid = 0.5 * (lo + hi);
        let score = |s: f64| {
            let outside = (lo - s).max(s - hi).max(0.0);
            let above = (d - wz * s).min(0.0).abs();
            (outside + above, (s - mid).abs())
        };
        let (s0, s1) = (roots[0], roots[1]);
        if score(s0) <= score(s1) {
            s0
        } else {
            s1
        }
    }
}
