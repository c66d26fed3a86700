//! The third stage: ports and mappings resolved and checked. `[[map]]`
//! entries become operations, and every operation runs through the node's
//! own builder, whose refusals (units, modes, fan-in, cycles, capacities) are
//! mapped back to the file.

use crate::emit::Op;
use crate::file::{names, ComponentDef, FileError, GraphFile, Loc};
use crate::raw::RawMap;
use crate::source::Source;
use motet_node::graph::port::Dir;
use motet_node::graph::spec::{self, BuildError};
use motet_node::graph::{Capacity, GraphBuilder, GraphError, Mode, PortRef};
use motet_node::{GRAPH_COMPONENTS, GRAPH_MAPPINGS};
use toml::Spanned;

/// Resolves `port` of `c`: its exact name, or `out`/`in` for the sole output
/// or input.
pub(crate) fn resolve_port(c: &ComponentDef, port: &str) -> Option<u8> {
    let ports = c.info.ports;
    if let Some(i) = ports.iter().position(|p| p.name == port) {
        return Some(i as u8);
    }
    let dir = match port {
        "out" => Dir::Out,
        "in" => Dir::In,
        _ => return None,
    };
    let mut it = ports.iter().enumerate().filter(|(_, p)| p.dir == dir);
    match (it.next(), it.next()) {
        (Some((i, _)), None) => Some(i as u8),
        _ => None,
    }
}

fn parse_mode(s: &str) -> Option<Mode> {
    match s {
        "incremental" => Some(Mode::Incremental),
        "absolute" => Some(Mode::Absolute),
        _ => None,
    }
}

/// `component.port` in a mapping.
fn find_port(
    src: &Source,
    components: &[ComponentDef],
    s: &Spanned<String>,
    key: &str,
) -> Result<PortRef, FileError> {
    let text = s.get_ref();
    let Some((c, p)) = text.rsplit_once('.') else {
        return Err(src.err(s.span(), key, format!("`{text}` is not `component.port`")));
    };
    let Some(def) = components.iter().find(|d| d.name == c) else {
        return Err(src.err(s.span(), key, format!("no component `{c}`")));
    };
    let Some(port) = resolve_port(def, p) else {
        return Err(src.err(
            s.span(),
            key,
            format!(
                "`{c}` (a `{}`) has no port `{p}`; ports: {}",
                def.info.name,
                names(def.info_ports().into_iter())
            ),
        ));
    };
    Ok(PortRef::new(def.index, port))
}

/// The `[[map]]` entries as operations.
pub(crate) fn mappings(
    src: &Source,
    components: &[ComponentDef],
    map: &[Spanned<RawMap>],
) -> Result<Vec<(Op, Loc, String)>, FileError> {
    let mut ops = Vec::new();
    for (i, m) in map.iter().enumerate() {
        let mk = format!("map[{i}]");
        let r = m.get_ref();
        let from = find_port(src, components, &r.from, &format!("{mk}.from"))?;
        let to = find_port(src, components, &r.to, &format!("{mk}.to"))?;
        let mode = match &r.mode {
            Some(s) => parse_mode(s.get_ref()).ok_or_else(|| {
                src.err(
                    s.span(),
                    format!("{mk}.mode"),
                    format!(
                        "unknown mode `{}`; expected \"incremental\" or \"absolute\"",
                        s.get_ref()
                    ),
                )
            })?,
            None => Mode::Incremental,
        };
        ops.push((Op::Map(from, to, mode, r.tap), src.loc(m.span()), mk));
    }
    Ok(ops)
}

/// A builder refusal in the file's names.
fn describe(gf: &GraphFile, e: BuildError) -> String {
    let e = match e {
        BuildError::Params(p) => return format!("bad parameter values: {p}"),
        BuildError::Graph(e) => e,
    };
    let pn = |p: PortRef| gf.port_name(p);
    match e {
            GraphError::UnknownComponent(c) => format!("no component #{c}"),
            GraphError::UnknownPort(p) => format!("no port {}", pn(p)),
            GraphError::NotAnOutput(p) => format!(
                "{} is an input: a mapping goes from an output (use `tap = true` to pull from an input)",
                pn(p)
            ),
            GraphError::NotAnInput(p) => format!("{} is an output: a mapping goes to an input", pn(p)),
            GraphError::UnitMismatch { from, to } => format!(
                "{} and {} carry different quantities (length, angle, speed, scalar)",
                pn(from),
                pn(to)
            ),
            GraphError::ModeMismatch { from, to } => format!(
                "{} → {}: a level port (analog value, button, speed, flag) needs mode = \"absolute\"",
                pn(from),
                pn(to)
            ),
            GraphError::AbsoluteFanIn(p) => format!(
                "{} receives an absolute mapping and another mapping: the result would depend on their order",
                pn(p)
            ),
            GraphError::DuplicateMapping { from, to } => {
                format!("{} is already mapped onto {}", pn(from), pn(to))
            }
            GraphError::BackwardAbsolute { from, to } => format!(
                "{} → {}: an absolute mapping into a component that runs earlier in the frame closes a cycle; make it incremental (one frame late) or reorder the components",
                pn(from),
                pn(to)
            ),
            GraphError::BadRatio(p) => format!("bad ratio for {}: zero, infinite or NaN", pn(p)),
            GraphError::UnknownParam { comp, param } => format!("no parameter {param} of #{comp}"),
            GraphError::BadValue { comp, param } => format!("bad value for parameter {param} of #{comp}"),
            GraphError::CapacityExceeded(c) => format!("a node's graph holds at most {GRAPH_COMPONENTS} components, {GRAPH_MAPPINGS} mappings and {} channels ({c:?} ran out)", motet_node::graph::MAX_FRAME_STEPS),
            GraphError::TooDeep => "the graph is too deep (a cycle)".to_string(),
    }
}

/// Runs the operations through the node's own builder and maps its errors
/// back to the file.
pub(crate) fn check_build(src: &Source, gf: &GraphFile) -> Result<(), FileError> {
    let mut b: GraphBuilder<GRAPH_COMPONENTS, GRAPH_MAPPINGS> = GraphBuilder::new();
    b.frame_us(gf.frame_us);
    for (op, loc, key) in &gf.ops {
        let r = match op {
            Op::Add(kind, params) => spec::add(&mut b, *kind, params).map(|_| ()),
            Op::Ratio(p, w, bl) => b.set_ratio(*p, *w, *bl).map_err(BuildError::from),
            Op::Map(from, to, mode, tap) => if *tap {
                b.tap(*to, *from, *mode)
            } else {
                b.map(*from, *to, *mode)
            }
            .map_err(BuildError::from),
        };
        if let Err(e) = r {
            let mut msg = describe(gf, e);
            if e == BuildError::Graph(GraphError::CapacityExceeded(Capacity::Channels)) {
                msg = format!("too many channels: {msg}");
            }
            return Err(src.err_at(*loc, key, msg));
        }
    }
    if let Err(e) = b.build() {
        // Find the mapping the error is about.
        let at = gf.ops.iter().find(|(op, _, _)| match (op, e) {
            (Op::Map(_, to, Mode::Absolute, _), GraphError::AbsoluteFanIn(p)) => *to == p,
            (Op::Map(f, t, _, _), GraphError::BackwardAbsolute { from, to }) => {
                *f == from && *t == to
            }
            _ => false,
        });
        let (loc, key) = at
            .map(|(_, l, k)| (*l, k.clone()))
            .unwrap_or((Loc { line: 1, column: 1 }, String::new()));
        return Err(src.err_at(loc, key, describe(gf, e.into())));
    }
    Ok(())
}
