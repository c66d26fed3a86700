//! Hardware input components: analog inputs, buttons (digital inputs),
//! quadrature encoders and motion-stream input ports.

use super::component::{finite, non_negative, Kind, ParamError, Phase};
use super::declare::{live, Declaration, Domain, HostKey, Param};
use super::io::{Ctx, Inputs, MAX_HW};
use super::port::{Port, PortSpec, Unit};
use super::wire::CODES;
use motet_wire::message::GraphInputKind;

fn hw_index(hw: u8) -> usize {
    (hw as usize).min(MAX_HW - 1)
}

/// An analog reading mapped linearly from `(floor_raw → floor_value)` to
/// `(ceiling_raw → ceiling_value)` and clamped between the two values, after an
/// exponential average over `average` samples and a deadband (raw readings
/// within `deadband_width` of `deadband_center` read as the centre).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnalogInput {
    /// Which analog input it reads, below [`MAX_HW`] (the first construction value).
    pub hw: u8,
    /// The `floor_value` parameter: value at `floor_raw`.
    pub floor_value: f64,
    /// The raw reading that maps to `floor_value`.
    pub floor_raw: f64,
    /// The `ceiling_value` parameter: value at `ceiling_raw`.
    pub ceiling_value: f64,
    /// The raw reading that maps to `ceiling_value`.
    pub ceiling_raw: f64,
    /// Raw readings within `deadband_width` of this read as it.
    pub deadband_center: f64,
    /// Width of the deadband, raw units (0: none).
    pub deadband_width: f64,
    /// Samples the exponential average spans (1: none).
    pub average: f64,
    avg: Option<f64>,
}

impl AnalogInput {
    /// Port 0: the `value` level output (any quantity).
    pub const OUT: u8 = 0;
    /// `set_param` id of the `floor_value` parameter: value at `floor_raw`.
    pub const FLOOR_VALUE: u8 = 0;
    /// `set_param` id of the `floor_raw` parameter.
    pub const FLOOR_RAW: u8 = 1;
    /// `set_param` id of the `ceiling_value` parameter: value at `ceiling_raw`.
    pub const CEILING_VALUE: u8 = 2;
    /// `set_param` id of the `ceiling_raw` parameter.
    pub const CEILING_RAW: u8 = 3;
    /// `set_param` id of the `deadband_center` parameter.
    pub const DEADBAND_CENTER: u8 = 4;
    /// `set_param` id of the `deadband_width` parameter.
    pub const DEADBAND_WIDTH: u8 = 5;
    /// `set_param` id of the `average` parameter (samples).
    pub const AVERAGE: u8 = 6;

    /// Raw 0..1023 read as 0..1, no deadband, no averaging.
    pub fn new(hw: u8) -> AnalogInput {
        AnalogInput {
            hw,
            floor_value: 0.0,
            floor_raw: 0.0,
            ceiling_value: 1.0,
            ceiling_raw: 1023.0,
            deadband_center: 0.0,
            deadband_width: 0.0,
            average: 1.0,
            avg: None,
        }
    }

    /// Raw reading `raw` maps to `value`.
    pub fn floor(mut self, value: f64, raw: f64) -> Self {
        self.floor_value = value;
        self.floor_raw = raw;
        self
    }

    /// Raw reading `raw` maps to `value`.
    pub fn ceiling(mut self, value: f64, raw: f64) -> Self {
        self.ceiling_value = value;
        self.ceiling_raw = raw;
        self
    }

    /// Raw readings within `width_raw` of `center_raw` read as `center_raw`.
    pub fn deadband(mut self, center_raw: f64, width_raw: f64) -> Self {
        self.deadband_center = center_raw;
        self.deadband_width = width_raw;
        self
    }

    /// Averages over `samples` readings (at least 1).
    pub fn averaging(mut self, samples: f64) -> Self {
        self.average = samples.max(1.0);
        self
    }

    /// The mapped value for a (filtered) raw reading.
    pub fn map(&self, raw: f64) -> f64 {
        let raw = if (raw - self.deadband_center).abs() <= self.deadband_width {
            self.deadband_center
        } else {
            raw
        };
        let span = self.ceiling_raw - self.floor_raw;
        let v = if span == 0.0 {
            self.floor_value
        } else {
            self.floor_value
                + (raw - self.floor_raw) * (self.ceiling_value - self.floor_value) / span
        };
        let (lo, hi) = if self.floor_value <= self.ceiling_value {
            (self.floor_value, self.ceiling_value)
        } else {
            (self.ceiling_value, self.floor_value)
        };
        v.clamp(lo, hi)
    }
}

