//! Kinematics components. Outputs are computed from the inputs' absolute
//! values every frame, so incremental transmission never drifts; each has an
//! inverse for `read_deep` and `reset_deep`.

use super::component::{positive, Kind, ParamError};
use super::declare::{live, Declaration, Domain, Param, ParamFault};
use super::io::Ctx;
use super::math::{atan2, cos, hypot, sin, unwrap_near};
use super::port::{Port, PortSpec, Unit};
use motet_trajectory::kinematics::FiveBar;

/// CoreXY: `a = x + y`, `b = x − y`; inverse `x = (a + b)/2`, `y = (a − b)/2`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CoreXY;

impl CoreXY {
    /// Port 0: the `x` input (a length).
    pub const X: u8 = 0;
    /// Port 1: the `y` input (a length).
    pub const Y: u8 = 1;
    /// Port 2: the `a` output (a length).
    pub const A: u8 = 2;
    /// Port 3: the `b` output (a length).
    pub const B: u8 = 3;

    /// Motor positions `(a, b)` of the carriage position `(x, y)`.
    pub fn motors(x: f64, y: f64) -> (f64, f64) {
        (x + y, x - y)
    }

    /// The carriage position `(x, y)` of motor positions `(a, b)`.
    pub fn cartesian(a: f64, b: f64) -> (f64, f64) {
        ((a + b) * 0.5, (a - b) * 0.5)
    }
}

impl Kind for CoreXY {
    const DECL: Declaration = Declaration {
        name: "corexy",
        input: None,
        params: &[],
        live: &[],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "a = x + y, b = x − y",
        build: |_| Ok(CoreXY.into()),
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::input("x", Unit::Length),
        PortSpec::input("y", Unit::Length),
        PortSpec::output("a", Unit::Length),
        PortSpec::output("b", Unit::Length),
    ];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], _ctx: &mut Ctx<'_, '_, Q>) {
        let (a, b) = CoreXY::motors(ports[0].value, ports[1].value);
        ports[2].value = a;
        ports[3].value = b;
    }

    fn reset_input(&mut self, ports: &mut [Port], _port: usize) -> bool {
        let (a, b) = CoreXY::motors(ports[0].value, ports[1].value);
        ports[2].value = a;
        ports[3].value = b;
        true
    }

    fn invertible(&self) -> bool {
        true
    }

    fn inverse(&self, _ports: &[Port], input: usize, outs: &[f64]) -> Option<f64> {
        let (x, y) = CoreXY::cartesian(outs[2], outs[3]);
        Some(if input == 0 { x } else { y })
    }
}

/// Polar to Cartesian: `x = r cos θ`, `y = r sin θ` (θ in radians). Also serves
/// as Stepdance's Lever (a link of length r at angle θ).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PolarToCartesian;

impl PolarToCartesian {
    /// Port 0: the `r` input (a length).
    pub const R: u8 = 0;
    /// Port 1: the `theta` input (an angle).
    pub const THETA: u8 = 1;
    /// Port 2: the `x` output (a length).
    pub const X: u8 = 2;
    /// Port 3: the `y` output (a length).
    pub const Y: u8 = 3;

    /// The point `(x, y)` at radius `r` and angle `theta` (radians).
    pub fn cartesian(r: f64, theta: f64) -> (f64, f64) {
        (r * cos(theta), r * sin(theta))
    }

    /// `(r, θ)` with θ the turn nearest `theta_ref`.
    pub fn polar(x: f64, y: f64, theta_ref: f64) -> (f64, f64) {
        (hypot(x, y), unwrap_near(atan2(y, x), theta_ref))
    }
}

impl Kind for PolarToCartesian {
    const DECL: Declaration = Declaration {
        name: "polar",
        input: None,
        params: &[],
        live: &[],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "x = r cos θ, y = r sin θ (θ in radians; also the Lever)",
        build: |_| Ok(PolarToCartesian.into()),
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::input("r", Unit::Length),
        PortSpec::input("theta", Unit::Angle),
        PortSpec::output("x", Unit::Length),
        PortSpec::output("y", Unit::Length),
    ];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], _ctx: &mut Ctx<'_, '_, Q>) {
        let (x, y) = PolarToCartesian::cartesian(ports[0].value, ports[1].value);
        ports[2].value = x;
        ports[3].value = y;
    }

    fn reset_input(&mut self, ports: &mut [Port], _port: usize) -> bool {
        let (x, y) = PolarToCartesian::cartesian(ports[0].value, ports[1].value);
        ports[2].value = x;
        ports[3].value = y;
        true
    }

    fn invertible(&self) -> bool {
        true
    }

    fn inverse(&self, ports: &[Port], input: usize, outs: &[f64]) -> Option<f64> {
        let (r, t) = PolarToCartesian::polar(outs[2], outs[3], ports[1].value);
        Some(if input == 0 { r } else { t })
    }
}

/// Forward kinematics of a five-bar linkage (parallel SCARA). Base pivots at
/// `(0, 0)` and `(s, 0)`; proximal links `l1` (left) and `l2` (right) at angles
/// θ1, θ2 from the +x axis; distal links `l3` (left) and `l4` (right) meet at
/// the joint above the elbows (+y side of the line from left to right elbow);
/// the stylus sits on the left distal link extended by `ext` beyond the joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FiveBarForward {
    /// The `s` parameter (length): distance between the pivots.
    pub s: f64,
    /// The `l1` parameter (length): left proximal link.
    pub l1: f64,
    /// The `l2` parameter (length): right proximal link.
    pub l2: f64,
    /// The `l3` parameter (length): left distal link.
    pub l3: f64,
    /// The `l4` parameter (length): right distal link.
    pub l4: f64,
    /// The `ext` parameter (length): stylus beyond the joint, along the left distal link.
    pub ext: f64,
}

