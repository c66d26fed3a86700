//! A module's description of itself: what it is, what each of its channels
//! drives, its limits and where it sits in the machine's kinematic chain.
//!
//! A machine built from modules is composed on the host from what the
//! modules on the bus say of themselves (the open-architecture controller's
//! "data download"). Every node serves its description on port 8
//! ([`crate::service::port::DESCRIBE`]) in parts, one part per reply, so
//! that a 4×4 placement and several channels fit the wire's 192-byte
//! messages: part 0 is the [`Head`] (kind, uid, how many parts, a digest of
//! the rest), then [`Identity`], [`Placement`], [`Limits`] and one
//! [`Channel`] per channel. The head is small, so the host's presence probe
//! is one short request and answer; the digest tells it when the rest
//! changed. Numbers are `f32`: a description states what a module can do to
//! a few significant digits, and the host checks it in `f64`.
//!
//! The description lives in a fixed-size form ([`Description`], no
//! allocation) that a simulated node reads from a file and a board builds
//! from its channels ([`Description::default_for`]) or keeps in its store.
//! [`Assembler`] puts the parts back together on the host, checking each
//! part's place and the digest. Bytes in docs/wire.md, section 5.

use crate::frame::Crc32c;
use crate::{encode, MAX_MESSAGE};
use heapless::{String, Vec};
use serde::{Deserialize, Serialize};

/// Most channels a module describes.
pub const MAX_MODULE_CHANNELS: usize = 8;
/// Parts before the channels: head, identity, placement, limits.
pub const FIXED_PARTS: u8 = 4;
/// Longest module name (what a person orders it by, and the machine
/// file's name for its node).
pub const NAME_LEN: usize = 16;
/// Longest model text.
pub const MODEL_LEN: usize = 32;
/// Longest short label (a channel's use, a sensor's quantity).
pub const LABEL_LEN: usize = 16;
/// Longest unit text.
pub const UNIT_LEN: usize = 8;

/// A module's name: `[a-z][a-z0-9_]*`, at most [`NAME_LEN`] bytes.
pub type Name = String<NAME_LEN>;
/// A short label, at most [`LABEL_LEN`] bytes.
pub type Label = String<LABEL_LEN>;

/// What a module is. A module adds one degree of freedom (an axis module),
/// a process (a tool), or something the process needs (a heater, a
/// sensor, an input).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum ModuleKind {
    /// A translational axis driven by a stepper motor (open loop).
    StepperAxis,
    /// A translational axis driven by a servo (a motor and an encoder,
    /// closed loop on the node).
    ServoAxis,
    /// A rotary axis, stepper or servo driven.
    Rotary,
    /// A tool: a spindle, a laser or a pen.
    Tool,
    /// A heater (a hot end, a bed, a chamber).
    Heater,
    /// A sensor: it measures, it drives nothing.
    Sensor,
    /// An input: a button, a knob, a pedal.
    Input,
}

impl ModuleKind {
    /// Every kind, in the wire's order.
    pub const ALL: [ModuleKind; 7] = [
        ModuleKind::StepperAxis,
        ModuleKind::ServoAxis,
        ModuleKind::Rotary,
        ModuleKind::Tool,
        ModuleKind::Heater,
        ModuleKind::Sensor,
        ModuleKind::Input,
    ];

    /// The kind as a description file writes it.
    pub const fn name(self) -> &'static str {
        match self {
            ModuleKind::StepperAxis => "stepper-axis",
            ModuleKind::ServoAxis => "servo-axis",
            ModuleKind::Rotary => "rotary",
            ModuleKind::Tool => "tool",
            ModuleKind::Heater => "heater",
            ModuleKind::Sensor => "sensor",
            ModuleKind::Input => "input",
        }
    }

    /// The kind a description file names, if it is one.
    pub fn parse(s: &str) -> Option<ModuleKind> {
        ModuleKind::ALL.into_iter().find(|k| k.name() == s)
    }

    /// A kind whose module moves a joint (translational or rotary).
    pub const fn is_axis(self) -> bool {
        matches!(
            self,
            ModuleKind::StepperAxis | ModuleKind::ServoAxis | ModuleKind::Rotary
        )
    }

    /// A kind that drives nothing: taking it away or adding it changes no
    /// motion and no process.
    pub const fn is_passive(self) -> bool {
        matches!(self, ModuleKind::Sensor | ModuleKind::Input)
    }
}

