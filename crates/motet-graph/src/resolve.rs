//! The second stage: names resolved against the declarations. `[inputs]`
//! and each `[components.NAME]` table become a [`ComponentDef`] (its kind's
//! [`Declaration`], hardware input, construction values) and the operations
//! that build it on a node.

use crate::emit::Op;
use crate::file::{names, ChannelDef, ComponentDef, FileError, InputDef, Loc};
use crate::kinds::{self, input_prefix, COMMON_KEYS};
use crate::ports::resolve_port;
use crate::raw::{RawComponent, RawFile};
use crate::source::Source;
use motet_node::graph::component::Kind;
use motet_node::graph::declare::{Declaration, Domain, Param};
use motet_node::graph::{spec, MAX_HW};
use motet_node::graph::{GraphChannel, PortRef};
use motet_node::GRAPH_COMPONENTS;
use motet_wire::message::{GraphInputKind, MAX_GRAPH_PARAMS};
use std::collections::BTreeMap;
use std::ops::Range;
use toml::Spanned;

/// `[inputs]`: component name → (place of the name, hardware input, its span).
pub(crate) type InputNames = BTreeMap<String, (Loc, String, Range<usize>)>;

/// What the components stage produces.
pub(crate) struct Resolved {
    pub components: Vec<ComponentDef>,
    pub inputs: Vec<InputDef>,
    pub ops: Vec<(Op, Loc, String)>,
}

/// The core frame period, µs.
pub(crate) fn frame_us(src: &Source, raw: &RawFile) -> Result<f64, FileError> {
    match &raw.frame_us {
        Some(f) => {
            let v = *f.get_ref();
            if !(v.is_finite() && v >= 1.0) {
                return Err(src.err(f.span(), "frame_us", "must be at least 1 µs"));
            }
            Ok(v)
        }
        None => Ok(motet_node::graph::DEFAULT_FRAME_US),
    }
}

/// `[inputs]`, each naming a component.
pub(crate) fn input_names(src: &Source, raw: &RawFile) -> Result<InputNames, FileError> {
    let mut input_of = InputNames::new();
    for (k, v) in &raw.inputs {
        input_of.insert(
            k.get_ref().clone(),
            (src.loc(k.span()), v.get_ref().clone(), v.span()),
        );
        if !raw.components.contains_key(k.get_ref().as_str()) {
            return Err(src.err(
                k.span(),
                format!("inputs.{}", k.get_ref()),
                "names no component; an input is named after the component that reads it",
            ));
        }
    }
    Ok(input_of)
}

/// Every component in file order, with the operations that build it.
pub(crate) fn components(
    src: &Source,
    raw: &RawFile,
    input_of: &InputNames,
) -> Result<Resolved, FileError> {
    let mut comps: Vec<_> = raw.components.iter().collect();
    comps.sort_by_key(|(k, _)| k.span().start);
    if comps.len() > GRAPH_COMPONENTS {
        let (k, _) = comps[GRAPH_COMPONENTS];
        return Err(src.err(
            k.span(),
            format!("components.{}", k.get_ref()),
            format!("more than {GRAPH_COMPONENTS} components"),
        ));
    }
    let mut out = Resolved {
        components: Vec::new(),
        inputs: Vec::new(),
        ops: Vec::new(),
    };
    let mut channels = 0u8;
    for (index, (name, table)) in comps.into_iter().enumerate() {
        let def = component(src, &mut out, input_of, index as u8, name, table, channels)?;
        channels += def.channel.is_some() as u8;
        out.components.push(def);
    }
    Ok(out)
}

/// A component table's keys, read.
struct Keys {
    /// Construction values by parameter (`None`: required and not given).
    values: Vec<Option<f64>>,
    units: Option<f64>,
    steps: Option<f64>,
    actuator: Option<String>,
    /// An encoder's `ratio` and its span.
    enc_ratio: Option<(f64, Range<usize>)>,
    /// `ratios = { port = [world, block] }`: port, span, world, block.
    ratios: Vec<(String, Range<usize>, f64, f64)>,
}

/// One component: its declaration, input, values and operations.
fn component(
    src: &Source,
    out: &mut Resolved,
    input_of: &InputNames,
    index: u8,
    name: &Spanned<String>,
    table: &Spanned<RawComponent>,
    channels: u8,
) -> Result<ComponentDef, FileError> {
    let cname = name.get_ref().clone();
    let key = format!("components.{cname}");
    let decl = declaration(src, &key, name, table)?;
    let mut params: Vec<f64> = Vec::new();
    if let Some(input) = hardware_input(src, &cname, &key, name, decl, index, input_of)? {
        params.push(input.index as f64);
        out.inputs.push(input);
    }
    let keys = read_keys(src, &key, decl, table.get_ref())?;
    for (i, v) in keys.values.iter().enumerate() {
        let Some(v) = v else {
            return Err(src.err(
                name.span(),
                &key,
                format!("a `{}` needs `{}`", decl.name, decl.params[i].name),
            ));
        };
        params.push(*v);
    }
    debug_assert!(params.len() <= MAX_GRAPH_PARAMS);
    let loc = src.loc(name.span());
    // Every declaration found by name is in the node's table.
    let Some(kind) = decl.kind() else {
        return Err(src.err(
            name.span(),
            &key,
            format!("`{}` is not in this node's component table", decl.name),
        ));
    };
    if let Err(e) = spec::component(kind, &params) {
        return Err(src.err(
            name.span(),
            &key,
            format!("bad parameter values for a `{}`: {e}", decl.name),
        ));
    }
    out.ops
        .push((Op::Add(kind, params.clone()), loc, key.clone()));
    let mut def = ComponentDef {
        name: cname,
        info: decl,
        index,
        params,
        channel: None,
        loc,
    };
    component_ratios(src, out, &mut def, &key, keys, name, channels)?;
    Ok(def)
}