impl FiveBarForward {
    /// Port 0: the `theta1` input (an angle).
    pub const THETA1: u8 = 0;
    /// Port 1: the `theta2` input (an angle).
    pub const THETA2: u8 = 1;
    /// Port 2: the `x` output (a length).
    pub const X: u8 = 2;
    /// Port 3: the `y` output (a length).
    pub const Y: u8 = 3;
    /// `set_param` id of the `s` parameter (length): distance between the pivots.
    pub const S: u8 = 0;
    /// `set_param` id of the `l1` parameter (length): left proximal link.
    pub const L1: u8 = 1;
    /// `set_param` id of the `l2` parameter (length): right proximal link.
    pub const L2: u8 = 2;
    /// `set_param` id of the `l3` parameter (length): left distal link.
    pub const L3: u8 = 3;
    /// `set_param` id of the `l4` parameter (length): right distal link.
    pub const L4: u8 = 4;
    /// `set_param` id of the `ext` parameter (length): stylus beyond the joint, along the left
    /// distal link.
    pub const EXT: u8 = 5;

    /// A linkage of these lengths, the stylus at the joint (`ext` 0).
    pub fn new(s: f64, l1: f64, l2: f64, l3: f64, l4: f64) -> FiveBarForward {
        FiveBarForward {
            s,
            l1,
            l2,
            l3,
            l4,
            ext: 0.0,
        }
    }

    /// The linkage as the kinematics table has it: one five-bar, shared
    /// with machines whose arms are five-bars.
    fn linkage(&self) -> FiveBar {
        FiveBar {
            s: self.s,
            l1: self.l1,
            l2: self.l2,
            l3: self.l3,
            l4: self.l4,
            ext: self.ext,
        }
    }

    /// The stylus point; `None` when the distal links cannot meet.
    pub fn stylus(&self, t1: f64, t2: f64) -> Option<(f64, f64)> {
        self.linkage().point(t1, t2)
    }

    /// Joint angles for a stylus point, elbows outward (left elbow
    /// counter-clockwise of the left pivot→joint line, right elbow clockwise).
    pub fn angles(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        self.linkage().angles(x, y)
    }

    fn write(&self, ports: &mut [Port]) {
        if let Some((x, y)) = self.stylus(ports[0].value, ports[1].value) {
            ports[2].value = x;
            ports[3].value = y;
        }
    }
}

impl Kind for FiveBarForward {
    const DECL: Declaration = Declaration {
        name: "fivebar",
        input: None,
        params: &[
            Param::required("s", "length", Domain::REAL).doc("distance between the pivots"),
            Param::required("l1", "length", Domain::Positive).doc("left proximal link"),
            Param::required("l2", "length", Domain::Positive).doc("right proximal link"),
            Param::required("l3", "length", Domain::Positive).doc("left distal link"),
            Param::required("l4", "length", Domain::Positive).doc("right distal link"),
            Param::new("ext", "length", 0.0, Domain::REAL)
                .doc("stylus beyond the joint, along the left distal link"),
        ],
        live: &[
            live("s", Self::S),
            live("l1", Self::L1),
            live("l2", Self::L2),
            live("l3", Self::L3),
            live("l4", Self::L4),
            live("ext", Self::EXT),
        ],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "five-bar linkage, joint angles (radians) to the stylus",
        build: |a| {
            let mut f = FiveBarForward::new(a.get(0), a.get(1), a.get(2), a.get(3), a.get(4));
            f.ext = a.get(5);
            if f.l3 + f.ext <= 0.0 {
                return Err(ParamFault::Inconsistent("`l3` + `ext` must be positive"));
            }
            Ok(f.into())
        },
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::input("theta1", Unit::Angle),
        PortSpec::input("theta2", Unit::Angle),
        PortSpec::output("x", Unit::Length),
        PortSpec::output("y", Unit::Length),
    ];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], _ctx: &mut Ctx<'_, '_, Q>) {
        // Out of reach: the stylus holds its last point.
        self.write(ports);
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        let mut next = *self;
        match id {
            Self::S => next.s = v,
            Self::L1 => next.l1 = positive(v)?,
            Self::L2 => next.l2 = positive(v)?,
            Self::L3 => next.l3 = positive(v)?,
            Self::L4 => next.l4 = positive(v)?,
            Self::EXT => next.ext = v,
            _ => return Err(ParamError::Unknown),
        }
        if !next.s.is_finite() || !next.ext.is_finite() || next.l3 + next.ext <= 0.0 {
            return Err(ParamError::BadValue);
        }
        *self = next;
        Ok(())
    }

    fn reset_input(&mut self, ports: &mut [Port], _port: usize) -> bool {
        self.write(ports);
        true
    }

    fn invertible(&self) -> bool {
        true
    }

    fn inverse(&self, _ports: &[Port], input: usize, outs: &[f64]) -> Option<f64> {
        let (t1, t2) = self.angles(outs[2], outs[3])?;
        Some(if input == 0 { t1 } else { t2 })
    }
}
