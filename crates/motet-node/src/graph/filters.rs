//! Filters: scaling (1D, 2D) and thresholds.

use super::component::{finite, Kind, ParamError};
use super::declare::{live, Declaration, Domain, Param, ParamFault};
use super::io::Ctx;
use super::port::{Mode, Port, PortSpec, Unit};

/// The scaling filters' construction parameters: the ratio, then the mode.
const SCALING_PARAMS: &[Param] = &[
    Param::new("ratio", "", 1.0, Domain::REAL),
    Param::new(
        "mode",
        "",
        0.0,
        Domain::Choice(&["incremental", "absolute"]),
    )
    .doc("incremental: changes scaled; absolute: values"),
];

/// A scaling filter's mode from its `mode` flag.
fn scaling_mode(absolute: bool) -> Mode {
    if absolute {
        Mode::Absolute
    } else {
        Mode::Incremental
    }
}

/// `out = in × ratio`. In INCREMENTAL mode each frame's change of the input is
/// scaled (a live ratio change affects only later motion); in ABSOLUTE mode the
/// output is the scaled absolute input (a ratio change moves the output at
/// once, e.g. Wheelbot's ellipse stretch).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalingFilter1D {
    /// Block units out per block unit in (the `ratio` parameter).
    pub ratio: f64,
    /// Whether changes or the absolute input are scaled (the `mode` parameter).
    pub mode: Mode,
}

impl ScalingFilter1D {
    /// Port 0: the `in` input (any quantity).
    pub const IN: u8 = 0;
    /// Port 1: the `out` output (any quantity).
    pub const OUT: u8 = 1;
    /// `set_param` id of the `ratio` parameter.
    pub const RATIO: u8 = 0;

    /// A filter scaling by `ratio` in `mode`.
    pub fn new(ratio: f64, mode: Mode) -> ScalingFilter1D {
        ScalingFilter1D { ratio, mode }
    }
}

impl Kind for ScalingFilter1D {
    const DECL: Declaration = Declaration {
        name: "scale",
        input: None,
        params: SCALING_PARAMS,
        live: &[live("ratio", Self::RATIO)],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "out = in × ratio",
        build: |a| Ok(ScalingFilter1D::new(a.get(0), scaling_mode(a.flag(1))).into()),
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::input("in", Unit::Any),
        PortSpec::output("out", Unit::Any),
    ];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], _ctx: &mut Ctx<'_, '_, Q>) {
        let d = ports[0].take_delta();
        match self.mode {
            Mode::Incremental => ports[1].value += d * self.ratio,
            Mode::Absolute => ports[1].value = ports[0].value * self.ratio,
        }
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        match id {
            Self::RATIO => self.ratio = finite(v)?,
            _ => return Err(ParamError::Unknown),
        }
        Ok(())
    }

    fn param(&self, _ports: &[Port], id: u8) -> Option<f64> {
        (id == Self::RATIO).then_some(self.ratio)
    }

    fn reset_input(&mut self, ports: &mut [Port], _port: usize) -> bool {
        ports[1].value = ports[0].value * self.ratio;
        true
    }

    fn invertible(&self) -> bool {
        self.ratio != 0.0
    }

    fn inverse(&self, _ports: &[Port], _input: usize, outs: &[f64]) -> Option<f64> {
        (self.ratio != 0.0).then(|| outs[1] / self.ratio)
    }
}

/// Two inputs scaled by the same ratio (see [`ScalingFilter1D`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalingFilter2D {
    /// Block units out per block unit in, both axes (the `ratio` parameter).
    pub ratio: f64,
    /// Whether changes or the absolute inputs are scaled (the `mode` parameter).
    pub mode: Mode,
}

impl ScalingFilter2D {
    /// Port 0: the `in_x` input (any quantity).
    pub const IN_X: u8 = 0;
    /// Port 1: the `in_y` input (any quantity).
    pub const IN_Y: u8 = 1;
    /// Port 2: the `out_x` output (any quantity).
    pub const OUT_X: u8 = 2;
    /// Port 3: the `out_y` output (any quantity).
    pub const OUT_Y: u8 = 3;
    /// `set_param` id of the `ratio` parameter.
    pub const RATIO: u8 = 0;

    /// A filter scaling both inputs by `ratio` in `mode`.
    pub fn new(ratio: f64, mode: Mode) -> ScalingFilter2D {
        ScalingFilter2D { ratio, mode }
    }
}