/// The declaration `kind = "..."` names.
fn declaration(
    src: &Source,
    key: &str,
    name: &Spanned<String>,
    table: &Spanned<RawComponent>,
) -> Result<&'static Declaration, FileError> {
    let kind_v = table
        .get_ref()
        .iter()
        .find(|(k, _)| k.get_ref() == "kind")
        .map(|(_, v)| v);
    let Some(kind_v) = kind_v else {
        return Err(src.err(name.span(), key, "missing `kind`"));
    };
    let kind_s = kind_v.get_ref().as_str().unwrap_or("");
    kinds::kind(kind_s).ok_or_else(|| {
        src.err(
            kind_v.span(),
            format!("{key}.kind"),
            format!(
                "unknown component kind `{}`; expected one of: {}",
                kind_v.get_ref().as_str().unwrap_or("(not a string)"),
                kinds::kind_names()
            ),
        )
    })
}

/// The hardware input a component reads, as `[inputs]` names it.
fn hardware_input(
    src: &Source,
    cname: &str,
    key: &str,
    name: &Spanned<String>,
    decl: &Declaration,
    index: u8,
    input_of: &InputNames,
) -> Result<Option<InputDef>, FileError> {
    let Some(ik) = decl.input else {
        if let Some((loc, _, _)) = input_of.get(cname) {
            return Err(src.err_at(
                *loc,
                format!("inputs.{cname}"),
                format!("a `{}` reads no external input", decl.name),
            ));
        }
        return Ok(None);
    };
    let Some((_, hw, span)) = input_of.get(cname) else {
        return Err(src.err(
            name.span(),
            key,
            format!(
                "a `{}` reads an external input: name it in [inputs], e.g. {cname} = \"{}0\"",
                decl.name,
                input_prefix(ik)
            ),
        ));
    };
    let prefix = input_prefix(ik);
    let idx = hw
        .strip_prefix(prefix)
        .or_else(|| {
            (ik == GraphInputKind::Digital)
                .then(|| hw.strip_prefix("digital"))
                .flatten()
        })
        .and_then(|n| n.parse::<u8>().ok())
        .filter(|&n| (n as usize) < MAX_HW);
    let Some(idx) = idx else {
        return Err(src.err(
            span.clone(),
            format!("inputs.{cname}"),
            format!(
                "`{hw}` is not an input a `{}` reads; expected `{prefix}0` .. `{prefix}{}`",
                decl.name,
                MAX_HW - 1
            ),
        ));
    };
    Ok(Some(InputDef {
        name: cname.to_string(),
        kind: ik,
        index: idx,
        component: index,
    }))
}

fn number(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Integer(i) => Some(*i as f64),
        toml::Value::Float(f) => Some(*f),
        toml::Value::Boolean(b) => Some(if *b { 1.0 } else { 0.0 }),
        _ => None,
    }
}

/// What a parameter's domain takes, for messages.
fn expected(d: Domain) -> String {
    match d {
        Domain::Choice(names) if names.len() == 2 => {
            format!("\"{}\" or \"{}\"", names[0], names[1])
        }
        Domain::Choice(names) => format!(
            "a code 0..{} or one of {}",
            names.len() - 1,
            names
                .iter()
                .map(|n| format!("\"{n}\""))
                .collect::<Vec<_>>()
                .join(" ")
        ),
        Domain::Flag => "true or false".into(),
        Domain::Index(n) => format!("an integer 0..{}", n.saturating_sub(1)),
        Domain::Positive => "a number above 0".into(),
        Domain::Number { min, max } if min.is_finite() && max.is_finite() => {
            format!("a number in {min}..{max}")
        }
        Domain::Number { min, .. } if min.is_finite() => format!("a number not below {min}"),
        Domain::Number { .. } => "a finite number".into(),
        Domain::Bound => "a number".into(),
    }
}

/// A construction parameter's value as written.
fn param_value(
    src: &Source,
    pkey: &str,
    p: &Param,
    v: &Spanned<toml::Value>,
) -> Result<f64, FileError> {
    let val = match (p.domain, v.get_ref()) {
        (Domain::Choice(names), toml::Value::String(s)) => {
            names.iter().position(|n| n == s).map(|i| i as f64)
        }
        (_, v) => number(v),
    };
    match val {
        Some(x) if p.domain.accepts(x) => Ok(x),
        _ => Err(src.err(v.span(), pkey, format!("expected {}", expected(p.domain)))),
    }
}

