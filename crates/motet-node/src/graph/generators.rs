//! Generators: velocity, position, waves, circles and path length.

use super::component::{finite, non_negative, Kind, ParamError};
use super::declare::{live, Declaration, Domain, Param};
use super::io::Ctx;
use super::math::{cos, floor, hypot, sin, sqrt, TAU};
use super::port::{Port, PortSpec, Unit};

/// Integrates a speed: each frame the output moves by `speed × dt`. The speed
/// is its level input (units/s, e.g. from an analog input in ABSOLUTE mode) or
/// set as a parameter (which writes the same input).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VelocityGenerator;

impl VelocityGenerator {
    /// Port 0: the `speed` level input (any quantity).
    pub const SPEED: u8 = 0;
    /// Port 1: the `out` output (any quantity).
    pub const OUT: u8 = 1;
    /// Parameter: the speed (units/s).
    pub const SPEED_PARAM: u8 = 0;
}

impl Kind for VelocityGenerator {
    const DECL: Declaration = Declaration {
        name: "velocity",
        input: None,
        params: &[Param::new("speed", "units/s", 0.0, Domain::REAL)],
        live: &[live("speed", Self::SPEED_PARAM)],
        host_keys: &[],
        in_ports: &[(0, Self::SPEED_PARAM)],
        ports: Self::PORTS,
        doc: "integrates a speed",
        build: |_| Ok(VelocityGenerator.into()),
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::level_in("speed", Unit::Any),
        PortSpec::output("out", Unit::Any),
    ];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
        ports[1].value += ports[0].value * ctx.dt;
    }

    fn set_param(&mut self, ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        match id {
            Self::SPEED_PARAM => ports[0].value = finite(v)?,
            _ => return Err(ParamError::Unknown),
        }
        Ok(())
    }

    fn param(&self, ports: &[Port], id: u8) -> Option<f64> {
        (id == Self::SPEED_PARAM).then_some(ports[0].value)
    }
}

/// Moves its output to a target at constant speed (`go`): parameters
/// `GO_ABSOLUTE` (target), `GO_RELATIVE` (target = current + value), `SPEED`
/// (units/s, block units of the output), `STOP`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionGenerator {
    /// Speed toward the target, block units of the output per second (the `speed` parameter).
    pub speed: f64,
    target: f64,
    moving: bool,
}

impl PositionGenerator {
    /// Port 0: the `out` output (any quantity).
    pub const OUT: u8 = 0;
    /// `set_param` id of the `speed` parameter (units/s).
    pub const SPEED: u8 = 0;
    /// `set_param` id of `go`: moves to the value (absolute target).
    pub const GO_ABSOLUTE: u8 = 1;
    /// `set_param` id of `go_relative`: moves by the value from where the output is.
    pub const GO_RELATIVE: u8 = 2;
    /// `set_param` id of `stop`: stops where the output is (any value).
    pub const STOP: u8 = 3;

    /// A generator at rest at 0, moving at `speed` once told to go.
    pub fn new(speed: f64) -> PositionGenerator {
        PositionGenerator {
            speed,
            target: 0.0,
            moving: false,
        }
    }

    /// Whether it is on its way to the target.
    pub fn moving(&self) -> bool {
        self.moving
    }

    /// Where it is going (or went), block units.
    pub fn target(&self) -> f64 {
        self.target
    }
}

impl Kind for PositionGenerator {
    const DECL: Declaration = Declaration {
        name: "position",
        input: None,
        params: &[Param::new("speed", "units/s", 0.0, Domain::NON_NEGATIVE)],
        live: &[
            live("speed", Self::SPEED),
            live("go", Self::GO_ABSOLUTE),
            live("go_relative", Self::GO_RELATIVE),
            live("stop", Self::STOP),
        ],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "moves to a target at constant speed (`go` absolute, `go_relative`)",
        build: |a| Ok(PositionGenerator::new(a.get(0)).into()),
    };

    const PORTS: &'static [PortSpec] = &[PortSpec::output("out", Unit::Any)];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
        if !self.moving {
            return;
        }
        let pos = ports[0].value;
        let diff = self.target - pos;
        let step = self.speed * ctx.dt;
        if diff.abs() <= step {
            ports[0].value = self.target;
            self.moving = false;
        } else {
            ports[0].value = pos + step.copysign(diff);
        }
    }

    fn set_param(&mut self, ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        match id {
            Self::SPEED => self.speed = non_negative(v)?,
            Self::GO_ABSOLUTE => {
                self.target = finite(v)?;
                self.moving = true;
            }
            Self::GO_RELATIVE => {
                self.target = ports[0].value + finite(v)?;
                self.moving = true;
            }
            Self::STOP => self.moving = false,
            _ => return Err(ParamError::Unknown),
        }
        Ok(())
    }

    fn param(&self, _ports: &[Port], id: u8) -> Option<f64> {
        match id {
            Self::SPEED => Some(self.speed),
            Self::GO_ABSOLUTE => Some(self.target),
            _ => None,
        }
    }

    fn reset_output(&mut self, ports: &mut [Port], _port: usize) {
        self.target = ports[0].value;
        self.moving = false;
    }
}

