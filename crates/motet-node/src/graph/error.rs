//! Typed errors from building and updating a graph.

use core::fmt;

use super::port::PortRef;

/// Which fixed capacity ran out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Capacity {
    /// Components ([`super::GraphBuilder`]'s `C`).
    Components,
    /// Mappings ([`super::GraphBuilder`]'s `M`).
    Mappings,
    /// More channels than a frame's step list holds ([`super::MAX_FRAME_STEPS`]).
    Channels,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
/// Why a graph description or a parameter change was refused (nothing changed).
pub enum GraphError {
    /// No component with this index.
    UnknownComponent(u8),
    /// The component has no port with this index.
    UnknownPort(PortRef),
    /// A mapping's source must be an output (taps may read inputs: use `tap`).
    NotAnOutput(PortRef),
    /// A mapping's target (or a tap's listener) must be an input.
    NotAnInput(PortRef),
    /// The two ports carry different quantities (e.g. a length into an angle).
    UnitMismatch {
        /// The mapping's source.
        from: PortRef,
        /// The mapping's target.
        to: PortRef,
    },
    /// An INCREMENTAL mapping touches a level port (analog reading, button,
    /// speed, flag), which only has an absolute meaning.
    ModeMismatch {
        /// The mapping's source.
        from: PortRef,
        /// The mapping's target (either end may be the level port).
        to: PortRef,
    },
    /// An input receives an ABSOLUTE mapping and any other mapping: the result
    /// would depend on the order of transmission.
    AbsoluteFanIn(PortRef),
    /// The same source is mapped onto the same target twice.
    DuplicateMapping {
        /// The source.
        from: PortRef,
        /// The target.
        to: PortRef,
    },
    /// An ABSOLUTE mapping whose target component runs before its source in the
    /// frame (a later component into an earlier one, or a component into
    /// itself). Every cycle contains such a backward mapping; INCREMENTAL ones
    /// are delayed by one frame, ABSOLUTE ones would need the same frame and are
    /// refused.
    BackwardAbsolute {
        /// The source (later in the run order).
        from: PortRef,
        /// The target (earlier in the run order).
        to: PortRef,
    },
    /// A ratio that is zero, infinite or NaN.
    BadRatio(PortRef),
    /// The component has no parameter with this id.
    UnknownParam {
        /// The component, by index.
        comp: u8,
        /// The parameter id asked for.
        param: u8,
    },
    /// The value is out of range for the parameter (NaN, negative speed, ...).
    BadValue {
        /// The component, by index.
        comp: u8,
        /// The parameter whose value was refused.
        param: u8,
    },
    /// A fixed-capacity table is full.
    CapacityExceeded(Capacity),
    /// A reset or read walked further than the graph has components (a cycle).
    TooDeep,
}

impl fmt::Display for Capacity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Capacity::Components => "components",
            Capacity::Mappings => "mappings",
            Capacity::Channels => "channels",
        })
    }
}

/// Ports and components by index (`#component.port`); the graph file
/// compiler names them instead.
impl fmt::Display for GraphError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GraphError::UnknownComponent(c) => write!(f, "no component #{c}"),
            GraphError::UnknownPort(r) => write!(f, "no port #{}.{}", r.comp, r.port),
            GraphError::NotAnOutput(r) => {
                write!(
                    f,
                    "#{}.{} is an input: a mapping goes from an output",
                    r.comp, r.port
                )
            }
            GraphError::NotAnInput(r) => {
                write!(
                    f,
                    "#{}.{} is an output: a mapping goes to an input",
                    r.comp, r.port
                )
            }
            GraphError::UnitMismatch { from, to } => write!(
                f,
                "#{}.{} and #{}.{} carry different quantities",
                from.comp, from.port, to.comp, to.port
            ),
            GraphError::ModeMismatch { from, to } => write!(
                f,
                "#{}.{} → #{}.{}: a level port needs an absolute mapping",
                from.comp, from.port, to.comp, to.port
            ),
            GraphError::AbsoluteFanIn(r) => write!(
                f,
                "#{}.{} receives an absolute mapping and another mapping",
                r.comp, r.port
            ),
            GraphError::DuplicateMapping { from, to } => write!(
                f,
                "#{}.{} is already mapped onto #{}.{}",
                from.comp, from.port, to.comp, to.port
            ),
            GraphError::BackwardAbsolute { from, to } => write!(
                f,
                "#{}.{} → #{}.{}: an absolute mapping backward in the frame closes a cycle",
                from.comp, from.port, to.comp, to.port
            ),
            GraphError::BadRatio(r) => {
                write!(
                    f,
                    "bad ratio for #{}.{}: zero, infinite or NaN",
                    r.comp, r.port
                )
            }
            GraphError::UnknownParam { comp, param } => {
                write!(f, "no parameter {param} of #{comp}")
            }
            GraphError::BadValue { comp, param } => {
                write!(f, "bad value for parameter {param} of #{comp}")
            }
            GraphError::CapacityExceeded(c) => write!(f, "too many {c} for the graph"),
            GraphError::TooDeep => f.write_str("the graph is too deep (a cycle)"),
        }
    }
}
