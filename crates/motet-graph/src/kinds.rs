//! The component kinds a graph file names: the node's declarations
//! ([`motet_node::graph::declare`]), looked up by name, and the Markdown table
//! of them that `examples/dance/README.md` holds.

use motet_node::graph::declare::{Declaration, Domain, Param};
use motet_node::graph::port::Dir;
use motet_node::graph::COMPONENTS;
use motet_wire::message::GraphInputKind;

pub use motet_node::graph::COMPONENTS as KINDS;

/// The kind named `name` in a graph file.
pub fn kind(name: &str) -> Option<&'static Declaration> {
    COMPONENTS.iter().copied().find(|k| k.name == name)
}

/// Keys a component table may hold besides its kind's parameters and host
/// keys.
pub const COMMON_KEYS: &[&str] = &["kind", "ratios"];

/// Names of the kinds, for messages.
pub fn kind_names() -> String {
    COMPONENTS
        .iter()
        .map(|k| k.name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// The prefix of the hardware inputs a kind reads in `[inputs]`.
pub fn input_prefix(kind: GraphInputKind) -> &'static str {
    match kind {
        GraphInputKind::Encoder => "encoder",
        GraphInputKind::Analog => "analog",
        GraphInputKind::Digital => "button",
        GraphInputKind::Stream => "stream",
    }
}

/// A number as a reader writes it.
fn number(v: f64) -> String {
    if v == f64::INFINITY {
        "+∞".into()
    } else if v == f64::NEG_INFINITY {
        "−∞".into()
    } else if v < 0.0 {
        format!("−{}", -v)
    } else {
        format!("{v}")
    }
}

/// `name default unit` (or `name (required)`), with the choices of a choice.
fn param(p: &Param) -> String {
    let value = match (p.default, p.domain) {
        (None, _) => "(required)".to_string(),
        (Some(d), Domain::Flag) => (d != 0.0).to_string(),
        (Some(d), Domain::Choice(names)) => format!("\"{}\"", names[d as usize]),
        (Some(d), _) => number(d),
    };
    let unit = match (p.default, p.unit) {
        (_, "") | (None, _) => String::new(),
        (Some(_), u) => format!(" {u}"),
    };
    let range = match p.domain {
        Domain::Choice(names) if names.len() > 2 => format!(
            " ({})",
            names
                .iter()
                .map(|n| format!("\"{n}\""))
                .collect::<Vec<_>>()
                .join(" ")
        ),
        Domain::Choice(names) => format!(" (or \"{}\")", names[1..].join("\", \"")),
        Domain::Positive => " (> 0)".into(),
        Domain::Number { min, max } if min.is_finite() || max.is_finite() => {
            format!(" ({}..{})", number(min), number(max))
        }
        _ => String::new(),
    };
    format!("{} {value}{unit}{range}", p.name)
}

/// One row of the table.
fn row(d: &Declaration) -> String {
    let reads = d
        .input
        .map_or(String::new(), |i| format!("{}N", input_prefix(i)));
    let mut params: Vec<String> = d.params.iter().map(param).collect();
    params.extend(
        d.host_keys
            .iter()
            .map(|k| format!("{} ({})", k.name, k.doc)),
    );
    let params = if params.is_empty() {
        "—".to_string()
    } else {
        params.join(", ")
    };
    let live: Vec<&str> = d.live.iter().map(|l| l.name).collect();
    let all: Vec<&str> = d.params.iter().map(|p| p.name).collect();
    let live = if live.is_empty() {
        "—".to_string()
    } else if live == all && live.len() > 1 {
        "all of them".to_string()
    } else {
        live.join(", ")
    };
    let ports: Vec<String> = d
        .ports
        .iter()
        .map(|p| {
            let dir = if p.dir == Dir::In { "in" } else { "out" };
            let level = if p.level { ", level" } else { "" };
            format!("{} ({dir}{level})", p.name)
        })
        .collect();
    let ports = if ports.is_empty() {
        "—".to_string()
    } else {
        ports.join(", ")
    };
    format!(
        "| `{}` | {reads} | {params} | {live} | {ports} | {} |",
        d.name, d.doc
    )
}

/// The Markdown table of every kind: name, the input it reads, parameters
/// with defaults (and host keys), live parameters, ports, what it does.
pub fn markdown_table() -> String {
    let mut out = String::from(
        "| kind | reads | parameters (default) | live parameters | ports | what it does |\n\
         |---|---|---|---|---|---|\n",
    );
    for d in COMPONENTS {
        out.push_str(&row(d));
        out.push('\n');
    }
    out
}