/// Keeps a phase in cycles within `[0, 1)` to keep its precision.
#[inline]
fn advance(cycles: f64, by: f64) -> f64 {
    let c = cycles + by;
    c - floor(c)
}

/// A sine: `out = amplitude × sin(2π·cycles + phase)`, where `cycles` advances
/// by `frequency × dt` every frame plus `per_input ×` the change of the drive
/// input (e.g. waves per radian of a turntable's angle). The phase is an angle
/// inside the sine, never added to the amplitude.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveGenerator1D {
    /// Peak of the sine, block units of the output (the `amplitude` parameter).
    pub amplitude: f64,
    /// Cycles per second added to the phase (the `frequency` parameter).
    pub frequency: f64,
    /// Angle inside the sine, radians (the `phase` parameter).
    pub phase: f64,
    /// The `per_input` parameter (cycles/unit): cycles per unit of drive change.
    pub per_input: f64,
    cycles: f64,
}

impl WaveGenerator1D {
    /// Port 0: the `drive` input (any quantity).
    pub const DRIVE: u8 = 0;
    /// Port 1: the `out` output (any quantity).
    pub const OUT: u8 = 1;
    /// `set_param` id of the `amplitude` parameter (units).
    pub const AMPLITUDE: u8 = 0;
    /// `set_param` id of the `frequency` parameter (Hz).
    pub const FREQUENCY: u8 = 1;
    /// `set_param` id of the `phase` parameter (rad).
    pub const PHASE: u8 = 2;
    /// `set_param` id of the `per_input` parameter (cycles/unit): cycles per unit of drive change.
    pub const PER_INPUT: u8 = 3;

    /// A sine of `amplitude` at `frequency` Hz and `phase` radians, not driven by an input.
    pub fn new(amplitude: f64, frequency: f64, phase: f64) -> WaveGenerator1D {
        WaveGenerator1D {
            amplitude,
            frequency,
            phase,
            per_input: 0.0,
            cycles: 0.0,
        }
    }

    /// Cycles per unit of the drive input.
    pub fn driven(mut self, per_input: f64) -> Self {
        self.per_input = per_input;
        self
    }
}

fn wave_params(
    id: u8,
    v: f64,
    a: &mut f64,
    f: &mut f64,
    p: &mut f64,
    k: &mut f64,
) -> Result<(), ParamError> {
    let v = finite(v)?;
    match id {
        0 => *a = v,
        1 => *f = v,
        2 => *p = v,
        3 => *k = v,
        _ => return Err(ParamError::Unknown),
    }
    Ok(())
}

impl Kind for WaveGenerator1D {
    const DECL: Declaration = Declaration {
        name: "wave",
        input: None,
        params: &[
            Param::required("amplitude", "units", Domain::REAL),
            Param::new("frequency", "Hz", 0.0, Domain::REAL),
            Param::new("phase", "rad", 0.0, Domain::REAL),
            Param::new("per_input", "cycles/unit", 0.0, Domain::REAL)
                .doc("cycles per unit of drive change"),
        ],
        live: &[
            live("amplitude", Self::AMPLITUDE),
            live("frequency", Self::FREQUENCY),
            live("phase", Self::PHASE),
            live("per_input", Self::PER_INPUT),
        ],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "amplitude × sin(2π·cycles + phase); cycles advance with time and with the drive",
        build: |a| {
            Ok(WaveGenerator1D::new(a.get(0), a.get(1), a.get(2))
                .driven(a.get(3))
                .into())
        },
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::input("drive", Unit::Any),
        PortSpec::output("out", Unit::Any),
    ];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
        let d = ports[0].take_delta();
        self.cycles = advance(self.cycles, self.frequency * ctx.dt + d * self.per_input);
        ports[1].value = self.amplitude * sin(TAU * self.cycles + self.phase);
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        wave_params(
            id,
            v,
            &mut self.amplitude,
            &mut self.frequency,
            &mut self.phase,
            &mut self.per_input,
        )
    }
}

