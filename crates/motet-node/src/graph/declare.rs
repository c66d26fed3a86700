//! Graph components declared once: each kind's [`Declaration`] (its name in
//! graph files, its wire kind, the hardware input it reads, its construction
//! parameters with units, defaults, ranges and documentation, its live
//! parameters, its ports and how it is built from the values of a
//! [`GraphAdd`](motet_wire::HostMessage::GraphAdd)) is an associated constant
//! of the kind, next to its behaviour. The node builds components from it
//! ([`super::spec`]), the graph file compiler (`motet-graph`) reads its
//! names, defaults and ranges from it, and the table of component kinds in
//! `examples/dance/README.md` is rendered from it (a test in `motet-graph`
//! fails when the table differs).
//!
//! # Adding a component
//!
//! 1. Write one file under `motet-node/src/graph/` holding the type, its
//!    [`Kind`](super::component::Kind) implementation and, in it,
//!    `const DECL: Declaration` (parameters in wire order, required ones
//!    first; live parameters by the ids `set_param` takes; a `build` function
//!    from [`Args`]).
//! 2. Add one line to the `components!` table in
//!    [`super::component`]; its position is the kind's [`GraphKind`] on the
//!    wire (so new kinds go last).
//!
//! Then run `cargo test -p motet-graph`: it checks the declaration (defaults
//! accepted by the node and the compiler, round trip through the wire) and
//! prints the README's new table.

use core::fmt;

use motet_wire::message::{GraphInputKind, GraphKind, MAX_GRAPH_PARAMS};

use super::component::Component;
use super::port::PortSpec;

/// What values a construction parameter takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Domain {
    /// A finite number in `min..=max`.
    Number {
        /// Least value accepted.
        min: f64,
        /// Greatest value accepted.
        max: f64,
    },
    /// A finite number above zero.
    Positive,
    /// Any number but NaN; ±∞ allowed (bounds).
    Bound,
    /// A flag: any number but NaN, nonzero for true (`true`/`false` in files).
    Flag,
    /// An integer `0..n`.
    Index(u8),
    /// One of the names, sent as its index (its index is accepted in files too).
    Choice(&'static [&'static str]),
}

impl Domain {
    /// Any finite number.
    pub const REAL: Domain = Domain::Number {
        min: f64::NEG_INFINITY,
        max: f64::INFINITY,
    };
    /// A finite number not below zero.
    pub const NON_NEGATIVE: Domain = Domain::Number {
        min: 0.0,
        max: f64::INFINITY,
    };

    /// Whether `v` is in the domain.
    pub fn accepts(&self, v: f64) -> bool {
        let index = |n: usize| v >= 0.0 && v < n as f64 && v == libm::floor(v);
        match *self {
            Domain::Number { min, max } => v.is_finite() && min <= v && v <= max,
            Domain::Positive => v.is_finite() && v > 0.0,
            Domain::Bound | Domain::Flag => !v.is_nan(),
            Domain::Index(n) => index(n as usize),
            Domain::Choice(names) => index(names.len()),
        }
    }
}

/// A construction parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Param {
    /// Its key in graph files.
    pub name: &'static str,
    /// Its unit (`""`: none).
    pub unit: &'static str,
    /// `None`: required.
    pub default: Option<f64>,
    /// The values it takes.
    pub domain: Domain,
    /// One line for the docs (`""`: none).
    pub doc: &'static str,
}

impl Param {
    /// A parameter with a default.
    pub const fn new(name: &'static str, unit: &'static str, default: f64, domain: Domain) -> Self {
        Param {
            name,
            unit,
            default: Some(default),
            domain,
            doc: "",
        }
    }

    /// A required parameter.
    pub const fn required(name: &'static str, unit: &'static str, domain: Domain) -> Self {
        Param {
            name,
            unit,
            default: None,
            domain,
            doc: "",
        }
    }

    /// The same with a one-line documentation.
    pub const fn doc(mut self, doc: &'static str) -> Self {
        self.doc = doc;
        self
    }
}

/// A parameter changeable while the graph runs: its name and the id
/// [`Kind::set_param`](super::component::Kind::set_param) takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Live {
    /// Its key in graph files and in `set` stages.
    pub name: &'static str,
    /// The id [`Kind::set_param`](super::component::Kind::set_param) takes.
    pub id: u8,
}

/// Shorthand for a [`Live`].
pub const fn live(name: &'static str, id: u8) -> Live {
    Live { name, id }
}

/// A key graph files accept for a kind that is not sent as a construction
/// value (port ratios, names for the host).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HostKey {
    /// The key in graph files.
    pub name: &'static str,
    /// One line for the docs: what the host does with it.
    pub doc: &'static str,
}

