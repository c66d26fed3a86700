//! Components: an enum over every kind (no trait objects, no allocation), each
//! kind in its own file. The [`Kind`] trait is only used for static dispatch.
//! The `components!` table at the end lists every kind once, in wire order;
//! each kind's [`Declaration`] (see [`super::declare`]) says the rest.
//!
//! Every kind declares its ports ([`PortSpec`]); a port is addressed by its
//! index in that list. Parameters are set live by `(parameter id, value)`; the
//! ids are associated constants of each kind.

use super::channel::GraphChannel;
use super::declare::Declaration;
use super::filters::{ScalingFilter1D, ScalingFilter2D, ThresholdGenerator};
use super::generators::{
    CircleGenerator, PathLength2D, PathLength3D, PositionGenerator, VelocityGenerator,
    WaveGenerator1D, WaveGenerator2D,
};
use super::homing::Homing;
use super::inputs::{AnalogInput, Button, Encoder, StreamInput};
use super::io::{Ctx, Inputs};
use super::kinematics::{CoreXY, FiveBarForward, PolarToCartesian};
use super::port::{Port, PortSpec};
use super::reader::TrajectoryReader;
use super::recorder::{FourTrackPlayer, FourTrackRecorder};

/// When a component runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Phase {
    /// In the 1 kHz slow frame (buttons).
    Slow,
    /// First in the core frame: hardware inputs, stream inputs, players,
    /// trajectory readers.
    Input,
    /// The bulk of components, in creation order.
    Pre,
    /// Channels.
    Channel,
    /// After the channels have emitted their steps: recorders.
    Post,
}

/// Why a parameter change was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamError {
    /// The component has no parameter with this id.
    Unknown,
    /// The value is outside what the parameter takes (NaN, a negative speed, …).
    BadValue,
}

pub(crate) fn finite(v: f64) -> Result<f64, ParamError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ParamError::BadValue)
    }
}

pub(crate) fn positive(v: f64) -> Result<f64, ParamError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(ParamError::BadValue)
    }
}

pub(crate) fn non_negative(v: f64) -> Result<f64, ParamError> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(ParamError::BadValue)
    }
}

/// Behaviour of one component kind. All values are in the ports' block units.
pub trait Kind {
    /// The kind's ports, in index order (its
    /// [`Declaration::ports`](super::declare::Declaration::ports)).
    const PORTS: &'static [PortSpec];
    /// Everything the host and the wire know of the kind.
    const DECL: Declaration;
    /// When in the frame the kind runs (default: before the channels).
    const PHASE: Phase = Phase::Pre;

    /// One core frame: read the inputs, set the outputs' absolute values.
    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>);

    /// One slow (1 kHz) frame.
    fn slow(&mut self, _ports: &mut [Port], _inputs: &Inputs, _dt: f64) {}

    /// Sets parameter `id`; must change nothing when it fails.
    fn set_param(&mut self, _ports: &mut [Port], _id: u8, _v: f64) -> Result<(), ParamError> {
        Err(ParamError::Unknown)
    }

    /// The current value of parameter `id`, if the kind reports it.
    fn param(&self, _ports: &[Port], _id: u8) -> Option<f64> {
        None
    }

    /// The output `port` was reset to `ports[port].value`: align internal state.
    fn reset_output(&mut self, _ports: &mut [Port], _port: usize) {}

    /// The input `port` was reset to `ports[port].value`: recompute the outputs'
    /// absolute values and return true to propagate them, or false to stop.
    fn reset_input(&mut self, _ports: &mut [Port], _port: usize) -> bool {
        false
    }

    /// Whether [`Kind::inverse`] can answer.
    fn invertible(&self) -> bool {
        false
    }

    /// The absolute value of `input` that gives the outputs `outs` (indexed by
    /// port, block units).
    fn inverse(&self, _ports: &[Port], _input: usize, _outs: &[f64]) -> Option<f64> {
        None
    }

    /// A reset the component asks the graph to perform after it ran:
    /// `(output port, world value)` (homing).
    fn take_reset(&mut self) -> Option<(u8, f64)> {
        None
    }
}

