//! Graph channels (distinct from the trajectory [`crate::channel::Channel`]):
//! one actuator's step output driven by a motion stream.
//!
//! Two target inputs are summed into `target_position` (steps, f64; the
//! inputs' ratio is the channel's `(units, steps)`, set with
//! [`super::GraphBuilder::channel_ratio`]). Each frame the target is optionally
//! filtered, `f = (f·(N−1) + t)/N`, and when `|f − current| > 0.5` the channel
//! takes one step toward it: at most one step per frame, and no more often than
//! the maximum pulse rate. A step that would leave the limits (world units) is
//! neither emitted nor counted, so `current_position` is always the position
//! the motor was actually driven to.

use super::component::{non_negative, Kind, ParamError, Phase};
use super::declare::{live, Declaration, Domain, HostKey, Param, ParamFault};
use super::io::{Ctx, StepOut, MAX_HW};
use super::math::round;
use super::port::{Port, PortSpec, Unit};

#[derive(Clone, Copy, Debug, PartialEq)]
/// A graph channel: one actuator's steps toward the sum of its two target inputs (see the module's
/// description), limited, filtered and rate-capped.
pub struct GraphChannel {
    /// Filter length N (≤ 1: no filter).
    pub filter: f64,
    /// Whether the direction output is inverted (the `invert` parameter).
    pub invert: bool,
    /// Steps per second; 0 = only the frame rate limits.
    pub max_pulse_rate: f64,
    /// World units; −∞/+∞ for none.
    pub lower: f64,
    /// Upper limit, world units; +∞ for none (the `upper` parameter).
    pub upper: f64,
    /// Output port and signal code the steps go to on the wire.
    pub signal: Option<(u8, u8)>,
    target: f64,
    filtered: f64,
    current: f64,
    since_us: f64,
}

impl Default for GraphChannel {
    fn default() -> Self {
        GraphChannel::new()
    }
}

impl GraphChannel {
    /// Port 0: the `target` input (any quantity).
    pub const TARGET: u8 = 0;
    /// Port 1: the `target_b` input (any quantity).
    pub const TARGET_B: u8 = 1;
    /// Port 2: the `position` output (any quantity).
    pub const POSITION: u8 = 2;

    /// `set_param` id of the `filter` parameter (frames): filter length (≤ 1: none).
    pub const FILTER: u8 = 0;
    /// `set_param` id of the `invert` parameter (nonzero: invert the direction).
    pub const INVERT: u8 = 1;
    /// `set_param` id of the `max_pulse_rate` parameter (steps/s): 0: the frame rate only.
    pub const MAX_PULSE_RATE: u8 = 2;
    /// `set_param` id of the `lower` parameter (world units; −∞: none).
    pub const LOWER: u8 = 3;
    /// `set_param` id of the `upper` parameter (world units; +∞: none).
    pub const UPPER: u8 = 4;

    /// A channel with no filter, no limits and no pulse-rate cap, at 0.
    pub fn new() -> GraphChannel {
        GraphChannel {
            filter: 0.0,
            invert: false,
            max_pulse_rate: 0.0,
            lower: f64::NEG_INFINITY,
            upper: f64::INFINITY,
            signal: None,
            target: 0.0,
            filtered: 0.0,
            current: 0.0,
            since_us: f64::INFINITY,
        }
    }

    /// Steps go to wire output `port` as signal `code`.
    pub fn output(mut self, port: u8, code: u8) -> Self {
        self.signal = Some((port, code));
        self
    }

    /// Filters the target over `n` frames (≤ 1: none).
    pub fn filtering(mut self, n: f64) -> Self {
        self.filter = n;
        self
    }

    /// Inverts the direction output.
    pub fn inverted(mut self) -> Self {
        self.invert = true;
        self
    }

    /// Steps only between `lower` and `upper`, world units.
    pub fn limits(mut self, lower: f64, upper: f64) -> Self {
        self.lower = lower;
        self.upper = upper;
        self
    }

    /// Steps at most `steps_per_s` per second (0: as often as the frame rate allows).
    pub fn pulse_rate(mut self, steps_per_s: f64) -> Self {
        self.max_pulse_rate = steps_per_s;
        self
    }

    /// Target, steps.
    pub fn target_position(&self) -> f64 {
        self.target
    }

    /// Steps taken (counted in the positive direction, before inversion).
    pub fn current_position(&self) -> f64 {
        self.current
    }
}