impl Kind for ScalingFilter2D {
    const DECL: Declaration = Declaration {
        name: "scale2d",
        input: None,
        params: SCALING_PARAMS,
        live: &[live("ratio", Self::RATIO)],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "two inputs scaled alike",
        build: |a| Ok(ScalingFilter2D::new(a.get(0), scaling_mode(a.flag(1))).into()),
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::input("in_x", Unit::Any),
        PortSpec::input("in_y", Unit::Any),
        PortSpec::output("out_x", Unit::Any),
        PortSpec::output("out_y", Unit::Any),
    ];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], _ctx: &mut Ctx<'_, '_, Q>) {
        for i in 0..2 {
            let d = ports[i].take_delta();
            match self.mode {
                Mode::Incremental => ports[i + 2].value += d * self.ratio,
                Mode::Absolute => ports[i + 2].value = ports[i].value * self.ratio,
            }
        }
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        match id {
            Self::RATIO => self.ratio = finite(v)?,
            _ => return Err(ParamError::Unknown),
        }
        Ok(())
    }

    fn param(&self, _ports: &[Port], id: u8) -> Option<f64> {
        (id == Self::RATIO).then_some(self.ratio)
    }

    fn reset_input(&mut self, ports: &mut [Port], port: usize) -> bool {
        ports[port + 2].value = ports[port].value * self.ratio;
        true
    }

    fn invertible(&self) -> bool {
        self.ratio != 0.0
    }

    fn inverse(&self, _ports: &[Port], input: usize, outs: &[f64]) -> Option<f64> {
        (self.ratio != 0.0).then(|| outs[input + 2] / self.ratio)
    }
}

/// Clamps its input between `lower` and `upper` and flags where it is: the
/// flag output is −1 below, 0 inside, +1 above. `crossings` counts flag
/// changes (the main loop's substitute for callbacks).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThresholdGenerator {
    /// The input's lower bound, block units (the `lower` parameter).
    pub lower: f64,
    /// The input's upper bound, block units (the `upper` parameter).
    pub upper: f64,
    crossings: u32,
}

impl ThresholdGenerator {
    /// Port 0: the `in` input (any quantity).
    pub const IN: u8 = 0;
    /// Port 1: the `out` output (any quantity).
    pub const OUT: u8 = 1;
    /// Port 2: the `flag` level output (a scalar).
    pub const FLAG: u8 = 2;
    /// `set_param` id of the `lower` parameter.
    pub const LOWER: u8 = 0;
    /// `set_param` id of the `upper` parameter.
    pub const UPPER: u8 = 1;

    /// A threshold between `lower` and `upper`, with no crossings counted yet.
    pub fn new(lower: f64, upper: f64) -> ThresholdGenerator {
        ThresholdGenerator {
            lower,
            upper,
            crossings: 0,
        }
    }

    /// How often the flag output changed since the component was made.
    pub fn crossings(&self) -> u32 {
        self.crossings
    }
}

impl Kind for ThresholdGenerator {
    const DECL: Declaration = Declaration {
        name: "threshold",
        input: None,
        params: &[
            Param::required("lower", "", Domain::Bound),
            Param::required("upper", "", Domain::Bound),
        ],
        live: &[live("lower", Self::LOWER), live("upper", Self::UPPER)],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "clamps between lower and upper; flag −1/0/+1 below/inside/above",
        build: |a| {
            let (lower, upper) = (a.get(0), a.get(1));
            if lower > upper {
                return Err(ParamFault::Inconsistent("`lower` is above `upper`"));
            }
            Ok(ThresholdGenerator::new(lower, upper).into())
        },
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::input("in", Unit::Any),
        PortSpec::output("out", Unit::Any),
        PortSpec::level_out("flag", Unit::Scalar),
    ];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], _ctx: &mut Ctx<'_, '_, Q>) {
        let v = ports[0].value;
        ports[0].last = v;
        let flag = if v > self.upper {
            1.0
        } else if v < self.lower {
            -1.0
        } else {
            0.0
        };
        if flag != ports[2].value {
            self.crossings += 1;
        }
        ports[2].value = flag;
        ports[1].value = v.clamp(self.lower, self.upper);
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        let v = if v.is_nan() {
            return Err(ParamError::BadValue);
        } else {
            v
        };
        match id {
            Self::LOWER if v <= self.upper => self.lower = v,
            Self::UPPER if v >= self.lower => self.upper = v,
            Self::LOWER | Self::UPPER => return Err(ParamError::BadValue),
            _ => return Err(ParamError::Unknown),
        }
        Ok(())
    }

    fn reset_input(&mut self, ports: &mut [Port], _port: usize) -> bool {
        ports[1].value = ports[0].value.clamp(self.lower, self.upper);
        true
    }
}