/// The axis of a module's own frame its joint moves along (translational)
/// or turns about (rotary), right-handed; `Neg*` the opposite way.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum JointAxis {
    /// +x of the module's frame.
    X,
    /// +y.
    Y,
    /// +z.
    Z,
    /// −x.
    NegX,
    /// −y.
    NegY,
    /// −z.
    NegZ,
}

impl JointAxis {
    /// Every axis, in the wire's order.
    pub const ALL: [JointAxis; 6] = [
        JointAxis::X,
        JointAxis::Y,
        JointAxis::Z,
        JointAxis::NegX,
        JointAxis::NegY,
        JointAxis::NegZ,
    ];

    /// `x`, `y`, `z`, `-x`, `-y`, `-z`.
    pub const fn name(self) -> &'static str {
        match self {
            JointAxis::X => "x",
            JointAxis::Y => "y",
            JointAxis::Z => "z",
            JointAxis::NegX => "-x",
            JointAxis::NegY => "-y",
            JointAxis::NegZ => "-z",
        }
    }

    /// The axis a description file names, if it is one.
    pub fn parse(s: &str) -> Option<JointAxis> {
        JointAxis::ALL.into_iter().find(|a| a.name() == s)
    }

    /// The unit vector in the module's frame.
    pub const fn vector(self) -> [f32; 3] {
        match self {
            JointAxis::X => [1.0, 0.0, 0.0],
            JointAxis::Y => [0.0, 1.0, 0.0],
            JointAxis::Z => [0.0, 0.0, 1.0],
            JointAxis::NegX => [-1.0, 0.0, 0.0],
            JointAxis::NegY => [0.0, -1.0, 0.0],
            JointAxis::NegZ => [0.0, 0.0, -1.0],
        }
    }
}

/// Part 0: what the module is, and how to read the rest.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Head {
    /// What the module is.
    pub kind: ModuleKind,
    /// The node's unique id (the one `Info` reports).
    pub uid: u64,
    /// Parts in all, this one included: [`FIXED_PARTS`] plus one per channel.
    pub parts: u8,
    /// CRC-32C of the encoded parts 1.. in order ([`Description::digest`]):
    /// the description changed exactly when it changed.
    pub digest: u32,
    /// False for a board's default description, made from its channels
    /// alone (no limits, no placement): the module has not been described.
    pub described: bool,
}

/// Part 1: names.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Identity {
    /// What a person orders the module by; the machine file names its
    /// node after it.
    pub name: Name,
    /// The module's model (the hardware it is).
    pub model: String<MODEL_LEN>,
    /// Its hardware revision or serial text; empty if none.
    pub hardware: Label,
}

/// Part 2: where the module sits in the chain.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Placement {
    /// The homogeneous transform (row-major 4×4, mm) from the module's own
    /// frame to the frame of the next module towards the workpiece, with
    /// its joint at 0: a rotation and a translation, bottom row 0 0 0 1.
    pub htm: [f32; 16],
    /// The axis of its own frame its joint moves along or turns about.
    pub joint: JointAxis,
}

/// Part 3: what the module's joint can do (all zero for modules without
/// one). Lengths in mm, angles in degrees.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// Fastest the joint moves, units/s.
    pub max_velocity: f32,
    /// Hardest it accelerates, units/s².
    pub max_acceleration: f32,
    /// `[min, max]` of the joint, units.
    pub travel: [f32; 2],
    /// The smallest move it makes, units.
    pub resolution: f32,
    /// How close to the commanded position it gets, units.
    pub accuracy: f32,
    /// Where it starts (its home), units, within the travel.
    pub home: f32,
}

/// A tool's kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ToolKind {
    /// A rotating cutter; motion stops while it spins up or down.
    Spindle,
    /// A laser; its power changes on the fly.
    Laser,
    /// A pen lifted and lowered at rest.
    Pen,
    /// An output of unknown use (a board's default description).
    Output,
}

impl ToolKind {
    /// Every kind, in the wire's order.
    pub const ALL: [ToolKind; 4] = [
        ToolKind::Spindle,
        ToolKind::Laser,
        ToolKind::Pen,
        ToolKind::Output,
    ];

