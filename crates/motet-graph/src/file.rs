//! Graph files: parsing, validation with file locations, and conversion to
//! the message sequence that builds the graph on a node.

use crate::kinds::{self, KindInfo, COMMON_KEYS};
use motet_node::graph::spec;
use motet_node::graph::{GraphBuilder, GraphError, Mode, PortRef};
use motet_node::{GRAPH_COMPONENTS, GRAPH_MAPPINGS};
use motet_wire::message::{GraphInputKind, GraphKind, GraphMode, GraphPort, MAX_GRAPH_PARAMS};
use motet_wire::HostMessage;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;
use toml::Spanned;

/// A problem in a graph file, with its place (line 0: the whole file, as
/// when it cannot be read).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}: {message}", place(.file, *.line, *.column))]
pub struct FileError {
    pub file: String,
    pub line: usize,
    pub column: usize,
    /// The key the problem is about (`components.knob.kind`, `map[2].to`).
    pub key: String,
    pub message: String,
}

/// A place in the graph file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Loc {
    pub line: usize,
    pub column: usize,
}

/// A problem with a live request (a parameter change, an input value).
/// `file:line:column`, or the file alone when the error has no line.
fn place(file: &str, line: usize, column: usize) -> String {
    match line {
        0 => file.to_string(),
        _ => format!("{file}:{line}:{column}"),
    }
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LiveError {
    #[error("no component `{0}` in the graph")]
    UnknownComponent(String),
    #[error("component `{component}` ({kind}) has no live parameter `{param}`; it has: {known}")]
    UnknownParam {
        component: String,
        kind: &'static str,
        param: String,
        known: String,
    },
    #[error("no input `{0}` in the graph's [inputs]")]
    UnknownInput(String),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    #[serde(default)]
    frame_us: Option<Spanned<f64>>,
    #[serde(default)]
    components: BTreeMap<Spanned<String>, Spanned<RawComponent>>,
    #[serde(default)]
    map: Vec<Spanned<RawMap>>,
    #[serde(default)]
    inputs: BTreeMap<Spanned<String>, Spanned<String>>,
    #[serde(default)]
    stage: Vec<Spanned<crate::stage::RawStage>>,
    #[serde(default)]
    pendulum: Vec<Spanned<RawPendulum>>,
    #[serde(default)]
    render: Option<RawRender>,
}

type RawComponent = BTreeMap<Spanned<String>, Spanned<toml::Value>>;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMap {
    from: Spanned<String>,
    to: Spanned<String>,
    #[serde(default)]
    mode: Option<Spanned<String>>,
    #[serde(default)]
    tap: bool,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPendulum {
    input: Spanned<String>,
    amplitude: f64,
    frequency: f64,
    #[serde(default)]
    damping: f64,
    #[serde(default)]
    phase: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRender {
    #[serde(default)]
    pen_channel: Option<Spanned<String>>,
    #[serde(default)]
    pen_down_below: f64,
}

/// A graph channel's place among the channels and its scale.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelDef {
    /// Ordinal among the graph's channels (creation order).
    pub ordinal: u8,
    /// `units` world units are `steps` steps.
    pub units: f64,
    pub steps: f64,
    /// The machine actuator it drives (simulation), if named.
    pub actuator: Option<String>,
}

/// One component of the file.
#[derive(Clone, Debug)]
pub struct ComponentDef {
    pub name: String,
    pub info: &'static KindInfo,
    /// Index in the graph (creation order = file order).
    pub index: u8,
    /// Construction values as sent.
    pub params: Vec<f64>,
    pub channel: Option<ChannelDef>,
    pub loc: Loc,
}

/// An external input named in `[inputs]`.
#[derive(Clone, Debug, PartialEq)]
pub struct InputDef {
    /// The component reading it (also the input's name).
    pub name: String,
    pub kind: GraphInputKind,
    pub index: u8,
    pub component: u8,
}

/// A damped pendulum swinging an input (simulation only):
/// `amplitude · e^(−damping·t) · sin(2π·frequency·t + phase)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Pendulum {
    pub input: String,
    pub amplitude: f64,
    pub frequency: f64,
    pub damping: f64,
    pub phase: f64,
}

/// Render hints (simulation only): the pen is down while channel
/// `pen_channel`'s position (steps) is below `pen_down_below`.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct RenderDef {
    pub pen_channel: Option<String>,
    pub pen_down_below: f64,
}

