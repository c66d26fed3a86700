//! The component declarations hold the node, the graph files, the wire and
//! the README together: every kind's defaults are accepted by the node and
//! by the compiler and round-trip through the wire encoding, the declaration
//! order is the wire order, and `examples/dance/README.md`'s table is the one
//! the declarations render.

use motet_graph::{markdown_table, GraphFile};
use motet_node::graph::declare::{Declaration, Domain};
use motet_node::graph::spec;
use motet_node::graph::{GraphBuilder, COMPONENTS};
use motet_node::{GRAPH_COMPONENTS, GRAPH_MAPPINGS};
use motet_wire::message::MAX_GRAPH_PARAMS;
use motet_wire::{decode, encode, HostMessage, MAX_MESSAGE};

/// A value for a required parameter (all kinds accept 1 for each).
const REQUIRED: f64 = 1.0;

/// Every construction value, defaults written out (hardware index 0).
fn full_values(d: &Declaration) -> Vec<f64> {
    d.defaults().map(|v| v.unwrap_or(REQUIRED)).collect()
}

/// Only the values without a default.
fn required_values(d: &Declaration) -> Vec<f64> {
    let (min, _) = d.arity();
    full_values(d)[..min].to_vec()
}

/// The kind as a graph file writes it, every parameter given.
fn graph_file(d: &Declaration, explicit: bool) -> String {
    let mut s = format!("[components.c]\nkind = \"{}\"\n", d.name);
    for p in d.params {
        if !explicit && p.default.is_some() {
            continue;
        }
        let v = p.default.unwrap_or(REQUIRED);
        let text = match p.domain {
            Domain::Flag => (v != 0.0).to_string(),
            Domain::Choice(names) => format!("\"{}\"", names[v as usize]),
            _ if v == f64::INFINITY => "inf".to_string(),
            _ if v == f64::NEG_INFINITY => "-inf".to_string(),
            _ => format!("{v:?}"),
        };
        s.push_str(&format!("{} = {text}\n", p.name));
    }
    if let Some(input) = d.input {
        s.push_str(&format!(
            "[inputs]\nc = \"{}0\"\n",
            motet_graph::kinds::input_prefix(input)
        ));
    }
    s
}

#[test]
fn every_kind_is_declared_in_wire_order() {
    for (i, d) in COMPONENTS.iter().enumerate() {
        // A kind is found by its name: names are unique.
        assert_eq!(
            COMPONENTS.iter().filter(|o| o.name == d.name).count(),
            1,
            "`{}` is declared twice",
            d.name
        );
        // On the wire a kind is one byte: its place in the table.
        let mut buf = [0u8; 8];
        let bytes = encode(&d.kind().unwrap(), &mut buf).unwrap();
        assert_eq!(
            bytes,
            [i as u8],
            "`{}` is declared out of wire order",
            d.name
        );
        assert_eq!(spec::declaration(d.kind().unwrap()).unwrap().name, d.name);
        let (min, max) = d.arity();
        assert!(
            max <= MAX_GRAPH_PARAMS,
            "`{}` takes too many values",
            d.name
        );
        assert!(
            d.params[..min - d.offset()]
                .iter()
                .all(|p| p.default.is_none()),
            "`{}`: required parameters come first",
            d.name
        );
        let names: Vec<&str> = d.params.iter().map(|p| p.name).collect();
        for (j, n) in names.iter().enumerate() {
            assert!(!names[..j].contains(n), "`{}`: `{n}` twice", d.name);
        }
        for p in d.params {
            if let Some(v) = p.default {
                assert!(
                    p.domain.accepts(v),
                    "`{}.{}`: default out of range",
                    d.name,
                    p.name
                );
            }
        }
        for l in d.live {
            assert_eq!(
                d.live
                    .iter()
                    .filter(|m| m.name == l.name || m.id == l.id)
                    .count(),
                1,
                "`{}`: live `{}` twice",
                d.name,
                l.name
            );
        }
        assert_eq!(COMPONENTS.iter().filter(|e| e.name == d.name).count(), 1);
    }
}

#[test]
fn defaults_are_accepted_by_the_node_the_compiler_and_the_wire() {
    for d in COMPONENTS {
        let full = full_values(d);
        let short = required_values(d);
        // The node: the defaults written out build the same component as
        // the defaults left out, and the builder takes it.
        let a = spec::component(d.kind().unwrap(), &full)
            .unwrap_or_else(|e| panic!("`{}`: {e}", d.name));
        let b = spec::component(d.kind().unwrap(), &short)
            .unwrap_or_else(|e| panic!("`{}`: {e}", d.name));
        assert_eq!(a, b, "`{}`: defaults differ from the ones left out", d.name);
        assert_eq!(a.declaration().name, d.name);
        assert_eq!(a.ports(), d.ports);
        let mut builder: GraphBuilder<GRAPH_COMPONENTS, GRAPH_MAPPINGS> = GraphBuilder::new();
        spec::add(&mut builder, d.kind().unwrap(), &full)
            .unwrap_or_else(|e| panic!("`{}`: {e}", d.name));
        builder
            .build()
            .unwrap_or_else(|e| panic!("`{}`: {e}", d.name));
        // The wire: the message round-trips.
        let m = HostMessage::GraphAdd {
            kind: d.kind().unwrap(),
            params: heapless::Vec::from_slice(&full).unwrap(),
        };
        let mut buf = [0u8; MAX_MESSAGE];
        let bytes = encode(&m, &mut buf).unwrap();
        assert_eq!(decode::<HostMessage>(bytes).unwrap(), m, "`{}`", d.name);
        // The compiler: every default written out, or none, gives the same
        // construction values and the same messages.
        for explicit in [true, false] {
            let text = graph_file(d, explicit);
            let g = GraphFile::parse(&text, "g.toml")
                .unwrap_or_else(|e| panic!("`{}`: {e}\n{text}", d.name));
            assert_eq!(g.components[0].params, full, "`{}`:\n{text}", d.name);
            assert_eq!(g.messages()[1], m, "`{}`:\n{text}", d.name);
        }
    }
}

#[test]
fn out_of_range_values_are_refused_with_their_name() {
    for d in COMPONENTS {
        for (i, p) in d.params.iter().enumerate() {
            let mut values = full_values(d);
            values[d.offset() + i] = f64::NAN;
            let e = spec::component(d.kind().unwrap(), &values).expect_err(p.name);
            assert!(e.to_string().contains(p.name), "`{}`: {e}", d.name);
        }
    }
}

/// The lines of the README's component table.
fn readme_table(readme: &str) -> String {
    let start = readme
        .find("### Component kinds")
        .expect("a `### Component kinds` section");
    readme[start..]
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .map(|l| format!("{l}\n"))
        .collect()
}

#[test]
fn readme_table_is_the_declarations() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/dance/README.md"
    );
    let readme = std::fs::read_to_string(path).unwrap();
    let expected = markdown_table();
    assert!(
        readme_table(&readme) == expected,
        "examples/dance/README.md's table under `### Component kinds` differs from the \
         components' declarations; replace it with:\n\n{expected}"
    );
}
