//! Components from their wire description ([`motet_wire::message::GraphKind`]
//! and its construction values), shared by the node (which builds graphs from
//! messages) and the host (which validates a graph file before sending it).
//! What each kind takes is its [`Declaration`] in [`COMPONENTS`].

use core::fmt;

use motet_wire::message::GraphKind;

use super::component::{Component, COMPONENTS};
use super::declare::{Declaration, ParamFault};
use super::error::GraphError;

/// The declaration of a wire kind.
pub fn declaration(kind: GraphKind) -> Option<&'static Declaration> {
    COMPONENTS.get(usize::from(kind.0)).copied()
}

/// Builds a component from its kind and construction values (see
/// [`Declaration::params`]).
pub fn component(kind: GraphKind, params: &[f64]) -> Result<Component, ParamFault> {
    declaration(kind)
        .ok_or(ParamFault::UnknownKind)?
        .component(params)
}

/// Why a component could not be added to a graph.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BuildError {
    /// Its construction values were refused.
    Params(ParamFault),
    /// The builder refused it (capacity) or a value kept in a port.
    Graph(GraphError),
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BuildError::Params(e) => write!(f, "bad construction values: {e}"),
            BuildError::Graph(e) => e.fmt(f),
        }
    }
}

impl From<ParamFault> for BuildError {
    fn from(e: ParamFault) -> Self {
        BuildError::Params(e)
    }
}

impl From<GraphError> for BuildError {
    fn from(e: GraphError) -> Self {
        BuildError::Graph(e)
    }
}

/// Adds the component `kind` with construction values `params` to `b`,
/// including values that live in ports (a velocity generator's speed).
/// Returns its index. Construction values are checked before anything is
/// added; a value kept in a port is checked by the declaration's domain, so
/// setting it fails only when the declaration and the kind disagree (then the
/// component stays added and the caller abandons the graph, as the node's
/// failed commit does).
pub fn add<const C: usize, const M: usize>(
    b: &mut super::GraphBuilder<C, M>,
    kind: GraphKind,
    params: &[f64],
) -> Result<u8, BuildError> {
    let decl = declaration(kind).ok_or(ParamFault::UnknownKind)?;
    let c = decl.component(params)?;
    let i = b.add(c)?;
    for &(param, id) in decl.in_ports {
        if let Some(&v) = params.get(decl.offset() + param) {
            b.set_param(i, id, v)?;
        }
    }
    Ok(i)
}