#[derive(Clone, Debug)]
enum Op {
    Add(GraphKind, Vec<f64>),
    Ratio(PortRef, f64, f64),
    Map(PortRef, PortRef, Mode, bool),
}

/// A validated graph file.
#[derive(Clone, Debug)]
pub struct GraphFile {
    pub file: String,
    pub frame_us: f64,
    pub components: Vec<ComponentDef>,
    pub inputs: Vec<InputDef>,
    pub stages: Vec<crate::stage::Stage>,
    pub pendulums: Vec<Pendulum>,
    pub render: RenderDef,
    ops: Vec<(Op, Loc, String)>,
}

pub(crate) struct Source<'a> {
    pub file: String,
    pub text: &'a str,
}

impl Source<'_> {
    pub fn loc(&self, span: Range<usize>) -> Loc {
        let at = span.start.min(self.text.len());
        let before = &self.text[..at];
        Loc {
            line: before.matches('\n').count() + 1,
            column: before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1,
        }
    }

    pub fn err_at(
        &self,
        loc: Loc,
        key: impl Into<String>,
        message: impl Into<String>,
    ) -> FileError {
        let key = key.into();
        let message = message.into();
        FileError {
            file: self.file.clone(),
            line: loc.line,
            column: loc.column,
            message: if key.is_empty() {
                message
            } else {
                format!("`{key}`: {message}")
            },
            key,
        }
    }

    pub fn err(
        &self,
        span: Range<usize>,
        key: impl Into<String>,
        message: impl Into<String>,
    ) -> FileError {
        self.err_at(self.loc(span), key, message)
    }
}

fn number(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Integer(i) => Some(*i as f64),
        toml::Value::Float(f) => Some(*f),
        toml::Value::Boolean(b) => Some(if *b { 1.0 } else { 0.0 }),
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

fn input_prefix(kind: GraphInputKind) -> &'static str {
    match kind {
        GraphInputKind::Encoder => "encoder",
        GraphInputKind::Analog => "analog",
        GraphInputKind::Digital => "button",
        GraphInputKind::Stream => "stream",
    }
}

impl GraphFile {
    /// Reads and validates a graph file.
    pub fn load(path: &Path) -> Result<GraphFile, FileError> {
        let text = std::fs::read_to_string(path).map_err(|e| FileError {
            file: path.display().to_string(),
            line: 0,
            column: 0,
            key: String::new(),
            message: format!("cannot read graph file: {e}"),
        })?;
        GraphFile::parse(&text, &path.display().to_string())
    }

    /// Validates a graph file given as text (`file` names it in errors).
    pub fn parse(text: &str, file: &str) -> Result<GraphFile, FileError> {
        let src = Source {
            file: file.to_string(),
            text,
        };
        let raw: RawFile = toml::from_str(text).map_err(|e| {
            let span = e.span().unwrap_or(0..0);
            src.err(span, "", e.message().trim().to_string())
        })?;
        compile(&src, raw)
    }

    /// The component named `name`.
    pub fn component(&self, name: &str) -> Option<&ComponentDef> {
        self.components.iter().find(|c| c.name == name)
    }

    /// The graph channels, in creation order.
    pub fn channels(&self) -> impl Iterator<Item = &ComponentDef> {
        self.components.iter().filter(|c| c.channel.is_some())
    }

