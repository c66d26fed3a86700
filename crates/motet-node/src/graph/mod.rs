//! A frame-synchronous dataflow graph runtime after Stepdance: components
//! connected by BlockPort-style mappings, run once per core frame (25 kHz by
//! default), driving step channels. The graph is plain data (fixed-capacity
//! tables, indices instead of references, no allocation), so it can be rebuilt
//! at run time from a description and swapped in only when it validates.
//!
//! * [`port`](mod@port): ports, units, mapping modes and mappings.
//! * [`component`]: the [`Component`] enum; one file per family:
//!   [`inputs`], [`filters`], [`kinematics`], [`generators`], [`homing`],
//!   [`reader`], [`recorder`], [`channel`].
//! * [`declare`]: each kind's declaration (name, parameters, defaults,
//!   ports), read by the node, the graph file compiler and the docs; how to
//!   add a component.
//! * [`graph`](mod@graph) and [`builder`]: the runtime and its validation.
//! * [`wire`]: the motion-stream wire encoding; [`record`]: the recording format.

pub mod builder;
pub mod channel;
pub mod component;
pub mod declare;
pub mod error;
pub mod filters;
pub mod generators;
#[allow(clippy::module_inception)]
pub mod graph;
pub mod homing;
pub mod inputs;
pub mod io;
pub mod kinematics;
pub(crate) mod math;
pub mod port;
pub mod reader;
pub mod record;
pub mod recorder;
pub mod spec;
pub mod wire;

pub use builder::GraphBuilder;
pub use channel::GraphChannel;
pub use component::{Component, Phase, COMPONENTS};
pub use declare::{Declaration, Domain, Param, ParamFault};
pub use error::{Capacity, GraphError};
pub use filters::{ScalingFilter1D, ScalingFilter2D, ThresholdGenerator};
pub use generators::{
    CircleGenerator, PathLength2D, PathLength3D, PositionGenerator, VelocityGenerator,
    WaveGenerator1D, WaveGenerator2D,
};
pub use graph::{Graph, DEFAULT_FRAME_US, MAX_PORTS, SLOW_FRAME_US};
pub use homing::{Homing, HomingState};
pub use inputs::{AnalogInput, Button, ButtonMode, Encoder, StreamInput};
pub use io::{FrameOut, Inputs, StepOut, MAX_FRAME_STEPS, MAX_HW};
pub use kinematics::{CoreXY, FiveBarForward, PolarToCartesian};
pub use port::{port, Mode, Port, PortRef, Unit};
pub use reader::TrajectoryReader;
pub use record::{StepQuantizer, Tape, DEFAULT_RESOLUTION};
pub use recorder::{FourTrackPlayer, FourTrackRecorder};
pub use spec::BuildError;