    /// `spindle`, `laser`, `pen`, `output`.
    pub const fn name(self) -> &'static str {
        match self {
            ToolKind::Spindle => "spindle",
            ToolKind::Laser => "laser",
            ToolKind::Pen => "pen",
            ToolKind::Output => "output",
        }
    }

    /// The kind a description file names, if it is one.
    pub fn parse(s: &str) -> Option<ToolKind> {
        ToolKind::ALL.into_iter().find(|k| k.name() == s)
    }
}

/// Which temperature commands a heater answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum HeaterChannel {
    /// A hot end (M104/M109 with T index).
    Hotend(u8),
    /// The bed (M140/M190).
    Bed,
    /// The chamber (M141/M191).
    Chamber,
}

/// The closed-loop settings of a servo channel (the machine file's
/// `[actuators.NAME.servo]` keys).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ServoGains {
    /// The node's control loop rate, Hz.
    pub rate_hz: u32,
    /// Proportional gain.
    pub kp: f32,
    /// Integral gain.
    pub ki: f32,
    /// Derivative gain.
    pub kd: f32,
    /// Velocity feed-forward.
    pub kv: f32,
    /// Acceleration feed-forward.
    pub ka: f32,
    /// Clamp on the integral term's share of the output.
    pub integral_limit: f32,
    /// |drive| at most this (1: full PWM).
    pub output_limit: f32,
    /// Counts of following error beyond which the node stops.
    pub following_limit: u32,
}

/// What a channel is and the mechanics behind it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ChannelSpec {
    /// A step/direction output.
    Step {
        /// mm of travel per turn of the screw or pulley (translational
        /// modules); 0 for a rotary one.
        lead: f32,
        /// Motor turns per output turn (a gearbox; 1 without one).
        ratio: f32,
        /// Degrees per full step.
        step_angle: f32,
        /// Microsteps per full step.
        microstep: u16,
        /// The motor turns the other way round.
        invert: bool,
        /// Fastest step rate the channel reaches, steps/s (0: no limit).
        max_step_hz: u32,
    },
    /// A motor with an encoder, closed loop on the node.
    Servo {
        /// As for [`ChannelSpec::Step`].
        lead: f32,
        /// As for [`ChannelSpec::Step`].
        ratio: f32,
        /// Encoder lines per motor turn (counts are four times as many).
        encoder_lines: u32,
        /// The motor turns the other way round.
        invert: bool,
        /// Its loop.
        gains: ServoGains,
    },
    /// A tool output.
    Tool {
        /// What the tool is.
        tool: ToolKind,
        /// Its full output (rpm, W, or 1 for a pen).
        max: f32,
        /// Seconds to stand still after a change.
        settle: f32,
    },
    /// A heater output with its temperature sensor.
    Heater {
        /// Which temperature commands set it.
        channel: HeaterChannel,
        /// Highest target, °C.
        max_c: f32,
        /// Time constant of its first-order response, s.
        time_constant: f32,
    },
    /// A measurement.
    Sensor {
        /// What it measures (`temperature`, `force`, `position`).
        quantity: Label,
        /// Its unit (`°C`, `N`, `mm`).
        unit: String<UNIT_LEN>,
        /// Samples per second.
        rate_hz: f32,
    },
    /// A person's input.
    Input {
        /// What it is (`button`, `knob`, `pedal`).
        input: Label,
    },
}

/// One channel (a part from 4 on): what it drives (`joint`, a tool's
/// name, `hotend`), and what it is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Channel {
    /// What it drives or measures.
    pub drives: Label,
    /// Its kind and mechanics.
    pub spec: ChannelSpec,
}

/// One part of a description, as one reply carries it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum DescribePart {
    /// Part 0.
    Head(Head),
    /// Part 1.
    Identity(Identity),
    /// Part 2.
    Placement(Placement),
    /// Part 3.
    Limits(Limits),
    /// Parts 4.. .
    Channel(Channel),
}

/// A whole description, in the fixed-size form a node keeps.
#[derive(Clone, Debug, PartialEq)]
pub struct Description {
    /// What the module is.
    pub kind: ModuleKind,
    /// False for a board's default description ([`Description::default_for`]).
    pub described: bool,
    /// Its names.
    pub identity: Identity,
    /// Where it sits in the chain.
    pub placement: Placement,
    /// What its joint can do.
    pub limits: Limits,
    /// Its channels.
    pub channels: Vec<Channel, MAX_MODULE_CHANNELS>,
}