    /// The messages that build this graph on a node: `GraphBegin`, one message
    /// per component, ratio and mapping, `GraphCommit`.
    pub fn messages(&self) -> Vec<HostMessage> {
        let mut out = vec![HostMessage::GraphBegin {
            frame_us: self.frame_us,
        }];
        let wp = |p: PortRef| GraphPort {
            comp: p.comp,
            port: p.port,
        };
        for (op, _, _) in &self.ops {
            out.push(match op {
                Op::Add(kind, params) => HostMessage::GraphAdd {
                    kind: *kind,
                    params: heapless::Vec::from_slice(params).expect("checked arity"),
                },
                Op::Ratio(p, w, b) => HostMessage::GraphRatio {
                    port: wp(*p),
                    world: *w,
                    block: *b,
                },
                Op::Map(from, to, mode, tap) => HostMessage::GraphMap {
                    from: wp(*from),
                    to: wp(*to),
                    mode: match mode {
                        Mode::Incremental => GraphMode::Incremental,
                        Mode::Absolute => GraphMode::Absolute,
                    },
                    tap: *tap,
                },
            });
        }
        out.push(HostMessage::GraphCommit);
        out
    }

    /// The component index and parameter id of `component.param`.
    pub fn param_id(&self, component: &str, param: &str) -> Result<(u8, u8), LiveError> {
        let c = self
            .component(component)
            .ok_or_else(|| LiveError::UnknownComponent(component.to_string()))?;
        let id = c
            .info
            .live
            .iter()
            .find(|(n, _)| *n == param)
            .map(|(_, id)| *id)
            .ok_or_else(|| LiveError::UnknownParam {
                component: component.to_string(),
                kind: c.info.name,
                param: param.to_string(),
                known: names(c.info.live.iter().map(|(n, _)| *n)),
            })?;
        Ok((c.index, id))
    }

    /// A live parameter change of the running graph.
    pub fn set(&self, component: &str, param: &str, value: f64) -> Result<HostMessage, LiveError> {
        let (component, param) = self.param_id(component, param)?;
        Ok(HostMessage::GraphParam {
            component,
            param,
            value,
        })
    }

    /// The input named `name` in `[inputs]`.
    pub fn input(&self, name: &str) -> Option<&InputDef> {
        self.inputs.iter().find(|i| i.name == name)
    }

    /// A reading of the input `name`.
    pub fn input_message(&self, name: &str, value: f64) -> Result<HostMessage, LiveError> {
        let i = self
            .input(name)
            .ok_or_else(|| LiveError::UnknownInput(name.to_string()))?;
        Ok(HostMessage::GraphInput {
            kind: i.kind,
            index: i.index,
            value,
        })
    }

    /// `component.port` for messages.
    pub fn port_name(&self, p: PortRef) -> String {
        match self.components.get(p.comp as usize) {
            Some(c) => {
                let port = c
                    .info_ports()
                    .get(p.port as usize)
                    .map_or("?".to_string(), |s| s.to_string());
                format!("{}.{}", c.name, port)
            }
            None => format!("#{}.{}", p.comp, p.port),
        }
    }
}

impl ComponentDef {
    /// Port names in port order.
    pub fn info_ports(&self) -> Vec<&'static str> {
        spec::component(self.info.kind, &self.params)
            .map(|c| c.ports().iter().map(|p| p.name).collect())
            .unwrap_or_default()
    }
}

pub(crate) fn names<'a>(it: impl Iterator<Item = &'a str>) -> String {
    let v: Vec<&str> = it.collect();
    if v.is_empty() {
        "(none)".to_string()
    } else {
        v.join(", ")
    }
}

