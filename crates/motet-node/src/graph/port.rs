//! BlockPorts: the inputs and outputs of components, and the mappings between
//! them.
//!
//! A port holds an absolute value in its component's *block* units. What flows
//! over a mapping is in *world* units: a port's ratio (`set_ratio(world,
//! block)`) converts on the way out of an output and on the way into an input,
//! so a mapping between two ports is the identity in world units.
//!
//! * An **input** port accumulates: an INCREMENTAL mapping adds the source's
//!   change since the mapping last ran (so several outputs mapped onto one
//!   input sum: fan-in), an ABSOLUTE mapping overwrites. The owning component
//!   reads the absolute value or the change since it last read
//!   ([`Port::take_delta`]).
//! * An **output** port holds the absolute value its component computed;
//!   the change since the last frame is what INCREMENTAL mappings transmit.
//! * Fan-out is by pull: an input may *tap* any other port (output or input)
//!   and receives that port's changes (or its absolute value) when its own
//!   component runs.
//!
//! Ports are addressed by [`PortRef`] (component index, port index); no port
//! refers to another by reference, so a graph is plain data.

/// Address of a port: component index and port index within the component.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PortRef {
    /// Index of the component in the graph, in the order added.
    pub comp: u8,
    /// Index of the port in its component's port list (its kind's declaration).
    pub port: u8,
}

impl PortRef {
    /// The port `port` of component `comp`.
    pub const fn new(comp: u8, port: u8) -> PortRef {
        PortRef { comp, port }
    }
}

/// Shorthand for [`PortRef::new`].
pub const fn port(comp: u8, port: u8) -> PortRef {
    PortRef { comp, port }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
/// Whether a port is read or written by its component.
pub enum Dir {
    /// An input: written by mappings, read by its component.
    In,
    /// An output: written by its component, read by mappings.
    Out,
}

/// The physical quantity a port carries, checked when mapping. `Any` matches
/// everything.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    /// Matches any quantity (a generic pass-through).
    Any,
    /// A length, mm in world units.
    Length,
    /// An angle, radians in world units.
    Angle,
    /// A rate: units per second.
    Speed,
    /// Dimensionless (flags, analog readings, ratios).
    Scalar,
}

impl Unit {
    /// Whether a port carrying `self` may be mapped to or from one carrying `other`: equal, or
    /// either is `Any`.
    pub fn compatible(self, other: Unit) -> bool {
        self == Unit::Any || other == Unit::Any || self == other
    }
}

/// How a mapping transmits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Mode {
    /// Changes are added to the target (the default; fan-in sums).
    #[default]
    Incremental,
    /// The target is overwritten with the source's absolute value.
    Absolute,
}

/// Static description of one port of a component kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PortSpec {
    /// The port's name in graph files.
    pub name: &'static str,
    /// Input or output.
    pub dir: Dir,
    /// The quantity it carries, checked when mapping.
    pub unit: Unit,
    /// A level (parameter-like) port: it only makes sense in ABSOLUTE mappings
    /// (analog readings, button states, speeds, flags).
    pub level: bool,
}

impl PortSpec {
    /// An input that accumulates changes (incremental or absolute mappings).
    pub const fn input(name: &'static str, unit: Unit) -> PortSpec {
        PortSpec {
            name,
            dir: Dir::In,
            unit,
            level: false,
        }
    }
    /// An output whose changes incremental mappings carry.
    pub const fn output(name: &'static str, unit: Unit) -> PortSpec {
        PortSpec {
            name,
            dir: Dir::Out,
            unit,
            level: false,
        }
    }
    /// A level input: absolute mappings only.
    pub const fn level_in(name: &'static str, unit: Unit) -> PortSpec {
        PortSpec {
            name,
            dir: Dir::In,
            unit,
            level: true,
        }
    }
    /// A level output: absolute mappings only.
    pub const fn level_out(name: &'static str, unit: Unit) -> PortSpec {
        PortSpec {
            name,
            dir: Dir::Out,
            unit,
            level: true,
        }
    }
}

/// One port's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Port {
    /// Absolute value, block units.
    pub value: f64,
    /// Input ports: the value when the component last took its delta.
    pub last: f64,
    world: f64,
    block: f64,
    /// Input or output, as declared.
    pub dir: Dir,
    /// The quantity it carries, as declared.
    pub unit: Unit,
    /// Absolute mappings only, as declared.
    pub level: bool,
}

impl Port {
    /// A port as `spec` declares it, at 0, with a 1:1 ratio.
    pub fn new(spec: &PortSpec) -> Port {
        Port {
            value: 0.0,
            last: 0.0,
            world: 1.0,
            block: 1.0,
            dir: spec.dir,
            unit: spec.unit,
            level: spec.level,
        }
    }

    /// `world` world units correspond to `block` block units, e.g. an encoder
    /// output `set_ratio(24.0, 2400.0)`: 24 mm per 2400 counts; a channel input
    /// `set_ratio(25.4, 2874.0)`: 2874 steps per inch.
    pub fn set_ratio(&mut self, world: f64, block: f64) -> bool {
        if !(world.is_finite() && block.is_finite() && world != 0.0 && block != 0.0) {
            return false;
        }
        self.world = world;
        self.block = block;
        true
    }

    /// `(world, block)`.
    pub fn ratio(&self) -> (f64, f64) {
        (self.world, self.block)
    }

    /// Block units to world units.
    #[inline]
    pub fn to_world(&self, v: f64) -> f64 {
        v * self.world / self.block
    }

    /// World units to block units.
    #[inline]
    pub fn from_world(&self, v: f64) -> f64 {
        v * self.block / self.world
    }

    /// The change since the last call (inputs), in block units.
    #[inline]
    pub fn take_delta(&mut self) -> f64 {
        let d = self.value - self.last;
        self.last = self.value;
        d
    }

    /// Absolute value in world units.
    #[inline]
    pub fn world_value(&self) -> f64 {
        self.to_world(self.value)
    }
}

/// Whether a mapping pushes (output → input, run when the source's component
/// has run) or pulls (an input taps another port, run when the tapping
/// component runs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapKind {
    /// Run when the source's component has run.
    Push,
    /// Run when the tapping (target) component runs.
    Tap,
}

/// A mapping from `from` to the input `to`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mapping {
    /// The source port.
    pub from: PortRef,
    /// The target input port.
    pub to: PortRef,
    /// Whether the target gets the change (added) or the value (overwritten).
    pub mode: Mode,
    /// Push or pull.
    pub kind: MapKind,
    /// Source value (block units) when the mapping last transmitted.
    pub last: f64,
    /// The data reaches the target one frame late (a backward mapping: its
    /// target's component runs before its source's). Set when building.
    pub delayed: bool,
}

impl Mapping {
    /// Transmits from `src` into `dst`.
    #[inline]
    pub fn transfer(&mut self, src: &Port, dst: &mut Port) {
        match self.mode {
            Mode::Incremental => {
                let d = src.value - self.last;
                if d != 0.0 {
                    dst.value += dst.from_world(src.to_world(d));
                }
            }
            Mode::Absolute => dst.value = dst.from_world(src.to_world(src.value)),
        }
        self.last = src.value;
    }
}