impl Kind for AnalogInput {
    const DECL: Declaration = Declaration {
        name: "analog",
        input: Some(GraphInputKind::Analog),
        params: &[
            Param::new("floor_value", "", 0.0, Domain::REAL).doc("value at `floor_raw`"),
            Param::new("floor_raw", "raw", 0.0, Domain::REAL),
            Param::new("ceiling_value", "", 1.0, Domain::REAL).doc("value at `ceiling_raw`"),
            Param::new("ceiling_raw", "raw", 1023.0, Domain::REAL),
            Param::new("deadband_center", "raw", 0.0, Domain::REAL),
            Param::new("deadband_width", "raw", 0.0, Domain::NON_NEGATIVE),
            Param::new(
                "average",
                "samples",
                1.0,
                Domain::Number {
                    min: 1.0,
                    max: f64::INFINITY,
                },
            ),
        ],
        live: &[
            live("floor_value", Self::FLOOR_VALUE),
            live("floor_raw", Self::FLOOR_RAW),
            live("ceiling_value", Self::CEILING_VALUE),
            live("ceiling_raw", Self::CEILING_RAW),
            live("deadband_center", Self::DEADBAND_CENTER),
            live("deadband_width", Self::DEADBAND_WIDTH),
            live("average", Self::AVERAGE),
        ],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "analog reading mapped from raw floor..ceiling to values, deadband, averaging",
        build: |a| {
            Ok(AnalogInput::new(a.hw())
                .floor(a.get(0), a.get(1))
                .ceiling(a.get(2), a.get(3))
                .deadband(a.get(4), a.get(5))
                .averaging(a.get(6))
                .into())
        },
    };

    const PORTS: &'static [PortSpec] = &[PortSpec::level_out("value", Unit::Any)];
    const PHASE: Phase = Phase::Input;

    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
        let raw = ctx.inputs.analog[hw_index(self.hw)] as f64;
        let avg = match self.avg {
            Some(a) => a + (raw - a) / self.average,
            None => raw,
        };
        self.avg = Some(avg);
        ports[0].value = self.map(avg);
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        let v = finite(v)?;
        match id {
            Self::FLOOR_VALUE => self.floor_value = v,
            Self::FLOOR_RAW => self.floor_raw = v,
            Self::CEILING_VALUE => self.ceiling_value = v,
            Self::CEILING_RAW => self.ceiling_raw = v,
            Self::DEADBAND_CENTER => self.deadband_center = v,
            Self::DEADBAND_WIDTH => self.deadband_width = non_negative(v)?,
            Self::AVERAGE => {
                if v < 1.0 {
                    return Err(ParamError::BadValue);
                }
                self.average = v
            }
            _ => return Err(ParamError::Unknown),
        }
        Ok(())
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
/// What a button's output follows.
pub enum ButtonMode {
    /// Output 1 while pressed.
    Standard,
    /// Output flips on every press.
    Toggle,
}

/// A debounced digital input, read in the 1 kHz slow frame. A new level is
/// accepted after it has been stable for `debounce_ms` slow frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Button {
    /// Which digital input it reads, below [`MAX_HW`] (the first construction value).
    pub hw: u8,
    /// Whether the output follows the level or flips on each press.
    pub mode: ButtonMode,
    /// Slow frames (ms) a new level must hold before it is taken (the `debounce_ms` parameter).
    pub debounce_ms: u16,
    stable: bool,
    count: u16,
    toggled: bool,
    presses: u32,
    releases: u32,
}

impl Button {
    /// Port 0: the `state` level output (a scalar).
    pub const OUT: u8 = 0;
    /// `set_param` id of the `debounce_ms` parameter.
    pub const DEBOUNCE_MS: u8 = 0;

    /// A button on digital input `hw`, debounced over 5 ms.
    pub fn new(hw: u8, mode: ButtonMode) -> Button {
        Button {
            hw,
            mode,
            debounce_ms: 5,
            stable: false,
            count: 0,
            toggled: false,
            presses: 0,
            releases: 0,
        }
    }

    /// A plain digital input: standard mode, no debouncing.
    pub fn digital(hw: u8) -> Button {
        Button {
            debounce_ms: 0,
            ..Button::new(hw, ButtonMode::Standard)
        }
    }

    /// Debounces over `ms` slow frames (0: none).
    pub fn debounce(mut self, ms: u16) -> Self {
        self.debounce_ms = ms;
        self
    }

    /// Debounced level.
    pub fn pressed(&self) -> bool {
        self.stable
    }

    /// Debounced presses and releases so far.
    pub fn events(&self) -> (u32, u32) {
        (self.presses, self.releases)
    }
}

impl Kind for Button {
    const DECL: Declaration = Declaration {
        name: "button",
        input: Some(GraphInputKind::Digital),
        params: &[
            Param::new("toggle", "", 0.0, Domain::Flag).doc("each press flips the state"),
            Param::new(
                "debounce_ms",
                "ms",
                5.0,
                Domain::Number {
                    min: 0.0,
                    max: u16::MAX as f64,
                },
            ),
        ],
        live: &[live("debounce_ms", Self::DEBOUNCE_MS)],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "debounced digital input (1 kHz), standard or toggle; state 0/1",
        build: |a| {
            let mode = if a.flag(0) {
                ButtonMode::Toggle
            } else {
                ButtonMode::Standard
            };
            Ok(Button::new(a.hw(), mode).debounce(a.get(1) as u16).into())
        },
    };