macro_rules! components {
    ($($name:ident($ty:ty)),* $(,)?) => {
        /// A component of the graph.
        #[derive(Clone, Debug, PartialEq)]
        pub enum Component {
            $(
                #[doc = concat!("A `", stringify!($name), "`: see [`", stringify!($ty), "`].")]
                $name($ty),
            )*
        }

        /// Every kind's declaration, in wire order (that of
        /// [`motet_wire::message::GraphKind`]).
        pub static COMPONENTS: &[&Declaration] = &[$(&<$ty as Kind>::DECL,)*];

        $(impl From<$ty> for Component {
            fn from(c: $ty) -> Component {
                Component::$name(c)
            }
        })*

        impl Component {
            /// The component's ports, in index order.
            pub fn ports(&self) -> &'static [PortSpec] {
                match self { $(Component::$name(_) => <$ty as Kind>::PORTS,)* }
            }
            /// Its kind's declaration.
            pub fn declaration(&self) -> &'static Declaration {
                match self { $(Component::$name(_) => &<$ty as Kind>::DECL,)* }
            }
            /// When in the frame it runs.
            pub fn phase(&self) -> Phase {
                match self { $(Component::$name(_) => <$ty as Kind>::PHASE,)* }
            }
            /// Its kind's Rust name (as in [`Component`]'s variants).
            pub fn name(&self) -> &'static str {
                match self { $(Component::$name(_) => stringify!($name),)* }
            }
            #[inline]
            pub(crate) fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
                match self { $(Component::$name(c) => Kind::run(c, ports, ctx),)* }
            }
            pub(crate) fn slow(&mut self, ports: &mut [Port], inputs: &Inputs, dt: f64) {
                match self { $(Component::$name(c) => Kind::slow(c, ports, inputs, dt),)* }
            }
            pub(crate) fn set_param(&mut self, ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
                match self { $(Component::$name(c) => Kind::set_param(c, ports, id, v),)* }
            }
            pub(crate) fn param(&self, ports: &[Port], id: u8) -> Option<f64> {
                match self { $(Component::$name(c) => Kind::param(c, ports, id),)* }
            }
            pub(crate) fn reset_output(&mut self, ports: &mut [Port], port: usize) {
                match self { $(Component::$name(c) => Kind::reset_output(c, ports, port),)* }
            }
            pub(crate) fn reset_input(&mut self, ports: &mut [Port], port: usize) -> bool {
                match self { $(Component::$name(c) => Kind::reset_input(c, ports, port),)* }
            }
            pub(crate) fn invertible(&self) -> bool {
                match self { $(Component::$name(c) => Kind::invertible(c, ),)* }
            }
            pub(crate) fn inverse(&self, ports: &[Port], input: usize, outs: &[f64]) -> Option<f64> {
                match self { $(Component::$name(c) => Kind::inverse(c, ports, input, outs),)* }
            }
            #[inline]
            pub(crate) fn take_reset(&mut self) -> Option<(u8, f64)> {
                match self { $(Component::$name(c) => Kind::take_reset(c, ),)* }
            }
        }
    };
}

components! {
    AnalogInput(AnalogInput),
    Button(Button),
    Encoder(Encoder),
    StreamInput(StreamInput),
    ScalingFilter1D(ScalingFilter1D),
    ScalingFilter2D(ScalingFilter2D),
    ThresholdGenerator(ThresholdGenerator),
    CoreXY(CoreXY),
    PolarToCartesian(PolarToCartesian),
    FiveBarForward(FiveBarForward),
    VelocityGenerator(VelocityGenerator),
    PositionGenerator(PositionGenerator),
    WaveGenerator1D(WaveGenerator1D),
    WaveGenerator2D(WaveGenerator2D),
    CircleGenerator(CircleGenerator),
    PathLength2D(PathLength2D),
    PathLength3D(PathLength3D),
    FourTrackRecorder(FourTrackRecorder),
    FourTrackPlayer(FourTrackPlayer),
    Homing(Homing),
    TrajectoryReader(TrajectoryReader),
    Channel(GraphChannel),
}
