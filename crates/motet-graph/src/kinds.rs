//! The component kinds a graph file names: the node's declarations
//! ([`motet_node::graph::declare`]), looked up by name, and the Markdown table
//! of them that `examples/dance/README.md` holds.

use motet_node::graph::declare::{Declaration, Domain, Param};
use motet_node::graph::port::Dir;
use motet_wire::message::GraphInputKind;

/// Every component kind the node has, in wire order (the node's table,
/// under its own name).
pub use motet_node::graph::COMPONENTS;

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

/// `name default unit (range)`, or `name (required, range)`.
fn param(p: &Param) -> String {
    let mut notes = Vec::new();
    let value = match (p.default, p.domain) {
        (None, _) => {
            notes.push("required".to_string());
            if !p.unit.is_empty() {
                notes.push(p.unit.to_string());
            }
            String::new()
        }
        (Some(d), Domain::Flag) => format!(" {}", d != 0.0),
        (Some(d), Domain::Choice(names)) => format!(" \"{}\"", names[d as usize]),
        (Some(d), _) if p.unit.is_empty() => format!(" {}", number(d)),
        (Some(d), _) => format!(" {} {}", number(d), p.unit),
    };
    match p.domain {
        Domain::Choice(names) => notes.push(format!(
            "one of {}",
            names
                .iter()
                .map(|n| format!("\"{n}\""))
                .collect::<Vec<_>>()
                .join(" ")
        )),
        Domain::Positive => notes.push("> 0".into()),
        Domain::Index(n) => notes.push(format!("0..{}", n.saturating_sub(1))),
        Domain::Number { min, max } if max.is_finite() => {
            notes.push(format!("{}..{}", number(min), number(max)))
        }
        Domain::Number { min, .. } if min.is_finite() => notes.push(format!("≥ {}", number(min))),
        _ => {}
    }
    if notes.is_empty() {
        format!("{}{value}", p.name)
    } else {
        format!("{}{value} ({})", p.name, notes.join(", "))
    }
}

/// `in: a b; out: c (level)`.
fn ports(d: &Declaration) -> String {
    let side = |dir: Dir, label: &str| {
        let names: Vec<String> = d
            .ports
            .iter()
            .filter(|p| p.dir == dir)
            .map(|p| {
                if p.level {
                    format!("{} (level)", p.name)
                } else {
                    p.name.to_string()
                }
            })
            .collect();
        (!names.is_empty()).then(|| format!("{label}: {}", names.join(" ")))
    };
    [side(Dir::In, "in"), side(Dir::Out, "out")]
        .into_iter()
        .flatten()
        .collect::<Vec<_>>()
        .join("; ")
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
    let ports = ports(d);
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
