//! Homing: seek at a speed until a limit input, back off, then reset the chain
//! to the home position without generating steps.

use super::component::{finite, non_negative, positive, Kind, ParamError};
use super::declare::{live, Declaration, Domain, Param, ParamFault};
use super::io::Ctx;
use super::port::{Port, PortSpec, Unit};

#[derive(Clone, Copy, Debug, PartialEq)]
/// Where a homing cycle is.
pub enum HomingState {
    /// Not homing (before the first `start`).
    Idle,
    /// Moving at `speed` toward the limit.
    Seeking,
    /// Backing off; distance still to go (block units).
    BackingOff(f64),
    /// Homed: the chain reads `home`.
    Done,
}

/// Per-axis homing. Its output moves by `speed × dt` per frame (the sign of
/// `speed` is the seek direction) until the limit input (a level port, e.g.
/// from a [`super::inputs::Button`] in ABSOLUTE mode) exceeds 0.5; then it moves
/// back by `backoff` at the same speed, and asks the graph to
/// `reset_deep(output, home)`, so the chain reads `home` without a step.
/// Parameter `START` (any value) starts a cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Homing {
    /// The `speed` parameter (units/s): signed: the direction of the seek.
    pub speed: f64,
    /// How far to move back off the limit, block units (the `backoff` parameter).
    pub backoff: f64,
    /// Home position, world units of the output port.
    pub home: f64,
    state: HomingState,
    reset: Option<(u8, f64)>,
}

impl Homing {
    /// Port 0: the `limit` level input (a scalar).
    pub const LIMIT: u8 = 0;
    /// Port 1: the `out` output (any quantity).
    pub const OUT: u8 = 1;
    /// `set_param` id of `start`: starts a cycle (any value).
    pub const START: u8 = 0;
    /// `set_param` id of the `speed` parameter (units/s): signed: the direction of the seek.
    pub const SPEED: u8 = 1;
    /// `set_param` id of the `backoff` parameter.
    pub const BACKOFF: u8 = 2;
    /// `set_param` id of the `home` parameter (units): the position the chain is reset to.
    pub const HOME: u8 = 3;

    /// Homing at `speed` (signed), backing off by `backoff`, reset to `home`; idle until started.
    pub fn new(speed: f64, backoff: f64, home: f64) -> Homing {
        Homing {
            speed,
            backoff,
            home,
            state: HomingState::Idle,
            reset: None,
        }
    }

    /// Where the cycle is.
    pub fn state(&self) -> HomingState {
        self.state
    }
}

impl Kind for Homing {
    const DECL: Declaration = Declaration {
        name: "homing",
        input: None,
        params: &[
            Param::required("speed", "units/s", Domain::REAL)
                .doc("signed: the direction of the seek"),
            Param::new("backoff", "units", 0.0, Domain::NON_NEGATIVE),
            Param::new("home", "units", 0.0, Domain::REAL)
                .doc("the position the chain is reset to"),
        ],
        live: &[
            live("start", Self::START),
            live("speed", Self::SPEED),
            live("backoff", Self::BACKOFF),
            live("home", Self::HOME),
        ],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "seeks until the limit, backs off, resets the chain to home",
        build: |a| {
            if a.get(0) == 0.0 {
                return Err(ParamFault::Inconsistent("`speed` must not be zero"));
            }
            Ok(Homing::new(a.get(0), a.get(1), a.get(2)).into())
        },
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::level_in("limit", Unit::Scalar),
        PortSpec::output("out", Unit::Any),
    ];

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
        match self.state {
            HomingState::Seeking => {
                if ports[0].value > 0.5 {
                    self.state = HomingState::BackingOff(self.backoff);
                } else {
                    ports[1].value += self.speed * ctx.dt;
                }
            }
            HomingState::BackingOff(left) => {
                let step = self.speed.abs() * ctx.dt;
                let mv = step.min(left);
                ports[1].value -= mv.copysign(self.speed);
                let left = left - mv;
                if left <= 0.0 {
                    self.state = HomingState::Done;
                    self.reset = Some((Self::OUT, self.home));
                } else {
                    self.state = HomingState::BackingOff(left);
                }
            }
            HomingState::Idle | HomingState::Done => {}
        }
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        match id {
            Self::START => self.state = HomingState::Seeking,
            Self::SPEED => {
                let v = finite(v)?;
                positive(v.abs())?;
                self.speed = v;
            }
            Self::BACKOFF => self.backoff = non_negative(v)?,
            Self::HOME => self.home = finite(v)?,
            _ => return Err(ParamError::Unknown),
        }
        Ok(())
    }

    fn take_reset(&mut self) -> Option<(u8, f64)> {
        self.reset.take()
    }
}