/// Adds a sine across the direction of travel of a 2D stream: the outputs are
/// the inputs plus `amplitude × sin(2π·cycles + phase)` along the normal of the
/// last motion; `cycles` advances by `frequency × dt` plus `per_distance ×`
/// the distance travelled (waves per unit length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveGenerator2D {
    /// Peak of the sine, across the direction of travel (the `amplitude` parameter).
    pub amplitude: f64,
    /// Cycles per second added to the phase (the `frequency` parameter).
    pub frequency: f64,
    /// Angle inside the sine, radians (the `phase` parameter).
    pub phase: f64,
    /// The `per_distance` parameter (cycles/unit): cycles per unit travelled.
    pub per_distance: f64,
    cycles: f64,
    normal: (f64, f64),
}

impl WaveGenerator2D {
    /// Port 0: the `in_x` input (any quantity).
    pub const IN_X: u8 = 0;
    /// Port 1: the `in_y` input (any quantity).
    pub const IN_Y: u8 = 1;
    /// Port 2: the `out_x` output (any quantity).
    pub const OUT_X: u8 = 2;
    /// Port 3: the `out_y` output (any quantity).
    pub const OUT_Y: u8 = 3;
    /// `set_param` id of the `amplitude` parameter (units).
    pub const AMPLITUDE: u8 = 0;
    /// `set_param` id of the `frequency` parameter (Hz).
    pub const FREQUENCY: u8 = 1;
    /// `set_param` id of the `phase` parameter (rad).
    pub const PHASE: u8 = 2;
    /// `set_param` id of the `per_distance` parameter (cycles/unit): cycles per unit travelled.
    pub const PER_DISTANCE: u8 = 3;

    /// A sine of `amplitude` at `frequency` Hz and `phase` radians plus `per_distance` cycles per
    /// unit travelled.
    pub fn new(amplitude: f64, frequency: f64, phase: f64, per_distance: f64) -> WaveGenerator2D {
        WaveGenerator2D {
            amplitude,
            frequency,
            phase,
            per_distance,
            cycles: 0.0,
            normal: (0.0, 1.0),
        }
    }
}

impl Kind for WaveGenerator2D {
    const DECL: Declaration = Declaration {
        name: "wave2d",
        input: None,
        params: &[
            Param::required("amplitude", "units", Domain::REAL),
            Param::new("frequency", "Hz", 0.0, Domain::REAL),
            Param::new("phase", "rad", 0.0, Domain::REAL),
            Param::new("per_distance", "cycles/unit", 0.0, Domain::REAL)
                .doc("cycles per unit travelled"),
        ],
        live: &[
            live("amplitude", Self::AMPLITUDE),
            live("frequency", Self::FREQUENCY),
            live("phase", Self::PHASE),
            live("per_distance", Self::PER_DISTANCE),
        ],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "adds a sine across the direction of travel",
        build: |a| Ok(WaveGenerator2D::new(a.get(0), a.get(1), a.get(2), a.get(3)).into()),
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::input("in_x", Unit::Any),
        PortSpec::input("in_y", Unit::Any),
        PortSpec::output("out_x", Unit::Any),
        PortSpec::output("out_y", Unit::Any),
    ];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
        let dx = ports[0].take_delta();
        let dy = ports[1].take_delta();
        let dist = hypot(dx, dy);
        if dist > 0.0 {
            self.normal = (-dy / dist, dx / dist);
        }
        self.cycles = advance(
            self.cycles,
            self.frequency * ctx.dt + dist * self.per_distance,
        );
        let off = self.amplitude * sin(TAU * self.cycles + self.phase);
        ports[2].value = ports[0].value + off * self.normal.0;
        ports[3].value = ports[1].value + off * self.normal.1;
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        wave_params(
            id,
            v,
            &mut self.amplitude,
            &mut self.frequency,
            &mut self.phase,
            &mut self.per_distance,
        )
    }
}

/// A circle of `radius` at `rev_per_s` revolutions per second, starting where
/// its outputs are: `x = r (cos 2πn − 1)`, `y = r sin 2πn` after `n`
/// revolutions (revolutions throughout; radians only inside the trigonometry).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CircleGenerator {
    /// Radius of the circle, block units of the outputs (the `radius` parameter).
    pub radius: f64,
    /// Revolutions per second; the sign is the direction (the `rev_per_s` parameter).
    pub rev_per_s: f64,
    revs: f64,
}

impl CircleGenerator {
    /// Port 0: the `x` output (any quantity).
    pub const X: u8 = 0;
    /// Port 1: the `y` output (any quantity).
    pub const Y: u8 = 1;
    /// `set_param` id of the `radius` parameter (units).
    pub const RADIUS: u8 = 0;
    /// `set_param` id of the `rev_per_s` parameter (rev/s).
    pub const REV_PER_S: u8 = 1;