/// The identity transform, row-major.
pub const IDENTITY_HTM: [f32; 16] = [
    1.0, 0.0, 0.0, 0.0, //
    0.0, 1.0, 0.0, 0.0, //
    0.0, 0.0, 1.0, 0.0, //
    0.0, 0.0, 0.0, 1.0,
];

/// `s` cut to the capacity of `String<N>` on a character boundary.
fn short<const N: usize>(s: &str) -> String<N> {
    let mut out = String::new();
    for c in s.chars() {
        if out.push(c).is_err() {
            break;
        }
    }
    out
}

impl Description {
    /// What a board says of itself before anyone described it: its step
    /// channels and tool outputs (as many as fit), no limits, the identity
    /// placement. The host refuses to compose it, saying so.
    pub fn default_for(
        node_kind: &str,
        board: &str,
        channels: u8,
        tools: u8,
        max_step_hz: u32,
    ) -> Description {
        let mut list = Vec::new();
        for k in 0..channels {
            let mut drives: Label = short("channel ");
            let _ = drives.push(char::from(b'0' + (k % 10)));
            let spec = ChannelSpec::Step {
                lead: 0.0,
                ratio: 1.0,
                step_angle: 0.0,
                microstep: 0,
                invert: false,
                max_step_hz,
            };
            if list.push(Channel { drives, spec }).is_err() {
                break;
            }
        }
        for k in 0..tools {
            let mut drives: Label = short("output ");
            let _ = drives.push(char::from(b'0' + (k % 10)));
            let spec = ChannelSpec::Tool {
                tool: ToolKind::Output,
                max: 0.0,
                settle: 0.0,
            };
            if list.push(Channel { drives, spec }).is_err() {
                break;
            }
        }
        Description {
            kind: if channels > 0 {
                ModuleKind::StepperAxis
            } else {
                ModuleKind::Tool
            },
            described: false,
            identity: Identity {
                name: short("node"),
                model: short(node_kind),
                hardware: short(board),
            },
            placement: Placement {
                htm: IDENTITY_HTM,
                joint: JointAxis::X,
            },
            limits: Limits::default(),
            channels: list,
        }
    }

    /// Parts in all.
    pub fn parts(&self) -> u8 {
        FIXED_PARTS + self.channels.len() as u8
    }

    /// Part `index` of the description of the node whose uid is `uid`, or
    /// `None` past the last.
    pub fn part(&self, uid: u64, index: u8) -> Option<DescribePart> {
        Some(match index {
            0 => DescribePart::Head(self.head(uid)),
            1 => DescribePart::Identity(self.identity.clone()),
            2 => DescribePart::Placement(self.placement),
            3 => DescribePart::Limits(self.limits),
            i => DescribePart::Channel(self.channels.get(usize::from(i - FIXED_PARTS))?.clone()),
        })
    }

    /// The head of the description of node `uid`.
    pub fn head(&self, uid: u64) -> Head {
        Head {
            kind: self.kind,
            uid,
            parts: self.parts(),
            digest: self.digest(),
            described: self.described,
        }
    }

    /// CRC-32C over the encoding of parts 1.. in order: the head's digest.
    pub fn digest(&self) -> u32 {
        let mut crc = Crc32c::new();
        let mut buf = [0u8; MAX_MESSAGE];
        for i in 1..self.parts() {
            if let Some(p) = self.part(0, i) {
                if let Ok(b) = encode(&p, &mut buf) {
                    crc.update(b);
                }
            }
        }
        // The kind and whether it was described count too: a part-for-part
        // equal description of another kind is another module.
        crc.update(&[self.kind as u8, self.described as u8]);
        crc.finish()
    }
}

/// Why parts do not make a description.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DescribeError {
    /// The head announces fewer than [`FIXED_PARTS`] parts or more channels
    /// than [`MAX_MODULE_CHANNELS`].
    BadHead {
        /// The parts it announced.
        parts: u8,
    },
    /// Part `index` is not the kind of part its place holds (or is beyond
    /// the parts the head announced).
    WrongPart {
        /// The part's index.
        index: u8,
    },
    /// Part `index` has not come.
    Missing {
        /// The part's index.
        index: u8,
    },
    /// The parts do not give the digest the head announced: they come from
    /// two different descriptions (the module changed while it was read).
    Digest {
        /// The head's digest.
        expected: u32,
        /// The parts' digest.
        actual: u32,
    },
}