/// One component kind, declared once.
#[derive(Clone, Copy, Debug)]
pub struct Declaration {
    /// `kind = "..."` in graph files.
    pub name: &'static str,
    /// The hardware input it reads (its index is the first construction
    /// value, before [`Declaration::params`]).
    pub input: Option<GraphInputKind>,
    /// Construction parameters in wire order, required ones first.
    pub params: &'static [Param],
    /// Parameters changeable while the graph runs.
    pub live: &'static [Live],
    /// Graph-file keys that are not construction values.
    pub host_keys: &'static [HostKey],
    /// Construction values the component keeps in its ports (a velocity
    /// generator's speed): `(parameter index, live id)`, set through
    /// `set_param` once it is in a graph, when given.
    pub in_ports: &'static [(usize, u8)],
    /// Its ports, in index order.
    pub ports: &'static [PortSpec],
    /// One line: what it does.
    pub doc: &'static str,
    /// The component from checked construction values.
    pub build: fn(&Args) -> Result<Component, ParamFault>,
}

/// Why construction values were refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamFault {
    /// No kind with this wire identity is declared.
    UnknownKind,
    /// Fewer values than the required ones or more than the kind takes
    /// (counting the hardware index of input kinds).
    Count {
        /// How many values were given.
        given: usize,
        /// How many the kind requires.
        min: usize,
        /// How many it takes at most.
        max: usize,
    },
    /// A value outside its parameter's domain.
    OutOfRange {
        /// The parameter's name.
        param: &'static str,
    },
    /// Values that do not go together (lower above upper).
    Inconsistent(&'static str),
}

impl fmt::Display for ParamFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamFault::UnknownKind => write!(f, "no such component kind"),
            ParamFault::Count { given, min, max } => {
                write!(f, "{given} values given; the kind takes {min} to {max}")
            }
            ParamFault::OutOfRange { param } => write!(f, "`{param}` is out of range"),
            ParamFault::Inconsistent(why) => f.write_str(why),
        }
    }
}

impl Declaration {
    /// Its identity on the wire: its position in the `components!` table
    /// (`None` for a declaration not in it).
    pub fn kind(&self) -> Option<GraphKind> {
        super::component::COMPONENTS
            .iter()
            .position(|d| d.name == self.name)
            .and_then(|i| u8::try_from(i).ok())
            .map(GraphKind)
    }

    /// Values before the parameters (the hardware index).
    pub fn offset(&self) -> usize {
        self.input.is_some() as usize
    }

    /// Fewest and most construction values.
    pub fn arity(&self) -> (usize, usize) {
        let required = self.params.iter().filter(|p| p.default.is_none()).count();
        (self.offset() + required, self.offset() + self.params.len())
    }

    /// The construction values checked against the declaration.
    pub fn args<'a>(&'static self, values: &'a [f64]) -> Result<Args<'a>, ParamFault> {
        let (min, max) = self.arity();
        if values.len() < min || values.len() > max || max > MAX_GRAPH_PARAMS {
            return Err(ParamFault::Count {
                given: values.len(),
                min,
                max,
            });
        }
        let args = Args { decl: self, values };
        if self.input.is_some() && !Domain::Index(super::io::MAX_HW as u8).accepts(values[0]) {
            return Err(ParamFault::OutOfRange { param: "input" });
        }
        for (i, p) in self.params.iter().enumerate() {
            if !p.domain.accepts(args.get(i)) {
                return Err(ParamFault::OutOfRange { param: p.name });
            }
        }
        Ok(args)
    }

    /// The component built from `values`.
    pub fn component(&'static self, values: &[f64]) -> Result<Component, ParamFault> {
        (self.build)(&self.args(values)?)
    }

    /// The construction values with every default (the hardware index 0).
    pub fn defaults(&self) -> impl Iterator<Item = Option<f64>> + '_ {
        let hw = self.input.map(|_| Some(0.0));
        hw.into_iter().chain(self.params.iter().map(|p| p.default))
    }
}

/// Construction values checked against their [`Declaration`]: missing ones
/// read as their defaults.
#[derive(Clone, Copy, Debug)]
pub struct Args<'a> {
    decl: &'static Declaration,
    values: &'a [f64],
}

impl Args<'_> {
    /// The hardware input index (input kinds).
    pub fn hw(&self) -> u8 {
        self.values.first().map_or(0, |&v| v as u8)
    }

    /// Parameter `i` (index in [`Declaration::params`]).
    pub fn get(&self, i: usize) -> f64 {
        let at = i + self.decl.offset();
        self.values
            .get(at)
            .copied()
            .or(self.decl.params[i].default)
            .unwrap_or(f64::NAN)
    }

    /// Parameter `i` as a flag.
    pub fn flag(&self, i: usize) -> bool {
        self.get(i) != 0.0
    }
}