/// Resolves `port` of `c`: its exact name, or `out`/`in` for the sole output
/// or input.
fn resolve_port(c: &ComponentDef, port: &str) -> Option<u8> {
    let comp = spec::component(c.info.kind, &c.params)?;
    let ports = comp.ports();
    if let Some(i) = ports.iter().position(|p| p.name == port) {
        return Some(i as u8);
    }
    use motet_node::graph::port::Dir;
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

fn compile(src: &Source, raw: RawFile) -> Result<GraphFile, FileError> {
    let frame_us = match &raw.frame_us {
        Some(f) => {
            let v = *f.get_ref();
            if !(v.is_finite() && v >= 1.0) {
                return Err(src.err(f.span(), "frame_us", "must be at least 1 µs"));
            }
            v
        }
        None => motet_node::graph::DEFAULT_FRAME_US,
    };
    // Inputs first: the components need their hardware index.
    let mut input_of: BTreeMap<String, (Loc, String, Range<usize>)> = BTreeMap::new();
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
    let mut components = Vec::new();
    let mut inputs = Vec::new();
    let mut ops: Vec<(Op, Loc, String)> = Vec::new();
    let mut channels = 0u8;
    for (index, (name, table)) in comps.into_iter().enumerate() {
        let cname = name.get_ref().clone();
        let key = format!("components.{cname}");
        let kind_v = table
            .get_ref()
            .iter()
            .find(|(k, _)| k.get_ref() == "kind")
            .map(|(_, v)| v);
        let Some(kind_v) = kind_v else {
            return Err(src.err(name.span(), &key, "missing `kind`"));
        };
        let kind_s = kind_v.get_ref().as_str().unwrap_or("");
        let Some(info) = kinds::kind(kind_s) else {
            return Err(src.err(
                kind_v.span(),
                format!("{key}.kind"),
                format!(
                    "unknown component kind `{}`; expected one of: {}",
                    kind_v.get_ref().as_str().unwrap_or("(not a string)"),
                    kinds::kind_names()
                ),
            ));
        };
        let mut params: Vec<f64> = Vec::new();
        if let Some(ik) = info.input {
            let Some((_, hw, span)) = input_of.get(&cname) else {
                return Err(src.err(
                    name.span(),
                    &key,
                    format!(
                        "a `{}` reads an external input: name it in [inputs], e.g. {cname} = \"{}0\"",
                        info.name,
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
                .filter(|&n| (n as usize) < motet_node::graph::MAX_HW);
            let Some(idx) = idx else {
                return Err(src.err(
                    span.clone(),
                    format!("inputs.{cname}"),
                    format!(
                        "`{hw}` is not an input a `{}` reads; expected `{prefix}0` .. `{prefix}{}`",
                        info.name,
                        motet_node::graph::MAX_HW - 1
                    ),
                ));
            };
            params.push(idx as f64);
            inputs.push(InputDef {
                name: cname.clone(),
                kind: ik,
                index: idx,
                component: index as u8,
            });
        } else if let Some((loc, _, _)) = input_of.get(&cname) {
            return Err(src.err_at(
                *loc,
                format!("inputs.{cname}"),
                format!("a `{}` reads no external input", info.name),
            ));
        }
        let mut build: Vec<Option<f64>> = info.build.iter().map(|(_, d)| *d).collect();
        let mut units: Option<f64> = None;
        let mut steps: Option<f64> = None;
        let mut actuator = None;
        let mut enc_ratio = None;
        let mut ratios: Vec<(Spanned<String>, Range<usize>, f64, f64)> = Vec::new();
        for (k, v) in table.get_ref() {
            let kname = k.get_ref().as_str();
            let pkey = format!("{key}.{kname}");
            if kname == "kind" {
                continue;
            }
            if let Some(i) = info.build.iter().position(|(n, _)| *n == kname) {
                let val = match (kname, v.get_ref()) {
                    ("mode", toml::Value::String(s)) => match parse_mode(s) {
                        Some(Mode::Absolute) => Some(1.0),
                        Some(Mode::Incremental) => Some(0.0),
                        None => None,
                    },
                    ("signal", toml::Value::String(s)) => ["x", "y", "r", "t", "z", "e"]
                        .iter()
                        .position(|c| c == s)
                        .map(|c| c as f64),
                    (_, v) => number(v),
                };
                let Some(val) = val else {
                    let want = match kname {
                        "mode" => "\"incremental\" or \"absolute\"",
                        "signal" => {
                            "a signal code 0..5 or one of \"x\" \"y\" \"r\" \"t\" \"z\" \"e\""
                        }
                        _ => "a number",
                    };
                    return Err(src.err(v.span(), pkey, format!("expected {want}")));
                };
                build[i] = Some(val);
                continue;
            }
            let num = || {
                number(v.get_ref())
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| src.err(v.span(), &pkey, "expected a finite number"))
            };
            match (info.kind, kname) {
                (GraphKind::Channel, "units") => units = Some(num()?),
                (GraphKind::Channel, "steps") => steps = Some(num()?),
                (GraphKind::Channel, "actuator") => {
                    actuator = Some(
                        v.get_ref()
                            .as_str()
                            .ok_or_else(|| src.err(v.span(), &pkey, "expected an actuator name"))?
                            .to_string(),
                    )
                }
                (GraphKind::Encoder, "ratio") => enc_ratio = Some((num()?, v.span())),
                (_, "ratios") => {
                    let Some(t) = v.get_ref().as_table() else {
                        return Err(src.err(
                            v.span(),
                            pkey,
                            "expected a table of port = [world, block]",
                        ));
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
                        ratios.push((Spanned::new(v.span(), port.clone()), v.span(), w, b));
                    }
                }
                _ => {
                    let mut known: Vec<&str> = info.build.iter().map(|(n, _)| *n).collect();
                    known.extend(kinds::extra_keys(info.kind));
                    known.extend(COMMON_KEYS.iter().filter(|k| **k != "kind"));
                    return Err(src.err(
                        k.span(),
                        pkey,
                        format!(
                            "unknown parameter `{kname}` for a `{}`; expected one of: {}",
                            info.name,
                            names(known.into_iter())
                        ),
                    ));
                }
            }
        }
        for (i, b) in build.iter().enumerate() {
            match b {
                Some(v) => params.push(*v),
                None => {
                    return Err(src.err(
                        name.span(),
                        &key,
                        format!("a `{}` needs `{}`", info.name, info.build[i].0),
                    ))
                }
            }
        }
        debug_assert!(params.len() <= MAX_GRAPH_PARAMS);
        let loc = src.loc(name.span());
        if spec::component(info.kind, &params).is_none() {
            return Err(src.err(
                name.span(),
                &key,
                format!("bad parameter values for a `{}`: {}", info.name, info.doc),
            ));
        }
        ops.push((Op::Add(info.kind, params.clone()), loc, key.clone()));
        let idx = index as u8;
        let mut def = ComponentDef {
            name: cname.clone(),
            info,
            index: idx,
            params,
            channel: None,
            loc,
        };
        if info.kind == GraphKind::Channel {
            let (u, s) = (units.unwrap_or(1.0), steps.unwrap_or(1.0));
            if u == 0.0 || s == 0.0 {
                return Err(src.err(name.span(), &key, "`units` and `steps` must be nonzero"));
            }
            if units.is_some() || steps.is_some() {
                for p in 0..3 {
                    ops.push((Op::Ratio(PortRef::new(idx, p), u, s), loc, key.clone()));
                }
            }
            def.channel = Some(ChannelDef {
                ordinal: channels,
                units: u,
                steps: s,
                actuator,
            });
            channels += 1;
        }
        if let Some((r, span)) = enc_ratio {
            ops.push((
                Op::Ratio(PortRef::new(idx, 0), r, 1.0),
                src.loc(span),
                format!("{key}.ratio"),
            ));
        }
        for (port, span, w, b) in ratios {
            let Some(p) = resolve_port(&def, port.get_ref()) else {
                return Err(src.err(
                    span,
                    format!("{key}.ratios.{}", port.get_ref()),
                    format!(
                        "`{}` has no port `{}`; ports: {}",
                        cname,
                        port.get_ref(),
                        names(def.info_ports().into_iter())
                    ),
                ));
            };
            ops.push((
                Op::Ratio(PortRef::new(idx, p), w, b),
                src.loc(span),
                format!("{key}.ratios.{}", port.get_ref()),
            ));
        }
        components.push(def);
    }
    // Mappings.
    let find_port = |s: &Spanned<String>, key: &str| -> Result<PortRef, FileError> {
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
    };
    for (i, m) in raw.map.iter().enumerate() {
        let mk = format!("map[{i}]");
        let r = m.get_ref();
        let from = find_port(&r.from, &format!("{mk}.from"))?;
        let to = find_port(&r.to, &format!("{mk}.to"))?;
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
    let mut gf = GraphFile {
        file: src.file.clone(),
        frame_us,
        components,
        inputs,
        stages: Vec::new(),
        pendulums: Vec::new(),
        render: RenderDef::default(),
        ops,
    };
    check_build(src, &gf)?;
    gf.stages = crate::stage::compile(src, &gf, &raw.stage)?;
    for (i, p) in raw.pendulum.iter().enumerate() {
        let r = p.get_ref();
        let ok = gf
            .input(r.input.get_ref())
            .is_some_and(|d| matches!(d.kind, GraphInputKind::Encoder | GraphInputKind::Analog));
        if !ok {
            return Err(src.err(
                r.input.span(),
                format!("pendulum[{i}].input"),
                format!(
                    "`{}` is not an encoder or analog input named in [inputs]",
                    r.input.get_ref()
                ),
            ));
        }
        if ![r.amplitude, r.frequency, r.damping, r.phase]
            .iter()
            .all(|v| v.is_finite())
            || r.frequency < 0.0
            || r.damping < 0.0
        {
            return Err(src.err(
                p.span(),
                format!("pendulum[{i}]"),
                "amplitude and phase must be finite, frequency and damping finite and not negative",
            ));
        }
        gf.pendulums.push(Pendulum {
            input: r.input.get_ref().clone(),
            amplitude: r.amplitude,
            frequency: r.frequency,
            damping: r.damping,
            phase: r.phase,
        });
    }
    if let Some(r) = &raw.render {
        if let Some(c) = &r.pen_channel {
            if gf
                .component(c.get_ref())
                .and_then(|d| d.channel.as_ref())
                .is_none()
            {
                return Err(src.err(
                    c.span(),
                    "render.pen_channel",
                    format!("`{}` is not a channel of the graph", c.get_ref()),
                ));
            }
        }
        gf.render = RenderDef {
            pen_channel: r.pen_channel.as_ref().map(|c| c.get_ref().clone()),
            pen_down_below: r.pen_down_below,
        };
    }
    Ok(gf)
}

/// Runs the operations through the node's own builder and maps its errors
/// back to the file.
fn check_build(src: &Source, gf: &GraphFile) -> Result<(), FileError> {
    let mut b: GraphBuilder<GRAPH_COMPONENTS, GRAPH_MAPPINGS> = GraphBuilder::new();
    b.frame_us(gf.frame_us);
    let describe = |e: GraphError| -> String {
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
    };
    for (op, loc, key) in &gf.ops {
        let r =
            match op {
                Op::Add(kind, params) => spec::add(&mut b, *kind, params).map(|_| ()).ok_or(
                    GraphError::CapacityExceeded(motet_node::graph::Capacity::Components),
                ),
                Op::Ratio(p, w, bl) => b.set_ratio(*p, *w, *bl),
                Op::Map(from, to, mode, tap) => {
                    if *tap {
                        b.tap(*to, *from, *mode)
                    } else {
                        b.map(*from, *to, *mode)
                    }
                }
            };
        if let Err(e) = r {
            let mut msg = describe(e);
            if matches!(
                e,
                GraphError::CapacityExceeded(motet_node::graph::Capacity::Channels)
            ) {
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
        return Err(src.err_at(loc, key, describe(e)));
    }
    Ok(())
}