impl core::fmt::Display for DescribeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            DescribeError::BadHead { parts } => write!(
                f,
                "the description's head announces {parts} parts (from {FIXED_PARTS} to {})",
                FIXED_PARTS as usize + MAX_MODULE_CHANNELS
            ),
            DescribeError::WrongPart { index } => {
                write!(f, "part {index} of the description is not the part its place holds")
            }
            DescribeError::Missing { index } => write!(f, "part {index} of the description never came"),
            DescribeError::Digest { expected, actual } => write!(
                f,
                "the description's parts give digest {actual:08x}, its head {expected:08x}: it changed while it was read"
            ),
        }
    }
}

/// A description put together from its parts, in any order.
#[derive(Clone, Debug)]
pub struct Assembler {
    head: Head,
    identity: Option<Identity>,
    placement: Option<Placement>,
    limits: Option<Limits>,
    channels: [Option<Channel>; MAX_MODULE_CHANNELS],
}

impl Assembler {
    /// The parts announced by `head`.
    pub fn new(head: Head) -> Result<Assembler, DescribeError> {
        let ok = head.parts >= FIXED_PARTS
            && usize::from(head.parts - FIXED_PARTS) <= MAX_MODULE_CHANNELS;
        if !ok {
            return Err(DescribeError::BadHead { parts: head.parts });
        }
        Ok(Assembler {
            head,
            identity: None,
            placement: None,
            limits: None,
            channels: core::array::from_fn(|_| None),
        })
    }

    /// The head the parts are read for.
    pub fn head(&self) -> &Head {
        &self.head
    }

    /// Takes part `index`; a part again replaces the one before.
    pub fn take(&mut self, index: u8, part: DescribePart) -> Result<(), DescribeError> {
        let wrong = DescribeError::WrongPart { index };
        if index >= self.head.parts {
            return Err(wrong);
        }
        match (index, part) {
            (0, DescribePart::Head(h)) if h == self.head => {}
            (1, DescribePart::Identity(i)) => self.identity = Some(i),
            (2, DescribePart::Placement(p)) => self.placement = Some(p),
            (3, DescribePart::Limits(l)) => self.limits = Some(l),
            (i, DescribePart::Channel(c)) if i >= FIXED_PARTS => {
                self.channels[usize::from(i - FIXED_PARTS)] = Some(c)
            }
            _ => return Err(wrong),
        }
        Ok(())
    }

    /// Whether part `index` came.
    pub fn has(&self, index: u8) -> bool {
        match index {
            0 => true,
            1 => self.identity.is_some(),
            2 => self.placement.is_some(),
            3 => self.limits.is_some(),
            i if i < self.head.parts => self.channels[usize::from(i - FIXED_PARTS)].is_some(),
            _ => false,
        }
    }

    /// The first part still to come, if any.
    pub fn missing(&self) -> Option<u8> {
        if self.identity.is_none() {
            return Some(1);
        }
        if self.placement.is_none() {
            return Some(2);
        }
        if self.limits.is_none() {
            return Some(3);
        }
        let n = usize::from(self.head.parts - FIXED_PARTS);
        (0..n)
            .find(|&k| self.channels[k].is_none())
            .map(|k| FIXED_PARTS + k as u8)
    }

    /// The description, once every part came and they give the head's
    /// digest.
    pub fn finish(&self) -> Result<Description, DescribeError> {
        if let Some(index) = self.missing() {
            return Err(DescribeError::Missing { index });
        }
        let mut channels = Vec::new();
        let n = usize::from(self.head.parts - FIXED_PARTS);
        for c in self.channels[..n].iter().flatten() {
            // At most MAX_MODULE_CHANNELS: checked in `new`.
            let _ = channels.push(c.clone());
        }
        let d = Description {
            kind: self.head.kind,
            described: self.head.described,
            identity: self.identity.clone().unwrap_or_else(|| Identity {
                name: Name::new(),
                model: String::new(),
                hardware: Label::new(),
            }),
            placement: self.placement.unwrap_or(Placement {
                htm: IDENTITY_HTM,
                joint: JointAxis::X,
            }),
            limits: self.limits.unwrap_or_default(),
            channels,
        };
        let actual = d.digest();
        if actual != self.head.digest {
            return Err(DescribeError::Digest {
                expected: self.head.digest,
                actual,
            });
        }
        Ok(d)
    }
}