    const PORTS: &'static [PortSpec] = &[PortSpec::level_out("state", Unit::Scalar)];
    const PHASE: Phase = Phase::Slow;

    fn run<const Q: usize>(&mut self, _ports: &mut [Port], _ctx: &mut Ctx<'_, '_, Q>) {}

    fn slow(&mut self, ports: &mut [Port], inputs: &Inputs, _dt: f64) {
        let raw = inputs.digital[hw_index(self.hw)];
        if raw == self.stable {
            self.count = 0;
        } else {
            self.count += 1;
            if self.count > self.debounce_ms {
                self.count = 0;
                self.stable = raw;
                if raw {
                    self.presses += 1;
                    self.toggled = !self.toggled;
                } else {
                    self.releases += 1;
                }
            }
        }
        let on = match self.mode {
            ButtonMode::Standard => self.stable,
            ButtonMode::Toggle => self.toggled,
        };
        ports[0].value = if on { 1.0 } else { 0.0 };
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        match id {
            Self::DEBOUNCE_MS => {
                let v = non_negative(v)?;
                if v > u16::MAX as f64 {
                    return Err(ParamError::BadValue);
                }
                self.debounce_ms = v as u16;
                Ok(())
            }
            _ => Err(ParamError::Unknown),
        }
    }
}

/// A quadrature encoder: its output is the count (block units; set the output
/// port's ratio for world units), optionally inverted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Encoder {
    /// Which encoder it reads, below [`MAX_HW`] (the first construction value).
    pub hw: u8,
    /// Whether the count is negated (the `invert` parameter).
    pub invert: bool,
    offset: f64,
    count: i64,
}

impl Encoder {
    /// Port 0: the `count` output (any quantity).
    pub const OUT: u8 = 0;
    /// `set_param` id of the `invert` parameter (nonzero: negate).
    pub const INVERT: u8 = 0;

    /// The encoder `hw`, counting as wired.
    pub fn new(hw: u8) -> Encoder {
        Encoder {
            hw,
            invert: false,
            offset: 0.0,
            count: 0,
        }
    }

    /// Negates the count.
    pub fn inverted(mut self) -> Self {
        self.invert = true;
        self
    }

    fn raw(&self, count: i64) -> f64 {
        if self.invert {
            -(count as f64)
        } else {
            count as f64
        }
    }
}

impl Kind for Encoder {
    const DECL: Declaration = Declaration {
        name: "encoder",
        input: Some(GraphInputKind::Encoder),
        params: &[Param::new("invert", "", 0.0, Domain::Flag)],
        live: &[live("invert", Self::INVERT)],
        host_keys: &[HostKey {
            name: "ratio",
            doc: "world units per count",
        }],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "quadrature count (`count`, alias `out`)",
        build: |a| {
            let e = Encoder::new(a.hw());
            Ok(if a.flag(0) { e.inverted() } else { e }.into())
        },
    };

    const PORTS: &'static [PortSpec] = &[PortSpec::output("count", Unit::Any)];
    const PHASE: Phase = Phase::Input;

    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
        self.count = ctx.inputs.encoders[hw_index(self.hw)];
        ports[0].value = self.raw(self.count) - self.offset;
    }

    fn set_param(&mut self, ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        match id {
            Self::INVERT => {
                let inv = finite(v)? != 0.0;
                // The output stays where it is.
                self.invert = inv;
                self.offset = self.raw(self.count) - ports[0].value;
                Ok(())
            }
            _ => Err(ParamError::Unknown),
        }
    }

    fn reset_output(&mut self, ports: &mut [Port], _port: usize) {
        self.offset = self.raw(self.count) - ports[0].value;
    }
}

/// A motion-stream input port: each decoded signal code steps its output by
/// one block unit (set the outputs' ratios for world units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamInput {
    /// Which motion-stream input port it decodes, below [`MAX_HW`] (the first construction value).
    pub hw: u8,
}

impl StreamInput {
    /// The stream input `hw`.
    pub fn new(hw: u8) -> StreamInput {
        StreamInput { hw }
    }
}

impl Kind for StreamInput {
    const DECL: Declaration = Declaration {
        name: "stream_input",
        input: Some(GraphInputKind::Stream),
        params: &[],
        live: &[],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "motion-stream input port: one step each frame per signal",
        build: |a| Ok(StreamInput::new(a.hw()).into()),
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::output("x", Unit::Any),
        PortSpec::output("y", Unit::Any),
        PortSpec::output("r", Unit::Any),
        PortSpec::output("t", Unit::Any),
        PortSpec::output("z", Unit::Any),
        PortSpec::output("e", Unit::Any),
    ];
    const PHASE: Phase = Phase::Input;

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
        let s = ctx.inputs.streams[hw_index(self.hw)];
        if s.active == 0 {
            return;
        }
        for (code, port) in ports.iter_mut().enumerate().take(CODES) {
            if let Some(fwd) = s.get(code as u8) {
                port.value += if fwd { 1.0 } else { -1.0 };
            }
        }
    }
}