/// The keys of a component table: construction values (defaults filled in)
/// and host keys.
fn read_keys(
    src: &Source,
    key: &str,
    decl: &Declaration,
    table: &RawComponent,
) -> Result<Keys, FileError> {
    let mut keys = Keys {
        values: decl.params.iter().map(|p| p.default).collect(),
        units: None,
        steps: None,
        actuator: None,
        enc_ratio: None,
        ratios: Vec::new(),
    };
    for (k, v) in table {
        let kname = k.get_ref().as_str();
        let pkey = format!("{key}.{kname}");
        if kname == "kind" {
            continue;
        }
        if let Some(i) = decl.params.iter().position(|p| p.name == kname) {
            keys.values[i] = Some(param_value(src, &pkey, &decl.params[i], v)?);
        } else if decl.host_keys.iter().any(|h| h.name == kname) || kname == "ratios" {
            host_key(src, &pkey, kname, v, &mut keys)?;
        } else {
            let mut known: Vec<&str> = decl.params.iter().map(|p| p.name).collect();
            known.extend(decl.host_keys.iter().map(|h| h.name));
            known.extend(COMMON_KEYS.iter().filter(|k| **k != "kind"));
            return Err(src.err(
                k.span(),
                pkey,
                format!(
                    "unknown parameter `{kname}` for a `{}`; expected one of: {}",
                    decl.name,
                    names(known.into_iter())
                ),
            ));
        }
    }
    Ok(keys)
}

/// A key the host reads (scales, names, port ratios).
fn host_key(
    src: &Source,
    pkey: &str,
    kname: &str,
    v: &Spanned<toml::Value>,
    keys: &mut Keys,
) -> Result<(), FileError> {
    let num = || {
        number(v.get_ref())
            .filter(|x| x.is_finite())
            .ok_or_else(|| src.err(v.span(), pkey, "expected a finite number"))
    };
    match kname {
        "units" => keys.units = Some(num()?),
        "steps" => keys.steps = Some(num()?),
        "ratio" => keys.enc_ratio = Some((num()?, v.span())),
        "actuator" => {
            let name = v.get_ref().as_str();
            let name = name.ok_or_else(|| src.err(v.span(), pkey, "expected an actuator name"))?;
            keys.actuator = Some(name.to_string());
        }
        _ => {
            let Some(t) = v.get_ref().as_table() else {
                return Err(src.err(v.span(), pkey, "expected a table of port = [world, block]"));
            };
            for (port, pair) in t {
                let p = pair
                    .as_array()
                    .filter(|a| a.len() == 2)
                    .and_then(|a| Some((number(&a[0])?, number(&a[1])?)));
                let Some((w, b)) = p else {
                    return Err(src.err(
                        v.span(),
                        format!("{pkey}.{port}"),
                        "expected [world units, block units]",
                    ));
                };
                keys.ratios.push((port.clone(), v.span(), w, b));
            }
        }
    }
    Ok(())
}

/// A channel's scale and a component's port ratios, as operations.
fn component_ratios(
    src: &Source,
    out: &mut Resolved,
    def: &mut ComponentDef,
    key: &str,
    keys: Keys,
    name: &Spanned<String>,
    channels: u8,
) -> Result<(), FileError> {
    let (idx, loc) = (def.index, def.loc);
    if def.info.name == <GraphChannel as Kind>::DECL.name {
        let (u, s) = (keys.units.unwrap_or(1.0), keys.steps.unwrap_or(1.0));
        if u == 0.0 || s == 0.0 {
            return Err(src.err(name.span(), key, "`units` and `steps` must be nonzero"));
        }
        if keys.units.is_some() || keys.steps.is_some() {
            for p in 0..3 {
                out.ops
                    .push((Op::Ratio(PortRef::new(idx, p), u, s), loc, key.to_string()));
            }
        }
        def.channel = Some(ChannelDef {
            ordinal: channels,
            units: u,
            steps: s,
            actuator: keys.actuator,
        });
    }
    if let Some((r, span)) = keys.enc_ratio {
        out.ops.push((
            Op::Ratio(PortRef::new(idx, 0), r, 1.0),
            src.loc(span),
            format!("{key}.ratio"),
        ));
    }
    for (port, span, w, b) in keys.ratios {
        let Some(p) = resolve_port(def, &port) else {
            return Err(src.err(
                span,
                format!("{key}.ratios.{port}"),
                format!(
                    "`{}` has no port `{port}`; ports: {}",
                    def.name,
                    names(def.info_ports().into_iter())
                ),
            ));
        };
        out.ops.push((
            Op::Ratio(PortRef::new(idx, p), w, b),
            src.loc(span),
            format!("{key}.ratios.{port}"),
        ));
    }
    Ok(())
}