impl Kind for GraphChannel {
    const DECL: Declaration = Declaration {
        name: "channel",
        input: None,
        params: &[
            Param::new("filter", "frames", 0.0, Domain::NON_NEGATIVE)
                .doc("filter length (≤ 1: none)"),
            Param::new("invert", "", 0.0, Domain::Flag),
            Param::new("max_pulse_rate", "steps/s", 0.0, Domain::NON_NEGATIVE)
                .doc("0: the frame rate only"),
            Param::new("lower", "units", f64::NEG_INFINITY, Domain::Bound),
            Param::new("upper", "units", f64::INFINITY, Domain::Bound),
            Param::new(
                "output",
                "",
                -1.0,
                Domain::Number {
                    min: -1.0,
                    max: (MAX_HW - 1) as f64,
                },
            )
            .doc("wire output port; −1: none"),
            Param::new(
                "signal",
                "",
                0.0,
                Domain::Choice(&["x", "y", "r", "t", "z", "e"]),
            )
            .doc("signal code on the wire output"),
        ],
        live: &[
            live("filter", Self::FILTER),
            live("invert", Self::INVERT),
            live("max_pulse_rate", Self::MAX_PULSE_RATE),
            live("lower", Self::LOWER),
            live("upper", Self::UPPER),
        ],
        host_keys: &[
            HostKey {
                name: "units",
                doc: "world units that are `steps` steps; default 1",
            },
            HostKey {
                name: "steps",
                doc: "steps in `units` world units; default 1",
            },
            HostKey {
                name: "actuator",
                doc: "the machine actuator it drives, in simulation",
            },
        ],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "step channel driving one actuator",
        build: |a| {
            let mut c = GraphChannel::new().filtering(a.get(0)).pulse_rate(a.get(2));
            if a.flag(1) {
                c = c.inverted();
            }
            let (lower, upper) = (a.get(3), a.get(4));
            if lower > upper {
                return Err(ParamFault::Inconsistent("`lower` is above `upper`"));
            }
            c = c.limits(lower, upper);
            let output = a.get(5);
            if output >= 0.0 {
                if output != libm::floor(output) {
                    return Err(ParamFault::OutOfRange { param: "output" });
                }
                c = c.output(output as u8, a.get(6) as u8);
            }
            Ok(c.into())
        },
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::input("target", Unit::Any),
        PortSpec::input("target_b", Unit::Any),
        PortSpec::output("position", Unit::Any),
    ];
    const PHASE: Phase = Phase::Channel;

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
        ports[0].last = ports[0].value;
        ports[1].last = ports[1].value;
        self.target = ports[0].value + ports[1].value;
        self.filtered = if self.filter > 1.0 {
            (self.filtered * (self.filter - 1.0) + self.target) / self.filter
        } else {
            self.target
        };
        self.since_us += ctx.dt * 1e6;
        let diff = self.filtered - self.current;
        let dir = if diff > 0.5 {
            1.0
        } else if diff < -0.5 {
            -1.0
        } else {
            return;
        };
        if self.max_pulse_rate > 0.0 && self.since_us * self.max_pulse_rate < 1e6 {
            return;
        }
        let next = self.current + dir;
        // Limits in world units, compared in steps.
        let world = ports[0].to_world(next);
        if world < self.lower || world > self.upper {
            return;
        }
        self.current = next;
        ports[2].value = next;
        self.since_us = 0.0;
        let forward = (dir > 0.0) != self.invert;
        let _ = ctx.out.steps.push(StepOut {
            channel: ctx.comp,
            forward,
        });
        if let Some((port, code)) = self.signal {
            if let Some(s) = ctx.out.ports.get_mut(port as usize) {
                s.set(code, forward);
            }
        }
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        if v.is_nan() {
            return Err(ParamError::BadValue);
        }
        match id {
            Self::FILTER => {
                self.filter = non_negative(v)?;
                self.filtered = self.target;
            }
            Self::INVERT => self.invert = v != 0.0,
            Self::MAX_PULSE_RATE => self.max_pulse_rate = non_negative(v)?,
            Self::LOWER if v <= self.upper && v != f64::INFINITY => self.lower = v,
            Self::UPPER if v >= self.lower && v != f64::NEG_INFINITY => self.upper = v,
            Self::LOWER | Self::UPPER => return Err(ParamError::BadValue),
            _ => return Err(ParamError::Unknown),
        }
        Ok(())
    }

    fn param(&self, _ports: &[Port], id: u8) -> Option<f64> {
        match id {
            Self::FILTER => Some(self.filter),
            Self::MAX_PULSE_RATE => Some(self.max_pulse_rate),
            Self::LOWER => Some(self.lower),
            Self::UPPER => Some(self.upper),
            _ => None,
        }
    }

    /// Reset: the new target (sum of both inputs) becomes the position; no step.
    fn reset_input(&mut self, ports: &mut [Port], port: usize) -> bool {
        if port < 2 {
            self.target = ports[0].value + ports[1].value;
            self.filtered = self.target;
            self.current = round(self.target);
            ports[2].value = self.current;
            ports[2].last = self.current;
        }
        false
    }

    fn invertible(&self) -> bool {
        true
    }

    fn inverse(&self, ports: &[Port], input: usize, _outs: &[f64]) -> Option<f64> {
        match input {
            0 => Some(self.current - ports[1].value),
            1 => Some(self.current - ports[0].value),
            _ => None,
        }
    }

    fn reset_output(&mut self, ports: &mut [Port], _port: usize) {
        // Declaring where the motor is: position and target follow.
        self.current = round(ports[2].value);
        self.target = self.current;
        self.filtered = self.current;
        ports[0].value = self.current - ports[1].value;
        ports[0].last = ports[0].value;
    }
}
