//! The table of kinematics: one line per kind (see the module
//! documentation). The macro makes [`KinematicsKind`] with a variant per
//! kind, and the dispatch every layer goes through.

use super::{
    Cartesian, ClosedForm, CoreXY, FiveBar, GeometryError, HBot, JointMap, JointSpec, Kinematics,
    Param, Polar, Scara, Unreachable, MAX_PARAMS,
};
use crate::point::MAX_AXES;
use serde::{Deserialize, Serialize};

macro_rules! kinematics {
    ($($kind:ident),* $(,)?) => {
        /// A machine's kinematics with its geometry: one variant per kind in
        /// the table.
        #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
        pub enum KinematicsKind {
            $($kind($kind)),*
        }

        impl KinematicsKind {
            /// Every kind's name, in the table's order.
            pub const NAMES: &'static [&'static str] = &[$(<$kind as Kinematics>::NAME),*];

            /// The kind named `name` built from its geometry values (in
            /// the order of [`KinematicsKind::params_of`]); `None` for an
            /// unknown name.
            pub fn from_name(name: &str, values: &[f64]) -> Option<Result<Self, GeometryError>> {
                $(if name == <$kind as Kinematics>::NAME {
                    return Some(<$kind as Kinematics>::from_params(values).map(KinematicsKind::$kind));
                })*
                None
            }

            /// The geometry the kind named `name` reads.
            pub fn params_of(name: &str) -> Option<&'static [Param]> {
                $(if name == <$kind as Kinematics>::NAME {
                    return Some(<$kind as Kinematics>::PARAMS);
                })*
                None
            }

            pub fn name(&self) -> &'static str {
                match self { $(KinematicsKind::$kind(_) => <$kind as Kinematics>::NAME),* }
            }

            /// The joints that replace x and y (none: x and y are joints).
            pub fn joints(&self) -> &'static [JointSpec] {
                match self { $(KinematicsKind::$kind(_) => <$kind as Kinematics>::JOINTS),* }
            }

            pub fn param_specs(&self) -> &'static [Param] {
                match self { $(KinematicsKind::$kind(_) => <$kind as Kinematics>::PARAMS),* }
            }

            pub fn params(&self) -> [f64; MAX_PARAMS] {
                match self { $(KinematicsKind::$kind(k) => k.params()),* }
            }

            pub fn inverse(&self, j: usize, x: f64, y: f64, reference: f64) -> Option<f64> {
                match self { $(KinematicsKind::$kind(k) => k.inverse(j, x, y, reference)),* }
            }

            pub fn forward(&self, joints: [f64; 2]) -> Option<(f64, f64)> {
                match self { $(KinematicsKind::$kind(k) => k.forward(joints)),* }
            }

            pub fn linear(&self, j: usize) -> Option<[f64; 2]> {
                match self { $(KinematicsKind::$kind(k) => k.linear(j)),* }
            }

            pub fn closed_form(
                &self,
                j: usize,
                p0: (f64, f64),
                w: (f64, f64),
                reference: f64,
            ) -> Option<ClosedForm> {
                match self { $(KinematicsKind::$kind(k) => k.closed_form(j, p0, w, reference)),* }
            }

            pub fn reach(&self, x: f64, y: f64) -> Result<(), Unreachable> {
                match self { $(KinematicsKind::$kind(k) => k.reach(x, y)),* }
            }
        }
    };
}

kinematics!(Cartesian, CoreXY, HBot, Polar, FiveBar, Scara);

impl KinematicsKind {
    /// The kinds that have no geometry.
    pub const CARTESIAN: KinematicsKind = KinematicsKind::Cartesian(Cartesian);
    pub const COREXY: KinematicsKind = KinematicsKind::CoreXY(CoreXY);
    pub const HBOT: KinematicsKind = KinematicsKind::HBot(HBot);
    pub const POLAR: KinematicsKind = KinematicsKind::Polar(Polar);

    /// Whether its geometry is one its kind accepts (a value off the wire
    /// is checked before use).
    pub fn is_valid(&self) -> bool {
        let n = self.param_specs().len();
        KinematicsKind::from_name(self.name(), &self.params()[..n]).is_some_and(|r| r.is_ok())
    }

    /// Whether joint `j` of [`KinematicsKind::joints`] is an angle (degrees).
    pub fn joint_is_angle(&self, j: usize) -> bool {
        self.joints().get(j).is_some_and(|s| s.angle)
    }

    /// The map of joint `j` given the indices of the x and y axes: a row of
    /// coefficients where the joint is linear.
    pub fn joint_map(&self, j: usize, x: usize, y: usize) -> JointMap {
        match self.linear(j) {
            Some([cx, cy]) => {
                let mut coeffs = [0.0; MAX_AXES];
                coeffs[x] = cx;
                coeffs[y] = cy;
                JointMap::Linear { coeffs }
            }
            None => JointMap::Plane {
                kinematics: *self,
                joint: j as u8,
                x: x as u8,
                y: y as u8,
            },
        }
    }

    /// Machine (x, y) from the two joints; NaN where they cannot meet.
    pub fn forward_xy(&self, j0: f64, j1: f64) -> (f64, f64) {
        self.forward([j0, j1]).unwrap_or((f64::NAN, f64::NAN))
    }
}