    /// A circle of `radius` at `rev_per_s`.
    pub fn new(radius: f64, rev_per_s: f64) -> CircleGenerator {
        CircleGenerator {
            radius,
            rev_per_s,
            revs: 0.0,
        }
    }
}

impl Kind for CircleGenerator {
    const DECL: Declaration = Declaration {
        name: "circle",
        input: None,
        params: &[
            Param::required("radius", "units", Domain::REAL),
            Param::required("rev_per_s", "rev/s", Domain::REAL),
        ],
        live: &[
            live("radius", Self::RADIUS),
            live("rev_per_s", Self::REV_PER_S),
        ],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "a circle from where it starts",
        build: |a| Ok(CircleGenerator::new(a.get(0), a.get(1)).into()),
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::output("x", Unit::Any),
        PortSpec::output("y", Unit::Any),
    ];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
        self.revs = advance(self.revs, self.rev_per_s * ctx.dt);
        let a = TAU * self.revs;
        ports[0].value = self.radius * (cos(a) - 1.0);
        ports[1].value = self.radius * sin(a);
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        match id {
            Self::RADIUS => self.radius = finite(v)?,
            Self::REV_PER_S => self.rev_per_s = finite(v)?,
            _ => return Err(ParamError::Unknown),
        }
        Ok(())
    }
}

/// Output grows by `ratio ×` the distance travelled by the 2D input (drives
/// extruders).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathLength2D {
    /// Output units per unit of distance travelled (the `ratio` parameter).
    pub ratio: f64,
}

impl PathLength2D {
    /// Port 0: the `in_x` input (any quantity).
    pub const IN_X: u8 = 0;
    /// Port 1: the `in_y` input (any quantity).
    pub const IN_Y: u8 = 1;
    /// Port 2: the `out` output (any quantity).
    pub const OUT: u8 = 2;
    /// `set_param` id of the `ratio` parameter (output per distance).
    pub const RATIO: u8 = 0;

    /// Path length times `ratio`.
    pub fn new(ratio: f64) -> PathLength2D {
        PathLength2D { ratio }
    }
}

impl Kind for PathLength2D {
    const DECL: Declaration = Declaration {
        name: "path_length",
        input: None,
        params: &[Param::new("ratio", "", 1.0, Domain::REAL)],
        live: &[live("ratio", Self::RATIO)],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "out grows by ratio × the distance (in_x, in_y) travels",
        build: |a| Ok(PathLength2D::new(a.get(0)).into()),
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::input("in_x", Unit::Any),
        PortSpec::input("in_y", Unit::Any),
        PortSpec::output("out", Unit::Any),
    ];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], _ctx: &mut Ctx<'_, '_, Q>) {
        let dx = ports[0].take_delta();
        let dy = ports[1].take_delta();
        if dx != 0.0 || dy != 0.0 {
            ports[2].value += self.ratio * sqrt(dx * dx + dy * dy);
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
}

/// [`PathLength2D`] in three dimensions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathLength3D {
    /// Output units per unit of distance travelled (the `ratio` parameter).
    pub ratio: f64,
}

impl PathLength3D {
    /// Port 0: the `in_x` input (any quantity).
    pub const IN_X: u8 = 0;
    /// Port 1: the `in_y` input (any quantity).
    pub const IN_Y: u8 = 1;
    /// Port 2: the `in_z` input (any quantity).
    pub const IN_Z: u8 = 2;
    /// Port 3: the `out` output (any quantity).
    pub const OUT: u8 = 3;
    /// `set_param` id of the `ratio` parameter (output per distance).
    pub const RATIO: u8 = 0;

    /// Path length times `ratio`.
    pub fn new(ratio: f64) -> PathLength3D {
        PathLength3D { ratio }
    }
}

impl Kind for PathLength3D {
    const DECL: Declaration = Declaration {
        name: "path_length3d",
        input: None,
        params: &[Param::new("ratio", "", 1.0, Domain::REAL)],
        live: &[live("ratio", Self::RATIO)],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "path length in 3D",
        build: |a| Ok(PathLength3D::new(a.get(0)).into()),
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::input("in_x", Unit::Any),
        PortSpec::input("in_y", Unit::Any),
        PortSpec::input("in_z", Unit::Any),
        PortSpec::output("out", Unit::Any),
    ];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], _ctx: &mut Ctx<'_, '_, Q>) {
        let dx = ports[0].take_delta();
        let dy = ports[1].take_delta();
        let dz = ports[2].take_delta();
        if dx != 0.0 || dy != 0.0 || dz != 0.0 {
            ports[3].value += self.ratio * sqrt(dx * dx + dy * dy + dz * dz);
        }
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        match id {
            Self::RATIO => self.ratio = finite(v)?,
            _ => return Err(ParamError::Unknown),
        }
        Ok(())
    }
}
