//! The `kinematics!` macro behind the table of kinematics in the module's
//! `mod.rs` (one line per kind: its file and its type; see the module
//! documentation): it declares each kind's module, and makes
//! [`KinematicsKind`] with a variant per kind and the dispatch every layer
//! goes through.

use super::{Cartesian, CoreXY, HBot, JointMap, KinematicsKind, Polar, Xyz, NO_AXIS};
use crate::point::MAX_AXES;

macro_rules! kinematics {
    ($($module:ident :: $kind:ident),* $(,)?) => {
        $(
            mod $module;
            pub use $module::$kind;
        )*

        /// A machine's kinematics with its geometry: one variant per kind in
        /// the table.
        #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
        pub enum KinematicsKind {
            $(
                #[doc = concat!("[`", stringify!($kind), "`] kinematics, with its geometry.")]
                $kind($kind)
            ),*
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

            /// Its name in machine files ([`Kinematics::NAME`]).
            pub fn name(&self) -> &'static str {
                match self { $(KinematicsKind::$kind(_) => <$kind as Kinematics>::NAME),* }
            }

            /// The joints that replace x and y, or x, y and z (none: the
            /// axes are the joints).
            pub fn joints(&self) -> &'static [JointSpec] {
                match self { $(KinematicsKind::$kind(_) => <$kind as Kinematics>::JOINTS),* }
            }

            /// The geometry keys its kind reads ([`Kinematics::PARAMS`]).
            pub fn param_specs(&self) -> &'static [Param] {
                match self { $(KinematicsKind::$kind(_) => <$kind as Kinematics>::PARAMS),* }
            }

            /// Its geometry values in [`KinematicsKind::param_specs`]'
            /// order, padded with 0: what the wire carries and
            /// [`KinematicsKind::from_name`] rebuilds it from.
            pub fn params(&self) -> [f64; MAX_PARAMS] {
                match self { $(KinematicsKind::$kind(k) => k.params()),* }
            }

            /// [`Kinematics::inverse`].
            pub fn inverse(&self, j: usize, p: Xyz, reference: f64) -> Option<f64> {
                match self { $(KinematicsKind::$kind(k) => k.inverse(j, p, reference)),* }
            }

            /// [`Kinematics::forward`].
            pub fn forward(&self, joints: Xyz) -> Option<Xyz> {
                match self { $(KinematicsKind::$kind(k) => k.forward(joints)),* }
            }

            /// [`Kinematics::linear`].
            pub fn linear(&self, j: usize) -> Option<Xyz> {
                match self { $(KinematicsKind::$kind(k) => k.linear(j)),* }
            }

            /// [`Kinematics::closed_form`].
            pub fn closed_form(&self, j: usize, p0: Xyz, w: Xyz, reference: f64) -> Option<ClosedForm> {
                match self { $(KinematicsKind::$kind(k) => k.closed_form(j, p0, w, reference)),* }
            }

            /// [`Kinematics::gradient_bound`].
            pub fn gradient_bound(&self, j: usize) -> Option<f64> {
                match self { $(KinematicsKind::$kind(k) => k.gradient_bound(j)),* }
            }

            /// [`Kinematics::LIMITED_REACH`].
            pub fn limited_reach(&self) -> bool {
                match self { $(KinematicsKind::$kind(_) => <$kind as Kinematics>::LIMITED_REACH),* }
            }

            /// [`Kinematics::reach`].
            pub fn reach(&self, p: Xyz) -> Result<(), Unreachable> {
                match self { $(KinematicsKind::$kind(k) => k.reach(p)),* }
            }
        }
    };
}

impl KinematicsKind {
    /// Cartesian: x and y are joints of their own (no geometry).
    pub const CARTESIAN: KinematicsKind = KinematicsKind::Cartesian(Cartesian);
    /// CoreXY: joints a = x + y, b = x − y (no geometry).
    pub const COREXY: KinematicsKind = KinematicsKind::CoreXY(CoreXY);
    /// H-bot: CoreXY's joint math under its own name (no geometry).
    pub const HBOT: KinematicsKind = KinematicsKind::HBot(HBot);
    /// Polar: radius r (mm) and turntable angle θ (degrees) of (x, y), no
    /// geometry.
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

    /// The map of joint `j` given the indices of the machine's x, y and z
    /// axes (z [`NO_AXIS`] where it has none): a row of coefficients where
    /// the joint is linear.
    pub fn joint_map(&self, j: usize, axes: [usize; 3]) -> JointMap {
        let index = |a: usize| u8::try_from(a).unwrap_or(NO_AXIS);
        match self.linear(j) {
            Some(c) => {
                let mut coeffs = [0.0; MAX_AXES];
                for (a, c) in axes.iter().zip(c) {
                    if let Some(slot) = coeffs.get_mut(*a) {
                        *slot += c;
                    }
                }
                JointMap::Linear { coeffs }
            }
            None => JointMap::Kinematic {
                kinematics: *self,
                joint: j as u8,
                axes: axes.map(index),
            },
        }
    }

    /// The tool point from the joints (see [`super::Kinematics::forward`]); NaN
    /// where they cannot meet.
    pub fn forward_or_nan(&self, joints: Xyz) -> Xyz {
        self.forward(joints).unwrap_or([f64::NAN; 3])
    }
}
